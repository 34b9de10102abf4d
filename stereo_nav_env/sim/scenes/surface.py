"""Surface detail: the vertical structure real rooms have on their faces (issue 42).

The rendered world is flat-shaded: a face seen face-on shows segment stereo on a horizontal
baseline nothing to match (its top and bottom edges lie along the epipolar rows), only its two
vertical ends. Real rooms are not like that (the paper's Fig. 1): walls have panel seams and door
frames, cabinets have door and drawer fronts, shelves hold books. :func:`add_surface_detail`
gives each face of a scene such vertical features (:class:`~stereo_nav_env.sim.scenes.types.
FaceFeature`), drawn from a seed, by what the face is:

* walls (each side at least 0.4 m long whose outside is within the bounds, i.e. not the outer
  side of a boundary wall): panel seams, dark joints or cover strips 4-6 cm wide from the floor
  to the top (narrower ones are under 3 px beyond 2 m, which the surrogate's photometry,
  sampling 1.5 and 3 px beside an edge, cannot see, while the stereo's extraction still finds a
  thin line), spaced by a panel width drawn per side (0.6-1.2 m) times 0.75-1.25 per seam
  (walls are made of sections of several widths; strictly periodic seams are look-alikes whose
  wrong matches all agree, the repeated pattern of the paper's section 4.2); on sides longer
  than 2 m, a door in one of three: two jambs 6-8 cm wide, 0.8-0.9 m apart, 2 m tall (or the
  wall's height), in a wood colour, with no seam between them;
* boxes (cabinets; each side at least 0.3 m long): either doors, seams 2-3 cm wide dividing
  the side into 0.3-0.5 m wide doors, or one front, a drawer or door panel of 25-60 % of the
  side in a shade of its own (0.7-0.85 or 1.15-1.3 of the box's colour, clipped), from the
  floor to 55-95 % of its height;
* bookshelves (rectangular, their front): books on two or three of the shelves, in groups of
  2-7 spines 2-5 cm wide between the dividers, 65-95 % of the shelf's clear height, in a
  palette of book colours, set back 1 cm behind the open front;
* tables and chairs: none (their legs and backs are their vertical structure).

The draws come from their own stream (``np.random.default_rng([seed, 42])``), after the scene is
made: the scene itself (its layout, what the robot collides with) is the same with or without
the detail. :func:`plain_surfaces` takes the detail away again.
"""

from __future__ import annotations

import itertools
import zlib
from dataclasses import replace

import numpy as np
from shapely.geometry import Point, Polygon, box

from stereo_nav_env.sim.scenes.parts import rect_frame, shelf_layout
from stereo_nav_env.sim.scenes.types import (
    Color,
    DetailKind,
    FaceFeature,
    Obstacle,
    ObstacleKind,
    Scene,
    outline_sides,
)

__all__ = [
    "BOOK_PALETTE",
    "DETAIL_STREAM",
    "add_surface_detail",
    "detail_seed",
    "has_surface_detail",
    "plain_surfaces",
]

DETAIL_STREAM = 42
"""The detail's random stream: ``np.random.default_rng([seed, DETAIL_STREAM])``."""
BOOK_PALETTE: tuple[Color, ...] = (
    (0.55, 0.12, 0.12),
    (0.12, 0.22, 0.50),
    (0.15, 0.42, 0.22),
    (0.85, 0.80, 0.62),
    (0.20, 0.18, 0.16),
    (0.80, 0.55, 0.15),
    (0.42, 0.20, 0.45),
    (0.90, 0.90, 0.88),
)
"""Colours of book spines."""
_DOOR_COLOR: Color = (0.45, 0.30, 0.18)
_END_MARGIN_M = 0.2
"""Features keep this far from a wall side's ends (where other walls may cover it), metres."""


def _round(x: float) -> float:
    return round(float(x), 4)


def _shade(color: Color, factor: float) -> Color:
    c = np.clip(np.asarray(color) * factor, 0.0, 1.0)
    return (_round(c[0]), _round(c[1]), _round(c[2]))


def _feature(
    kind: DetailKind, face: int, offset: float, width: float, z: tuple[float, float], color: Color
) -> FaceFeature:
    """A strip of ``kind`` on side ``face``, its numbers rounded to 0.1 mm (as maps store them)."""
    return FaceFeature(
        kind=kind,
        face=face,
        offset_m=_round(offset),
        width_m=_round(width),
        z_min_m=_round(z[0]),
        z_max_m=_round(z[1]),
        color=color,
    )


def _wall_detail(rng: np.random.Generator, ob: Obstacle, inside: Polygon) -> list[FaceFeature]:
    out: list[FaceFeature] = []
    side, length, normal = outline_sides(ob.footprint)
    middle = ob.footprint + side / 2.0
    h = ob.height_m
    for k in range(ob.footprint.shape[0]):
        L = float(length[k])
        if L < 0.4 or not inside.contains(Point(*(middle[k] + 0.05 * normal[k]))):
            continue
        lo, hi = min(_END_MARGIN_M, L / 4), L - min(_END_MARGIN_M, L / 4)
        door: tuple[float, float] | None = None
        if L > 2.0 and rng.random() < 1 / 3:
            jamb = float(rng.uniform(0.06, 0.08))
            leaf = float(rng.uniform(0.8, 0.9))
            span = leaf + 2 * jamb
            start = float(rng.uniform(lo, hi - span))
            top = min(2.0, h)
            for centre in (start + jamb / 2, start + span - jamb / 2):
                out.append(
                    _feature(DetailKind.DOOR_FRAME, k, centre, jamb, (0.0, top), _DOOR_COLOR)
                )
            door = (start - 0.05, start + span + 0.05)
        panel = float(rng.uniform(0.6, 1.2))
        width = float(rng.uniform(0.04, 0.06))
        color = _shade(ob.color, float(rng.uniform(0.55, 0.75)))
        s = lo + float(rng.uniform(0.0, panel))
        while s + width / 2 <= hi:
            if door is None or not (door[0] - width / 2 <= s <= door[1] + width / 2):
                out.append(_feature(DetailKind.SEAM, k, s, width, (0.0, h), color))
            s += panel * float(rng.uniform(0.75, 1.25))
    return out


def _box_detail(rng: np.random.Generator, ob: Obstacle) -> list[FaceFeature]:
    out: list[FaceFeature] = []
    _, length, _ = outline_sides(ob.footprint)
    h = ob.height_m
    for k in range(ob.footprint.shape[0]):
        L = float(length[k])
        if L < 0.3:
            continue
        if rng.random() < 0.5:  # doors: seams between them
            n = max(2, round(L / float(rng.uniform(0.3, 0.5))))
            width = float(rng.uniform(0.02, 0.03))
            color = _shade(ob.color, float(rng.uniform(0.45, 0.6)))
            for j in range(1, n):
                out.append(_feature(DetailKind.SEAM, k, j * L / n, width, (0.0, h), color))
        else:  # one front: a drawer or door panel of its own shade
            width = float(rng.uniform(0.25, 0.6)) * L
            centre = float(rng.uniform(width / 2 + 0.02, L - width / 2 - 0.02))
            factor = float(rng.choice([rng.uniform(0.7, 0.85), rng.uniform(1.15, 1.3)]))
            top = h * float(rng.uniform(0.55, 0.95))
            out.append(
                _feature(DetailKind.FRONT, k, centre, width, (0.0, top), _shade(ob.color, factor))
            )
    return out


def _bookshelf_detail(rng: np.random.Generator, ob: Obstacle) -> list[FaceFeature]:
    frame = rect_frame(ob.footprint)
    if frame is None:
        return []
    _, length, depth, _ = frame
    shelf = shelf_layout(length, depth, ob.height_m)
    t, board = shelf.side_m, shelf.board_m
    walls = [t, *shelf.divider_u_m, length - t]  # inner faces of sides and dividers: middles
    levels = list(itertools.pairwise(shelf.board_z_m))
    if not levels:
        return []
    chosen = rng.choice(len(levels), size=min(len(levels), int(rng.integers(2, 4))), replace=False)
    out: list[FaceFeature] = []
    for level in sorted(int(c) for c in chosen):
        z0, z1 = levels[level]
        bottom, clear = z0 + board, z1 - z0 - board
        for left, right in itertools.pairwise(walls):
            u0 = left + t / 2 + 0.005
            u1 = right - t / 2 - 0.005
            if u1 - u0 < 0.05 or rng.random() < 0.3:
                continue
            u = u0 + float(rng.uniform(0.0, 0.5)) * (u1 - u0)
            for _ in range(int(rng.integers(2, 8))):
                w = float(rng.uniform(0.02, 0.05))
                if u + w > u1:
                    break
                top = bottom + clear * float(rng.uniform(0.65, 0.95))
                color = BOOK_PALETTE[int(rng.integers(len(BOOK_PALETTE)))]
                out.append(
                    _feature(DetailKind.SPINE, 0, u + w / 2, w - 0.002, (bottom, top), color)
                )
                u += w
    return out


def detail_seed(scene: Scene) -> int:
    """The seed of a scene's detail where none is given: the CRC-32 of its name (a map's
    detail is the same at every load)."""
    return zlib.crc32(scene.name.encode("utf-8"))


def add_surface_detail(scene: Scene, seed: int | None = None) -> Scene:
    """``scene`` with surface detail on its walls, boxes and bookshelves (the module docstring).

    Args:
        scene: The scene; detail it already has is replaced.
        seed: Non-negative integer seed of the draws (None: :func:`detail_seed`).

    Returns:
        A new scene: the same bounds, start, goal and obstacles (footprints, heights, colours,
        parts), each with its ``detail``.
    """
    if seed is None:
        seed = detail_seed(scene)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng([int(seed), DETAIL_STREAM])
    x0, y0, x1, y1 = scene.bounds
    inside = box(x0, y0, x1, y1)
    obstacles = []
    for ob in scene.obstacles:
        if ob.kind is ObstacleKind.WALL:
            detail = _wall_detail(rng, ob, inside)
        elif ob.kind is ObstacleKind.BOX:
            detail = _box_detail(rng, ob)
        elif ob.kind is ObstacleKind.BOOKSHELF:
            detail = _bookshelf_detail(rng, ob)
        else:
            detail = []
        obstacles.append(replace(ob, detail=tuple(detail)))
    return replace(scene, obstacles=tuple(obstacles))


def has_surface_detail(scene: Scene) -> bool:
    """Whether any obstacle of ``scene`` has surface detail."""
    return any(ob.detail for ob in scene.obstacles)


def plain_surfaces(scene: Scene) -> Scene:
    """``scene`` without surface detail (``scene`` itself if it has none)."""
    if not has_surface_detail(scene):
        return scene
    return replace(scene, obstacles=tuple(replace(ob, detail=()) for ob in scene.obstacles))
