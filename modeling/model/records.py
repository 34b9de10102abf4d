"""The records of an environment model (paper section 4): obstacles, critical regions,
passages, situations and the model itself.

All are frozen, slotted, keyword-only dataclasses (``eq=False``: they hold arrays). Frames: world,
metres; covariances m^2; probabilities in [0, 1]. :func:`modeling.model.build.build_model` makes
them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from modeling.model.relations import SegmentRelations
from modeling.observation import FloorObservation
from modeling.types import FloatArray
from modeling.validation import positive

if TYPE_CHECKING:  # pragma: no cover
    import networkx as nx

    from modeling.model.topology import Route

__all__ = ["CriticalRegion", "EnvironmentModel", "Obstacle", "Passage", "Situation"]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Obstacle:
    """A cluster of segments no robot can pass between (a component of impassable relations).

    Attributes:
        points: (k, 2) endpoint means of its segments, world frame, metres.
        polygon: (m, 2) convex hull of ``points`` (counter-clockwise, not closed; when they are
            collinear, the rectangle around them at distance ``outline_buffer_m``), metres: the
            plane figure of the paper. For a non-convex cluster (an L of walls) it covers free
            floor; use :meth:`outline` for the exact shape.
        segments: Indices into ``observation.segments`` of its unambiguous segments.
        candidates: ``(ambiguous index, candidate index)`` of its ambiguous-segment candidates.
        lines: (q, 2, 2) its skeleton: its segments' mean endpoints, then the impassable links
            (closest point to closest point) that join them, metres.
    """

    points: FloatArray
    polygon: FloatArray
    segments: tuple[int, ...]
    candidates: tuple[tuple[int, int], ...] = ()
    lines: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))

    def outline(self, radius_m: float) -> Any:
        """The skeleton grown by ``radius_m`` (> 0) as a shapely geometry (may have holes)."""
        r = positive(radius_m, "radius_m")
        lines = self.lines if self.lines.shape[0] else self.points.reshape(-1, 2, 2)
        return shapely.buffer(shapely.multilinestrings(safe_linestrings(lines)), r, quad_segs=4)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class CriticalRegion:
    """A space between two obstacles whose passability is undecided (Fig. 5).

    Attributes:
        obstacles: ``(i, j)``, ``i < j``, indices into the situation's obstacles.
        polygon: (m, 2) convex hull of the endpoints of all its undecided relations,
            counter-clockwise, not closed (a 0.1 m wide rectangle when they are collinear, so it
            is never degenerate), metres.
        width_mean_m: Mean of the distance across the narrowest undecided relation, metres
            (12 x 12 Gauss-Hermite rule: within about 1 cm, or 4 % of the standard deviation,
            when the mean difference is within a few standard deviations of zero; closer
            otherwise).
        width_std_m: Its standard deviation, metres (from the exact second moment).
        p_passable: Probability that the narrowest relation is wider than the robot.
        narrowest: (2, 2) the mean closest points of the narrowest relation (row 0 on obstacle i).
        relations: Indices into ``model.relations`` of its undecided relations (least passable
            first).
        relation_lines: (k, 2, 2) the closest points of each of those relations, metres.
    """

    obstacles: tuple[int, int]
    polygon: FloatArray
    width_mean_m: float
    width_std_m: float
    p_passable: float
    narrowest: FloatArray
    relations: tuple[int, ...] = ()
    relation_lines: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Passage:
    """The narrowest clearly passable gap between two obstacles (examined pairs only).

    Attributes:
        obstacles: ``(i, j)``, ``i < j``, indices into the situation's obstacles.
        narrowest: (2, 2) the mean closest points (row 0 on obstacle i), metres.
        width_mean_m: Distance between them, metres.
        p_passable: Probability that the gap is wider than the robot (> 1 - eps).
        relation: Index into ``model.relations``.
    """

    obstacles: tuple[int, int]
    narrowest: FloatArray
    width_mean_m: float
    p_passable: float
    relation: int


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Situation:
    """One possible state of the environment (one choice per ambiguous unit).

    Attributes:
        probability: Its probability (Eq. 2).
        obstacles: Its obstacles.
        critical_regions: Its critical regions (one per obstacle pair with undecided relations).
        choice: ``{ambiguous segment index: candidate index}`` chosen in this situation (for every
            member of every remaining unit); ``-1`` (``modeling.model.ambiguity.NONE``) when the
            choice is "none" (probability ``p_none``): the segment is no obstacle in this situation,
            and no item of it is in the situation.
        passages: Narrowest clearly passable gap per nearby obstacle pair.
        robot_width_m: Robot width the model was built for, metres.
    """

    probability: float
    obstacles: tuple[Obstacle, ...]
    critical_regions: tuple[CriticalRegion, ...]
    choice: dict[int, int]
    passages: tuple[Passage, ...] = ()
    robot_width_m: float

    def path_graph(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], **kw: Any
    ) -> nx.Graph:
        """The graph of possible paths from ``start_xy`` to ``goal_xy``; see
        :func:`modeling.model.topology.path_graph`."""
        from modeling.model.topology import path_graph

        return path_graph(self, start_xy, goal_xy, **kw)

    def routes(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], *, max_routes: int = 5, **kw: Any
    ) -> list[Route]:
        """The shortest distinct routes from ``start_xy`` to ``goal_xy`` (one per sequence of
        critical regions), shortest first; see :func:`modeling.model.topology.routes`. ``kw`` goes
        to :func:`modeling.model.topology.path_graph`."""
        from modeling.model.topology import path_graph, routes

        return routes(path_graph(self, start_xy, goal_xy, **kw), max_routes=max_routes)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class EnvironmentModel:
    """The modeling result: possible situations, most probable first.

    Attributes:
        situations: Sorted by probability, descending.
        residual_probability: Probability mass of the situations left out (``max_situations``);
            ``sum(s.probability) + residual_probability == 1``.
        occluded: Occluded polygons, each (m, 2) exterior ring, world frame, metres: the floor
            behind the obstacles of the most probable situation (see
            :mod:`modeling.model.occlusion`).
        observation: The input observation.
        robot_width_m: Robot width, metres.
        eps: Classification tolerance.
        relations: Relations between items (see ``item_segment`` / ``item_candidate``).
        item_segment: (N,) index into ``observation.segments`` of each item, -1 for a candidate.
        item_candidate: (N, 2) ``(ambiguous index, candidate index)`` of each item (-1: segment).
        kept_segments: Indices of the unambiguous segments kept (not isolated and short).
        eliminated_segments: Indices of the unambiguous segments eliminated as isolated and short.
        eliminated_ambiguous: Ambiguous indices eliminated: isolated short ones and those whose
            candidates all have the same effect.
        merged_ambiguous: ``{ambiguous index: candidate index}`` of eliminated ones whose common
            effect was not empty; that candidate is part of every situation (Fig. 8).
        units: Ambiguous segments moving together (Fig. 7), one tuple per remaining unit.
        groups: Independent groups of remaining ambiguous segments (Fig. 9).
    """

    situations: tuple[Situation, ...]
    residual_probability: float
    occluded: tuple[FloatArray, ...]
    observation: FloorObservation
    robot_width_m: float
    eps: float
    relations: SegmentRelations
    item_segment: np.ndarray
    item_candidate: np.ndarray
    kept_segments: tuple[int, ...] = ()
    eliminated_segments: tuple[int, ...] = ()
    eliminated_ambiguous: tuple[int, ...] = ()
    merged_ambiguous: dict[int, int] = field(default_factory=dict)
    units: tuple[tuple[int, ...], ...] = ()
    groups: tuple[tuple[int, ...], ...] = ()

    @property
    def occluded_geometry(self) -> Any:
        """The occluded area as one shapely geometry: the polygons of ``occluded`` (an empty
        Polygon, a Polygon or a MultiPolygon), made on each access."""
        if not self.occluded:
            return shapely.Polygon()
        sizes = [ring.shape[0] for ring in self.occluded]
        rings = shapely.linearrings(
            np.concatenate(self.occluded), indices=np.repeat(np.arange(len(sizes)), sizes)
        )
        polygons = shapely.polygons(rings)
        return polygons[0] if len(self.occluded) == 1 else shapely.multipolygons(polygons)

    @property
    def most_probable(self) -> Situation:
        """The most probable situation."""
        return self.situations[0]

    @property
    def probabilities(self) -> FloatArray:
        """(K,) the situations' probabilities."""
        return np.array([s.probability for s in self.situations])


def safe_linestrings(coords: FloatArray) -> np.ndarray:
    """shapely LineStrings of (q, 2, 2) coordinates (metres); zero-length lines are nudged to 1
    micron along x, so that every line has a length."""
    coords = np.asarray(coords, dtype=np.float64).reshape(-1, 2, 2)
    d = coords[:, 1] - coords[:, 0]
    zero = np.hypot(d[:, 0], d[:, 1]) < 1e-9
    if np.any(zero):
        coords = coords.copy()
        coords[zero, 1, 0] += 1e-6
    out: np.ndarray = shapely.linestrings(coords)
    return out
