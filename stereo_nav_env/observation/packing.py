"""The observation: its ``Dict`` space and the packing of a model into fixed-size arrays.

Frames: the **robot frame** has its origin at the robot's centre, +x along the body heading
(forward) and +y to the robot's left, metres; bearings are radians counter-clockwise from +x, in
[-pi, pi].

Keys (K = ``num_situations``, R = ``num_regions``, F = ``len(REGION_FEATURES)`` = 12,
S = ``raster_size_px``; the model keys are present in modes ``"model"``, ``"both"`` and
``"model_memory"``, the images in ``"images"`` and ``"both"``, the fused model's keys
(``memory_*``) in ``"memory"`` and ``"model_memory"``, ``goal`` and ``head_pan`` always):

| key                | shape       | dtype   | meaning                                          |
|--------------------|-------------|---------|--------------------------------------------------|
| `situation_probs`  | (K,)        | float32 | probabilities of the K most probable situations,  |
|                    |             |         | descending; 0 for missing ones; sum <= 1         |
| `critical_regions` | (K * R * F,)| float32 | row-major (K, R, F): per situation, its critical |
|                    |             |         | regions nearest first, features below            |
| `raster`           | (S, S, 3)   | uint8   | egocentric top-down raster (:mod:`.raster`)      |
| `goal`             | (4,)        | float32 | goal in the robot frame: x_m, y_m, distance_m,   |
|                    |             |         | bearing_rad                                      |
| `head_pan`         | (1,)        | float32 | head pan relative to the body / ``pan_limit_rad`` |
| `left`, `right`    | (H, W, 3)   | uint8   | the rectified pair the model was built from       |
| `memory_situation_probs` | (K,)  | float32 | ``situation_probs`` of the fused model            |
| `memory_critical_regions` | (K * R * F,) | float32 | ``critical_regions`` of the fused model  |
| `memory_raster`    | (S, S, 4)   | uint8   | the raster's three channels of the fused model,  |
|                    |             |         | then unknown: 255 where the floor was never seen |

Mode ``"policy"`` (``StereoNav-v1``'s default) has its own keys, every non-image feature in a
documented bounded range:

| key                | shape        | dtype   | range    | meaning                                |
|--------------------|--------------|---------|----------|----------------------------------------|
| `raster`           | (S, S, 5)    | uint8   | 0-255    | occupancy, doubt, seen free (this      |
|                    |              |         |          | view), occluded, never seen (episode): |
|                    |              |         |          | :func:`~.raster.rasterize_policy`      |
| `situation_probs`  | (K,)         | float32 | [0, 1]   | as above                               |
| `critical_regions` | (K * R * F,) | float32 | [-1, 1]  | as above, each feature over its bound  |
|                    |              |         |          | (positions over ``feature_range_m``,   |
|                    |              |         |          | angles over pi)                        |
| `goal`             | (3,)         | float32 | [0, 1],  | distance over ``goal_range_m``         |
|                    |              |         | [-1, 1], | (clipped to 1), cos and sin of the     |
|                    |              |         | [-1, 1]  | bearing (robot frame)                  |
| `head_pan`         | (1,)         | float32 | [-1, 1]  | as above                               |
| `contact`          | (1,)         | float32 | {0, 1}   | 1 when the last step touched something |
| `prev_action`      | (3,)         | float32 | [-1, 1]  | the last step's (forward, turn, pan)   |
|                    |              |         |          | command; zeros after reset             |

The fused model is :func:`modeling.memory.fusion.build_memory_model` of the episode's
:class:`~modeling.memory.fusion.ModelMemory` (every view so far fused in the world frame; ``info
["memory_model"]``); its features are those of the model, in the robot frame of now.

``critical_regions`` is flat because stable-baselines3 treats every 3-D ``Box`` as an image (its
checker warns about a float one); ``obs["critical_regions"].reshape(K, R, F)`` recovers the
table. The F features of one region (:data:`~stereo_nav_env.config.REGION_FEATURES`), robot frame:

| column | name           | meaning                                                        |
|--------|----------------|----------------------------------------------------------------|
| 0      | `valid`        | 1 for a region, 0 for padding (then every column is 0)         |
| 1, 2   | `x_m`, `y_m`   | centre: midpoint of the narrowest undecided relation, metres   |
| 3      | `width_mean_m` | mean width across the narrowest relation, metres               |
| 4      | `width_std_m`  | its standard deviation, metres                                 |
| 5      | `p_passable`   | probability the robot fits through                             |
| 6      | `doubt`        | ``4 p (1 - p)``: 1 at p = 0.5, 0 when certain                 |
| 7      | `distance_m`   | distance from the robot's centre to the centre, metres         |
| 8      | `bearing_rad`  | bearing of the centre, radians                                 |
| 9, 10  | `axis_x`, `axis_y` | unit vector across the gap (obstacle i to obstacle j)      |
| 11     | `radius_m`     | largest distance from the centre to the region's polygon, m    |

Positions and lengths are clipped to ``feature_range_m``.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from modeling.geometry import to_robot_frame
from modeling.model.records import EnvironmentModel
from modeling.stereo.rig import StereoRig
from modeling.types import Float32Array
from stereo_nav_env.config import REGION_FEATURES, ObservationConfig
from stereo_nav_env.observation.raster import rasterize_memory, rasterize_model, rasterize_policy

__all__ = [
    "GOAL_RANGE_M",
    "goal_features",
    "observation_space",
    "pack_memory",
    "pack_model",
    "pack_policy",
    "pan_fraction",
    "policy_goal",
    "region_bounds",
    "to_robot_frame",
]

GOAL_RANGE_M = 100.0
"""Bound of the goal coordinates, metres (scenes are far smaller)."""
_PI32 = np.float32(math.pi)


@functools.lru_cache(maxsize=16)
def region_bounds(cfg: ObservationConfig) -> tuple[Float32Array, Float32Array]:
    """``(low, high)`` (F,) float32 bounds of one region's features (read-only, cached)."""
    L = np.float32(cfg.feature_range_m)
    low = np.array([0, -L, -L, 0, 0, 0, 0, 0, -_PI32, -1, -1, 0], dtype=np.float32)
    high = np.array([1, L, L, L, L, 1, 1, L * np.float32(2.0), _PI32, 1, 1, L], dtype=np.float32)
    assert low.shape == (len(REGION_FEATURES),)
    low.setflags(write=False)
    high.setflags(write=False)
    return low, high


@functools.lru_cache(maxsize=16)
def _region_scale(cfg: ObservationConfig) -> Float32Array:
    """(F,) float32: each region feature's largest magnitude (mode ``"policy"`` divides by it)."""
    low, high = region_bounds(cfg)
    scale = np.maximum(np.abs(low), np.abs(high))
    scale.setflags(write=False)
    return scale


def observation_space(cfg: ObservationConfig, rig: StereoRig) -> spaces.Dict:
    """The ``Dict`` observation space for ``cfg`` (keys in the module docstring)."""
    if cfg.has_policy:
        return _policy_space(cfg)
    G = np.float32(GOAL_RANGE_M)
    fields: dict[str, spaces.Space[Any]] = {
        "goal": spaces.Box(
            low=np.array([-G, -G, 0, -_PI32], dtype=np.float32),
            high=np.array([G, G, G * np.float32(2.0), _PI32], dtype=np.float32),
            dtype=np.float32,
        ),
        "head_pan": spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32),
    }
    K, R, S = cfg.num_situations, cfg.num_regions, cfg.raster_size_px
    low, high = region_bounds(cfg)
    for prefix, wanted, channels in (("", cfg.has_model, 3), ("memory_", cfg.has_memory, 4)):
        if not wanted:
            continue
        fields[f"{prefix}situation_probs"] = spaces.Box(0.0, 1.0, shape=(K,), dtype=np.float32)
        fields[f"{prefix}critical_regions"] = spaces.Box(
            low=np.tile(low, K * R), high=np.tile(high, K * R), dtype=np.float32
        )
        fields[f"{prefix}raster"] = spaces.Box(0, 255, shape=(S, S, channels), dtype=np.uint8)
    if cfg.has_images:
        shape = (rig.height_px, rig.width_px, 3)
        fields["left"] = spaces.Box(0, 255, shape=shape, dtype=np.uint8)
        fields["right"] = spaces.Box(0, 255, shape=shape, dtype=np.uint8)
    return spaces.Dict(fields)


def _policy_space(cfg: ObservationConfig) -> spaces.Dict:
    """The space of mode ``"policy"``: every non-image feature in [-1, 1] (or [0, 1])."""
    K, R, S = cfg.num_situations, cfg.num_regions, cfg.raster_size_px
    unit = np.array([0.0, -1.0, -1.0], dtype=np.float32), np.ones(3, dtype=np.float32)
    low, high = region_bounds(cfg)
    scale = _region_scale(cfg)
    return spaces.Dict(
        {
            "raster": spaces.Box(0, 255, shape=(S, S, 5), dtype=np.uint8),
            "situation_probs": spaces.Box(0.0, 1.0, shape=(K,), dtype=np.float32),
            "critical_regions": spaces.Box(
                low=np.tile(low / scale, K * R), high=np.tile(high / scale, K * R), dtype=np.float32
            ),
            "goal": spaces.Box(low=unit[0], high=unit[1], dtype=np.float32),
            "head_pan": spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32),
            "contact": spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32),
            "prev_action": spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32),
        }
    )


def policy_goal(
    goal_xy: tuple[float, float], robot_pose: tuple[float, float, float], range_m: float
) -> Float32Array:
    """``(min(distance / range_m, 1), cos(bearing), sin(bearing))`` (3,) float32 of the goal in
    the robot frame (the bearing's cos and sin do not jump at +-pi; (0, 1, 0) at the goal)."""
    # to_robot_frame's arithmetic, on two floats
    rx, ry, heading = robot_pose
    c, s = math.cos(heading), math.sin(heading)
    dx, dy = float(goal_xy[0]) - rx, float(goal_xy[1]) - ry
    x, y = c * dx + s * dy, -s * dx + c * dy
    d = math.hypot(x, y)
    c, s = (x / d, y / d) if d > 1e-9 else (1.0, 0.0)
    return np.array([min(d / range_m, 1.0), c, s], dtype=np.float32)


def pack_policy(
    model: EnvironmentModel,
    never_seen: NDArray[np.uint8],
    goal_xy: tuple[float, float],
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    near_m: float,
    last: tuple[Float32Array, bool],
) -> dict[str, NDArray[Any]]:
    """The fields of mode ``"policy"`` but ``head_pan``: the five-channel ``raster``
    (:func:`~stereo_nav_env.observation.raster.rasterize_policy`), ``situation_probs``,
    ``critical_regions`` with every feature divided by its bound (so in [-1, 1]), ``goal``
    (:func:`policy_goal`), ``contact`` and ``prev_action``.

    Args:
        model: The latest view's model (world frame).
        never_seen: (S, S) uint8 egocentric, 255 where no view has seen the floor.
        goal_xy: The goal, world frame, metres.
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: K, R, raster size and extent, feature range, goal range.
        near_m: The blind band, metres (``EnvConfig.blind_range_m``).
        last: The last step's normalised command (3,) in [-1, 1] and whether it touched
            something.

    Returns:
        New arrays: (S, S, 5) uint8, (K,), (K * R * F,), (3,), (1,), (3,) float32.
    """
    table = _region_table(model, robot_pose, cfg) / _region_scale(cfg)
    return {
        "raster": rasterize_policy(model, never_seen, robot_pose, cfg, near_m=near_m),
        "situation_probs": _situation_probs(model, cfg),
        "critical_regions": table.astype(np.float32).reshape(-1),
        "goal": policy_goal(goal_xy, robot_pose, cfg.goal_range_m),
        "contact": np.array([1.0 if last[1] else 0.0], dtype=np.float32),
        "prev_action": np.clip(last[0], -1.0, 1.0).astype(np.float32),
    }


def pan_fraction(pan_rad: float, limit_rad: float) -> float:
    """Head pan as a fraction of its limit, in [-1, 1] (0 when the head cannot pan)."""
    return min(max(pan_rad / limit_rad, -1.0), 1.0) if limit_rad > 0 else 0.0


def goal_features(
    goal_xy: tuple[float, float], robot_pose: tuple[float, float, float]
) -> Float32Array:
    """``(x_m, y_m, distance_m, bearing_rad)`` (4,) float32 of the goal in the robot frame."""
    g = to_robot_frame(np.asarray(goal_xy, dtype=np.float64), robot_pose)
    x, y = float(g[0]), float(g[1])
    out = np.array(
        [x, y, math.hypot(x, y), math.atan2(y, x)],
        dtype=np.float64,
    )
    G = GOAL_RANGE_M
    return np.clip(out, [-G, -G, 0, -math.pi], [G, G, 2 * G, math.pi]).astype(np.float32)


def _region_table(
    model: EnvironmentModel, robot_pose: tuple[float, float, float], cfg: ObservationConfig
) -> Float32Array:
    """(K, R, F) float32 region features (see the module docstring), vectorised over regions."""
    K, R, F = cfg.num_situations, cfg.num_regions, cfg.num_features
    regions = [(k, r) for k, s in enumerate(model.situations[:K]) for r in s.critical_regions]
    if not regions:  # every slot empty: zeros (within the bounds of every feature)
        return np.zeros((K, R, F), dtype=np.float32)
    table = np.zeros((K, R, F), dtype=np.float64)
    which = np.array([k for k, _ in regions])
    narrow_w = np.stack([r.narrowest for _, r in regions])  # (n, 2, 2) world
    centre_w = narrow_w.mean(axis=1)
    narrow = to_robot_frame(narrow_w, robot_pose)
    centre = narrow.mean(axis=1)
    dist = np.hypot(centre[:, 0], centre[:, 1])
    order = np.lexsort((dist, which))  # by situation, then nearest first
    first = np.searchsorted(which[order], which[order], side="left")
    rank = np.arange(order.shape[0]) - first
    keep = order[rank < R]
    slot = rank[rank < R]
    across = narrow[:, 1] - narrow[:, 0]
    length = np.hypot(across[:, 0], across[:, 1])
    axis = across / np.maximum(length, 1e-12)[:, None]
    axis[length <= 1e-12] = 0.0
    p = np.array([r.p_passable for _, r in regions])
    # the farthest polygon vertex from the centre (rigid motions keep distances: world frame)
    polygons = [r.polygon for _, r in regions]
    sizes = np.array([q.shape[0] for q in polygons])
    rel = np.concatenate(polygons) - np.repeat(centre_w, sizes, axis=0)
    starts = np.concatenate(([0], np.cumsum(sizes[:-1])))
    radius = np.maximum.reduceat(np.hypot(rel[:, 0], rel[:, 1]), starts)
    feats = np.empty((len(regions), F))
    feats[:, 0] = 1.0
    feats[:, 1:3] = centre
    feats[:, 3] = [r.width_mean_m for _, r in regions]
    feats[:, 4] = [r.width_std_m for _, r in regions]
    feats[:, 5] = p
    feats[:, 6] = 4.0 * p * (1.0 - p)
    feats[:, 7] = dist
    feats[:, 8] = np.arctan2(centre[:, 1], centre[:, 0])
    feats[:, 9:11] = axis
    feats[:, 11] = radius
    table[which[keep], slot] = feats[keep]
    low, high = region_bounds(cfg)
    return np.clip(table.astype(np.float32), low, high)


def pack_model(
    model: EnvironmentModel,
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    *,
    near_m: float = 0.0,
) -> dict[str, NDArray[Any]]:
    """The model fields of the observation: ``situation_probs``, ``critical_regions``, ``raster``.

    Args:
        model: The environment model (world frame).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: K, R, raster size and extent, feature range.
        near_m: The blind band, metres (``EnvConfig.blind_range_m``).

    Returns:
        New arrays: (K,) float32, (K * R * F,) float32, (S, S, 3) uint8.
    """
    return {
        "situation_probs": _situation_probs(model, cfg),
        "critical_regions": _region_table(model, robot_pose, cfg).reshape(-1),
        "raster": rasterize_model(model, robot_pose, cfg, near_m=near_m),
    }


def _situation_probs(model: EnvironmentModel, cfg: ObservationConfig) -> Float32Array:
    """(K,) float32: the K most probable situations' probabilities, 0 for missing ones."""
    K = cfg.num_situations
    probs = np.zeros(K, dtype=np.float32)
    p = [s.probability for s in model.situations[:K]]
    probs[: len(p)] = np.minimum(np.maximum(np.asarray(p, dtype=np.float32), 0.0), 1.0)
    return probs


def pack_memory(
    model: EnvironmentModel,
    seen: Any,
    robot_pose: tuple[float, float, float],
    cfg: ObservationConfig,
    *,
    near_m: float = 0.0,
) -> dict[str, NDArray[Any]]:
    """The fused model's fields of the observation: ``memory_situation_probs``,
    ``memory_critical_regions``, ``memory_raster``.

    Args:
        model: The fused environment model (world frame).
        seen: The floor seen so far in the episode (a shapely geometry, world frame).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        cfg: K, R, raster size and extent, feature range.
        near_m: The blind band of the latest view, metres.

    Returns:
        New arrays: (K,) float32, (K * R * F,) float32, (S, S, 4) uint8.
    """
    return {
        "memory_situation_probs": _situation_probs(model, cfg),
        "memory_critical_regions": _region_table(model, robot_pose, cfg).reshape(-1),
        "memory_raster": rasterize_memory(model, seen, robot_pose, cfg, near_m=near_m),
    }
