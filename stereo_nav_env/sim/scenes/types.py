"""The scene's types: :class:`Scene`, :class:`Obstacle`, :class:`BoxPart`, :class:`FaceFeature`,
:class:`Gap`, :class:`ObstacleKind` and :class:`DetailKind`, with the checks that keep them valid.

A :class:`Scene` is what the simulator knows for certain: the room's bounds, the obstacles (each
with its true 2D collision outline and the 3D boxes that draw it), the robot's start pose and the
goal. Frames and units follow ARCHITECTURE.md: world metres, floor plane x-y, z up, headings in
radians counter-clockwise from +x.

Every obstacle has a ``kind``, a ``footprint`` (k, 2) polygon in world metres that is the robot's
true collision outline, a height and a tuple of :class:`BoxPart` prisms used only for rendering
(built from the kind by :func:`stereo_nav_env.sim.scenes.parts.make_obstacle`), and may carry
surface detail: :class:`FaceFeature` strips on its faces (panel seams, door frames, cabinet fronts,
book spines; issue 42), drawn as thin prisms (:attr:`Obstacle.detail_parts`) that give a face
seen face-on the vertical edges segment stereo matches. The detail is generated per scene by
:mod:`stereo_nav_env.sim.scenes.surface`; it changes nothing the robot collides with.

:meth:`Scene.gaps` lists the true gaps between pairs of obstacles (closest points, width), the
ground truth for passability; :meth:`Scene.doubtful_gaps` keeps those within a relative tolerance
of the robot's width.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

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
    "DETAIL_INSET_M",
    "DETAIL_PROUD_M",
    "SPINE_DEPTH_M",
    "SPINE_SETBACK_M",
    "BoxPart",
    "Color",
    "DetailKind",
    "FaceFeature",
    "Gap",
    "Obstacle",
    "ObstacleKind",
    "Scene",
    "outline_sides",
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


class DetailKind(str, enum.Enum):
    """The closed set of surface-detail kinds (:class:`FaceFeature`).

    ``seam``: a narrow dark joint between wall panels or cabinet doors; ``door_frame``: a door's
    jamb on a wall; ``front``: a door or drawer front of a piece of furniture, a panel of its own
    shade; ``spine``: a book standing on a shelf, set back behind the shelf's open front.
    """

    SEAM = "seam"
    DOOR_FRAME = "door_frame"
    FRONT = "front"
    SPINE = "spine"


DETAIL_PROUD_M = 0.003
"""How far a strip's front stands out of its face, metres (seams, door frames, fronts)."""
DETAIL_INSET_M = 0.012
"""How far a strip reaches into its face behind the face's plane, metres: its back corners lie
inside the obstacle, deeper than the surrogate's sight lines stop short of an edge
(``PULL_BACK_M``, 5 mm), so they are hidden as in the image."""
SPINE_SETBACK_M = 0.01
"""How far a book's spine stands behind the face's plane (a bookshelf's open front), metres."""
SPINE_DEPTH_M = 0.18
"""A book's depth into the shelf, metres."""

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


_E = TypeVar("_E", bound=enum.Enum)


def _member(cls: type[_E], value: Any, field: str) -> _E:
    """``cls(value)``, else a ``ValueError`` naming ``field`` and the choices."""
    try:
        return cls(value)
    except ValueError as exc:
        choices = [k.value for k in cls]
        raise _err(field, f"must be one of {choices}, got {value!r}") from exc


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise _err(field, f"must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise _err(field, f"must be finite, got {value!r}")
    return x


def _heights(z_min_m: object, z_max_m: object) -> tuple[float, float]:
    """``(z_min_m, z_max_m)`` as floats with ``0 <= z_min_m < z_max_m``, else a ``ValueError``."""
    z0, z1 = _number(z_min_m, "z_min_m"), _number(z_max_m, "z_max_m")
    if z0 < 0 or z1 <= z0:
        raise ValueError(f"z_min_m/z_max_m must satisfy 0 <= z_min_m < z_max_m, got {z0}, {z1}")
    return z0, z1


def outline_sides(fp: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The sides of the counter-clockwise outline ``fp`` (k, 2): side ``k`` runs from corner
    ``k`` to ``k + 1``. Returns their vectors (k, 2), lengths (k,) and outward unit normals
    (k, 2)."""
    side = np.roll(fp, -1, axis=0) - fp
    length = np.linalg.norm(side, axis=1)
    normal = np.stack([side[:, 1], -side[:, 0]], axis=1) / np.maximum(length, 1e-12)[:, None]
    return side, length, normal


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
@dataclass(frozen=True, slots=True, kw_only=True)
class FaceFeature:
    """One vertical feature on a face of an obstacle: a strip drawn on (or, for a book, behind)
    the face, whose two vertical sides are edges segment stereo can match.

    Attributes:
        kind: What it is (:class:`DetailKind`).
        face: The obstacle's side it lies on: the side from footprint corner ``face`` to corner
            ``face + 1`` of the counter-clockwise footprint (non-negative integer).
        offset_m: Position of the strip's middle along that side, metres from its first corner.
        width_m: Width of the strip along the side, metres (> 0).
        z_min_m: Bottom height, metres (>= 0).
        z_max_m: Top height, metres (> z_min_m, at most the obstacle's height).
        color: RGB in [0, 1]; the renderer shades the strip's faces by orientation like any part.
    """

    kind: DetailKind
    face: int
    offset_m: float
    width_m: float
    z_min_m: float
    z_max_m: float
    color: Color

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", _member(DetailKind, self.kind, "kind"))
        if (
            isinstance(self.face, bool)
            or not isinstance(self.face, int | np.integer)
            or self.face < 0
        ):
            raise ValueError(f"face must be a non-negative integer, got {self.face!r}")
        object.__setattr__(self, "face", int(self.face))
        object.__setattr__(self, "offset_m", _number(self.offset_m, "offset_m"))
        width = _number(self.width_m, "width_m")
        if width <= 0:
            raise ValueError(f"width_m must be positive, got {self.width_m!r}")
        object.__setattr__(self, "width_m", width)
        z0, z1 = _heights(self.z_min_m, self.z_max_m)
        object.__setattr__(self, "z_min_m", z0)
        object.__setattr__(self, "z_max_m", z1)
        object.__setattr__(self, "color", _color(self.color, "color"))

    def across_m(self) -> tuple[float, float]:
        """The strip's extent across its face, metres along the face's outward normal:
        ``(back, front)``, the face's plane at 0."""
        if self.kind is DetailKind.SPINE:
            return (-SPINE_SETBACK_M - SPINE_DEPTH_M, -SPINE_SETBACK_M)
        return (-DETAIL_INSET_M, DETAIL_PROUD_M)

    def footprint(self, obstacle_footprint: FloatArray) -> FloatArray:
        """The strip's floor outline (4, 2), world metres, counter-clockwise, on side
        :attr:`face` of ``obstacle_footprint`` (k, 2) (counter-clockwise)."""
        k = obstacle_footprint.shape[0]
        a, b = obstacle_footprint[self.face % k], obstacle_footprint[(self.face + 1) % k]
        t = (b - a) / float(np.linalg.norm(b - a))
        n = np.array([t[1], -t[0]])  # outward normal of a counter-clockwise outline
        s0, s1 = self.offset_m - self.width_m / 2.0, self.offset_m + self.width_m / 2.0
        d0, d1 = self.across_m()
        # counter-clockwise: along the side on the back line, then back on the front line
        out: FloatArray = np.array(
            [a + s0 * t + d1 * n, a + s1 * t + d1 * n, a + s1 * t + d0 * n, a + s0 * t + d0 * n]
        )
        return out


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
        z0, z1 = _heights(self.z_min_m, self.z_max_m)
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
        detail: Its surface detail (:class:`FaceFeature`; empty: plain faces). Each feature
            must lie on a side of the footprint (``face`` < the number of corners), within it
            (``0 <= offset_m - width_m / 2`` and ``offset_m + width_m / 2 <= `` the side's
            length) and below the top (``z_max_m <= height_m``).
        detail_parts: The detail's prisms (derived; one per feature, in order): what the
            renderer and the surrogate perception draw besides :attr:`parts`.
    """

    kind: ObstacleKind
    footprint: FloatArray
    height_m: float
    color: Color
    parts: tuple[BoxPart, ...]
    detail: tuple[FaceFeature, ...] = ()
    detail_parts: tuple[BoxPart, ...] = dataclasses.field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", _member(ObstacleKind, self.kind, "kind"))
        object.__setattr__(self, "footprint", _polygon_array(self.footprint, "footprint"))
        height = _number(self.height_m, "height_m")
        if height <= 0:
            raise ValueError(f"height_m must be positive, got {self.height_m!r}")
        object.__setattr__(self, "height_m", height)
        object.__setattr__(self, "color", _color(self.color, "color"))
        object.__setattr__(self, "parts", tuple(self.parts))
        detail = tuple(self.detail)
        fp = self.footprint
        k = fp.shape[0]
        _, sides, _ = outline_sides(fp)
        for i, feature in enumerate(detail):
            f = f"detail[{i}]"
            if not isinstance(feature, FaceFeature):
                raise ValueError(f"{f} must be a FaceFeature, got {type(feature).__name__}")
            if feature.face >= k:
                raise ValueError(
                    f"{f}.face must be a side of the footprint (< {k}), got {feature.face}"
                )
            length = float(sides[feature.face])
            lo = feature.offset_m - feature.width_m / 2.0
            hi = feature.offset_m + feature.width_m / 2.0
            if lo < -1e-9 or hi > length + 1e-9:
                raise ValueError(
                    f"{f}.offset_m/width_m must keep the strip on its side "
                    f"(0 <= offset - width/2, offset + width/2 <= {length:.6g}), "
                    f"got offset {feature.offset_m}, width {feature.width_m}"
                )
            if feature.z_max_m > height + 1e-9:
                raise ValueError(
                    f"{f}.z_max_m must not exceed the obstacle's height ({height}), "
                    f"got {feature.z_max_m}"
                )
        object.__setattr__(self, "detail", detail)
        object.__setattr__(
            self,
            "detail_parts",
            tuple(
                BoxPart(
                    footprint=feature.footprint(fp),
                    z_min_m=feature.z_min_m,
                    z_max_m=feature.z_max_m,
                    color=feature.color,
                )
                for feature in detail
            ),
        )

    @property
    def drawn_parts(self) -> tuple[BoxPart, ...]:
        """Every prism that draws it: :attr:`parts`, then :attr:`detail_parts`."""
        return self.parts + self.detail_parts if self.detail_parts else self.parts

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
