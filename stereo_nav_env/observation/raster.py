"""The egocentric top-down raster of an environment model (``obs["raster"]``).

A square uint8 image, channels last ``(S, S, 3)`` like the camera images (stable-baselines3 then
transposes every image of the observation alike; it cannot mix channel orders in one ``Dict``),
centred on the robot's centre with the robot's forward direction (+x of the robot frame) pointing
up (row 0) and its left (+y) pointing left (column 0); one pixel is ``2 * raster_half_extent_m /
S`` metres. Viewed as RGB: red occupancy, green doubt, blue unobserved. Channels:

0. **Expected occupancy**: over the K most probable situations, the probability-weighted mean
   (normalised by their total probability) of each situation's obstacles drawn as their skeleton
   lines (segments and the impassable links between them: where the robot cannot pass),
   anti-aliased, 255 = an obstacle line in every situation.
1. **Doubt**: the same weighted mean of each situation's critical regions filled with
   ``255 * 4 p (1 - p)`` (``p = p_passable``; 255 at p = 0.5, 0 when the passability is certain),
   the narrowest relation drawn as a line so thin regions are not lost; where regions overlap the
   larger doubt wins.
2. **Unobserved**: 255 in the occluded area (behind obstacles within the field of view and range,
   ``model.occluded``), 128 outside the field of view, beyond the range or in the blind band
   below the image (the floor within ``EnvConfig.blind_range_m`` of the head), 0 where the floor
   was seen free.

The raster of the fused model (``obs["memory_raster"]``, :func:`rasterize_memory`) has these
three channels, drawn from the fused model, and a fourth:

3. **Unknown**: 255 where the floor has never been seen in the episode (outside the memory's
   seen area, so also the floor near the robot that no view has covered), 0 where it has; a
   pixel the seen area's boundary crosses counts as unknown.

The policy's raster (``observation_mode="policy"``, :func:`rasterize_policy`) has five
channels that keep apart what channel 2 mixes: occupancy, doubt, seen free (this view),
occluded, never seen (in the episode).

All drawing is OpenCV (``fillPoly``, ``polylines``) with 4 bits of sub-pixel precision; no
per-pixel Python loops.
"""

from __future__ import annotations

import functools
import math
from typing import cast

import cv2
import numpy as np
import shapely
from numpy.typing import NDArray

from modeling.model.records import EnvironmentModel, Situation
from modeling.observation import FloorObservation
from modeling.types import FloatArray
from stereo_nav_env.config import ObservationConfig

__all__ = [
    "UNKNOWN_VALUE",
    "UNSEEN_VALUE",
    "rasterize_memory",
    "rasterize_model",
    "rasterize_policy",
    "unknown_channel",
    "view_masks",
    "view_wedge",
    "visible_mask",
    "world_to_raster",
]

UNSEEN_VALUE = 128
UNKNOWN_VALUE = 255
_SHIFT = 4
_SCALE = float(1 << _SHIFT)
_ARC_POINTS = 24


def world_to_raster(
    robot_pose: tuple[float, float, float], cfg: ObservationConfig
) -> tuple[FloatArray, FloatArray]:
    """The affine map from world ``(x, y)`` to raster ``(column, row)``: ``p @ A.T + b``.

    Args:
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: Raster size and extent.

    Returns:
        ``(A, b)``: (2, 2) and (2,), in pixels whose centres are at integer coordinates.
    """
    x, y, heading = robot_pose
    c, s = math.cos(heading), math.sin(heading)
    inv = 1.0 / cfg.raster_cell_m
    A = np.array([[s, -c], [-c, -s]]) * inv  # column = -y_robot, row = -x_robot
    centre = cfg.raster_size_px / 2.0 - 0.5
    b = np.array([centre, centre]) - A @ np.array([x, y])
    return A, b


def _fixed(points: FloatArray, A: FloatArray, b: FloatArray) -> NDArray[np.int32]:
    """World points (..., 2) to fixed-point raster coordinates (..., 2) int32 for OpenCV
    (clipped to +-1e5 pixels: ``np.clip``'s values, without its wrapper's cost)."""
    pix = points @ A.T + b
    return np.rint(np.minimum(np.maximum(pix, -1e5), 1e5) * _SCALE).astype(np.int32)


def _obstacle_lines(situation: Situation) -> FloatArray:
    """(q, 2, 2) skeleton lines of all obstacles of a situation, world metres."""
    parts = [
        ob.lines if ob.lines.shape[0] else np.asarray(ob.points).reshape(-1, 2, 2)
        for ob in situation.obstacles
    ]
    return np.concatenate(parts, axis=0) if parts else np.zeros((0, 2, 2))


def _draw_situation(
    situation: Situation,
    A: FloatArray,
    b: FloatArray,
    occ: NDArray[np.uint8],
    doubt: NDArray[np.uint8],
) -> None:
    """Draw one situation's obstacle lines into ``occ`` and its regions into ``doubt`` (zeroed)."""
    occ.fill(0)
    doubt.fill(0)
    lines = _obstacle_lines(situation)
    if lines.shape[0]:
        cv2.polylines(occ, list(_fixed(lines, A, b)), False, 255, 1, cv2.LINE_AA, _SHIFT)
    regions = situation.critical_regions
    if regions:
        p = np.array([r.p_passable for r in regions])
        values = np.rint(255.0 * 4.0 * p * (1.0 - p)).astype(int)
        # larger doubt drawn last, wins; every vertex mapped in one call
        order = [k for k in np.argsort(values, kind="stable").tolist() if values[k] != 0]
        if not order:
            return
        shapes = [regions[k].polygon for k in order]
        pix = _fixed(np.concatenate([*shapes, *(regions[k].narrowest for k in order)]), A, b)
        ends = pix[-2 * len(order) :].tolist()
        start = 0
        for n, k in enumerate(order):
            stop = start + shapes[n].shape[0]
            value = int(values[k])
            cv2.fillPoly(doubt, [pix[start:stop]], value, cv2.LINE_8, _SHIFT)
            cv2.line(doubt, ends[2 * n], ends[2 * n + 1], value, 1, cv2.LINE_8, _SHIFT)
            start = stop


@functools.lru_cache(maxsize=8)
def _arc_offsets(half: float) -> FloatArray:
    """``np.linspace(-half, half, _ARC_POINTS)``, read-only (the field of view rarely changes)."""
    out = np.linspace(-half, half, _ARC_POINTS)
    out.setflags(write=False)
    return out


_last_wedge: tuple[FloorObservation, float, FloatArray] | None = None
"""The latest :func:`view_wedge`: its observation (held, so its identity is not reused), blind
band and wedge. An env step draws the view's wedge twice (the seen floor's grid, the raster)."""


def view_wedge(model: EnvironmentModel, near_m: float = 0.0) -> FloatArray:
    """The floor the view of ``model`` can see, unoccluded: the sector of its field of view
    between ``near_m`` (the blind band below the image) and its range, world metres.

    Returns:
        (n, 2) read-only polygon vertices (the viewpoint then the range arc when ``near_m`` is
        0; the range arc then the near arc reversed otherwise; empty when ``near_m`` >= the
        range). The latest one is kept and given again for the same observation and band.
    """
    global _last_wedge
    obs = model.observation
    last = _last_wedge  # one read: another thread may replace it meanwhile
    if last is not None and last[0] is obs and last[1] == near_m:
        return last[2]
    vx, vy, heading = (float(v) for v in obs.viewpoint)
    ang = heading + _arc_offsets(0.5 * float(obs.fov_rad))
    unit = np.empty((ang.shape[0], 2))
    np.cos(ang, out=unit[:, 0])
    np.sin(ang, out=unit[:, 1])
    far = np.array([vx, vy]) + obs.max_range_m * unit
    if near_m <= 0.0:
        wedge = np.concatenate([[[vx, vy]], far])
    elif near_m >= obs.max_range_m:
        wedge = np.zeros((0, 2))
    else:
        wedge = np.concatenate([far, (np.array([vx, vy]) + near_m * unit)[::-1]])
    wedge.setflags(write=False)
    _last_wedge = (obs, near_m, wedge)
    return wedge


def view_masks(
    model: EnvironmentModel,
    A: FloatArray,
    b: FloatArray,
    shape: tuple[int, int],
    near_m: float,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """``(visible, occluded)`` uint8 masks of ``shape`` (255 inside): the view's sector beyond
    the blind band ``near_m``, less the occluded area; and the occluded area (``model.occluded``),
    drawn through the affine map ``p @ A.T + b`` from world metres to pixels (pixel centres at
    integer coordinates: :func:`world_to_raster`'s, or a world grid's)."""
    visible = np.zeros(shape, dtype=np.uint8)
    occluded = np.zeros(shape, dtype=np.uint8)
    wedge = view_wedge(model, near_m)
    if wedge.shape[0] >= 3:
        cv2.fillPoly(visible, [_fixed(wedge, A, b)], 255, cv2.LINE_8, _SHIFT)
    if model.occluded:
        cv2.fillPoly(occluded, [_fixed(p, A, b) for p in model.occluded], 255, cv2.LINE_8, _SHIFT)
        cv2.subtract(visible, occluded, dst=visible)  # 0 where occluded (both masks are 0/255)
    return visible, occluded


def visible_mask(
    model: EnvironmentModel,
    A: FloatArray,
    b: FloatArray,
    shape: tuple[int, int],
    near_m: float,
) -> NDArray[np.uint8]:
    """The ``visible`` mask of :func:`view_masks` alone (the occluded area drawn out of the
    sector directly: the same pixels, one array and one pass fewer)."""
    visible = np.zeros(shape, dtype=np.uint8)
    wedge = view_wedge(model, near_m)
    if wedge.shape[0] >= 3:
        cv2.fillPoly(visible, [_fixed(wedge, A, b)], 255, cv2.LINE_8, _SHIFT)
        if model.occluded:
            polys = [_fixed(p, A, b) for p in model.occluded]
            cv2.fillPoly(visible, polys, 0, cv2.LINE_8, _SHIFT)
    return visible


def _unobserved(
    model: EnvironmentModel, A: FloatArray, b: FloatArray, size: int, near_m: float
) -> NDArray[np.uint8]:
    """Channel 2: 128 outside the field of view and in the blind band, 0 seen, 255 occluded."""
    visible, occluded = view_masks(model, A, b, (size, size), near_m)
    out = np.full((size, size), UNSEEN_VALUE, dtype=np.uint8)
    out[visible > 0] = 0
    out[occluded > 0] = 255
    return out


def _model_channels(
    model: EnvironmentModel, A: FloatArray, b: FloatArray, cfg: ObservationConfig
) -> NDArray[np.uint8]:
    """Channels 0 and 1 (expected occupancy, doubt) as a (2, S, S) uint8 array."""
    size = cfg.raster_size_px
    situations = model.situations[: cfg.num_situations]
    out = np.zeros((2, size, size), dtype=np.uint8)
    weights = np.array([s.probability for s in situations], dtype=np.float64)
    total = float(weights.sum())
    if situations and total > 0:
        weights = weights / total
        if len(situations) == 1:
            _draw_situation(situations[0], A, b, out[0], out[1])
        else:
            occ = np.empty((size, size), dtype=np.uint8)
            doubt = np.empty((size, size), dtype=np.uint8)
            acc = np.zeros((2, size, size), dtype=np.float32)
            for w, situation in zip(weights.tolist(), situations, strict=True):
                _draw_situation(situation, A, b, occ, doubt)
                cv2.scaleAdd(occ.astype(np.float32), w, acc[0], dst=acc[0])
                cv2.scaleAdd(doubt.astype(np.float32), w, acc[1], dst=acc[1])
            np.rint(acc, out=acc)
            out[:] = np.clip(acc, 0, 255).astype(np.uint8)
    return out


def rasterize_model(
    model: EnvironmentModel,
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    *,
    near_m: float = 0.0,
) -> NDArray[np.uint8]:
    """The egocentric raster (S, S, 3) uint8 of ``model`` (channels in the module docstring).

    Args:
        model: The environment model (world frame).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: Raster size and extent, and K (``num_situations``).
        near_m: The blind band: floor nearer to the viewpoint than this is not seen, metres
            (``EnvConfig.blind_range_m``).

    Returns:
        A new uint8 array (S, S, 3), ``S = cfg.raster_size_px``.
    """
    A, b = world_to_raster(robot_pose, cfg)
    two = _model_channels(model, A, b, cfg)
    unobserved = _unobserved(model, A, b, cfg.raster_size_px, near_m)
    raster: NDArray[np.uint8] = np.dstack([two[0], two[1], unobserved])
    return raster


def rasterize_policy(
    model: EnvironmentModel,
    never_seen: NDArray[np.uint8],
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    *,
    near_m: float,
) -> NDArray[np.uint8]:
    """The policy's egocentric raster (S, S, 5) uint8 (``observation_mode="policy"``).

    Channels: 0 expected occupancy and 1 doubt (as :func:`rasterize_model`); 2 **seen free**:
    255 where this view sees the floor (in the field of view, beyond the blind band
    ``near_m``, within range, not occluded) and no obstacle line is drawn; 3 **occluded**: 255
    in ``model.occluded``; 4 **never seen**: ``never_seen`` (255 where no view of the episode
    has seen the floor, :class:`~stereo_nav_env.observation.seen.SeenFloor`).

    Args:
        model: The latest view's model (world frame).
        never_seen: (S, S) uint8, 255 where the floor was never seen (egocentric, as here).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: Raster size and extent, and K (``num_situations``).
        near_m: The blind band, metres.

    Returns:
        A new uint8 array (S, S, 5).
    """
    size = cfg.raster_size_px
    if never_seen.shape != (size, size):
        raise ValueError(f"never_seen must have shape {(size, size)}, got {never_seen.shape}")
    A, b = world_to_raster(robot_pose, cfg)
    two = _model_channels(model, A, b, cfg)
    visible, occluded = view_masks(model, A, b, (size, size), near_m)
    visible[two[0] > 0] = 0
    raster = cv2.merge([two[0], two[1], visible, occluded, never_seen])  # (S, S, 5)
    return cast(NDArray[np.uint8], raster)


def unknown_channel(
    seen: shapely.Geometry, robot_pose: tuple[float, float, float], cfg: ObservationConfig
) -> NDArray[np.uint8]:
    """Channel 3 of the memory raster: :data:`UNKNOWN_VALUE` outside ``seen``, 0 inside.

    Args:
        seen: The floor seen so far, world frame, metres (polygons; holes are left unknown).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: Raster size and extent.

    Returns:
        A new uint8 array (S, S).
    """
    size = cfg.raster_size_px
    out = np.full((size, size), UNKNOWN_VALUE, dtype=np.uint8)
    if seen is None or seen.is_empty:
        return out
    A, b = world_to_raster(robot_pose, cfg)
    # only the part within the raster's reach (its square, rotated, fits in this box) is drawn
    reach = cfg.raster_half_extent_m * math.sqrt(2.0) + cfg.raster_cell_m
    x, y = robot_pose[0], robot_pose[1]
    near = shapely.clip_by_rect(seen, x - reach, y - reach, x + reach, y + reach)
    rings = [
        np.asarray(ring.coords)[:-1]
        for part in shapely.get_parts(near)
        if isinstance(part, shapely.Polygon) and not part.is_empty
        for ring in (part.exterior, *part.interiors)
    ]
    rings = [r for r in rings if r.shape[0] >= 3]
    if rings:  # one call: the even-odd fill leaves the holes out
        pix = [_fixed(r, A, b) for r in rings]
        cv2.fillPoly(out, pix, 0, cv2.LINE_8, _SHIFT)
        # the fill covers every pixel its edges touch: those on the boundary count as unknown
        cv2.polylines(out, pix, True, UNKNOWN_VALUE, 1, cv2.LINE_8, _SHIFT)
    return out


def rasterize_memory(
    model: EnvironmentModel,
    seen: shapely.Geometry,
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    *,
    near_m: float = 0.0,
) -> NDArray[np.uint8]:
    """The egocentric raster (S, S, 4) uint8 of the fused ``model`` and its ``seen`` floor.

    Channels 0-2 are :func:`rasterize_model` of the fused model; channel 3 is
    :func:`unknown_channel` of ``seen`` (see the module docstring).

    Args:
        model: The fused environment model (world frame).
        seen: The floor seen so far in the episode, world frame.
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: Raster size and extent, and K (``num_situations``).
        near_m: The blind band of the latest view, metres.

    Returns:
        A new uint8 array (S, S, 4), ``S = cfg.raster_size_px``.
    """
    three = rasterize_model(model, robot_pose, cfg, near_m=near_m)
    raster: NDArray[np.uint8] = np.concatenate(
        [three, unknown_channel(seen, robot_pose, cfg)[..., None]], axis=2
    )
    return raster
