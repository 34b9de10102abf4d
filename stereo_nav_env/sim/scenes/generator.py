"""The seeded scene generator: six families of indoor layouts, easiest first.

Generated scenes always have walls around their bounds and a route from start to goal that the
robot fits through. The four standard families (:data:`STANDARD_FAMILIES`: room, corridor,
cluttered, office) have at least two doubtful gaps (width within 30 % of the robot width); the
two curriculum families before them need none: ``open`` (the room's walls only, the goal 1.5-4 m
away) and ``sparse`` (1-3 obstacles, the goal 2-5 m away), both with a random start heading. Each
family is a layout function that places obstacles with a :class:`_Builder` (no overlaps, a
keep-out around start and goal); :func:`generate_scene` retries layouts until the guarantees hold.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from shapely.geometry import Point, Polygon, box

from modeling.types import FloatArray
from modeling.validation import positive
from stereo_nav_env.sim.scenes.parts import make_obstacle, oriented_rect
from stereo_nav_env.sim.scenes.types import (
    DEFAULT_MARGIN_M,
    DEFAULT_ROBOT_WIDTH_M,
    Color,
    Obstacle,
    ObstacleKind,
    Scene,
)

__all__ = [
    "BOX_PALETTE",
    "CURRICULUM_FAMILIES",
    "FAMILIES",
    "STANDARD_FAMILIES",
    "WALL_THICKNESS_M",
    "generate_scene",
]


STANDARD_FAMILIES = ("room", "corridor", "cluttered", "office")
"""The families with doubtful gaps (``"random"`` draws among these)."""
CURRICULUM_FAMILIES = ("open", "sparse")
"""The easy families a curriculum starts with."""
FAMILIES = (*CURRICULUM_FAMILIES, *STANDARD_FAMILIES)
"""The generator's families, easiest first (see :func:`generate_scene`)."""
_FAMILY_STREAM = {"room": 0, "corridor": 1, "cluttered": 2, "office": 3, "open": 4, "sparse": 5}
"""Each family's random stream (the standard ones keep the indices they always had)."""
WALL_THICKNESS_M = 0.1
BOX_PALETTE: tuple[Color, ...] = (
    (0.70, 0.52, 0.30),
    (0.78, 0.30, 0.25),
    (0.30, 0.60, 0.35),
    (0.85, 0.78, 0.35),
    (0.55, 0.40, 0.65),
)


class _Builder:
    """Places obstacles without overlap; used by the family layouts."""

    def __init__(
        self, rng: np.random.Generator, bounds: tuple[float, float, float, float], w: float
    ) -> None:
        self.rng = rng
        self.bounds = bounds
        self.w = w
        self.obstacles: list[Obstacle] = []
        self.keepout: list[Any] = []

    def walls(self) -> None:
        x0, y0, x1, y1 = self.bounds
        t = WALL_THICKNESS_M
        for rect in (
            (x0, y0, x1, y0 + t),
            (x0, y1 - t, x1, y1),
            (x0, y0 + t, x0 + t, y1 - t),
            (x1 - t, y0 + t, x1, y1 - t),
        ):
            self.add(ObstacleKind.WALL, np.asarray(box(*rect).exterior.coords)[:4], force=True)

    def fits(self, fp: FloatArray, clearance: float = 0.03) -> bool:
        poly = Polygon(fp)
        x0, y0, x1, y1 = self.bounds
        inner = box(
            x0 + WALL_THICKNESS_M,
            y0 + WALL_THICKNESS_M,
            x1 - WALL_THICKNESS_M,
            y1 - WALL_THICKNESS_M,
        )
        if not inner.contains(poly):
            return False
        if any(k.intersects(poly) for k in self.keepout):
            return False
        return not any(
            ob.kind is not ObstacleKind.WALL and ob.polygon.distance(poly) < clearance
            for ob in self.obstacles
        )

    def add(
        self,
        kind: ObstacleKind,
        fp: FloatArray,
        height: float | None = None,
        color: Color | None = None,
        *,
        force: bool = False,
    ) -> bool:
        if not force and not self.fits(fp):
            return False
        if color is None and kind is ObstacleKind.BOX:
            color = BOX_PALETTE[int(self.rng.integers(len(BOX_PALETTE)))]
        self.obstacles.append(make_obstacle(kind, fp, height, color))
        return True

    def doubtful(self) -> float:
        """A gap width within 30 % of the robot width (kept 2 % inside the band)."""
        return float(self.w * self.rng.uniform(0.72, 1.28))

    def furniture(self, kind: ObstacleKind, center: ArrayLike, yaw: float) -> FloatArray:
        rng = self.rng
        if kind is ObstacleKind.BOOKSHELF:
            return oriented_rect(center, rng.uniform(1.2, 2.0), rng.uniform(0.3, 0.4), yaw)
        if kind is ObstacleKind.TABLE:
            return oriented_rect(center, rng.uniform(0.9, 1.6), rng.uniform(0.6, 0.9), yaw)
        if kind is ObstacleKind.CHAIR:
            s = rng.uniform(0.42, 0.5)
            return oriented_rect(center, s, s, yaw)
        return oriented_rect(center, rng.uniform(0.35, 0.9), rng.uniform(0.35, 0.8), yaw)

    def gate(
        self, kind_a: ObstacleKind, kind_b: ObstacleKind, center: ArrayLike, axis: float, gap: float
    ) -> bool:
        """Two obstacles side by side along ``axis`` with a gap of ``gap`` metres between them."""
        c = np.asarray(center, dtype=np.float64)
        u = np.array([math.cos(axis), math.sin(axis)])
        # both face the -v side, i.e. a front normal rotated -90 degrees from axis
        a = self.furniture(kind_a, [0.0, 0.0], 0.0)
        b = self.furniture(kind_b, [0.0, 0.0], 0.0)
        la, lb = np.ptp(a[:, 0]), np.ptp(b[:, 0])
        da, db = np.ptp(a[:, 1]), np.ptp(b[:, 1])
        ca = c - u * (gap / 2 + la / 2)
        cb = c + u * (gap / 2 + lb / 2)
        fa = oriented_rect(ca, la, da, axis)
        fb = oriented_rect(cb, lb, db, axis)
        if not (self.fits(fa) and self.fits(fb)):
            return False
        if Polygon(fa).distance(Polygon(fb)) < gap - 1e-6:
            return False
        self.add(kind_a, fa)
        self.add(kind_b, fb)
        return True

    def scatter(self, kinds: Sequence[ObstacleKind], count: int, tries: int = 40) -> None:
        x0, y0, x1, y1 = self.bounds
        for _ in range(count):
            kind = kinds[int(self.rng.integers(len(kinds)))]
            for _ in range(tries):
                c = self.rng.uniform([x0 + 0.5, y0 + 0.5], [x1 - 0.5, y1 - 0.5])
                yaw = float(self.rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2]))
                yaw += float(self.rng.normal(0.0, 0.15)) if kind is ObstacleKind.BOX else 0.0
                if self.add(kind, self.furniture(kind, c, yaw)):
                    break


def _layout_room(b: _Builder, W: float, H: float) -> None:
    rng = b.rng
    # the doubtful gate in view: a bookshelf beside a box or table, 3-6 m ahead of the start
    gx = rng.uniform(4.0, min(6.0, W - 2.5))
    for _ in range(30):
        if b.gate(
            ObstacleKind.BOOKSHELF,
            (ObstacleKind.BOX, ObstacleKind.TABLE)[int(rng.integers(2))],
            [gx, rng.uniform(1.8, H - 1.8)],
            math.pi / 2 + rng.normal(0, 0.1),
            b.doubtful(),
        ):
            break
    for _ in range(30):
        if b.gate(
            ObstacleKind.TABLE,
            ObstacleKind.BOX,
            rng.uniform([2.5, 1.0], [W - 1.5, H - 1.0]),
            float(rng.uniform(-np.pi, np.pi)),
            b.doubtful(),
        ):
            break
    b.scatter([ObstacleKind.CHAIR, ObstacleKind.BOX, ObstacleKind.TABLE], int(rng.integers(2, 5)))


def _layout_corridor(b: _Builder, W: float, H: float) -> None:
    rng = b.rng
    x = 2.5
    while x < W - 2.0:
        # one doubtful gap between an obstacle on one side and a middle obstacle; a wider lane on
        # the other side keeps the corridor passable
        side = float(rng.choice([-1.0, 1.0]))
        mid_w = rng.uniform(0.4, 0.7)
        gap = b.doubtful()
        y_mid = H / 2 + side * rng.uniform(0.0, 0.3)
        mid = oriented_rect([x, y_mid], rng.uniform(0.4, 1.0), mid_w, 0.0)
        edge = y_mid + side * (mid_w / 2 + gap)
        wall_y = H - WALL_THICKNESS_M if side > 0 else WALL_THICKNESS_M
        depth = abs(wall_y - edge) - 0.02
        if depth > 0.25:
            kind = (ObstacleKind.BOX, ObstacleKind.BOOKSHELF)[int(rng.integers(2))]
            yc = (edge + wall_y - side * 0.02) / 2
            length = rng.uniform(0.6, 1.4)
            yaw = 0.0 if side > 0 else math.pi  # bookshelf front faces the corridor centre
            side_fp = oriented_rect([x, yc], length, depth, yaw)
            if b.fits(mid) and b.fits(side_fp):
                b.add(ObstacleKind.BOX, mid)
                b.add(kind, side_fp)
        x += rng.uniform(1.6, 2.6)
    b.scatter([ObstacleKind.BOX, ObstacleKind.CHAIR], int(rng.integers(0, 3)))


def _layout_cluttered(b: _Builder, W: float, H: float) -> None:
    rng = b.rng
    for _ in range(3):
        for _ in range(30):
            kinds = [ObstacleKind.BOX, ObstacleKind.CHAIR, ObstacleKind.BOOKSHELF]
            ka = kinds[int(rng.integers(3))]
            kb = kinds[int(rng.integers(3))]
            if b.gate(
                ka,
                kb,
                rng.uniform([2.5, 1.0], [W - 1.5, H - 1.0]),
                float(rng.uniform(-np.pi, np.pi)),
                b.doubtful(),
            ):
                break
    b.scatter(
        [ObstacleKind.BOX, ObstacleKind.BOX, ObstacleKind.CHAIR, ObstacleKind.TABLE],
        int(rng.integers(6, 11)),
    )


def _layout_office(b: _Builder, W: float, H: float) -> None:
    rng = b.rng
    # a partition across the room with a doubtful doorway and a clearly passable one
    px = rng.uniform(0.45, 0.6) * W
    y0, y1 = WALL_THICKNESS_M, H - WALL_THICKNESS_M
    doors = sorted(
        [
            (rng.uniform(y0 + 0.5, (y0 + y1) / 2 - 1.0), b.doubtful()),
            (rng.uniform((y0 + y1) / 2 + 0.2, y1 - 1.6), rng.uniform(0.9, 1.2)),
        ]
    )
    if rng.random() < 0.5:  # swap which doorway is the doubtful one
        doors = [(doors[0][0], doors[1][1]), (doors[1][0], doors[0][1])]
        doors.sort()
    ys = [y0]
    for start, width in doors:
        ys += [start, start + width]
    ys.append(y1)
    for k in range(0, len(ys), 2):
        if ys[k + 1] - ys[k] > 0.05:
            b.add(
                ObstacleKind.WALL,
                oriented_rect(
                    [px, (ys[k] + ys[k + 1]) / 2], ys[k + 1] - ys[k], WALL_THICKNESS_M, math.pi / 2
                ),
                force=True,
            )
    for _ in range(30):
        if b.gate(
            ObstacleKind.BOOKSHELF,
            ObstacleKind.BOX,
            rng.uniform([px + 1.0, 1.0], [W - 1.0, H - 1.0]),
            math.pi / 2,
            b.doubtful(),
        ):
            break
    b.scatter([ObstacleKind.CHAIR, ObstacleKind.TABLE, ObstacleKind.BOX], int(rng.integers(2, 5)))


def _layout_open(b: _Builder, W: float, H: float) -> None:
    """The room's walls only."""


def _layout_sparse(b: _Builder, W: float, H: float) -> None:
    """1-3 obstacles: the first near the middle of the straight line to the goal, if it fits."""
    rng = b.rng
    count = int(rng.integers(1, 4))
    kinds = [ObstacleKind.BOX, ObstacleKind.CHAIR, ObstacleKind.TABLE, ObstacleKind.BOOKSHELF]
    start, goal = (np.asarray(k.centroid.coords[0]) for k in b.keepout)
    for _ in range(20):
        kind = kinds[int(rng.integers(len(kinds)))]
        centre = (start + goal) / 2 + rng.normal(0.0, 0.4, 2)
        if b.add(kind, b.furniture(kind, centre, float(rng.uniform(-np.pi, np.pi)))):
            count -= 1
            break
    b.scatter(kinds, count)


_LAYOUTS = {
    "open": (_layout_open, (5.0, 7.0), (4.5, 6.0)),
    "sparse": (_layout_sparse, (6.0, 8.0), (5.0, 6.5)),
    "room": (_layout_room, (8.0, 10.0), (5.5, 7.0)),
    "corridor": (_layout_corridor, (10.0, 13.0), (2.6, 3.2)),
    "cluttered": (_layout_cluttered, (7.0, 9.0), (6.0, 7.5)),
    "office": (_layout_office, (9.0, 11.0), (6.0, 7.0)),
}


_FAMILY_DEFAULTS: dict[str, tuple[int, tuple[float, float] | None, bool]] = {
    "open": (0, (1.5, 4.0), True),
    "sparse": (0, (2.0, 5.0), True),
}
"""Per family: (min_doubtful_gaps, goal_distance_m, random_heading); else (2, None, False)."""


def _goal_range(value: Any) -> tuple[float, float] | None:
    """``goal_distance_m`` checked: None or ``(low, high)`` metres with 0 < low <= high."""
    if value is None:
        return None
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"goal_distance_m must be None or (low, high), got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
        raise ValueError(f"goal_distance_m must satisfy 0 < low <= high, got {value!r}")
    return lo, hi


def _start_and_goal(
    rng: np.random.Generator, W: float, H: float, goal_range: tuple[float, float]
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """A start anywhere 0.8 m inside the walls and a goal ``goal_range`` metres from it (straight
    line) as far inside, or None when 100 draws found none."""
    m = min(0.8, 0.3 * H, 0.3 * W)
    for _ in range(100):
        start = rng.uniform([m, m], [W - m, H - m])
        distance = rng.uniform(*goal_range)
        angle = rng.uniform(-np.pi, np.pi)
        goal = start + distance * np.array([math.cos(angle), math.sin(angle)])
        if m <= goal[0] <= W - m and m <= goal[1] <= H - m:
            return (float(start[0]), float(start[1])), (float(goal[0]), float(goal[1]))
    return None


def generate_scene(
    seed: int,
    *,
    family: str = "room",
    robot_width_m: float = DEFAULT_ROBOT_WIDTH_M,
    margin_m: float = DEFAULT_MARGIN_M,
    min_doubtful_gaps: int | None = None,
    goal_distance_m: tuple[float, float] | None = None,
    random_heading: bool | None = None,
    max_attempts: int = 200,
) -> Scene:
    """A random indoor scene, deterministic in ``seed``.

    Every scene has walls around its bounds, furniture of the family's style, a start and a goal,
    both free and joined by a route a disc of diameter ``robot_width_m`` fits through with
    ``margin_m`` to spare on each side, and at least ``min_doubtful_gaps`` gaps whose width is
    within 30 % of ``robot_width_m``. By default the start of a standard family is on the left
    looking roughly towards the goal on the right; with ``goal_distance_m`` the start is anywhere
    and the goal that far from it.

    Args:
        seed: Non-negative integer seed.
        family: One of :data:`FAMILIES`: ``"open"`` (walls only), ``"sparse"`` (1-3 pieces of
            furniture), ``"room"`` (a bookshelf gate in view, a table, chairs, boxes),
            ``"corridor"`` (a long corridor narrowed by boxes and shelves), ``"cluttered"`` (many
            boxes and chairs) or ``"office"`` (a partition wall with two doorways).
        robot_width_m: Robot diameter, metres (0.1 to 1.5).
        margin_m: Clearance kept on each side of the robot along the route, metres.
        min_doubtful_gaps: Minimum number of doubtful gaps (None: 0 for ``open`` and
            ``sparse``, 2 for the others).
        goal_distance_m: ``(low, high)``: the straight-line distance from start to goal, metres,
            drawn uniformly (None: the family's default, (1.5, 4) for ``open``, (2, 5) for
            ``sparse``, the left-to-right layout for the others).
        random_heading: Start heading uniform in [-pi, pi) instead of towards the goal (None:
            True for ``open`` and ``sparse``).
        max_attempts: Layouts tried before giving up.

    Returns:
        The scene, named ``"<family>-<seed>"``.

    Raises:
        ValueError: A parameter is invalid (the message names it).
        RuntimeError: No layout met the guarantees within ``max_attempts``.
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if family not in _LAYOUTS:
        raise ValueError(f"family must be one of {list(FAMILIES)}, got {family!r}")
    w = positive(robot_width_m, "robot_width_m")
    if not 0.1 <= w <= 1.5:
        raise ValueError(f"robot_width_m must be in [0.1, 1.5], got {robot_width_m!r}")
    margin_m = positive(margin_m, "margin_m", allow_zero=True)
    default_gaps, default_goal, default_heading = _FAMILY_DEFAULTS.get(family, (2, None, False))
    min_doubtful_gaps = default_gaps if min_doubtful_gaps is None else min_doubtful_gaps
    if (
        isinstance(min_doubtful_gaps, bool)
        or not isinstance(min_doubtful_gaps, int)
        or min_doubtful_gaps < 0
    ):
        raise ValueError(
            f"min_doubtful_gaps must be a non-negative integer, got {min_doubtful_gaps!r}"
        )
    goal_range = _goal_range(default_goal if goal_distance_m is None else goal_distance_m)
    random_heading = default_heading if random_heading is None else random_heading
    if not isinstance(random_heading, bool):
        raise ValueError(f"random_heading must be None, True or False, got {random_heading!r}")
    if not isinstance(max_attempts, int) or max_attempts < 1:
        raise ValueError(f"max_attempts must be a positive integer, got {max_attempts!r}")
    layout, w_range, h_range = _LAYOUTS[family]
    rng = np.random.default_rng([int(seed), _FAMILY_STREAM[family]])
    scale = max(1.0, w / 0.5)
    for _ in range(max_attempts):
        W = float(rng.uniform(*w_range)) * scale
        H = float(rng.uniform(*h_range)) * scale
        bounds = (0.0, 0.0, W, H)
        if goal_range is None:  # the standard layout (these draws make the scenes they always did)
            start = (float(rng.uniform(0.8, 1.4)), float(rng.uniform(0.35, 0.65) * H))
            goal = (float(W - rng.uniform(0.8, 1.4)), float(rng.uniform(0.25, 0.75) * H))
        else:
            pair = _start_and_goal(rng, W, H, goal_range)
            if pair is None:
                continue
            start, goal = pair
        if random_heading:
            heading = float(rng.uniform(-np.pi, np.pi))
        else:
            heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) + float(rng.normal(0, 0.1))
        b = _Builder(rng, bounds, w)
        b.walls()
        r = w / 2 + margin_m + 0.3
        b.keepout = [Point(*start).buffer(r), Point(*goal).buffer(r)]
        layout(b, W, H)
        if family == "sparse" and all(ob.kind is ObstacleKind.WALL for ob in b.obstacles):
            continue  # no furniture found room: not a sparse scene
        scene = Scene(
            name=f"{family}-{int(seed)}",
            bounds=bounds,
            obstacles=tuple(b.obstacles),
            start=(start[0], start[1], heading),
            goal=goal,
        )
        if not scene.route_exists(w, margin_m):
            continue
        if len(scene.doubtful_gaps(w)) < min_doubtful_gaps:
            continue
        return scene
    raise RuntimeError(f"no {family!r} layout for seed {seed} met the guarantees")
