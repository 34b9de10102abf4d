"""Indoor scenes: a description, a seeded generator and a JSON map format.

A :class:`Scene` is what the simulator knows for certain: the room's bounds, the obstacles (each
with its true 2D collision outline and the 3D boxes that draw it), the robot's start pose and the
goal. Frames and units follow ARCHITECTURE.md: world metres, floor plane x-y, z up, headings in
radians counter-clockwise from +x.

Obstacles
---------
Every obstacle has a ``kind`` (:class:`ObstacleKind`), a ``footprint`` (k, 2) polygon in world
metres that is the robot's true collision outline, a height and a tuple of :class:`BoxPart` prisms
used only for rendering. A table's footprint is the outline of its top: the robot (1.0 m tall)
cannot pass under a 0.75 m table, although the camera sees the floor between its legs. Parts are
built from the kind (:func:`make_obstacle`): tables and chairs stand on legs, bookshelves carry
shelf boards and vertical dividers whose repeated front edges make stereo matching ambiguous, walls
and boxes are plain prisms. Walls with doorways are several wall obstacles; the doorway is the gap
between them.

Gaps
----
:meth:`Scene.gaps` lists the true gaps between pairs of obstacles (closest points, width), the
ground truth for passability; :meth:`Scene.doubtful_gaps` keeps those within a relative tolerance
of the robot's width. Generated scenes always have at least two doubtful gaps (width within 30 % of
the robot width) and a route from start to goal that the robot fits through.

JSON map format (``stereo-nav-map/1``)
--------------------------------------
A map file is one JSON object::

    {
      "format": "stereo-nav-map/1",          # optional; if present it must be this string
      "name": "default",                      # optional, default: the file's stem
      "bounds": [xmin, ymin, xmax, ymax],     # metres, the floor area (xmin < xmax, ymin < ymax)
      "start": [x, y, heading_rad],           # robot start pose, inside the bounds
      "goal": [x, y],                         # goal position, inside the bounds
      "obstacles": [                          # list, may be empty
        {
          "kind": "wall" | "table" | "chair" | "bookshelf" | "box",
          "footprint": [[x, y], ...],         # >= 3 points, a simple polygon, metres, world frame
          "rect": {"center": [x, y], "size": [length, depth], "yaw_deg": 0.0},
                                              # alternative to "footprint": an oriented rectangle
                                              # whose length runs along yaw; exactly one of the two
          "height": 0.75,                     # metres, > 0 (default per kind, see DEFAULT_HEIGHT_M)
          "color": [r, g, b],                 # optional, each in [0, 1] (default per kind)
          "parts": [                          # optional; default: built from kind/footprint/height
            {"footprint": [[x, y], ...], "z": [z_min, z_max], "color": [r, g, b]}
          ]
        }
      ]
    }

Tables, chairs and bookshelves need a rectangular footprint to get their legs, seat or shelves
(their front, i.e. a bookshelf's open side or a chair's seat edge, is the side from the first to
the second footprint corner); other footprints are drawn as one prism. A bookshelf's footprint runs
counter-clockwise with the front first. :func:`load_map` raises ``ValueError`` naming the bad field,
e.g. ``obstacles[2].footprint must have shape (k, 2) with k >= 3``.
"""

from __future__ import annotations

import enum
import json
import math
import pathlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Point, Polygon, box
from shapely.ops import unary_union

__all__ = [
    "DEFAULT_HEIGHT_M",
    "FAMILIES",
    "MAPS_DIR",
    "BoxPart",
    "Gap",
    "Obstacle",
    "ObstacleKind",
    "Scene",
    "available_maps",
    "generate_scene",
    "load_map",
    "load_scenario",
    "make_obstacle",
    "oriented_rect",
    "save_map",
    "scene_from_json",
    "scene_to_json",
]

FloatArray = NDArray[np.float64]
Color = tuple[float, float, float]

MAPS_DIR = pathlib.Path(__file__).resolve().parent / "maps"
MAP_FORMAT = "stereo-nav-map/1"
FAMILIES = ("room", "corridor", "cluttered", "office")
DEFAULT_MARGIN_M = 0.05
WALL_THICKNESS_M = 0.1


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
BOX_PALETTE: tuple[Color, ...] = (
    (0.70, 0.52, 0.30),
    (0.78, 0.30, 0.25),
    (0.30, 0.60, 0.35),
    (0.85, 0.78, 0.35),
    (0.55, 0.40, 0.65),
)
_LEG_COLOR: Color = (0.22, 0.18, 0.15)
_BACK_COLOR: Color = (0.20, 0.14, 0.10)


# ---------------------------------------------------------------------------------------- helpers
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


def oriented_rect(
    center_xy: ArrayLike, length_m: float, depth_m: float, yaw_rad: float = 0.0
) -> FloatArray:
    """Counter-clockwise corners (4, 2) of a rectangle, metres.

    Args:
        center_xy: (2,) centre, world metres.
        length_m: Side along the direction ``yaw_rad`` (the local u axis).
        depth_m: Side across it (the local v axis, u rotated by +90 degrees).
        yaw_rad: Direction of the length, radians counter-clockwise from +x.

    Returns:
        (4, 2) corners ``(-L/2,-D/2), (L/2,-D/2), (L/2,D/2), (-L/2,D/2)`` in the local frame,
        rotated and translated; the first edge is the "front" (local -v side).
    """
    c = np.asarray(center_xy, dtype=np.float64).reshape(2)
    half = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64) * [
        length_m / 2.0,
        depth_m / 2.0,
    ]
    co, si = math.cos(yaw_rad), math.sin(yaw_rad)
    rot = np.array([[co, -si], [si, co]])
    return half @ rot.T + c


def _rect_frame(footprint: FloatArray) -> tuple[FloatArray, float, float, float] | None:
    """(centre, length, depth, yaw) if the footprint is a rectangle, else None."""
    if footprint.shape[0] != 4:
        return None
    e0 = footprint[1] - footprint[0]
    e1 = footprint[2] - footprint[1]
    e2 = footprint[3] - footprint[2]
    length, depth = float(np.linalg.norm(e0)), float(np.linalg.norm(e1))
    if length < 1e-6 or depth < 1e-6:
        return None
    if abs(float(e0 @ e1)) > 1e-6 * length * depth or not np.allclose(e2, -e0, atol=1e-6):
        return None
    return footprint.mean(axis=0), length, depth, math.atan2(e0[1], e0[0])


# ---------------------------------------------------------------------------------------- model
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


def make_obstacle(
    kind: ObstacleKind | str,
    footprint: ArrayLike,
    height_m: float | None = None,
    color: Color | None = None,
) -> Obstacle:
    """An obstacle with the default rendered parts of its kind.

    Args:
        kind: Obstacle kind (or its string value).
        footprint: (k, 2) outline, world metres (rectangles give tables legs, chairs a seat and a
            back, bookshelves boards and dividers; the first edge is the front).
        height_m: Height, metres; default per kind (:data:`DEFAULT_HEIGHT_M`).
        color: Base RGB in [0, 1]; default per kind.

    Returns:
        The obstacle.
    """
    try:
        kind = ObstacleKind(kind)
    except ValueError as exc:
        raise ValueError(
            f"kind must be one of {[k.value for k in ObstacleKind]}, got {kind!r}"
        ) from exc
    fp = _polygon_array(footprint, "footprint")
    h = DEFAULT_HEIGHT_M[kind] if height_m is None else _number(height_m, "height_m")
    if h <= 0:
        raise ValueError(f"height_m must be positive, got {height_m!r}")
    col = DEFAULT_COLOR[kind] if color is None else _color(color, "color")
    return Obstacle(
        kind=kind, footprint=fp, height_m=h, color=col, parts=_build_parts(kind, fp, h, col)
    )


def _local_part(
    frame: tuple[FloatArray, float, float, float],
    u: tuple[float, float],
    v: tuple[float, float],
    z: tuple[float, float],
    color: Color,
) -> BoxPart:
    """A part given as local (u, v) ranges measured from the rectangle's min corner."""
    center, length, depth, yaw = frame
    cu = (u[0] + u[1]) / 2.0 - length / 2.0
    cv = (v[0] + v[1]) / 2.0 - depth / 2.0
    co, si = math.cos(yaw), math.sin(yaw)
    c = center + np.array([co * cu - si * cv, si * cu + co * cv])
    return BoxPart(
        footprint=oriented_rect(c, u[1] - u[0], v[1] - v[0], yaw),
        z_min_m=z[0],
        z_max_m=z[1],
        color=color,
    )


def _build_parts(kind: ObstacleKind, fp: FloatArray, h: float, color: Color) -> tuple[BoxPart, ...]:
    frame = _rect_frame(fp)
    plain = (BoxPart(footprint=fp, z_min_m=0.0, z_max_m=h, color=color),)
    if frame is None or kind in (ObstacleKind.WALL, ObstacleKind.BOX):
        if frame is None and not Polygon(fp).equals(Polygon(fp).convex_hull):
            tris = shapely.constrained_delaunay_triangles(Polygon(fp))
            return tuple(
                BoxPart(
                    footprint=np.asarray(t.exterior.coords)[:3], z_min_m=0.0, z_max_m=h, color=color
                )
                for t in tris.geoms
            )
        return plain
    _, length, depth, _ = frame
    parts: list[BoxPart] = []
    if kind is ObstacleKind.TABLE:
        top = min(0.04, h / 4)
        leg = min(0.06, length / 4, depth / 4)
        inset = min(0.04, length / 8, depth / 8)
        parts.append(_local_part(frame, (0, length), (0, depth), (h - top, h), color))
        for uu in (inset, length - inset - leg):
            for vv in (inset, depth - inset - leg):
                parts.append(
                    _local_part(frame, (uu, uu + leg), (vv, vv + leg), (0, h - top), _LEG_COLOR)
                )
    elif kind is ObstacleKind.CHAIR:
        seat_z = min(0.45, h * 0.5)
        seat_t = min(0.04, seat_z / 4)
        leg = min(0.04, length / 4, depth / 4)
        back_t = min(0.05, depth / 4)
        parts.append(_local_part(frame, (0, length), (0, depth), (seat_z - seat_t, seat_z), color))
        parts.append(_local_part(frame, (0, length), (depth - back_t, depth), (seat_z, h), color))
        for uu in (0.0, length - leg):
            for vv in (0.0, depth - leg):
                parts.append(
                    _local_part(
                        frame, (uu, uu + leg), (vv, vv + leg), (0, seat_z - seat_t), _LEG_COLOR
                    )
                )
    elif kind is ObstacleKind.BOOKSHELF:
        t = min(0.03, length / 8)
        back = min(0.02, depth / 4)
        board = min(0.025, h / 16)
        parts.append(_local_part(frame, (0, length), (depth - back, depth), (0, h), _BACK_COLOR))
        parts.append(_local_part(frame, (0, t), (0, depth - back), (0, h), color))
        parts.append(_local_part(frame, (length - t, length), (0, depth - back), (0, h), color))
        n_levels = max(2, round(h / 0.36))
        for k in range(n_levels):
            z0 = k * (h - board) / (n_levels - 1) if n_levels > 1 else 0.0
            parts.append(
                _local_part(frame, (t, length - t), (0, depth - back), (z0, z0 + board), color)
            )
        n_bays = max(1, round((length - 2 * t) / 0.3))
        inner = length - 2 * t
        for k in range(1, n_bays):
            uc = t + k * inner / n_bays
            parts.append(
                _local_part(frame, (uc - t / 2, uc + t / 2), (0, depth - back), (0, h), color)
            )
    else:  # pragma: no cover - kinds are exhaustive
        return plain
    return tuple(parts)


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
        r = _check_width(robot_width_m) / 2.0 + _check_margin(margin_m)
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
        max_width_m = _check_width(max_width_m, "max_width_m")
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
        w = _check_width(robot_width_m)
        if not (0 <= tolerance < 1):
            raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")
        lo, hi = (1 - tolerance) * w, (1 + tolerance) * w
        return tuple(g for g in self.gaps(max_width_m=hi) if lo <= g.width_m <= hi)


def _check_width(value: float, name: str = "robot_width_m") -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return x


def _check_margin(value: float) -> float:
    x = float(value)
    if not (math.isfinite(x) and x >= 0):
        raise ValueError(f"margin_m must be a non-negative finite number, got {value!r}")
    return x


# ---------------------------------------------------------------------------------------- JSON
def _obstacle_to_json(ob: Obstacle) -> dict[str, Any]:
    out: dict[str, Any] = {
        "kind": ob.kind.value,
        "footprint": np.round(ob.footprint, 6).tolist(),
        "height": round(ob.height_m, 6),
        "color": [round(c, 6) for c in ob.color],
    }
    default = _build_parts(ob.kind, ob.footprint, ob.height_m, ob.color)
    same = len(default) == len(ob.parts) and all(
        a.footprint.shape == b.footprint.shape
        and np.allclose(a.footprint, b.footprint, atol=1e-6)
        and abs(a.z_min_m - b.z_min_m) < 1e-6
        and abs(a.z_max_m - b.z_max_m) < 1e-6
        and np.allclose(a.color, b.color, atol=1e-6)
        for a, b in zip(default, ob.parts, strict=True)
    )
    if not same:
        out["parts"] = [
            {
                "footprint": np.round(p.footprint, 6).tolist(),
                "z": [p.z_min_m, p.z_max_m],
                "color": list(p.color),
            }
            for p in ob.parts
        ]
    return out


def scene_to_json(scene: Scene) -> dict[str, Any]:
    """The JSON-ready dict of a scene (map format ``stereo-nav-map/1``, see the module doc)."""
    return {
        "format": MAP_FORMAT,
        "name": scene.name,
        "bounds": list(scene.bounds),
        "start": list(scene.start),
        "goal": list(scene.goal),
        "obstacles": [_obstacle_to_json(ob) for ob in scene.obstacles],
    }


def save_map(scene: Scene, path: str | pathlib.Path) -> pathlib.Path:
    """Write a scene as a JSON map file; returns the path."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(scene_to_json(scene), indent=1) + "\n")
    return path


def _obstacle_from_json(data: Any, field: str) -> Obstacle:
    if not isinstance(data, Mapping):
        raise _err(field, f"must be an object, got {type(data).__name__}")
    unknown = sorted(set(data) - {"kind", "footprint", "rect", "height", "color", "parts"})
    if unknown:
        raise _err(field, f"has unknown keys {unknown}")
    if "kind" not in data:
        raise _err(f"{field}.kind", "is missing")
    try:
        kind = ObstacleKind(data["kind"])
    except ValueError as exc:
        choices = [k.value for k in ObstacleKind]
        raise _err(f"{field}.kind", f"must be one of {choices}, got {data['kind']!r}") from exc
    if ("footprint" in data) == ("rect" in data):
        raise _err(field, "must have exactly one of 'footprint' or 'rect'")
    if "footprint" in data:
        fp = _polygon_array(data["footprint"], f"{field}.footprint")
    else:
        rect = data["rect"]
        if not isinstance(rect, Mapping):
            raise _err(f"{field}.rect", "must be an object with center, size, yaw_deg")
        c = _vector(rect.get("center"), f"{field}.rect.center", 2)
        size = _vector(rect.get("size"), f"{field}.rect.size", 2)
        if size[0] <= 0 or size[1] <= 0:
            raise _err(f"{field}.rect.size", f"must be positive, got {list(size)}")
        yaw = math.radians(_number(rect.get("yaw_deg", 0.0), f"{field}.rect.yaw_deg"))
        fp = oriented_rect(c, size[0], size[1], yaw)
    height = _number(data.get("height", DEFAULT_HEIGHT_M[kind]), f"{field}.height")
    if height <= 0:
        raise _err(f"{field}.height", f"must be positive, got {height}")
    color = _color(data["color"], f"{field}.color") if "color" in data else DEFAULT_COLOR[kind]
    if "parts" not in data:
        return make_obstacle(kind, fp, height, color)
    raw_parts = data["parts"]
    if not isinstance(raw_parts, list) or not raw_parts:
        raise _err(f"{field}.parts", "must be a non-empty list")
    parts = []
    for k, p in enumerate(raw_parts):
        pf = f"{field}.parts[{k}]"
        if not isinstance(p, Mapping):
            raise _err(pf, "must be an object")
        pfp = _polygon_array(p.get("footprint"), f"{pf}.footprint")
        z = _vector(p.get("z"), f"{pf}.z", 2)
        if not 0 <= z[0] < z[1]:
            raise _err(f"{pf}.z", f"must satisfy 0 <= z_min < z_max, got {list(z)}")
        pc = _color(p["color"], f"{pf}.color") if "color" in p else color
        parts.append(BoxPart(footprint=pfp, z_min_m=z[0], z_max_m=z[1], color=pc))
    return Obstacle(kind=kind, footprint=fp, height_m=height, color=color, parts=tuple(parts))


def scene_from_json(data: Any, *, default_name: str = "map") -> Scene:
    """A scene from a parsed JSON map (see the module doc); ``ValueError`` names a bad field."""
    if not isinstance(data, Mapping):
        raise ValueError(f"map must be a JSON object, got {type(data).__name__}")
    unknown = sorted(set(data) - {"format", "name", "bounds", "start", "goal", "obstacles"})
    if unknown:
        raise ValueError(f"map has unknown keys {unknown}")
    if "format" in data and data["format"] != MAP_FORMAT:
        raise _err("format", f"must be {MAP_FORMAT!r}, got {data['format']!r}")
    for key in ("bounds", "start", "goal", "obstacles"):
        if key not in data:
            raise _err(key, "is missing")
    name = data.get("name", default_name)
    if not isinstance(name, str):
        raise _err("name", f"must be a string, got {name!r}")
    bounds = _vector(data["bounds"], "bounds", 4)
    if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
        raise _err("bounds", f"must satisfy xmin < xmax and ymin < ymax, got {list(bounds)}")
    start = _vector(data["start"], "start", 3)
    goal = _vector(data["goal"], "goal", 2)
    if not isinstance(data["obstacles"], list):
        raise _err("obstacles", "must be a list")
    obstacles = tuple(
        _obstacle_from_json(ob, f"obstacles[{i}]") for i, ob in enumerate(data["obstacles"])
    )
    return Scene(name=name, bounds=bounds, obstacles=obstacles, start=start, goal=goal)  # type: ignore[arg-type]


def load_map(path: str | pathlib.Path) -> Scene:
    """Load a JSON map file (see the module docstring for the format).

    Raises:
        ValueError: The file is not valid JSON or a field is malformed (the message names it).
    """
    path = pathlib.Path(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"map {path} is not valid JSON: {exc}") from exc
    return scene_from_json(data, default_name=path.stem)


def available_maps() -> tuple[str, ...]:
    """Names of the maps bundled in ``stereo_nav_env/maps``."""
    return tuple(sorted(p.stem for p in MAPS_DIR.glob("*.json")))


def load_scenario(scenario: str, seed: int = 0, *, robot_width_m: float = 0.5) -> Scene:
    """A scene by name: a bundled map, a ``.json`` path, a family name, or ``"random"``.

    Args:
        scenario: ``"default"`` or another bundled map name, a path ending in ``.json``, one of
            :data:`FAMILIES` (generated from ``seed``) or ``"random"`` (the family is drawn from
            ``seed`` as well).
        seed: Seed of generated scenes.
        robot_width_m: Robot width the generator guarantees a route for.
    """
    if not isinstance(scenario, str) or not scenario:
        raise ValueError(f"scenario must be a non-empty string, got {scenario!r}")
    if scenario.endswith(".json"):
        return load_map(scenario)
    if scenario in available_maps():
        return load_map(MAPS_DIR / f"{scenario}.json")
    if scenario == "random":
        family = FAMILIES[int(np.random.default_rng(seed).integers(len(FAMILIES)))]
        return generate_scene(seed, family=family, robot_width_m=robot_width_m)
    if scenario in FAMILIES:
        return generate_scene(seed, family=scenario, robot_width_m=robot_width_m)
    raise ValueError(
        f"scenario must be a map name {list(available_maps())}, a .json path, a family "
        f"{list(FAMILIES)} or 'random', got {scenario!r}"
    )


# ---------------------------------------------------------------------------------------- generator
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


_LAYOUTS = {
    "room": (_layout_room, (8.0, 10.0), (5.5, 7.0)),
    "corridor": (_layout_corridor, (10.0, 13.0), (2.6, 3.2)),
    "cluttered": (_layout_cluttered, (7.0, 9.0), (6.0, 7.5)),
    "office": (_layout_office, (9.0, 11.0), (6.0, 7.0)),
}


def generate_scene(
    seed: int,
    *,
    family: str = "room",
    robot_width_m: float = 0.5,
    margin_m: float = DEFAULT_MARGIN_M,
    min_doubtful_gaps: int = 2,
    max_attempts: int = 200,
) -> Scene:
    """A random indoor scene, deterministic in ``seed``.

    Every scene has walls around its bounds, furniture of the family's style, a start on the left
    looking roughly towards +x and a goal on the right, both free and joined by a route a disc of
    diameter ``robot_width_m`` fits through with ``margin_m`` to spare on each side, and at least
    ``min_doubtful_gaps`` gaps whose width is within 30 % of ``robot_width_m``.

    Args:
        seed: Non-negative integer seed.
        family: One of :data:`FAMILIES`: ``"room"`` (a bookshelf gate in view, a table, chairs,
            boxes), ``"corridor"`` (a long corridor narrowed by boxes and shelves), ``"cluttered"``
            (many boxes and chairs) or ``"office"`` (a partition wall with two doorways).
        robot_width_m: Robot diameter, metres (0.1 to 1.5).
        margin_m: Clearance kept on each side of the robot along the route, metres.
        min_doubtful_gaps: Minimum number of doubtful gaps.
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
    w = _check_width(robot_width_m)
    if not 0.1 <= w <= 1.5:
        raise ValueError(f"robot_width_m must be in [0.1, 1.5], got {robot_width_m!r}")
    margin_m = _check_margin(margin_m)
    if not isinstance(min_doubtful_gaps, int) or min_doubtful_gaps < 0:
        raise ValueError(
            f"min_doubtful_gaps must be a non-negative integer, got {min_doubtful_gaps!r}"
        )
    if not isinstance(max_attempts, int) or max_attempts < 1:
        raise ValueError(f"max_attempts must be a positive integer, got {max_attempts!r}")
    layout, w_range, h_range = _LAYOUTS[family]
    rng = np.random.default_rng([int(seed), FAMILIES.index(family)])
    scale = max(1.0, w / 0.5)
    for _ in range(max_attempts):
        W = float(rng.uniform(*w_range)) * scale
        H = float(rng.uniform(*h_range)) * scale
        bounds = (0.0, 0.0, W, H)
        start = (float(rng.uniform(0.8, 1.4)), float(rng.uniform(0.35, 0.65) * H))
        goal = (float(W - rng.uniform(0.8, 1.4)), float(rng.uniform(0.25, 0.75) * H))
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) + float(rng.normal(0, 0.1))
        b = _Builder(rng, bounds, w)
        b.walls()
        r = w / 2 + margin_m + 0.3
        b.keepout = [Point(*start).buffer(r), Point(*goal).buffer(r)]
        layout(b, W, H)
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
