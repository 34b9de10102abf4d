"""What the scripted agents remember between observations: an occupancy map and the gates.

The environment model of one observation covers only the field of view of one stereo pair
(ARCHITECTURE.md: ``info["model"]`` is the model of the latest observation). The agents keep, in
the world frame:

* :class:`OccupancyMap`: log-odds occupancy on a regular grid over the room's bounds. Every
  observation adds the obstacles of its situations, weighted by the situations' probabilities,
  and every unambiguous floor segment (also those the model drops as isolated and short: a
  vertical edge seen alone is still something solid), within ``insert_range_m`` (far segments are
  poorly localised); it clears what it sees free (inside the field of view, within range, not
  occluded). Bumps (``info["collision"]``) leave marks: the robot feels what its stereo head
  cannot see (plain walls have no edges between the floor and the robot's height). With the
  env's fused memory (``info["memory_model"]``, :mod:`modeling.memory.fusion`), the obstacles of its
  most probable situation within ``fused_range_m`` of the head count as seen in every
  observation too: what one view loses and the memory keeps (a face closed from farther away,
  bookshelf dividers whose ambiguity later views resolved, an edge that left the field of view)
  stays in the grid while the robot drives up to it. Only nearby: far confident phantoms of the
  memory would close routes. Off by default (``fused_range_m`` 0): on the suite it cuts
  collisions and closes narrow passages (``docs/evaluation.md``).
* :class:`GateHistory`: the critical regions seen so far, as :class:`Gate` s with the width
  distribution of their narrowest relation. A new observation of the same region replaces the
  estimate when it is not much less certain (a closer look narrows it); a look at a remembered gate
  that finds both its sides but no critical region between them decides it (passable when they are
  different obstacles, impassable when they merged). A bump near a gate closes it, unless the
  robot has driven through it: a gate whose narrowest relation the robot's centre crossed is
  passable for good (a bump just beyond it, in a pocket, must not close the way back out).

Frames and units: world, metres; a grid cell ``(row, col)`` is ``(y, x)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from numpy.typing import NDArray

from modeling.geometry import wrap_angle
from modeling.model.records import EnvironmentModel, Situation
from modeling.types import BoolArray, FloatArray, IntArray

__all__ = [
    "Gate",
    "GateHistory",
    "GridSpec",
    "OccupancyMap",
    "observed_segments",
    "rasterize_lines",
    "rasterize_obstacles",
    "top_situations",
    "visible_mask",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class GridSpec:
    """A regular grid over a rectangle of the floor.

    Attributes:
        xmin: World x of the grid's left edge, metres.
        ymin: World y of the grid's bottom edge, metres.
        resolution_m: Cell size, metres.
        nx: Number of columns.
        ny: Number of rows.
    """

    xmin: float
    ymin: float
    resolution_m: float
    nx: int
    ny: int

    @classmethod
    def from_bounds(
        cls, bounds: tuple[float, float, float, float], resolution_m: float = 0.1
    ) -> GridSpec:
        """The grid covering ``(xmin, ymin, xmax, ymax)`` with cells of ``resolution_m``."""
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        if not (xmax > xmin and ymax > ymin):
            raise ValueError(f"bounds must satisfy xmin < xmax and ymin < ymax, got {bounds}")
        if not resolution_m > 0:
            raise ValueError(f"resolution_m must be positive, got {resolution_m!r}")
        nx = max(1, math.ceil((xmax - xmin) / resolution_m))
        ny = max(1, math.ceil((ymax - ymin) / resolution_m))
        return cls(xmin=xmin, ymin=ymin, resolution_m=float(resolution_m), nx=nx, ny=ny)

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``."""
        return (self.ny, self.nx)

    @property
    def size(self) -> int:
        """Number of cells."""
        return self.nx * self.ny

    def cell_of(self, xy: NDArray[np.floating]) -> NDArray[np.int64]:
        """(n, 2) ``(row, col)`` of the cells holding the (n, 2) points (clipped to the grid)."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        col = np.clip(np.floor((p[:, 0] - self.xmin) / self.resolution_m), 0, self.nx - 1)
        row = np.clip(np.floor((p[:, 1] - self.ymin) / self.resolution_m), 0, self.ny - 1)
        return np.stack([row, col], axis=1).astype(np.int64)

    def index_of(self, xy: NDArray[np.floating]) -> NDArray[np.int64]:
        """(n,) flat cell indices of the (n, 2) points."""
        rc = self.cell_of(xy)
        return rc[:, 0] * self.nx + rc[:, 1]

    def xy_of(self, index: NDArray[np.integer]) -> FloatArray:
        """(n, 2) world centres of the flat cell indices."""
        idx = np.asarray(index, dtype=np.int64).reshape(-1)
        row, col = np.divmod(idx, self.nx)
        return np.stack(
            [
                self.xmin + (col + 0.5) * self.resolution_m,
                self.ymin + (row + 0.5) * self.resolution_m,
            ],
            axis=1,
        )

    def centers(self) -> tuple[FloatArray, FloatArray]:
        """``(X, Y)``: (ny, nx) world coordinates of the cell centres."""
        xs = self.xmin + (np.arange(self.nx) + 0.5) * self.resolution_m
        ys = self.ymin + (np.arange(self.ny) + 0.5) * self.resolution_m
        return np.meshgrid(xs, ys)

    def inside(self, xy: NDArray[np.floating]) -> NDArray[np.bool_]:
        """(n,) whether the (n, 2) points lie on the grid."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return (
            (p[:, 0] >= self.xmin)
            & (p[:, 0] < self.xmin + self.nx * self.resolution_m)
            & (p[:, 1] >= self.ymin)
            & (p[:, 1] < self.ymin + self.ny * self.resolution_m)
        )


def _line_points(lines: FloatArray, step_m: float) -> FloatArray:
    """(m, 2) points every ``step_m`` along (q, 2, 2) segments (both ends included)."""
    lines = np.asarray(lines, dtype=np.float64).reshape(-1, 2, 2)
    if lines.shape[0] == 0:
        return np.zeros((0, 2))
    lengths = np.hypot(*(lines[:, 1] - lines[:, 0]).T)
    counts = np.maximum(2, np.ceil(lengths / step_m).astype(np.int64) + 1)
    which = np.repeat(np.arange(lines.shape[0]), counts)
    # np.linspace(0, 1, c) of every line at once, bit for bit: k * (1 / (c - 1)), the last 1.
    ends = np.cumsum(counts)
    k = np.arange(ends[-1]) - np.repeat(ends - counts, counts)
    t = k * (1.0 / (counts - 1))[which]
    t[ends - 1] = 1.0
    a, b = lines[which, 0], lines[which, 1]
    points: FloatArray = a + (b - a) * t[:, None]
    return points


def _obstacle_lines(situation: Situation) -> tuple[FloatArray, IntArray]:
    """(q, 2, 2) the skeleton segments of ``situation``'s obstacles (an obstacle without lines:
    its points, as segments of zero length), and (q,) the obstacle of each."""
    parts = []
    for ob in situation.obstacles:
        if ob.lines.shape[0]:
            parts.append(np.asarray(ob.lines).reshape(-1, 2, 2))
        else:
            pts = np.asarray(ob.points).reshape(-1, 2)
            parts.append(np.stack([pts, pts], axis=1))
    if not parts:
        return np.zeros((0, 2, 2)), np.zeros(0, dtype=np.int64)
    owner = np.repeat(np.arange(len(parts)), [part.shape[0] for part in parts])
    return np.concatenate(parts), owner


def rasterize_lines(
    spec: GridSpec,
    lines: FloatArray,
    *,
    viewpoint_xy: NDArray[np.floating] | None = None,
    max_range_m: float = math.inf,
) -> BoolArray:
    """(ny, nx) cells touched by the (q, 2, 2) segments (points beyond ``max_range_m`` left out)."""
    grid = np.zeros(spec.shape, dtype=bool)
    pts = _line_points(lines, 0.5 * spec.resolution_m)
    if viewpoint_xy is not None and math.isfinite(max_range_m) and pts.shape[0]:
        keep = np.hypot(*(pts - np.asarray(viewpoint_xy)[:2]).T) <= max_range_m
        pts = pts[keep]
    pts = pts[spec.inside(pts)]
    if pts.shape[0]:
        rc = spec.cell_of(pts)
        grid[rc[:, 0], rc[:, 1]] = True
    return grid


def observed_segments(model: EnvironmentModel) -> FloatArray:
    """(q, 2, 2) every unambiguous floor segment of the observation, isolated short ones included.

    The model drops isolated short segments (section 4.1: possibly false matches); for a map they
    are still evidence of something solid there (typically the vertical edge of a box seen alone).
    """
    segs = model.observation.segments
    if not segs:
        return np.zeros((0, 2, 2))
    return np.asarray([s.endpoints for s in segs], dtype=np.float64).reshape(-1, 2, 2)


def rasterize_obstacles(
    spec: GridSpec,
    situation: Situation,
    *,
    viewpoint_xy: NDArray[np.floating] | None = None,
    max_range_m: float = math.inf,
) -> BoolArray:
    """(ny, nx) cells touched by the skeletons of ``situation``'s obstacles.

    Points farther than ``max_range_m`` from ``viewpoint_xy`` are left out.
    """
    return rasterize_lines(
        spec, _obstacle_lines(situation)[0], viewpoint_xy=viewpoint_xy, max_range_m=max_range_m
    )


def visible_mask(
    spec: GridSpec, model: EnvironmentModel, *, max_range_m: float, margin_rad: float = 0.05
) -> BoolArray:
    """(ny, nx) cells inside ``model``'s field of view, within ``max_range_m``, not occluded."""
    obs = model.observation
    vx, vy, heading = (float(v) for v in obs.viewpoint)
    X, Y = spec.centers()
    dx, dy = X - vx, Y - vy
    dist = np.hypot(dx, dy)
    ang = np.abs(wrap_angle(np.arctan2(dy, dx) - heading))
    mask = (dist <= max_range_m) & (ang <= obs.fov_rad / 2 - margin_rad) & (dist > 0.05)
    occ = model.occluded_geometry
    if not occ.is_empty and mask.any():
        rows, cols = np.nonzero(mask)
        hidden = shapely.contains_xy(occ, X[rows, cols], Y[rows, cols])
        mask[rows[hidden], cols[hidden]] = False
    return mask


def _point_segment_distances(p: FloatArray, segments: FloatArray) -> FloatArray:
    """(q,) distance from the point ``p`` (2,) to each of the (q, 2, 2) segments."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    a, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    length2 = np.maximum((d * d).sum(axis=1), 1e-12)
    t = np.clip(((p - a) * d).sum(axis=1) / length2, 0.0, 1.0)
    out: FloatArray = np.hypot(*(a + t[:, None] * d - p).T)
    return out


def top_situations(model: EnvironmentModel, max_k: int, mass: float = 0.95) -> list[Situation]:
    """The most probable situations, at most ``max_k``, until ``mass`` of probability is covered."""
    out: list[Situation] = []
    total = 0.0
    for s in model.situations[:max_k]:
        out.append(s)
        total += s.probability
        if total >= mass:
            break
    return out


@dataclass(slots=True)
class OccupancyMap:
    """Log-odds occupancy over the floor, fused from successive models, plus bump marks.

    Attributes:
        spec: The grid.
        log_odds: (ny, nx) occupancy log-odds (0: unknown, counted free).
        bumps: (ny, nx) step at which each cell was marked by a collision (-1: never; the border
            of the room is marked with -2, never forgotten).
        hit: Log-odds added to a cell seen occupied (times the situations' probability).
        miss: Log-odds removed from a cell seen free.
        insert_range_m: Obstacles farther than this from the viewpoint are not fused.
        fused_range_m: Obstacles of the fused memory model are fused within this distance of
            the viewpoint (0: never).
        clear_range_m: Cells farther than this are not cleared.
        clamp: Log-odds stay in ``[-clamp, 2 clamp]``.
    """

    spec: GridSpec
    log_odds: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    bumps: NDArray[np.int64] = field(default_factory=lambda: np.zeros((0, 0), dtype=np.int64))
    hit: float = 1.0
    miss: float = 0.35
    insert_range_m: float = 3.0
    clear_range_m: float = 4.0
    clamp: float = 2.0
    fused_range_m: float = 0.0

    def __post_init__(self) -> None:
        if self.log_odds.shape != self.spec.shape:
            self.log_odds = np.zeros(self.spec.shape)
        if self.bumps.shape != self.spec.shape:
            self.bumps = np.full(self.spec.shape, -1, dtype=np.int64)
            self.bumps[[0, -1], :] = -2
            self.bumps[:, [0, -1]] = -2

    def update(
        self,
        model: EnvironmentModel,
        *,
        max_situations: int = 4,
        fused: EnvironmentModel | None = None,
    ) -> None:
        """Fuse ``model``: occupied where its situations' obstacles are, free where it sees.

        With ``fused`` (the memory model of the episode so far), the obstacles of its most
        probable situation within ``fused_range_m`` of the viewpoint, weighted by that
        situation's share of its ``max_situations`` most probable ones, are taken as seen
        occupied too (a cell counts the larger of the two).
        """
        sits = top_situations(model, max_situations)
        if not sits:
            return
        vp = np.asarray(model.observation.viewpoint[:2])
        expected = self.expected_obstacles(sits, vp, self.insert_range_m)
        if fused is not None and self.fused_range_m > 0.0:
            kept = top_situations(fused, max_situations)
            if kept:
                near = self.expected_obstacles(kept, vp, self.fused_range_m, first_only=True)
                expected = np.maximum(expected, near)
        expected = np.maximum(
            expected,
            rasterize_lines(
                self.spec,
                observed_segments(model),
                viewpoint_xy=vp,
                max_range_m=self.insert_range_m,
            ),
        )
        seen = visible_mask(self.spec, model, max_range_m=self.clear_range_m)
        self.log_odds += self.hit * expected
        self.log_odds[seen] -= self.miss * (1.0 - expected[seen])
        np.clip(self.log_odds, -self.clamp, 2 * self.clamp, out=self.log_odds)

    def expected_obstacles(
        self,
        sits: list[Situation],
        viewpoint_xy: FloatArray,
        range_m: float,
        *,
        first_only: bool = False,
    ) -> FloatArray:
        """(ny, nx) probability that each cell holds an obstacle of ``sits`` (weighted by their
        probabilities, renormalised over ``sits``) within ``range_m``; ``first_only``: the first
        situation's term alone."""
        total = sum(s.probability for s in sits) or 1.0
        expected = np.zeros(self.spec.shape)
        for s in sits[:1] if first_only else sits:
            expected += (s.probability / total) * rasterize_obstacles(
                self.spec, s, viewpoint_xy=viewpoint_xy, max_range_m=range_m
            )
        return expected

    def add_bump(
        self, xy: NDArray[np.floating], direction_rad: float, length_m: float, step: int = 0
    ) -> None:
        """Mark a bump at ``step``: a segment of ``length_m`` through ``xy`` across
        ``direction_rad``."""
        c, s = math.cos(direction_rad), math.sin(direction_rad)
        across = np.array([-s, c])
        p = np.asarray(xy, dtype=np.float64).reshape(2)
        line = np.array([[p - 0.5 * length_m * across, p + 0.5 * length_m * across]])
        pts = _line_points(line, 0.5 * self.spec.resolution_m)
        pts = pts[self.spec.inside(pts)]
        if pts.shape[0]:
            rc = self.spec.cell_of(pts)
            self.bumps[rc[:, 0], rc[:, 1]] = max(0, int(step))

    def occupied(self) -> BoolArray:
        """(ny, nx) cells taken as obstacles: positive log-odds or bumped."""
        occupied: BoolArray = (self.log_odds > 0.0) | (self.bumps != -1)
        return occupied

    def forget(self, before_step: int) -> None:
        """Forget what was seen, and the bumps made before ``before_step`` (not the border)."""
        self.log_odds[:] = 0.0
        self.bumps[(self.bumps >= 0) & (self.bumps < before_step)] = -1


@dataclass(slots=True)
class Gate:
    """A remembered critical region: the narrowest undecided relation between two obstacles.

    Attributes:
        ends: (2, 2) mean closest points of the narrowest relation, world metres.
        width_mean_m: Mean width, metres.
        width_std_m: Standard deviation of the width, metres.
        p_passable: Probability that the robot fits through.
        polygon: (m, 2) the region's polygon, metres.
        seen_distance_m: Distance from the viewpoint of the observation that gave the estimate.
        viewed_distance_m: Smallest distance from which it has been in view since that estimate.
        last_step: Step of the last observation that matched it.
        failed: The robot bumped trying to cross it (then ``p_passable`` is 0).
        failed_step: Step of the bump that closed it (``None`` while not failed, and for a gate
            set failed without one: never re-opened).
        p_before_failure: ``p_passable`` just before that bump (what a re-opening restores).
        crossed: The robot has driven through it (then ``p_passable`` is 1, and a bump near it
            does not close it).
    """

    ends: FloatArray
    width_mean_m: float
    width_std_m: float
    p_passable: float
    polygon: FloatArray
    seen_distance_m: float
    viewed_distance_m: float
    last_step: int = 0
    failed: bool = False
    failed_step: int | None = None
    p_before_failure: float = 0.0
    crossed: bool = False

    @property
    def settled(self) -> bool:
        """Whether the robot's own motion decided it (it bumped there, or drove through): no
        view changes it any more."""
        return self.failed or self.crossed

    @property
    def midpoint(self) -> FloatArray:
        """(2,) midpoint of the narrowest relation."""
        mid: FloatArray = self.ends.mean(axis=0)
        return mid

    @property
    def direction(self) -> FloatArray:
        """(2,) unit vector from ``ends[0]`` to ``ends[1]``."""
        d = self.ends[1] - self.ends[0]
        n = float(np.hypot(*d))
        return d / n if n > 1e-9 else np.array([1.0, 0.0])

    @property
    def normal(self) -> FloatArray:
        """(2,) unit normal of the relation (the crossing direction)."""
        d = self.direction
        return np.array([-d[1], d[0]])

    def undecided(self, eps: float) -> bool:
        """Whether ``eps < p_passable < 1 - eps``."""
        return eps < self.p_passable < 1.0 - eps


@dataclass(slots=True)
class GateHistory:
    """The gates seen so far.

    Attributes:
        gates: The remembered gates.
        match_m: A region whose narrowest midpoint is this close to a gate's (and roughly parallel)
            is the same gate.
        worse_factor: A new estimate replaces the old unless its std is this much larger.
        max_range_m: Regions farther than this from the viewpoint are ignored.
        max_gates: Oldest gates are forgotten beyond this many.
    """

    gates: list[Gate] = field(default_factory=list)
    match_m: float = 0.35
    worse_factor: float = 1.25
    max_range_m: float = 6.5
    max_gates: int = 80

    def match(self, ends: FloatArray) -> int | None:
        """Index of the remembered gate matching a relation with (2, 2) ``ends``, or ``None``."""
        mid = ends.mean(axis=0)
        d = ends[1] - ends[0]
        n = float(np.hypot(*d))
        best, best_dist = None, self.match_m
        for k, g in enumerate(self.gates):
            dist = float(np.hypot(*(g.midpoint - mid)))
            if dist >= best_dist:
                continue
            if n > 1e-9 and abs(float(g.direction @ (d / n))) < 0.6:
                continue
            best, best_dist = k, dist
        return best

    def update(self, model: EnvironmentModel, step: int, *, fov_margin_rad: float = 0.1) -> None:
        """Fuse the critical regions of ``model``'s most probable situation (see module doc)."""
        if not model.situations:
            return
        obs = model.observation
        vp = np.asarray(obs.viewpoint, dtype=np.float64)
        sit = model.situations[0]
        matched: set[int] = set()
        for reg in sit.critical_regions:
            ends = np.asarray(reg.narrowest, dtype=np.float64).reshape(2, 2)
            dist = float(np.hypot(*(ends.mean(axis=0) - vp[:2])))
            if dist > self.max_range_m:
                continue
            k = self.match(ends)
            if k is None:
                self.gates.append(
                    Gate(
                        ends=ends.copy(),
                        width_mean_m=float(reg.width_mean_m),
                        width_std_m=float(reg.width_std_m),
                        p_passable=float(reg.p_passable),
                        polygon=np.asarray(reg.polygon, dtype=np.float64).copy(),
                        seen_distance_m=dist,
                        viewed_distance_m=dist,
                        last_step=step,
                    )
                )
                matched.add(len(self.gates) - 1)
                continue
            matched.add(k)
            g = self.gates[k]
            g.last_step = step
            g.viewed_distance_m = min(g.viewed_distance_m, dist)
            if g.settled:
                continue
            if float(reg.width_std_m) <= self.worse_factor * g.width_std_m:
                g.ends = ends.copy()
                g.width_mean_m = float(reg.width_mean_m)
                g.width_std_m = float(reg.width_std_m)
                g.p_passable = float(reg.p_passable)
                g.polygon = np.asarray(reg.polygon, dtype=np.float64).copy()
                g.seen_distance_m = dist
        self._resolve_unmatched(model, matched, step, fov_margin_rad)
        if len(self.gates) > self.max_gates:
            self.gates.sort(key=lambda g: g.last_step)
            del self.gates[: len(self.gates) - self.max_gates]

    def _resolve_unmatched(
        self, model: EnvironmentModel, matched: set[int], step: int, margin: float
    ) -> None:
        """Remembered gates in clear view with no region now: decide them from their sides."""
        obs = model.observation
        vp = np.asarray(obs.viewpoint, dtype=np.float64)
        sit = model.situations[0]
        if not sit.obstacles:
            return
        occ = model.occluded_geometry
        segments, owner = _obstacle_lines(sit)
        for k, g in enumerate(self.gates):
            if k in matched or g.settled:
                continue
            mid = g.midpoint
            rel = mid - vp[:2]
            dist = float(np.hypot(*rel))
            bearing = abs(float(wrap_angle(math.atan2(rel[1], rel[0]) - vp[2])))
            if dist > min(self.max_range_m, 4.5) or bearing > obs.fov_rad / 2 - margin:
                continue
            if not occ.is_empty and shapely.contains_xy(occ, *mid):
                continue
            g.viewed_distance_m = min(g.viewed_distance_m, dist)
            if dist >= g.seen_distance_m:
                continue  # no better view than the one that gave the estimate
            sides = [
                set(owner[_point_segment_distances(end, segments) < 0.15].tolist())
                for end in g.ends
            ]
            if not sides[0] or not sides[1]:
                continue  # a side was not seen: nothing learnt
            same = bool(sides[0] & sides[1])
            g.p_passable = 0.0 if same else 1.0
            g.width_std_m = min(g.width_std_m, 0.02)
            g.seen_distance_m = dist
            g.last_step = step

    def note_motion(self, start_xy: NDArray[np.floating], end_xy: NDArray[np.floating]) -> None:
        """The robot's centre moved from ``start_xy`` to ``end_xy``: a gate whose narrowest
        relation that motion crosses is passable (the robot fitted through it)."""
        motion = np.stack([start_xy, end_xy]).astype(np.float64).reshape(2, 2)
        open_gates = [g for g in self.gates if not g.crossed]
        if not open_gates or float(np.hypot(*(motion[1] - motion[0]))) < 1e-9:
            return
        lines = shapely.linestrings(np.stack([g.ends for g in open_gates]))
        for g, crossed in zip(
            open_gates, shapely.crosses(shapely.linestrings(motion), lines), strict=True
        ):
            if crossed:
                g.crossed, g.failed, g.p_passable = True, False, 1.0

    def mark_failed(self, xy: NDArray[np.floating], radius_m: float, step: int = 0) -> list[int]:
        """Gates whose midpoint is within ``radius_m`` of ``xy`` become impassable (a bump at
        ``step``), except those the robot has driven through."""
        out = []
        p = np.asarray(xy, dtype=np.float64).reshape(2)
        for k, g in enumerate(self.gates):
            if not g.settled and float(np.hypot(*(g.midpoint - p))) <= radius_m:
                g.p_before_failure = g.p_passable
                g.failed, g.failed_step, g.p_passable = True, step, 0.0
                out.append(k)
        return out

    def reopen(self, before_step: int) -> list[int]:
        """Gates closed by a bump before ``before_step`` are open again, with the passability
        the views gave them before it (and the views update them again); returns their
        indices. The planner's relax forgets the bump marks older than a few steps and, with
        this, the gates those bumps closed: a bump closes every gate within reach of the robot,
        not only the one it was crossing."""
        out = []
        for k, g in enumerate(self.gates):
            if g.failed and g.failed_step is not None and g.failed_step < before_step:
                g.failed, g.failed_step, g.p_passable = False, None, g.p_before_failure
                out.append(k)
        return out
