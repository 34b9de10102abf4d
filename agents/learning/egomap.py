"""The learned agents' observation: an egocentric map of what the robot has seen, and features.

:class:`EgoMap` keeps a memory built only from what the robot itself perceived and did, as the
scripted agents do: the environment model of each view (``info["model"]``), its own pose
(odometry: ``env.unwrapped.robot_pose``), the contact flag (``info["collision"]``), the command it
sent, the room outline (the rough map of :func:`agents.base.room_bounds`) and the goal. The memory
is the planner's own: an :class:`~agents.planning.gridmap.OccupancyMap` fused from the successive
models (occupied where the situations' obstacles are, weighted by their probabilities; free where
the view saw floor), bump marks placed by the planner's :class:`~agents.planning.recovery.Recovery`
(the contact normal measured from the blocked motion), and the remembered critical regions
(:class:`~agents.planning.gridmap.GateHistory`). Nothing else of the scene is read, so the
observation is *legal*: a change of the scene outside everything the robot has seen leaves it
unchanged (``tests/agents/learning/test_egomap.py`` checks it).

Observation (``Dict``; version :data:`OBSERVATION_VERSION`), S = ``size_px``, C = 8:

| key     | shape     | dtype   | range   | meaning                                           |
|---------|-----------|---------|---------|---------------------------------------------------|
| `map`   | (C, S, S) | uint8   | 0-255   | egocentric map, heading up: the robot at the      |
|         |           |         |         | centre looking to row 0, ``cell_m`` per pixel;    |
|         |           |         |         | channels in :data:`CHANNELS` (below)              |
| `state` | (V,)      | float32 | [-1, 1] | features in :data:`STATE_FEATURES` (below)        |

Map channels (each pixel one ``cell_m`` square of the floor; outside the room: ``outline`` 255,
every other channel 0):

| # | name           | value                                                                   |
|---|----------------|-------------------------------------------------------------------------|
| 0 | `occupancy`    | 128 + 32 x occupancy log-odds (64 seen free ... 255 seen occupied;     |
|   |                | 128 unknown)                                                            |
| 1 | `seen`         | 255 where the floor was ever seen (free or occupied), 0 never seen      |
| 2 | `bumps`        | 255 on the faces marked by bumps (the measured contact face)           |
| 3 | `outline`      | 255 outside the room and on its border (the rough map)                 |
| 4 | `view`         | 255 x probability that an obstacle of the latest view lies there (its  |
|   |                | most probable situations, weighted): 255 certain, between: doubtful    |
| 5 | `gates`        | remembered critical regions, their narrowest gap drawn with            |
|   |                | 1 + 254 x P(passable) (1: found impassable)                            |
| 6 | `goal`         | 255 within ``goal_radius_m`` of the goal                               |
| 7 | `cost_to_go`   | distance to the goal through what the memory holds free (obstacles     |
|   |                | grown by the robot's clearance, undecided gaps open, gaps found        |
|   |                | impassable closed), relative to the robot's:                           |
|   |                | 128 + 127 x clip((d - d_robot) / ``cost_range_m``, -1, 1); 255 where  |
|   |                | the goal cannot be reached                                             |

State features (float32, each within [-1, 1]):

| index  | name                  | meaning                                                         |
|--------|-----------------------|-----------------------------------------------------------------|
| 0      | `goal_distance`       | straight distance to the goal / ``goal_range_m``, clipped to 1  |
| 1, 2   | `goal_cos`, `goal_sin` | bearing of the goal, robot frame                               |
| 3      | `route_distance`      | the cost-to-go at the robot / (2 ``goal_range_m``), clipped     |
| 4, 5   | `route_cos`, `route_sin` | bearing of the point ``route_ahead_m`` along the descent of  |
|        |                       | the cost-to-go (the way its shortest route leaves), robot frame |
| 6      | `head_pan`            | head pan / pan limit                                            |
| 7      | `contact`             | 1 when the last step touched something                          |
| 8      | `since_contact`       | steps since the last contact / 50, clipped to 1 (1: none yet)   |
| 9-11   | `prev_action`         | the command sent last step (forward, turn, pan)                 |
| 12-14  | `situation_probs`     | the latest view's three most probable situations' probabilities |
| 15-26  | `regions`             | the latest view's two critical regions nearest the robot (most  |
|        |                       | probable situation), 6 each: valid, x / 5 m, y / 5 m (robot     |
|        |                       | frame), (mean width - robot width) / 1 m, width std / 0.5 m,    |
|        |                       | P(passable)                                                     |

The situations and regions are compacted (three probabilities, two regions of six numbers)
so that most of the vector is not zero; the map carries the rest of the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from agents.base import (
    ControlLimits,
    control_limits,
    goal_xy,
    model_of,
    robot_pose,
    room_bounds,
)
from agents.planning.config import NavigatorConfig, Policy
from agents.planning.gridmap import (
    GridSpec,
    observed_segments,
    rasterize_lines,
    top_situations,
)
from agents.planning.planner import PlannerCore
from agents.planning.recovery import Recovery
from modeling.model.records import EnvironmentModel
from modeling.types import BoolArray, FloatArray, IntArray
from modeling.validation import number, reject_unknown

__all__ = [
    "CHANNELS",
    "MIRROR_ODD_FEATURES",
    "OBSERVATION_VERSION",
    "STATE_FEATURES",
    "EgoMap",
    "EgoMapConfig",
    "grid_cost_to_go",
    "mirrored",
]

OBSERVATION_VERSION = 1
"""Bumped whenever a key, channel, feature or scale of the observation changes (a trained policy
records the version it was trained on and refuses another)."""
CHANNELS = ("occupancy", "seen", "bumps", "outline", "view", "gates", "goal", "cost_to_go")
STATE_FEATURES = (
    "goal_distance",
    "goal_cos",
    "goal_sin",
    "route_distance",
    "route_cos",
    "route_sin",
    "head_pan",
    "contact",
    "since_contact",
    "prev_forward",
    "prev_turn",
    "prev_pan",
    "situation_p0",
    "situation_p1",
    "situation_p2",
    *(f"region{k}_{f}" for k in range(2) for f in ("valid", "x", "y", "width", "std", "p")),
)

MIRROR_ODD_FEATURES = (
    "goal_sin",
    "route_sin",
    "head_pan",
    "prev_turn",
    "prev_pan",
    "region0_y",
    "region1_y",
)
"""The state features that change sign in the left-right mirror image of a scene (lateral
coordinates, bearings' sines, turns and pans); the others are unchanged by it."""
_MIRROR_SIGN = np.array(
    [-1.0 if name in MIRROR_ODD_FEATURES else 1.0 for name in STATE_FEATURES], dtype=np.float32
)


def mirrored(
    maps: NDArray[np.uint8], states: NDArray[np.float32]
) -> tuple[NDArray[np.uint8], NDArray[np.float32]]:
    """The observations of the left-right mirror image of the scenes: each map's columns
    reversed (the robot sits between columns ``S/2 - 1`` and ``S/2``, so its left becomes its
    right exactly) and :data:`MIRROR_ODD_FEATURES` negated. Batches ``(n, C, S, S)`` and
    ``(n, V)``; a command's turn and pan change sign with them. The one asymmetry it leaves:
    the 2 x 2 dilation that widens obstacle lines adds its pixel on the robot's right in the
    observation, so on its left in the mirror."""
    maps = np.asarray(maps)
    states = np.asarray(states, dtype=np.float32)
    if maps.ndim != 4 or states.ndim != 2 or states.shape[-1] != len(STATE_FEATURES):
        raise ValueError(
            f"mirrored needs maps (n, C, S, S) and states (n, {len(STATE_FEATURES)}), "
            f"got {maps.shape} and {states.shape}"
        )
    return np.ascontiguousarray(maps[..., ::-1]), states * _MIRROR_SIGN


@dataclass(frozen=True, slots=True, kw_only=True)
class EgoMapConfig:
    """The observation's geometry.

    Attributes:
        size_px: Side of the square map, pixels.
        cell_m: Floor per pixel, metres (an obstacle line is drawn two pixels wide).
        cost_range_m: The cost-to-go channel spans ``d_robot +- cost_range_m``, metres.
        goal_range_m: Distances are scaled by this, metres.
        route_ahead_m: How far along the cost-to-go's descent the route bearing looks, metres.
        memory_resolution_m: Cell of the world-frame memory and of the cost-to-go, metres.
    """

    size_px: int = 64
    cell_m: float = 0.125
    cost_range_m: float = 4.0
    goal_range_m: float = 10.0
    route_ahead_m: float = 1.0
    memory_resolution_m: float = 0.1

    def __post_init__(self) -> None:
        if isinstance(self.size_px, bool) or not isinstance(self.size_px, int) or self.size_px < 8:
            raise ValueError(f"size_px must be an integer >= 8, got {self.size_px!r}")
        for name in ("cell_m", "cost_range_m", "goal_range_m", "route_ahead_m"):
            number(getattr(self, name), name, low=0.0)
        if not 0.02 <= self.memory_resolution_m <= 0.5:
            raise ValueError(
                f"memory_resolution_m must be in [0.02, 0.5], got {self.memory_resolution_m!r}"
            )

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> EgoMapConfig:
        """The config of a saved dict (``ValueError`` naming an unknown field)."""
        reject_unknown(values, cls.__dataclass_fields__, "EgoMapConfig")
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict of the fields."""
        return {name: getattr(self, name) for name in self.__dataclass_fields__}


# ---------------------------------------------------------------------------- cost-to-go
@lru_cache(maxsize=16)
def _grid_edges(ny: int, nx: int) -> tuple[IntArray, IntArray, FloatArray]:
    """The 8-connected grid's undirected edges ``(a, b, length in cells)``, each pair once."""
    index = np.arange(ny * nx).reshape(ny, nx)
    a_parts, b_parts, lengths = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        rows = slice(0, ny - dr)
        a = index[rows, max(0, -dc) : nx - max(0, dc)]
        b = index[dr:, max(0, dc) : nx - max(0, -dc)][: a.shape[0]]
        a_parts.append(a.ravel())
        b_parts.append(b.ravel())
        lengths.append(np.full(a.size, math.hypot(dr, dc)))
    return np.concatenate(a_parts), np.concatenate(b_parts), np.concatenate(lengths)


def grid_cost_to_go(
    free: BoolArray, cost: FloatArray, target: tuple[int, int], cell_m: float
) -> FloatArray:
    """Shortest distance from every cell to ``target`` on the 8-connected grid of ``free`` cells.

    Args:
        free: (ny, nx) cells the robot's centre may occupy.
        cost: (ny, nx) cost per metre of each cell (>= 1; a move costs the mean of its two
            cells' times its length).
        target: ``(row, col)`` of the target (taken as free).
        cell_m: Cell size, metres.

    Returns:
        (ny, nx) metres; ``inf`` where the target cannot be reached.
    """
    ny, nx = free.shape
    a, b, length = _grid_edges(ny, nx)
    ok_cells = free.ravel().copy()
    t = target[0] * nx + target[1]
    ok_cells[t] = True
    flat_cost = cost.ravel()
    keep = ok_cells[a] & ok_cells[b]
    a, b = a[keep], b[keep]
    w = cell_m * length[keep] * 0.5 * (flat_cost[a] + flat_cost[b])
    matrix = csr_matrix(
        (np.concatenate([w, w]), (np.concatenate([a, b]), np.concatenate([b, a]))),
        shape=(ny * nx, ny * nx),
    )
    values: FloatArray = dijkstra(matrix, directed=True, indices=t)
    return values.reshape(ny, nx)


# ---------------------------------------------------------------------------- the map
class EgoMap:
    """The memory of one episode and the observation made from it.

    Call :meth:`reset` with the env just reset and its ``info``, then :meth:`step` after every
    ``env.step(action)`` with the action sent and the new ``info``; both return the observation.

    Args:
        config: The observation's geometry.
        navigator: The memory's parameters (those of the planner's map; the policy is ignored).
    """

    def __init__(
        self, config: EgoMapConfig | None = None, navigator: NavigatorConfig | None = None
    ) -> None:
        self.config = config or EgoMapConfig()
        base = navigator or NavigatorConfig()
        kw = {f: getattr(base, f) for f in base.__dataclass_fields__}
        kw["policy"] = Policy.GREEDY
        self.navigator = NavigatorConfig(**kw)
        self.core: PlannerCore | None = None
        self._recovery: Recovery | None = None
        self._limits: ControlLimits | None = None
        self._steps = 0
        self._last_contact = -(10**6)
        self._prev_action = np.zeros(3, dtype=np.float32)
        self._outline: BoolArray | None = None
        self._goal_disc: BoolArray | None = None

    # ------------------------------------------------------------------ spaces
    @property
    def map_shape(self) -> tuple[int, int, int]:
        """``(C, S, S)`` of the ``map`` key."""
        s = self.config.size_px
        return (len(CHANNELS), s, s)

    def observation_space(self) -> Any:
        """The gymnasium ``Dict`` space of the observation."""
        from gymnasium import spaces

        return spaces.Dict(
            {
                "map": spaces.Box(0, 255, self.map_shape, dtype=np.uint8),
                "state": spaces.Box(-1.0, 1.0, (len(STATE_FEATURES),), dtype=np.float32),
            }
        )

    # ------------------------------------------------------------------ episode
    def reset(self, env: Any, info: dict[str, Any]) -> dict[str, NDArray[Any]]:
        """Start the episode of ``env`` (just reset; ``info`` its reset info)."""
        limits = control_limits(env)
        self._limits = limits
        goal = goal_xy(env)
        bounds = room_bounds(env)
        self.core = PlannerCore(bounds, goal, limits, self.navigator)
        x, y, heading, _ = robot_pose(env)
        distance = float(np.hypot(x - goal[0], y - goal[1]))
        self._recovery = Recovery(self.navigator, limits, (x, y, heading), distance)
        self._steps = 0
        self._last_contact = -(10**6)
        self._prev_action = np.zeros(3, dtype=np.float32)
        spec = self.core.spec
        X, Y = spec.centers()
        self._goal_disc = np.hypot(X - goal[0], Y - goal[1]) <= limits.goal_radius_m
        outline = np.zeros(spec.shape, dtype=bool)
        outline[[0, -1], :] = True
        outline[:, [0, -1]] = True
        self._outline = outline
        return self._observe(env, info, collided=False)

    def step(
        self, env: Any, info: dict[str, Any], action: NDArray[np.floating]
    ) -> dict[str, NDArray[Any]]:
        """Take in the step just made: ``action`` sent, ``info`` returned."""
        if self.core is None or self._recovery is None:
            raise RuntimeError("EgoMap.step before reset")
        sent = np.clip(np.asarray(action, dtype=np.float32).reshape(-1)[:3], -1.0, 1.0)
        if sent.shape != (3,):
            raise ValueError(f"action must hold 3 numbers, got shape {np.shape(action)}")
        self._recovery.commanded(float(sent[0]))
        self._prev_action = sent
        self._steps += 1
        return self._observe(env, info, collided=bool(info.get("collision", False)))

    # ------------------------------------------------------------------ memory
    def _observe(
        self, env: Any, info: dict[str, Any], *, collided: bool
    ) -> dict[str, NDArray[Any]]:
        core, recovery = self.core, self._recovery
        assert core is not None and recovery is not None
        model = model_of(env, info)
        pose = robot_pose(env)
        x, y, heading, _ = pose
        core.observe(model, self._steps)
        distance = float(np.hypot(x - core.goal[0], y - core.goal[1]))
        events = recovery.update(
            (x, y, heading), self._steps, collided=collided, goal_distance_m=distance
        )
        if events.bump is not None:
            bump = events.bump
            core.bump(pose, backwards=bump.backwards, step=self._steps, normal=bump.normal)
        if collided:
            self._last_contact = self._steps
        view = self._view_layer(model, np.array([x, y]))
        gates, closed = self._gate_layer()
        value = self._cost_to_go(view, closed)
        here = float(value[tuple(core.spec.cell_of(np.array([[x, y]]))[0])])
        return {
            "map": self._egocentric(view, gates, value, here, pose),
            "state": self._state(model, value, here, pose, collided),
        }

    def _view_layer(self, model: EnvironmentModel, xy: FloatArray) -> FloatArray:
        """(ny, nx) probability that an obstacle of the latest view is in each cell."""
        core = self.core
        assert core is not None
        spec, rng = core.spec, self.navigator.obstacle_range_m
        sits = top_situations(model, self.navigator.max_situations)
        layer = core.occupancy.expected_obstacles(sits, xy, rng) if sits else np.zeros(spec.shape)
        lines = rasterize_lines(spec, observed_segments(model), viewpoint_xy=xy, max_range_m=rng)
        return np.maximum(layer, lines.astype(np.float64))

    def _gate_layer(self) -> tuple[FloatArray, BoolArray]:
        """(ny, nx) gate codes (0: none; 1 + 254 p) and the cells of gates found impassable."""
        core = self.core
        assert core is not None
        codes = np.zeros(core.spec.shape)
        closed = np.zeros(core.spec.shape, dtype=bool)
        for gate in core.gates.gates:
            cells = rasterize_lines(core.spec, np.asarray(gate.ends, dtype=np.float64)[None])
            p = 0.0 if gate.failed else float(gate.p_passable)
            codes[cells] = np.maximum(codes[cells], 1.0 + 254.0 * p)
            if gate.failed or p <= self.navigator.eps:
                closed |= cells
        return codes, closed

    def _cost_to_go(self, view: FloatArray, closed: BoolArray) -> FloatArray:
        """(ny, nx) distance to the goal through the memory's free space (see the table)."""
        core = self.core
        assert core is not None
        spec, nav = core.spec, self.navigator
        blocked = core.occupancy.occupied() | (view >= 0.5) | closed
        clearance = cv2.distanceTransform((~blocked).astype(np.uint8), cv2.DIST_L2, 5)
        clearance = clearance.astype(np.float64) * spec.resolution_m
        free = clearance > nav.hard_m
        cost = 1.0 + 2.0 * np.clip((nav.soft_m - clearance) / (nav.soft_m - nav.hard_m), 0, 1)
        row, col = spec.cell_of(core.goal[None])[0]
        return grid_cost_to_go(free, cost, (int(row), int(col)), spec.resolution_m)

    # ------------------------------------------------------------------ observation
    def _egocentric(
        self,
        view: FloatArray,
        gates: FloatArray,
        value: FloatArray,
        here: float,
        pose: tuple[float, float, float, float],
    ) -> NDArray[np.uint8]:
        core = self.core
        assert core is not None and self._outline is not None and self._goal_disc is not None
        occ = core.occupancy
        x, y, heading, _ = pose
        if math.isfinite(here):
            rel = np.clip((value - here) / self.config.cost_range_m, -1.0, 1.0)
            cost = np.where(np.isfinite(value), 128.0 + 127.0 * rel, 255.0)
        else:
            cost = np.full(value.shape, 255.0)
        layers = np.stack(
            [
                np.clip(128.0 + 32.0 * occ.log_odds, 0, 255),
                255.0 * (occ.log_odds != 0.0),
                255.0 * (occ.bumps >= 0),
                255.0 * self._outline,
                255.0 * view,
                gates,
                255.0 * self._goal_disc,
                cost,
            ],
            axis=-1,
        ).astype(np.float32)
        s, cell = self.config.size_px, self.config.cell_m
        res = core.spec.resolution_m
        # Output pixel (u, v) -> robot frame (forward, left) -> world -> memory cell (col, row).
        c, sn = math.cos(heading), math.sin(heading)
        half = 0.5 * s
        # forward = (half - v - 0.5) cell, left = (half - u - 0.5) cell
        fu, fv, f0 = 0.0, -cell, (half - 0.5) * cell
        lu, lv, l0 = -cell, 0.0, (half - 0.5) * cell
        wx = np.array([c * fu - sn * lu, c * fv - sn * lv, x + c * f0 - sn * l0])
        wy = np.array([sn * fu + c * lu, sn * fv + c * lv, y + sn * f0 + c * l0])
        col = (wx - np.array([0.0, 0.0, core.spec.xmin])) / res - np.array([0.0, 0.0, 0.5])
        row = (wy - np.array([0.0, 0.0, core.spec.ymin])) / res - np.array([0.0, 0.0, 0.5])
        matrix = np.stack([col, row]).astype(np.float64)
        out = np.empty((s, s, layers.shape[-1]), dtype=np.float32)
        for k in range(0, layers.shape[-1], 4):
            part = np.ascontiguousarray(layers[..., k : k + 4])
            warped = cv2.warpAffine(
                part,
                matrix,
                (s, s),
                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0.0,
            )
            out[..., k : k + 4] = warped.reshape(s, s, -1)
        # Outside the memory's grid: the outline's 255, the rest 0.
        inside = cv2.warpAffine(
            np.ones(core.spec.shape, np.float32),
            matrix,
            (s, s),
            flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0.0,
        )
        out[..., CHANNELS.index("outline")] = np.where(
            inside > 0.5, out[..., CHANNELS.index("outline")], 255.0
        )
        # An obstacle line is one memory cell wide: draw it at least two pixels wide.
        lines = [CHANNELS.index(n) for n in ("occupancy", "bumps", "view", "gates")]
        kernel = np.ones((2, 2), np.uint8)
        image = np.clip(np.rint(out), 0, 255).astype(np.uint8)
        for k in lines:
            image[..., k] = cv2.dilate(image[..., k], kernel)
        return np.ascontiguousarray(image.transpose(2, 0, 1))

    def _state(
        self,
        model: EnvironmentModel,
        value: FloatArray,
        here: float,
        pose: tuple[float, float, float, float],
        collided: bool,
    ) -> NDArray[np.float32]:
        core, limits, cfg = self.core, self._limits, self.config
        assert core is not None and limits is not None
        x, y, heading, pan = pose
        state = np.zeros(len(STATE_FEATURES), dtype=np.float32)
        dx, dy = core.goal[0] - x, core.goal[1] - y
        bearing = math.atan2(dy, dx) - heading
        state[0] = min(1.0, math.hypot(dx, dy) / cfg.goal_range_m)
        state[1], state[2] = math.cos(bearing), math.sin(bearing)
        route = _descent_point(value, core.spec, np.array([x, y]), cfg.route_ahead_m)
        state[3] = min(1.0, here / (2.0 * cfg.goal_range_m)) if math.isfinite(here) else 1.0
        if route is not None:
            rb = math.atan2(route[1] - y, route[0] - x) - heading
            state[4], state[5] = math.cos(rb), math.sin(rb)
        state[6] = np.clip(pan / limits.pan_limit_rad, -1, 1)
        state[7] = float(collided)
        state[8] = min(1.0, (self._steps - self._last_contact) / 50.0)
        state[9:12] = self._prev_action
        sits = sorted(model.situations, key=lambda s: -s.probability)
        for k, s in enumerate(sits[:3]):
            state[12 + k] = s.probability
        if sits:
            regions = sorted(
                sits[0].critical_regions,
                key=lambda r: float(np.hypot(*(np.mean(r.narrowest, axis=0) - [x, y]))),
            )
            c, sn = math.cos(heading), math.sin(heading)
            for k, reg in enumerate(regions[:2]):
                mx, my = np.mean(np.asarray(reg.narrowest, dtype=np.float64), axis=0) - [x, y]
                fwd, left = c * mx + sn * my, -sn * mx + c * my
                width = (reg.width_mean_m - limits.robot_width_m) / 1.0
                row = [1.0, fwd / 5.0, left / 5.0, width, reg.width_std_m / 0.5, reg.p_passable]
                state[15 + 6 * k : 21 + 6 * k] = np.clip(row, -1.0, 1.0)
        return state


def _descent_point(
    value: FloatArray, spec: GridSpec, xy: FloatArray, ahead_m: float
) -> FloatArray | None:
    """The world point ``ahead_m`` along steepest descent of ``value`` from ``xy`` (``None``
    when the robot's cell cannot reach the goal)."""
    ny, nx = value.shape
    r, c = (int(v) for v in spec.cell_of(xy[None])[0])
    if not math.isfinite(value[r, c]):
        # Inside an obstacle's clearance: start from the best free neighbour within 0.5 m.
        k = max(1, round(0.5 / spec.resolution_m))
        r0, r1, c0, c1 = max(0, r - k), min(ny, r + k + 1), max(0, c - k), min(nx, c + k + 1)
        window = value[r0:r1, c0:c1]
        if not np.isfinite(window).any():
            return None
        i = int(np.argmin(window))
        r, c = r0 + i // window.shape[1], c0 + i % window.shape[1]
    travelled = 0.0
    while travelled < ahead_m and value[r, c] > 0.0:
        r0, r1, c0, c1 = max(0, r - 1), min(ny, r + 2), max(0, c - 1), min(nx, c + 2)
        window = value[r0:r1, c0:c1]
        i = int(np.argmin(window))
        nr, nc = r0 + i // window.shape[1], c0 + i % window.shape[1]
        if (nr, nc) == (r, c) or not value[nr, nc] < value[r, c]:
            break
        travelled += spec.resolution_m * math.hypot(nr - r, nc - c)
        r, c = nr, nc
    point: FloatArray = spec.xy_of(np.array([r * nx + c]))[0]
    return point
