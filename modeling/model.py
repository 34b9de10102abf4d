"""Obstacles, free spaces and possible situations from a floor observation (paper section 4).

:func:`build_model` turns a :class:`~modeling.observation.FloorObservation` into an
:class:`EnvironmentModel`: a list of possible :class:`Situation` s with their probabilities, each
made of :class:`Obstacle` s and :class:`CriticalRegion` s, plus the occluded area. The stages (after
ARCHITECTURE.md, stages 5-10):

1. *Items.* Every unambiguous segment and every candidate of every ambiguous segment is an item;
   relations (:mod:`modeling.relations`) are computed once between nearby items (candidates of the
   same ambiguous segment are never related: they never coexist).
2. *Isolated short segments* (section 4.1): an unambiguous segment shorter than
   ``min_isolated_length_m`` whose relations to all other unambiguous segments are passable is
   dropped; an ambiguous segment is dropped when every candidate is short and isolated.
3. *Base obstacles*: connected components of impassable relations among the kept unambiguous
   segments (a vectorised union-find).
4. *Ambiguous segments* (section 4.2):

   * Fig. 7, *moving together*: two ambiguous segments with the same number of candidates whose
     candidates, ordered by distance from the viewpoint, are displaced consistently (the k-th
     displacement of each agrees within ``0.1 m + 0.2 |displacement|``) and lie within a robot
     width of each other form one *unit*; a unit chooses one candidate rank for all its members and
     counts once (its probabilities are the mean of its members').
   * The *effect* of a unit's choice on the base model is the set of changes of space passability
     it causes: a merge of two obstacles it is impassable to both (space becomes impassable), a new
     undecided relation between an obstacle it joins and another one where the space was passable,
     or, for a free-standing candidate, a new undecided space near the obstacles it is undecided to.
     Changes of width within an already undecided space are neglected, as in the paper.
   * Fig. 8: a unit whose every choice has the same effect is eliminated. If that common effect is
     not empty (e.g. every position joins obstacles A and C), its most probable candidate is added
     to every situation, so the obstacles are merged; otherwise it is dropped. This repeats until
     no unit is eliminated.
   * Fig. 9: the remaining units are split into independent groups: two units are in one group when
     they affect a common space (obstacle pair) or when any of their candidates are not passable
     to each other (connected components).
   * Eq. 2: a situation is one choice per unit; its probability is the product of the choices'
     probabilities. Since the product factorises over units, the ``max_situations`` most probable
     situations are enumerated best-first with a heap in which every joint choice has exactly one
     parent at least as probable (see ``_k_best``): exact probabilities, ``O(k log k)``, no
     enumeration of the full product; the mass left out is ``residual_probability``.

5. *Per situation*: obstacles are the connected components of impassable relations among its items;
   an obstacle's ``polygon`` is the convex hull of its endpoints (the paper's plane figure) and its
   ``lines`` the skeleton (segments plus the impassable links, closest point to closest point), see
   :meth:`Obstacle.outline`. Between two obstacles, all undecided relations form one
   :class:`CriticalRegion` (convex hull of the relation endpoints) whose width distribution is that
   of its narrowest (least passable) relation. Undecided relations inside one obstacle make no
   region, as in the paper (so a doorway whose two jambs are joined around a room is not one).
   Passable relations shorter than 3 robot widths (among the examined pairs, those within
   ``width + k (sigma_i + sigma_j)``, see :mod:`modeling.relations`) give, per obstacle pair, the
   narrowest :class:`Passage` (used by the path graph). Obstacles, region polygons and width
   moments are cached across situations; polygons of two points, or of collinear ones, are thin
   rectangles so that every polygon has an area.
6. *Occlusion*: the area behind the kept segments (and merged candidates) seen from the viewpoint,
   within the field-of-view wedge of radius ``max_range_m`` (an angular sweep of 361 rays, see
   ``_occlusion``); computed once, treated as free space.

Frames: world, metres; covariances m^2; probabilities in [0, 1].
"""

from __future__ import annotations

import dataclasses
import functools
import heapq
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import shapely

from modeling._compiled import hull as _model_kernel
from modeling._compiled import ray as _ray_kernel
from modeling.validation import FloatArray, positive
from modeling.gaps import Relation, _check_eps, gap_width_moments
from modeling.observation import FloorObservation
from modeling.relations import SegmentRelations, closest_points, segment_relations

if TYPE_CHECKING:  # pragma: no cover
    import networkx as nx

    from modeling.topology import Route

__all__ = [
    "CriticalRegion",
    "EnvironmentModel",
    "Obstacle",
    "Passage",
    "Situation",
    "build_model",
]

_IMP = int(Relation.IMPASSABLE)
_UND = int(Relation.UNDECIDED)
_PAS = int(Relation.PASSABLE)
_R = TypeVar("_R")


# ------------------------------------------------------------------------------------ types
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
        return shapely.buffer(shapely.multilinestrings(_safe_lines(lines)), r, quad_segs=4)


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
            member of every remaining unit).
        passages: Narrowest clearly passable gap per nearby obstacle pair.
        robot_width_m: Robot width the model was built for, metres.
    """

    probability: float
    obstacles: tuple[Obstacle, ...]
    critical_regions: tuple[CriticalRegion, ...]
    choice: dict[int, int]
    passages: tuple[Passage, ...] = ()
    robot_width_m: float = 0.5

    def path_graph(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], **kw: Any
    ) -> nx.Graph:
        """The graph of possible paths from ``start_xy`` to ``goal_xy``; see
        :func:`modeling.topology.path_graph`."""
        from modeling.topology import path_graph

        return path_graph(self, start_xy, goal_xy, **kw)

    def routes(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], *, max_routes: int = 5, **kw: Any
    ) -> list[Route]:
        """The shortest distinct routes from ``start_xy`` to ``goal_xy`` (one per sequence of
        critical regions), shortest first; see :func:`modeling.topology.routes`. ``kw`` goes to
        :func:`modeling.topology.path_graph`."""
        from modeling.topology import path_graph, routes

        return routes(path_graph(self, start_xy, goal_xy, **kw), max_routes=max_routes)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class EnvironmentModel:
    """The modeling result: possible situations, most probable first.

    Attributes:
        situations: Sorted by probability, descending.
        residual_probability: Probability mass of the situations left out (``max_situations``);
            ``sum(s.probability) + residual_probability == 1``.
        occluded: Occluded polygons, each (m, 2) exterior ring, world frame, metres.
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
        occluded_geometry: The occluded area as one shapely geometry.
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
    occluded_geometry: Any = None

    @property
    def most_probable(self) -> Situation:
        """The most probable situation."""
        return self.situations[0]

    @property
    def probabilities(self) -> FloatArray:
        """(K,) the situations' probabilities."""
        return np.array([s.probability for s in self.situations])


# ------------------------------------------------------------------------------- helpers
def _components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` nodes with edges ``(i, j)``: (n,) label of
    each node, the smallest node of its component (a compiled union-find: much cheaper than
    scipy's csgraph on the small graphs of one situation, which it calls many times)."""
    return _model_kernel.components(
        int(n), np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    )


def _record_maker(cls: type[_R], names: tuple[str, ...]) -> Callable[..., _R]:
    """A positional constructor of the frozen, slotted dataclass ``cls`` for hot loops.

    ``make(v1, v2, ...)`` sets the fields ``names`` (every field of ``cls``, in that order)
    through their slot descriptors: the same object the generated ``__init__`` makes through
    ``object.__setattr__``, at about 40 % of its cost, which matters for the hundreds of
    regions, passages and obstacles of a large model. The function is generated (as dataclasses
    generates ``__init__``): one line per field, no loop.
    """
    fields_ = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    if set(names) != fields_ or len(names) != len(fields_):
        raise TypeError(f"{cls.__name__} has fields {sorted(fields_)}, not {names}")
    lines = [f"def make({', '.join(names)}):", "    obj = new(cls)"]
    lines += [f"    set_{name}(obj, {name})" for name in names]
    lines.append("    return obj")
    namespace: dict[str, Any] = {"new": object.__new__, "cls": cls}
    namespace.update({f"set_{name}": getattr(cls, name).__set__ for name in names})
    exec("\n".join(lines), namespace)  # the source is built from the class's field names
    make: Callable[..., _R] = namespace["make"]
    make.__qualname__ = make.__name__ = f"make_{cls.__name__}"
    return make


_make_obstacle = _record_maker(Obstacle, ("points", "polygon", "segments", "candidates", "lines"))
_make_region = _record_maker(
    CriticalRegion,
    (
        "obstacles",
        "polygon",
        "width_mean_m",
        "width_std_m",
        "p_passable",
        "narrowest",
        "relations",
        "relation_lines",
    ),
)
_make_passage = _record_maker(
    Passage, ("obstacles", "narrowest", "width_mean_m", "p_passable", "relation")
)


def _safe_lines(coords: FloatArray) -> Any:
    """shapely LineStrings of (q, 2, 2) coordinates; zero-length lines are nudged to 1 micron."""
    d = coords[:, 1] - coords[:, 0]
    zero = np.hypot(d[:, 0], d[:, 1]) < 1e-9
    if np.any(zero):
        coords = coords.copy()
        coords[zero, 1, 0] += 1e-6
    return shapely.linestrings(coords)


def _split(arr: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
    """``arr`` cut into consecutive read-only views of ``counts`` rows each."""
    arr.setflags(write=False)
    b = [0, *np.cumsum(counts).tolist()]
    return [arr[b[k] : b[k + 1]] for k in range(len(b) - 1)]


def _hulls(
    points: FloatArray, index: np.ndarray, n: int, grow_m: float | FloatArray
) -> list[FloatArray]:
    """Convex hulls (each (m, 2), counter-clockwise, not closed) of point sets (vectorised).

    A degenerate hull (all points on a line, or one point) becomes the rectangle around that
    segment at distance ``grow_m``, so every polygon has an area. GEOS (shapely) makes the hulls
    of the sets of three or more points; the thin-hull test, the orientation and the rectangles
    are one compiled pass (:func:`modeling._compiled.hull.finish_hulls`). Every set is computed on
    its own, so a set's hull does not depend on the other sets of the call: callers batch as many
    sets as they can into one call to share its fixed cost.

    Args:
        points: (p, 2) points, metres.
        index: (p,) sorted set index of each point, in [0, n).
        n: Number of sets (every set non-empty).
        grow_m: Half-thickness of degenerate hulls, metres: one for all sets, or (n,) per set.

    Returns:
        ``n`` read-only (m, 2) arrays.
    """
    if n == 0:
        return []
    counts = np.bincount(index, minlength=n)
    flat = counts <= 2  # a hull of at most two points is flat: no need for GEOS
    big = (~flat).nonzero()[0]
    if big.shape[0]:
        sel = ~flat[index]
        rank = np.cumsum(~flat) - 1
        # Each set is a line string (much cheaper to build than a multipoint), same hull.
        hull = shapely.convex_hull(shapely.linestrings(points[sel], indices=rank[index[sel]]))
        is_poly = shapely.get_type_id(hull) == 3
        flat[big[~is_poly]] = True  # a line or a point: flat
        poly_set = big[is_poly]
        coords = shapely.get_coordinates(hull[is_poly])  # exterior rings (hulls have no holes)
        n_coords = shapely.get_num_coordinates(hull[is_poly])
    else:
        poly_set = np.zeros(0, dtype=np.int64)
        coords = np.zeros((0, 2))
        n_coords = np.zeros(0, dtype=np.int64)
    grow = np.broadcast_to(np.asarray(grow_m, dtype=np.float64), (n,))
    vertices, offsets = _model_kernel.finish_hulls(
        np.ascontiguousarray(points, dtype=np.float64),
        counts,
        flat,
        np.ascontiguousarray(grow),
        poly_set.astype(np.int64),
        coords,
        n_coords.astype(np.int64),
    )
    vertices.setflags(write=False)
    b = offsets.tolist()
    return [vertices[b[k] : b[k + 1]] for k in range(n)]


class _Partition:
    """What one situation's active items make: obstacles, and relation rows between them.

    Computed for every situation first (:func:`_partition`), so that the obstacles and region
    polygons that no earlier situation built are built for all situations in one batch
    (:meth:`_Context.prepare`) before the situations are assembled (:func:`_assemble`).

    Attributes:
        n_obst: Number of obstacles.
        items: (k,) active items sorted by (obstacle, item index).
        counts: (n_obst,) number of items of each obstacle.
        bounds: Where each obstacle's items start in ``items`` (n_obst + 1 entries).
        imp_rows: (q,) rows of the impassable relations inside obstacles (ascending).
        link_obst: (q,) obstacle of each of those rows.
        oi: (m,) obstacle of each relation's first item (-1: inactive).
        oj: (m,) obstacle of each relation's second item.
        und: Undecided rows between obstacles grouped by pair (see :func:`_pair_groups`).
        region_rows: The rows of each group of ``und``.
        pas_rows: (p,) short passable rows between obstacles (ascending).
        obstacles: Its :class:`Obstacle` records, and
        region_polygons: the polygon of each group of ``und``, both set by
            :meth:`_Context.prepare`.
    """

    __slots__ = (
        "bounds",
        "counts",
        "imp_rows",
        "items",
        "link_obst",
        "n_obst",
        "obstacles",
        "oi",
        "oj",
        "pas_rows",
        "region_polygons",
        "region_rows",
        "und",
    )

    def __init__(
        self,
        *,
        items: np.ndarray,
        counts: np.ndarray,
        imp_rows: np.ndarray,
        link_obst: np.ndarray,
        oi: np.ndarray,
        oj: np.ndarray,
        und: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        pas_rows: np.ndarray,
    ) -> None:
        self.n_obst = int(counts.shape[0])
        self.items = items
        self.counts = counts
        self.bounds = [0, *np.cumsum(counts).tolist()]
        self.imp_rows = imp_rows
        self.link_obst = link_obst
        self.oi = oi
        self.oj = oj
        self.und = und
        rows, starts = und[0], und[1]
        stops = [*starts[1:].tolist(), rows.shape[0]] if starts.shape[0] else []
        self.region_rows = [rows[s0:s1] for s0, s1 in zip(starts.tolist(), stops, strict=True)]
        self.pas_rows = pas_rows
        self.obstacles: list[Obstacle] = []
        self.region_polygons: list[FloatArray] = []

    def keys(self) -> list[bytes]:
        """Cache key of each obstacle (its items' bytes)."""
        b = self.bounds
        return [self.items[b[c] : b[c + 1]].tobytes() for c in range(self.n_obst)]

    def region_keys(self) -> list[bytes]:
        """Cache key of each group of ``und`` (its rows' bytes)."""
        return [r.tobytes() for r in self.region_rows]


class _Context:
    """Item arrays and caches shared by the situations of one model.

    Obstacles are identified by their member items and region polygons by their relation rows,
    so situations that share them (most do: they differ by a few ambiguous candidates) build
    them once (:meth:`prepare`); width moments are cached per relation row.
    """

    def __init__(
        self,
        ends: FloatArray,
        rel: SegmentRelations,
        item_segment: np.ndarray,
        item_candidate: np.ndarray,
        outline_buffer_m: float,
        passage_max_m: float,
    ) -> None:
        self.ends = ends
        self.rel = rel
        self.item_segment = item_segment
        self.item_candidate = item_candidate
        self.outline_buffer_m = outline_buffer_m
        m = len(rel)
        self.width_mean = np.full(m, np.nan)
        self.width_std = np.full(m, np.nan)
        self.links = np.stack([rel.point_i, rel.point_j], axis=1)  # (m, 2, 2)
        self.links.setflags(write=False)
        self.is_imp = rel.kind == _IMP
        self.is_und = rel.kind == _UND
        # Passable relations short enough to be a passage (the same in every situation).
        self.is_short_pas = (rel.kind == _PAS) & (rel.distance_m <= passage_max_m)

    def prepare(self, parts: list[_Partition]) -> None:
        """Build, in one batch, the obstacles and region polygons of ``parts`` (each once, from
        the first situation that has it; shared by content between situations), and set each
        part's ``obstacles`` and ``region_polygons``."""
        # Situations share obstacles and regions by content (their items' and rows' bytes); a
        # lone situation shares nothing, so its own indices serve as keys.
        shared = len(parts) > 1
        new_keys: list[bytes | int] = []  # the new obstacles, in the order of their new id
        seen: set[bytes | int] = set()
        it_parts: list[np.ndarray] = []  # their items, grouped by new id
        ob_parts: list[np.ndarray] = []  # the new id of each of those items
        link_parts: list[np.ndarray] = []  # their impassable links (relation rows)
        lob_parts: list[np.ndarray] = []  # the new id of each of those links
        new_regions: dict[bytes | int, np.ndarray] = {}
        keys: list[list[bytes] | range] = []
        region_keys: list[list[bytes] | range] = []
        for part in parts:
            keys.append(part.keys() if shared else range(part.n_obst))
            region_keys.append(part.region_keys() if shared else range(len(part.region_rows)))
            todo = []
            for c, key in enumerate(keys[-1]):
                if key not in seen:
                    seen.add(key)
                    todo.append(c)
            for key, rows in zip(region_keys[-1], part.region_rows, strict=True):
                if key not in new_regions:
                    new_regions[key] = rows
            if todo:
                # Vectorised selection of the new obstacles' items and links (new ids follow
                # the obstacle order, so items stay grouped by new id).
                new_id = np.full(part.n_obst, -1, dtype=np.int64)
                new_id[todo] = np.arange(len(new_keys), len(new_keys) + len(todo))
                new_keys.extend(keys[-1][c] for c in todo)
                ob = new_id[np.repeat(np.arange(part.n_obst), part.counts)]
                keep = ob >= 0
                it_parts.append(part.items[keep])
                ob_parts.append(ob[keep])
                lob = new_id[part.link_obst]
                lk = lob >= 0
                link_parts.append(part.imp_rows[lk])
                lob_parts.append(lob[lk])
        t = len(new_keys)
        empty = np.zeros(0, dtype=np.int64)
        it = np.concatenate(it_parts) if t else empty
        ob = np.concatenate(ob_parts) if t else empty
        link_rows = np.concatenate(link_parts) if t else empty
        lob = np.concatenate(lob_parts) if t else empty
        cnt = np.bincount(ob, minlength=t)
        lcnt = np.bincount(lob, minlength=t)
        pts = self.ends[it].reshape(-1, 2)
        # One hull computation for the obstacles and the regions (points of the regions: the
        # closest points of their relations), each kind with its own degenerate half-width.
        region_rows = list(new_regions.values())
        r_pts = self.links[np.concatenate(region_rows)].reshape(-1, 2) if region_rows else pts[:0]
        r_cnt = np.array([2 * r.shape[0] for r in region_rows], dtype=np.int64)
        n_sets = t + len(region_rows)
        grow = np.concatenate((np.full(t, self.outline_buffer_m), np.full(len(region_rows), 0.05)))
        hulls = _hulls(
            np.concatenate((pts, r_pts)),
            np.repeat(np.arange(n_sets), np.concatenate((2 * cnt, r_cnt))),
            n_sets,
            grow,
        )
        # Skeleton: the obstacle's segments, then its impassable links (closest points).
        order = np.argsort(np.concatenate((ob, lob)), kind="stable")
        lines = np.concatenate([self.ends[it], self.links[link_rows]])[order]
        line_parts = _split(lines, cnt + lcnt)
        pt_parts = _split(pts, 2 * cnt)
        seg_of = self.item_segment[it].tolist()
        cand_of = self.item_candidate[it].tolist()
        start = 0
        obstacles = []
        for k, n_items in enumerate(cnt.tolist()):
            stop = start + n_items
            obstacles.append(
                _make_obstacle(
                    pt_parts[k],
                    hulls[k],
                    tuple([s for s in seg_of[start:stop] if s >= 0]),
                    tuple([(a, b) for a, b in cand_of[start:stop] if a >= 0]),
                    line_parts[k],
                )
            )
            start = stop
        by_key = dict(zip(new_keys, obstacles, strict=True))
        region_by_key = dict(zip(new_regions, hulls[t:], strict=True))
        for part, part_keys, part_region_keys in zip(parts, keys, region_keys, strict=True):
            part.obstacles = [by_key[k] for k in part_keys]
            part.region_polygons = [region_by_key[k] for k in part_region_keys]

    def moments(self, rows: np.ndarray) -> tuple[list[float], list[float]]:
        """Mean and standard deviation (metres) of the width of each relation row (cached)."""
        todo = rows[np.isnan(self.width_mean[rows])]
        if todo.size:
            rel = self.rel
            mean, std = gap_width_moments(
                rel.point_j[todo] - rel.point_i[todo], rel.cov_i[todo] + rel.cov_j[todo]
            )
            self.width_mean[todo] = mean
            self.width_std[todo] = std
        return self.width_mean[rows].tolist(), self.width_std[rows].tolist()


def _oriented(ctx: _Context, rows: np.ndarray, i_first: np.ndarray) -> FloatArray:
    """(k, 2, 2) closest points of relation rows, the point on the lower-index obstacle first."""
    out = ctx.links[rows]
    out[~i_first] = out[~i_first, ::-1]
    out.setflags(write=False)
    return out


def _pair_groups(
    rows: np.ndarray, oi: np.ndarray, oj: np.ndarray, n_obst: int, within: FloatArray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relation rows grouped by obstacle pair, each group sorted by ``within`` (ascending).

    Returns:
        ``(rows, starts, lo, hi)``: the sorted rows, the start of each group in them, and the
        group's obstacle pair ``lo < hi``.
    """
    a, b = oi[rows], oj[rows]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (n_obst + 1) + hi
    srt = np.lexsort((within[rows], key))
    rows, key = rows[srt], key[srt]
    starts = np.concatenate(([True], key[1:] != key[:-1])).nonzero()[0]
    return rows, starts, lo[srt][starts], hi[srt][starts]


def _partition(ctx: _Context, active: np.ndarray) -> _Partition:
    """Obstacles of the situation whose items are ``active``, and its relations between them."""
    rel = ctx.rel
    n = active.shape[0]
    both = active[rel.i] & active[rel.j]
    imp_rows = (both & ctx.is_imp).nonzero()[0]
    labels = _components(n, rel.i[imp_rows], rel.j[imp_rows])
    act_idx = active.nonzero()[0]
    # Obstacles numbered in order of their smallest item (a component's label): the roots (the
    # active items that are their own label) in ascending order.
    act_labels = labels[act_idx]
    roots = act_idx[act_labels == act_idx]
    obst_of_root = np.empty(n, dtype=np.int64)
    obst_of_root[roots] = np.arange(roots.shape[0])
    obst_active = obst_of_root[act_labels]
    obst_of_item = np.full(n, -1, dtype=np.int64)
    obst_of_item[act_idx] = obst_active
    oi = obst_of_item[rel.i]
    oj = obst_of_item[rel.j]
    between = both & (oi != oj)
    n_obst = roots.shape[0]
    und_rows = (between & ctx.is_und).nonzero()[0]
    # The narrowest relation of a region is its least passable one (first in its group).
    und = (
        _pair_groups(und_rows, oi, oj, n_obst, rel.p_passable)
        if und_rows.shape[0]
        else (und_rows, und_rows, und_rows, und_rows)
    )
    return _Partition(
        items=act_idx[np.argsort(obst_active, kind="stable")],
        counts=np.bincount(obst_active, minlength=n_obst),
        imp_rows=imp_rows,
        link_obst=obst_of_item[rel.i[imp_rows]],
        oi=oi,
        oj=oj,
        und=und,
        pas_rows=(between & ctx.is_short_pas).nonzero()[0],
    )


def _regions(ctx: _Context, part: _Partition) -> list[CriticalRegion]:
    """One critical region per obstacle pair with undecided relations between them.

    Args:
        ctx: The model's context (region polygons already built by :meth:`_Context.prepare`).
        part: The situation's partition.
    """
    rows, starts, ra, rb = part.und
    if rows.size == 0:
        return []
    rel = ctx.rel
    oi, oj = part.oi, part.oj
    stops = [*starts[1:].tolist(), rows.shape[0]]
    narrowest = rows[starts]
    polys = part.region_polygons
    w_mean, w_std = ctx.moments(narrowest)
    narrow_pts = list(_oriented(ctx, narrowest, oi[narrowest] <= oj[narrowest]))
    rel_lines = ctx.links[rows]
    rel_lines.setflags(write=False)
    rows_list = rows.tolist()
    return [
        _make_region((a_, b_), poly, wm, ws, p_, nw, tuple(rows_list[s0:s1]), rel_lines[s0:s1])
        for a_, b_, poly, wm, ws, p_, nw, s0, s1 in zip(
            ra.tolist(),
            rb.tolist(),
            polys,
            w_mean,
            w_std,
            rel.p_passable[narrowest].tolist(),
            narrow_pts,
            starts.tolist(),
            stops,
            strict=True,
        )
    ]


def _passages(ctx: _Context, part: _Partition) -> list[Passage]:
    """The narrowest passage per obstacle pair among the situation's short passable relations.

    Args: as :func:`_regions`.
    """
    rows = part.pas_rows
    if rows.size == 0:
        return []
    rel = ctx.rel
    oi, oj = part.oi, part.oj
    rows, starts, ra, rb = _pair_groups(rows, oi, oj, part.n_obst, rel.distance_m)
    first = rows[starts]
    narrow_pts = list(_oriented(ctx, first, oi[first] <= oj[first]))
    return [
        _make_passage((a_, b_), nw, d_, p_, r0)
        for a_, b_, nw, d_, p_, r0 in zip(
            ra.tolist(),
            rb.tolist(),
            narrow_pts,
            rel.distance_m[first].tolist(),
            rel.p_passable[first].tolist(),
            first.tolist(),
            strict=True,
        )
    ]


def _situations(
    ctx: _Context,
    actives: list[np.ndarray],
    probabilities: list[float],
    choices: list[dict[int, int]],
    robot_width_m: float,
) -> list[Situation]:
    """Obstacles, critical regions and passages of each situation whose items are ``actives``.

    Three passes: the partitions of all situations, then one batch for every obstacle and region
    polygon not cached yet, then the situations (their width moments in situation order).
    """
    parts = [_partition(ctx, active) for active in actives]
    ctx.prepare(parts)
    return [
        Situation(
            probability=float(probability),
            obstacles=tuple(part.obstacles),
            critical_regions=tuple(_regions(ctx, part)),
            choice=dict(sorted(choice.items())),
            passages=tuple(_passages(ctx, part)),
            robot_width_m=robot_width_m,
        )
        for part, probability, choice in zip(parts, probabilities, choices, strict=True)
    ]


def _occlusion(obs: FloorObservation, ends: FloatArray, n_rays: int = 361) -> Any:
    """The area behind segments ``ends`` (n, 2, 2) seen from the viewpoint, within FOV and range.

    An angular sweep: ``n_rays`` rays across the field of view find the nearest segment (mean
    geometry); each run of consecutive rays that hit something within ``max_range_m`` gives one
    occluded polygon, from the hit points out to the range (angular resolution
    ``fov / (n_rays - 1)``, 0.18 deg by default). Only the rays within a segment's angular span
    are intersected with it.

    Returns:
        A shapely (Multi)Polygon, possibly empty; world frame, metres.
    """
    vp = np.asarray(obs.viewpoint[:2], dtype=np.float64)
    R = float(obs.max_range_m)
    half = 0.5 * float(obs.fov_rad)
    if ends.shape[0] == 0:
        return _EMPTY_POLYGON
    heading = float(obs.viewpoint[2])
    step = 2.0 * half / (n_rays - 1)
    ang = heading + _ray_offsets(half, n_rays)
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # (B, 2)
    p = ends[:, 0] - vp
    e = ends[:, 1] - ends[:, 0]
    # Angular span of each segment relative to the heading (the arc it subtends, < pi).
    a0 = np.arctan2(p[:, 1], p[:, 0]) - heading
    a1 = np.arctan2(p[:, 1] + e[:, 1], p[:, 0] + e[:, 0]) - heading
    a0 = (a0 + np.pi) % (2.0 * np.pi) - np.pi
    a1 = (a1 + np.pi) % (2.0 * np.pi) - np.pi
    lo, hi = np.minimum(a0, a1), np.maximum(a0, a1)
    ok = hi - lo < np.pi  # a segment whose shorter arc passes behind the viewpoint: not in FOV
    k0 = np.clip(np.ceil((lo + half) / step - 1e-9), 0, n_rays).astype(np.int64)
    k1 = np.clip(np.floor((hi + half) / step + 1e-9), -1, n_rays - 1).astype(np.int64)
    cnt = np.where(ok, np.maximum(k1 - k0 + 1, 0), 0)
    if not cnt.any():
        return _EMPTY_POLYGON
    rng = _ray_kernel.nearest_hits(u, p, e, k0, cnt)
    # Runs of consecutive blocked rays -> polygons (the wedge minus the star polygon of the ray
    # hits), all rings in one vectorised call (shapely closes each ring, as Polygon(shell) does).
    vertices, sizes = _ray_kernel.shadow_rings(vp, u, rng, R)
    if sizes.shape[0] == 0:
        return _EMPTY_POLYGON
    polys = shapely.polygons(
        shapely.linearrings(vertices, indices=np.repeat(np.arange(sizes.shape[0]), sizes))
    )
    return polys[0] if sizes.shape[0] == 1 else shapely.multipolygons(polys)


# The empty result of ``_occlusion`` (shapely geometries are immutable: one can be shared, and
# building it costs more than the rest of a small occlusion sweep).
_EMPTY_POLYGON = shapely.Polygon()


@functools.lru_cache(maxsize=16)
def _ray_offsets(half: float, n_rays: int) -> FloatArray:
    """(n_rays,) ray angles relative to the heading, read-only (cached: the field of view of a
    camera does not change between observations)."""
    out = np.linspace(-half, half, n_rays)
    out.setflags(write=False)
    return out


def _polygons_of(geom: Any) -> tuple[FloatArray, ...]:
    """Exterior rings (m, 2), not closed, of the polygons of ``geom`` with an area."""
    if geom is None or shapely.is_empty(geom):
        return ()
    parts = getattr(geom, "geoms", [geom])
    out = []
    for g in parts:
        if g.geom_type == "Polygon" and not g.is_empty and g.area > 1e-9:
            ring = np.asarray(g.exterior.coords, dtype=np.float64)[:-1]
            ring.setflags(write=False)
            out.append(ring)
    return tuple(out)


def _k_best(probs: list[np.ndarray], k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The ``k`` most probable joint choices of independent factors, best first (exact products).

    Best-first search in which every joint choice has exactly one parent that is at least as
    probable: factors are ordered by the loss of their first step down (``p[1] / p[0]``,
    largest first); a choice's children raise the rank of its last moved factor, move the next
    factor to rank 1, or, when the last moved factor is at rank 1, hand that step to the next
    factor. So each choice is generated once, with at most three heap pushes per output, and
    ``O(k log k + k n)`` work in all.

    Args:
        probs: One (m_u,) array per factor, sorted descending.
        k: How many to return.

    Returns:
        ``(probability, ranks)`` pairs, most probable first; ``ranks[u]`` indexes ``probs[u]``.
    """
    n = len(probs)
    plist = [p.tolist() for p in probs]
    logs = [[math.log(max(x, 1e-300)) for x in p] for p in plist]
    seq = sorted((u for u in range(n) if len(plist[u]) > 1), key=lambda u: logs[u][0] - logs[u][1])
    q = len(seq)
    start = (0,) * n
    heap: list[tuple[float, int, tuple[int, ...], int]] = [
        (-math.fsum(lg[0] for lg in logs), 0, start, -1)
    ]
    count = 1
    out: list[tuple[float, tuple[int, ...]]] = []
    while heap and len(out) < k:
        neg, _, state, last = heapq.heappop(heap)
        out.append((math.prod(plist[u][s] for u, s in enumerate(state)), state))
        children: list[tuple[float, tuple[int, ...], int]] = []
        if last >= 0:
            u = seq[last]
            r = state[u]
            if r + 1 < len(plist[u]):
                children.append((logs[u][r] - logs[u][r + 1], _with(state, u, r + 1), last))
        if last + 1 < q:
            v = seq[last + 1]
            loss = logs[v][0] - logs[v][1]
            children.append((loss, _with(state, v, 1), last + 1))
            if last >= 0 and state[seq[last]] == 1:
                u = seq[last]
                back = logs[u][1] - logs[u][0]
                children.append((loss + back, _with(_with(state, u, 0), v, 1), last + 1))
        for loss, child, pos in children:
            heapq.heappush(heap, (neg + loss, count, child, pos))
            count += 1
    return out


def _with(state: tuple[int, ...], u: int, value: int) -> tuple[int, ...]:
    """``state`` with entry ``u`` set to ``value``."""
    return (*state[:u], value, *state[u + 1 :])


# ------------------------------------------------------------------------------- build
def build_model(
    observation: FloorObservation,
    robot_width_m: float,
    *,
    eps: float = 0.05,
    max_situations: int = 64,
    min_isolated_length_m: float = 0.1,
    outline_buffer_m: float = 0.02,
) -> EnvironmentModel:
    """Model obstacles, free spaces and possible situations from a floor observation.

    Args:
        observation: The floor segments (unambiguous and ambiguous), world frame.
        robot_width_m: Robot width (diameter), metres, > 0.
        eps: Classification tolerance in (0, 0.5): passable if ``p > 1 - eps``, impassable if
            ``p < eps``, undecided otherwise.
        max_situations: At most this many situations are returned, most probable first.
        min_isolated_length_m: Isolated segments shorter than this are dropped (metres, >= 0).
        outline_buffer_m: Half-width of the rectangle that stands for the polygon of an obstacle
            whose points are collinear (one segment, or a straight wall), metres (> 0).

    Returns:
        The :class:`EnvironmentModel` (see the module docstring for the stages).

    Raises:
        ValueError: Bad arguments, naming them.
    """
    if not isinstance(observation, FloorObservation):
        raise ValueError(
            f"observation must be a FloorObservation, got {type(observation).__name__}"
        )
    width = positive(robot_width_m, "robot_width_m")
    eps = _check_eps(eps)
    if isinstance(max_situations, bool) or not isinstance(max_situations, int | np.integer):
        raise ValueError(f"max_situations must be an integer >= 1, got {max_situations!r}")
    if max_situations < 1:
        raise ValueError(f"max_situations must be an integer >= 1, got {max_situations!r}")
    min_len = positive(min_isolated_length_m, "min_isolated_length_m", allow_zero=True)
    buf = positive(outline_buffer_m, "outline_buffer_m")

    segs = observation.segments
    amb = observation.ambiguous
    n_seg = len(segs)
    ends_l = [s.endpoints for s in segs]
    cov_l = [s.cov for s in segs]
    cand_item: list[list[int]] = []
    for am in amb:
        cand_item.append(list(range(len(ends_l), len(ends_l) + len(am.candidates))))
        ends_l.extend(cand.endpoints for cand in am.candidates)
        cov_l.extend(cand.cov for cand in am.candidates)
    N = len(ends_l)
    # one concatenation of the (2, 2) and (2, 2, 2) arrays (np.asarray of a list of arrays
    # inspects every element first, at twice the cost)
    ends = np.concatenate(ends_l, dtype=np.float64).reshape(N, 2, 2) if N else np.zeros((0, 2, 2))
    covs = (
        np.concatenate(cov_l, dtype=np.float64).reshape(N, 2, 2, 2) if N else np.zeros((0, 2, 2, 2))
    )
    # item k < n_seg is segment k; the others are (ambiguous index, candidate index)
    item_seg_arr = np.full(N, -1, dtype=np.int64)
    item_seg_arr[:n_seg] = np.arange(n_seg)
    item_cand_arr = np.full((N, 2), -1, dtype=np.int64)
    if N > n_seg:
        item_cand_arr[n_seg:] = [
            (a, c) for a, am in enumerate(amb) for c in range(len(am.candidates))
        ]
    item_amb = item_cand_arr[:, 0]
    for arr in (item_seg_arr, item_cand_arr):
        arr.setflags(write=False)

    # Stage 1: relations among all items (never between candidates of one ambiguous segment).
    rel = segment_relations(ends, covs, width, eps)
    same_amb = (item_amb[rel.i] >= 0) & (item_amb[rel.i] == item_amb[rel.j])
    if np.any(same_amb):
        rel = rel.subset(~same_amb)
    nonpass = rel.kind != _PAS
    length = np.hypot(*(ends[:, 1] - ends[:, 0]).T) if N else np.zeros(0)

    # Stage 2: isolated short unambiguous segments.
    is_seg = item_seg_arr >= 0
    seg_pair = nonpass & is_seg[rel.i] & is_seg[rel.j]
    deg_seg = np.bincount(np.concatenate((rel.i[seg_pair], rel.j[seg_pair])), minlength=N)
    drop_seg = is_seg & (deg_seg == 0) & (length < min_len)
    kept_segments = tuple((is_seg & ~drop_seg).nonzero()[0].tolist())
    eliminated_segments = tuple(drop_seg.nonzero()[0].tolist())
    deg_all = np.bincount(np.concatenate((rel.i[nonpass], rel.j[nonpass])), minlength=N)
    live_amb: list[int] = []
    eliminated_amb: list[int] = []
    length_l, deg_l = length.tolist(), deg_all.tolist()  # Python scalars for the loop
    for a, ids in enumerate(cand_item):
        if all(length_l[x] < min_len and deg_l[x] == 0 for x in ids):
            eliminated_amb.append(a)
        else:
            live_amb.append(a)

    ctx = _Context(ends, rel, item_seg_arr, item_cand_arr, buf, 3.0 * width)

    # Fig. 7: units of ambiguous segments moving together.
    vp = np.asarray(observation.viewpoint[:2])
    order_of: dict[int, list[int]] = {}
    if live_amb:
        # Distance of every item's midpoint from the viewpoint, then a stable sort per segment
        # (Python's sort is stable, as ``argsort(kind="stable")`` was).
        mid_dist = np.hypot(*(ends.mean(axis=1) - vp).T).tolist()
        for a in live_amb:
            ids = cand_item[a]
            order_of[a] = sorted(range(len(ids)), key=lambda k, ids=ids: mid_dist[ids[k]])
    units = _group_moving_together(live_amb, cand_item, order_of, ends, width)
    unit_items: list[list[list[int]]] = []  # unit -> rank -> items
    unit_probs: list[np.ndarray] = []
    unit_cands: list[list[dict[int, int]]] = []
    for members in units:
        m = len(cand_item[members[0]])
        unit_items.append([[cand_item[a][order_of[a][k]] for a in members] for k in range(m)])
        pr = np.mean([np.asarray(amb[a].probabilities)[order_of[a]] for a in members], axis=0)
        unit_probs.append(pr / pr.sum())
        unit_cands.append([{a: order_of[a][k] for a in members} for k in range(m)])

    # Fig. 8: eliminate units whose every choice has the same effect (iterate to a fixed point).
    adjacency = _candidate_adjacency(rel, item_amb)
    fixed: list[int] = []  # items present in every situation besides the kept segments
    merged_ambiguous: dict[int, int] = {}
    remaining = list(range(len(units)))
    base_active = np.zeros(N, dtype=bool)
    base_active[list(kept_segments)] = True
    signatures: dict[int, list[frozenset[tuple[str, int, int]]]] = {}
    while remaining:
        labels, und_pairs = _base_state(rel, base_active)
        signatures = {
            u: [
                _signature(items, adjacency, labels, und_pairs, base_active)
                for items in unit_items[u]
            ]
            for u in remaining
        }
        gone = [u for u in remaining if all(s == signatures[u][0] for s in signatures[u])]
        if not gone:
            break
        for u in gone:
            remaining.remove(u)
            eliminated_amb.extend(units[u])
            if signatures[u][0]:
                best = int(np.argmax(unit_probs[u]))
                fixed.extend(unit_items[u][best])
                merged_ambiguous.update(unit_cands[u][best])
        base_active[fixed] = True

    # Fig. 9: independent groups by the spaces they affect, or by interacting candidates.
    affected = {
        u: set().union(*(_spaces(s) for s in signatures[u])) if u in signatures else set()
        for u in remaining
    }
    groups = _independent_groups(remaining, affected, unit_items, adjacency, item_amb, units)

    # Eq. 2: best-first enumeration of situations.
    order_u = [np.argsort(-unit_probs[u], kind="stable") for u in remaining]
    sorted_p = [unit_probs[u][o] for u, o in zip(remaining, order_u, strict=True)]
    # Items and choice of each remaining unit's k-th most probable candidate rank.
    ranked = [
        [(unit_items[u][k], unit_cands[u][k]) for k in o.tolist()]
        for u, o in zip(remaining, order_u, strict=True)
    ]
    actives: list[np.ndarray] = []
    probs: list[float] = []
    choices: list[dict[int, int]] = []
    for prob, state in _k_best(sorted_p, int(max_situations)):
        active = base_active.copy()
        choice: dict[int, int] = {}
        chosen: list[int] = []
        for pos, rank in enumerate(state):
            items, cands = ranked[pos][rank]
            chosen.extend(items)
            choice.update(cands)
        active[chosen] = True
        actives.append(active)
        probs.append(prob)
        choices.append(choice)
    situations = _situations(ctx, actives, probs, choices, width)
    situations.sort(key=lambda s: -s.probability)
    total = math.fsum(s.probability for s in situations)
    residual = max(0.0, 1.0 - total)

    occ = _occlusion(observation, ends[base_active])
    return EnvironmentModel(
        situations=tuple(situations),
        residual_probability=residual,
        occluded=_polygons_of(occ),
        observation=observation,
        robot_width_m=width,
        eps=eps,
        relations=rel,
        item_segment=item_seg_arr,
        item_candidate=item_cand_arr,
        kept_segments=kept_segments,
        eliminated_segments=eliminated_segments,
        eliminated_ambiguous=tuple(sorted(eliminated_amb)),
        merged_ambiguous=dict(sorted(merged_ambiguous.items())),
        units=tuple(tuple(units[u]) for u in remaining),
        groups=groups,
        occluded_geometry=occ,
    )


# ---------------------------------------------------------------------- ambiguity helpers
def _group_moving_together(
    live: list[int],
    cand_item: list[list[int]],
    order_of: dict[int, list[int]],
    ends: FloatArray,
    width: float,
) -> list[list[int]]:
    """Fig. 7: units (lists of ambiguous indices) whose candidates move together (vectorised)."""
    if not live:
        return []
    pos = {a: k for k, a in enumerate(live)}
    ii: list[np.ndarray] = []
    jj: list[np.ndarray] = []
    by_m: dict[int, list[int]] = {}
    for a in live:
        by_m.setdefault(len(cand_item[a]), []).append(a)
    for m, members in by_m.items():
        if len(members) < 2:
            continue
        E = np.stack([ends[cand_item[a]][order_of[a]] for a in members])  # (q, m, 2, 2)
        mids = E.mean(axis=2)
        disp = mids - mids[:, :1]  # (q, m, 2)
        # Every pair x < y of members, in row-major order (what ``np.triu_indices`` gives, at a
        # fraction of its cost for the few members seen here).
        x, y = np.array(list(itertools.combinations(range(len(members)), 2)), np.int64).T
        tol = 0.1 + 0.2 * np.hypot(disp[x, :, 0], disp[x, :, 1])
        ok = (np.hypot(*np.moveaxis(disp[x] - disp[y], -1, 0)) <= tol).all(axis=1)
        x, y = x[ok], y[ok]
        if x.size == 0:
            continue
        ea = E[x].reshape(-1, 2, 2)
        eb = E[y].reshape(-1, 2, 2)
        s, t = closest_points(ea[:, 0], ea[:, 1], eb[:, 0], eb[:, 1])
        pa = ea[:, 0] + s[:, None] * (ea[:, 1] - ea[:, 0])
        pb = eb[:, 0] + t[:, None] * (eb[:, 1] - eb[:, 0])
        close = (np.hypot(*(pa - pb).T) <= width).reshape(-1, m).all(axis=1)
        ii.append(np.array([pos[members[k]] for k in x[close]], dtype=np.int64))
        jj.append(np.array([pos[members[k]] for k in y[close]], dtype=np.int64))
    cat = (lambda v: np.concatenate(v)) if ii else (lambda v: np.zeros(0, dtype=np.int64))
    labels = _components(len(live), cat(ii), cat(jj))
    out: dict[int, list[int]] = {}
    for k, a in enumerate(live):
        out.setdefault(int(labels[k]), []).append(a)
    return sorted(out.values(), key=lambda m: m[0])


def _candidate_adjacency(rel: SegmentRelations, item_amb: np.ndarray) -> dict[int, dict[int, int]]:
    """For every candidate item: ``{other item: relation kind}`` of its non-passable relations."""
    adj: dict[int, dict[int, int]] = {}
    rows = ((rel.kind != _PAS) & ((item_amb[rel.i] >= 0) | (item_amb[rel.j] >= 0))).nonzero()[0]
    # Python ints (``tolist``) for the loop: numpy scalars would be converted row by row.
    is_cand = (item_amb >= 0).tolist()
    for i, j, k in zip(
        rel.i[rows].tolist(), rel.j[rows].tolist(), rel.kind[rows].tolist(), strict=True
    ):
        if is_cand[i]:
            adj.setdefault(i, {})[j] = k
        if is_cand[j]:
            adj.setdefault(j, {})[i] = k
    return adj


def _base_state(
    rel: SegmentRelations, active: np.ndarray
) -> tuple[np.ndarray, set[tuple[int, int]]]:
    """Component labels of the active items and the set of undecided component pairs."""
    both = active[rel.i] & active[rel.j]
    imp = both & (rel.kind == _IMP)
    labels = _components(active.shape[0], rel.i[imp], rel.j[imp])
    und = both & (rel.kind == _UND)
    li, lj = labels[rel.i[und]], labels[rel.j[und]]
    pairs = {(int(min(x, y)), int(max(x, y))) for x, y in zip(li, lj, strict=True) if x != y}
    return labels, pairs


def _signature(
    items: list[int],
    adjacency: dict[int, dict[int, int]],
    labels: np.ndarray,
    und_pairs: set[tuple[int, int]],
    active: np.ndarray,
) -> frozenset[tuple[str, int, int]]:
    """The changes of space passability caused by adding ``items`` to the base model."""
    joined: set[int] = set()
    undecided: set[int] = set()
    for it in items:
        for other, kind in adjacency.get(it, {}).items():
            if not active[other]:
                continue
            lab = int(labels[other])
            if kind == _IMP:
                joined.add(lab)
            else:
                undecided.add(lab)
    undecided -= joined
    changes: set[tuple[str, int, int]] = set()
    js = sorted(joined)
    for x, a in enumerate(js):
        for b in js[x + 1 :]:
            changes.add(("merge", a, b))
    if js:
        for b in undecided:
            for a in js:
                pair = (min(a, b), max(a, b))
                if pair not in und_pairs:
                    changes.add(("undecided", *pair))
    elif undecided:
        us = sorted(undecided)
        if len(us) == 1:
            changes.add(("near", us[0], us[0]))
        for x, a in enumerate(us):
            for b in us[x + 1 :]:
                if (a, b) not in und_pairs:
                    changes.add(("undecided", a, b))
    return frozenset(changes)


def _spaces(signature: frozenset[tuple[str, int, int]]) -> set[tuple[int, int]]:
    return {(a, b) for _, a, b in signature}


def _independent_groups(
    remaining: list[int],
    affected: dict[int, set[tuple[int, int]]],
    unit_items: list[list[list[int]]],
    adjacency: dict[int, dict[int, int]],
    item_amb: np.ndarray,
    units: list[list[int]],
) -> tuple[tuple[int, ...], ...]:
    """Fig. 9: connected components of units sharing a space or with interacting candidates."""
    if not remaining:
        return ()
    pos = {u: k for k, u in enumerate(remaining)}
    unit_of_amb = {a: u for u in remaining for a in units[u]}
    ii: list[int] = []
    jj: list[int] = []
    by_space: dict[tuple[int, int], list[int]] = {}
    for u in remaining:
        for sp in affected[u]:
            by_space.setdefault(sp, []).append(pos[u])
        for items in unit_items[u]:
            for it in items:
                for other in adjacency.get(it, {}):
                    v = unit_of_amb.get(int(item_amb[other]))
                    if v is not None and v != u:
                        ii.append(pos[u])
                        jj.append(pos[v])
    for members in by_space.values():
        ii.extend(members[:-1])
        jj.extend(members[1:])
    labels = _components(len(remaining), np.asarray(ii, np.int64), np.asarray(jj, np.int64))
    out: dict[int, list[int]] = {}
    for u in remaining:
        out.setdefault(int(labels[pos[u]]), []).extend(units[u])
    return tuple(sorted(tuple(sorted(g)) for g in out.values()))
