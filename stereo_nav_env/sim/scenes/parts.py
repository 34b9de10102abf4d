"""Furniture parts: the rendered prisms of each obstacle kind, built from its footprint.

A table's footprint is the outline of its top: the robot (1.0 m tall) cannot pass under a 0.75 m
table, although the camera sees the floor between its legs. Tables and chairs stand on legs,
bookshelves carry shelf boards and vertical dividers whose repeated front edges make stereo
matching ambiguous, walls and boxes are plain prisms. Tables, chairs and bookshelves need a
rectangular footprint to get their legs, seat or shelves (their front, i.e. a bookshelf's open side
or a chair's seat edge, is the side from the first to the second footprint corner); other
footprints are drawn as one prism (a non-convex one as triangles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike
from shapely.geometry import Polygon

from modeling.types import FloatArray
from stereo_nav_env.sim.scenes.types import (
    DEFAULT_COLOR,
    DEFAULT_HEIGHT_M,
    BoxPart,
    Color,
    Obstacle,
    ObstacleKind,
    _color,
    _member,
    _number,
    _polygon_array,
)

__all__ = [
    "ShelfLayout",
    "build_parts",
    "make_obstacle",
    "oriented_rect",
    "rect_frame",
    "shelf_layout",
]


_LEG_COLOR: Color = (0.22, 0.18, 0.15)
_BACK_COLOR: Color = (0.20, 0.14, 0.10)


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
    corners: FloatArray = half @ rot.T + c
    return corners


@dataclass(frozen=True, slots=True, kw_only=True)
class ShelfLayout:
    """Where a bookshelf's boards and dividers are (local coordinates: ``u`` along its front
    from the first footprint corner, metres; heights in metres).

    Attributes:
        side_m: Thickness of its sides and dividers.
        back_m: Thickness of its back panel.
        board_m: Thickness of a shelf board.
        board_z_m: Bottom height of each board, lowest first (the lowest at 0).
        divider_u_m: Middle of each vertical divider along the front.
    """

    side_m: float
    back_m: float
    board_m: float
    board_z_m: tuple[float, ...]
    divider_u_m: tuple[float, ...]


def shelf_layout(length_m: float, depth_m: float, height_m: float) -> ShelfLayout:
    """The boards and dividers of a bookshelf ``length_m`` long, ``depth_m`` deep and
    ``height_m`` tall: a board about every 0.36 m of height, a divider about every 0.3 m of
    length (the default parts, :func:`build_parts`; the books of
    :mod:`~stereo_nav_env.sim.scenes.surface` stand on the boards between the dividers)."""
    length, depth, h = length_m, depth_m, height_m
    t = min(0.03, length / 8)
    back = min(0.02, depth / 4)
    board = min(0.025, h / 16)
    n_levels = max(2, round(h / 0.36))
    board_z = tuple(
        k * (h - board) / (n_levels - 1) if n_levels > 1 else 0.0 for k in range(n_levels)
    )
    n_bays = max(1, round((length - 2 * t) / 0.3))
    inner = length - 2 * t
    dividers = tuple(t + k * inner / n_bays for k in range(1, n_bays))
    return ShelfLayout(
        side_m=t, back_m=back, board_m=board, board_z_m=board_z, divider_u_m=dividers
    )


def rect_frame(footprint: FloatArray) -> tuple[FloatArray, float, float, float] | None:
    """``(centre (2,), length, depth, yaw)`` of a rectangular footprint (4, 2) (its first side
    is the length), or None if the footprint is not a rectangle."""
    return _rect_frame(footprint)


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
    kind = _member(ObstacleKind, kind, "kind")
    fp = _polygon_array(footprint, "footprint")
    h = DEFAULT_HEIGHT_M[kind] if height_m is None else _number(height_m, "height_m")
    if h <= 0:
        raise ValueError(f"height_m must be positive, got {height_m!r}")
    col = DEFAULT_COLOR[kind] if color is None else _color(color, "color")
    return Obstacle(
        kind=kind, footprint=fp, height_m=h, color=col, parts=build_parts(kind, fp, h, col)
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


def build_parts(kind: ObstacleKind, fp: FloatArray, h: float, color: Color) -> tuple[BoxPart, ...]:
    """The default rendered prisms of an obstacle of ``kind`` with footprint ``fp`` (k, 2), height
    ``h`` metres and base colour ``color``: legs and a top for tables, a seat and a back for
    chairs, a back, sides, boards and dividers for bookshelves, one prism (or convex pieces) else.
    """
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
        shelf = shelf_layout(length, depth, h)
        t, back, board = shelf.side_m, shelf.back_m, shelf.board_m
        parts.append(_local_part(frame, (0, length), (depth - back, depth), (0, h), _BACK_COLOR))
        parts.append(_local_part(frame, (0, t), (0, depth - back), (0, h), color))
        parts.append(_local_part(frame, (length - t, length), (0, depth - back), (0, h), color))
        for z0 in shelf.board_z_m:
            parts.append(
                _local_part(frame, (t, length - t), (0, depth - back), (z0, z0 + board), color)
            )
        for uc in shelf.divider_u_m:
            parts.append(
                _local_part(frame, (uc - t / 2, uc + t / 2), (0, depth - back), (0, h), color)
            )
    else:  # pragma: no cover - kinds are exhaustive
        return plain
    return tuple(parts)
