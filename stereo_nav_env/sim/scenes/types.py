"""The scene's types: :class:`Scene`, :class:`Obstacle`, :class:`BoxPart`, :class:`Gap` and
:class:`ObstacleKind`, with the checks that keep them valid.

A :class:`Scene` is what the simulator knows for certain: the room's bounds, the obstacles (each
with its true 2D collision outline and the 3D boxes that draw it), the robot's start pose and the
goal. Frames and units follow ARCHITECTURE.md: world metres, floor plane x-y, z up, headings in
radians counter-clockwise from +x.

Every obstacle has a ``kind``, a ``footprint`` (k, 2) polygon in world metres that is the robot's
true collision outline, a height and a tuple of :class:`BoxPart` prisms used only for rendering
(built from the kind by :func:`stereo_nav_env.sim.scenes.parts.make_obstacle`).

:meth:`Scene.gaps` lists the true gaps between pairs of obstacles (closest points, width), the
ground truth for passability; :meth:`Scene.doubtful_gaps` keeps those within a relative tolerance
of the robot's width.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike
from shapely.geometry import Point, Polygon, box
from shapely.ops import unary_union

from modeling.types import FloatArray
from modeling.validation import positive

__all__ = [
    "DEFAULT_COLOR",
    "DEFAULT_HEIGHT_M",
    "DEFAULT_MARGIN_M",
    "DEFAULT_ROBOT_WIDTH_M",
    "BoxPart",
    "Color",
    "Gap",
    "Obstacle",
    "ObstacleKind",
    "Scene",
]

Color = tuple[float, float, float]

DEFAULT_ROBOT_WIDTH_M = 0.5
"""The robot's width (diameter), metres, where none is configured: ``WorldConfig.robot_width_m``'s
default, and what the scene generator sizes its near-width gaps for unless told otherwise."""

DEFAULT_MARGIN_M = 0.05
"""Clearance kept on each side of the robot by :meth:`Scene.free_space`, metres."""


class ObstacleKind(str, enum.Enum):
    """The closed set of obstacle kinds."""

    WALL = "wall"
    TABLE = "table"
    CHAIR = "chair"
    BOOKSHELF = "bookshelf"
    BOX = "box"


DEFAULT_HEIGHT_M: dict[ObstacleKind, float] = {
    ObstacleKind.WALL: 2.0,
    ObstacleKind.TABLE: 0.75,
    ObstacleKind.CHAIR: 0.9,
    ObstacleKind.BOOKSHELF: 1.8,
    ObstacleKind.BOX: 0.7,
}
DEFAULT_COLOR: dict[ObstacleKind, Color] = {
    ObstacleKind.WALL: (0.82, 0.80, 0.74),
    ObstacleKind.TABLE: (0.62, 0.40, 0.22),
    ObstacleKind.CHAIR: (0.22, 0.34, 0.62),
    ObstacleKind.BOOKSHELF: (0.80, 0.64, 0.42),
    ObstacleKind.BOX: (0.70, 0.52, 0.30),
}


# ---------------------------------------------------------------------------------------- checks
def _err(field: str, message: str) -> ValueError:
    return ValueError(f"{field} {message}")


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise _err(field, f"must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise _err(field, f"must be finite, got {value!r}")
    return x


def _vector(value: Any, field: str, n: int) -> tuple[float, ...]:
    if not isinstance(value, Sequence | np.ndarray) or isinstance(value, str) or len(value) != n:
        raise _err(field, f"must be a list of {n} numbers, got {value!r}")
    return tuple(_number(v, f"{field}[{i}]") for i, v in enumerate(value))


def _polygon_array(value: Any, field: str) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise _err(field, "must have shape (k, 2) with k >= 3 numbers") from exc
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
        raise _err(field, f"must have shape (k, 2) with k >= 3, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise _err(field, "contains NaN or infinite values")
    if np.allclose(arr[0], arr[-1]) and arr.shape[0] > 3:
        arr = arr[:-1]
    poly = Polygon(arr)
    if not poly.is_valid or poly.area <= 1e-9:
        raise _err(field, "must be a simple polygon with positive area")
    if not shapely.is_ccw(poly.exterior):
        arr = arr[::-1].copy()
    return arr


def _color(value: Any, field: str) -> Color:
    rgb = _vector(value, field, 3)
    if any(c < 0 or c > 1 for c in rgb):
        raise _err(field, f"must have components in [0, 1], got {list(rgb)}")
    return (rgb[0], rgb[1], rgb[2])


# ---------------------------------------------------------------------------------------- types
@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class BoxPart:
    """One rendered prism: a convex floor outline extruded between two heights.

    Attributes:
        footprint: (k, 2) convex outline, world metres, counter-clockwise.
        z_min_m: Bottom height, metres (>= 0).
        z_max_m: Top height, metres (> z_min_m).
        color: Base RGB in [0, 1]; the renderer shades each face from it by its orientation.
    """

    footprint: FloatArray
    z_min_m: float
    z_max_m: float
    color: Color

    def __post_init__(self) -> None:
        fp = _polygon_array(self.footprint, "footprint")
        object.__setattr__(self, "footprint", fp)
        z0, z1 = _number(self.z_min_m, "z_min_m"), _number(self.z_max_m, "z_max_m")
        if z0 < 0 or z1 <= z0:
            raise ValueError(f"z_min_m/z_max_m must satisfy 0 <= z_min_m < z_max_m, got {z0}, {z1}")
        object.__setattr__(self, "z_min_m", z0)
        object.__setattr__(self, "z_max_m", z1)
        object.__setattr__(self, "color", _color(self.color, "color"))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Obstacle:
    """A piece of the world the robot collides with.

    Attributes:
        kind: What it is.
        footprint: (k, 2) true collision outline, world metres, counter-clockwise.
        height_m: Height of its top, metres.
        color: Base RGB in [0, 1] of its main parts.
        parts: The prisms that draw it (renderer only).
    """

    kind: ObstacleKind
    footprint: FloatArray
    height_m: float
    color: Color
    parts: tuple[BoxPart, ...]

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "kind", ObstacleKind(self.kind))
        except ValueError as exc:
            choices = [k.value for k in ObstacleKind]
            raise ValueError(f"kind must be one of {choices}, got {self.kind!r}") from exc
        object.__setattr__(self, "footprint", _polygon_array(self.footprint, "footprint"))
        height = _number(self.height_m, "height_m")
        if height <= 0:
            raise ValueError(f"height_m must be positive, got {self.height_m!r}")
        object.__setattr__(self, "height_m", height)
        object.__setattr__(self, "color", _color(self.color, "color"))
        object.__setattr__(self, "parts", tuple(self.parts))

    @property
    def polygon(self) -> Polygon:
        """The footprint as a shapely polygon."""
        return Polygon(self.footprint)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Gap:
    """The true free gap between two obstacles.

    Attributes:
        i: Index of the first obstacle in ``Scene.obstacles`` (``i < j``).
        j: Index of the second obstacle.
        width_m: Shortest distance between the two footprints, metres.
        point_i: (2,) closest point on obstacle ``i``, world metres.
        point_j: (2,) closest point on obstacle ``j``.
    """

    i: int
    j: int
    width_m: float
    point_i: FloatArray
    point_j: FloatArray

    def passable(self, robot_width_m: float) -> bool:
        """Whether a disc of diameter ``robot_width_m`` fits through this gap."""
        return self.width_m > robot_width_m


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Scene:
    """A floor world: bounds, obstacles, start pose and goal.

    Attributes:
        name: A label (map name, or ``"<family>-<seed>"`` for generated scenes).
        bounds: ``(xmin, ymin, xmax, ymax)`` of the floor, metres.
        obstacles: The obstacles; walls included (generated rooms have boundary walls).
        start: ``(x, y, heading_rad)`` of the robot's centre at the start.
        goal: ``(x, y)`` of the goal, metres.
    """

    name: str
    bounds: tuple[float, float, float, float]
    obstacles: tuple[Obstacle, ...]
    start: tuple[float, float, float]
    goal: tuple[float, float]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise ValueError(f"name must be a string, got {self.name!r}")
        b = _vector(self.bounds, "bounds", 4)
        if not (b[0] < b[2] and b[1] < b[3]):
            raise ValueError(f"bounds must satisfy xmin < xmax and ymin < ymax, got {list(b)}")
        object.__setattr__(self, "bounds", b)
        start = _vector(self.start, "start", 3)
        goal = _vector(self.goal, "goal", 2)
        for field, xy in (("start", start[:2]), ("goal", goal)):
            if not (b[0] <= xy[0] <= b[2] and b[1] <= xy[1] <= b[3]):
                raise ValueError(f"{field} must lie inside bounds {list(b)}, got {list(xy)}")
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "goal", goal)
        obstacles = tuple(self.obstacles)
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise ValueError(f"obstacles[{i}] must be an Obstacle, got {type(ob).__name__}")
        object.__setattr__(self, "obstacles", obstacles)

    # ------------------------------------------------------------------ geometry
    def footprints(self) -> list[FloatArray]:
        """True obstacle outlines, each (k, 2) world metres (copies)."""
        return [ob.footprint.copy() for ob in self.obstacles]

    def obstacle_union(self) -> Any:
        """The union of all footprints (a shapely geometry; empty if there are none)."""
        return unary_union([ob.polygon for ob in self.obstacles])

    def free_space(self, robot_width_m: float, margin_m: float = DEFAULT_MARGIN_M) -> Any:
        """Where the robot's centre may be: bounds shrunk and obstacles grown by radius + margin."""
        r = positive(robot_width_m, "robot_width_m") / 2.0 + positive(
            margin_m, "margin_m", allow_zero=True
        )
        area = box(*self.bounds).buffer(-r, join_style="mitre")
        return area.difference(self.obstacle_union().buffer(r, quad_segs=8))

    def is_free(
        self, xy: ArrayLike, robot_width_m: float, margin_m: float = DEFAULT_MARGIN_M
    ) -> bool:
        """Whether a disc robot centred at ``xy`` (2,) is clear of obstacles and in the bounds."""
        return bool(self.free_space(robot_width_m, margin_m).contains(Point(*np.asarray(xy)[:2])))

    def route_exists(self, robot_width_m: float, margin_m: float = DEFAULT_MARGIN_M) -> bool:
        """Whether start and goal are free and lie in one connected component of free space."""
        free = self.free_space(robot_width_m, margin_m)
        s, g = Point(self.start[0], self.start[1]), Point(*self.goal)
        parts = getattr(free, "geoms", [free])
        return any(p.contains(s) and p.contains(g) for p in parts)

    def gaps(self, max_width_m: float = 1.5) -> tuple[Gap, ...]:
        """True gaps between obstacle pairs, narrowest first.

        A gap is the shortest segment between two footprints at distance in ``(0, max_width_m]``
        that crosses no third obstacle.

        Args:
            max_width_m: Widest gap listed, metres.

        Returns:
            The gaps, sorted by width then indices.
        """
        max_width_m = positive(max_width_m, "max_width_m")
        polys = [ob.polygon for ob in self.obstacles]
        if len(polys) < 2:
            return ()
        tree = shapely.STRtree(polys)
        left, right = tree.query(polys, predicate="dwithin", distance=max_width_m)
        out: list[Gap] = []
        for i, j in zip(left.tolist(), right.tolist(), strict=True):
            if i >= j:
                continue
            width = float(polys[i].distance(polys[j]))
            if width <= 1e-9 or width > max_width_m:
                continue
            line = shapely.shortest_line(polys[i], polys[j])
            pts = np.asarray(line.coords, dtype=np.float64)
            crossing = [
                k for k in tree.query(line, predicate="intersects").tolist() if k not in (i, j)
            ]
            if crossing:
                continue
            out.append(Gap(i=i, j=j, width_m=width, point_i=pts[0], point_j=pts[1]))
        out.sort(key=lambda g: (g.width_m, g.i, g.j))
        return tuple(out)

    def doubtful_gaps(self, robot_width_m: float, tolerance: float = 0.3) -> tuple[Gap, ...]:
        """Gaps whose width lies within ``tolerance`` (relative) of the robot width either way."""
        w = positive(robot_width_m, "robot_width_m")
        if not (0 <= tolerance < 1):
            raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")
        lo, hi = (1 - tolerance) * w, (1 + tolerance) * w
        return tuple(g for g in self.gaps(max_width_m=hi) if lo <= g.width_m <= hi)
