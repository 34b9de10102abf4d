"""The two reference agents that need no model: ``random`` (the floor) and ``oracle`` (the ceiling).

The oracle plans once per episode on the true obstacle outlines (``ground_truth_footprints()``)
with :func:`agents.planning.routes.shortest_route` and follows the route with the pure-pursuit
:class:`agents.planning.follower.PathFollower`, head straight ahead; it re-plans when it stops
making progress.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import Agent, control_limits, goal_xy, robot_pose, room_bounds
from agents.planning.follower import PathFollower
from agents.planning.routes import Route, shortest_route

__all__ = ["ORACLE_MARGINS_M", "OracleAgent", "RandomAgent", "true_shortest_route"]


class RandomAgent(Agent):
    """Uniform random actions, smoothed a little so the robot actually travels.

    Args:
        smoothing: Weight of the previous action in ``a_t = s a_{t-1} + (1 - s) u_t``.
    """

    name = "random"

    def __init__(self, smoothing: float = 0.7) -> None:
        super().__init__()
        if not 0.0 <= smoothing < 1.0:
            raise ValueError(f"smoothing must be in [0, 1), got {smoothing!r}")
        self.smoothing = smoothing
        self._rng = np.random.default_rng()
        self._last = np.zeros(3)

    def _reset(self, seed: int | None) -> None:
        self._rng = np.random.default_rng(seed)
        self._last = np.zeros(3)

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        u = self._rng.uniform(-1.0, 1.0, 3)
        self._last = self.smoothing * self._last + (1.0 - self.smoothing) * u
        return self._last


def true_shortest_route(
    env: Any,
    start_xy: NDArray[np.floating] | None = None,
    *,
    margins_m: tuple[float, ...] = (0.0,),
) -> Route | None:
    """The shortest route of the robot from ``start_xy`` (default: now) to the goal, on the truth.

    Args:
        env: The environment (its ``ground_truth_footprints()``).
        start_xy: (2,) start, world metres; default the robot's position.
        margins_m: Clearances beyond the robot radius to try in turn (the first that leaves a
            route wins); the default, no margin, gives the true shortest route (SPL's reference).

    Returns:
        The route, or ``None`` when none of the clearances leaves one.
    """
    limits = control_limits(env)
    x, y, _, _ = robot_pose(env)
    start = np.array([x, y]) if start_xy is None else np.asarray(start_xy, dtype=np.float64)
    footprints = env.unwrapped.ground_truth_footprints()
    for margin in margins_m:
        route = shortest_route(
            footprints,
            start,
            goal_xy(env),
            clearance_m=limits.robot_width_m / 2 + margin,
            bounds=room_bounds(env),
        )
        if route is not None:
            return route
    return None


ORACLE_MARGINS_M = (0.15, 0.1, 0.05, 0.01)
"""Clearances the oracle tries: wide first, down to the scene generator's guarantee (0.05 m)."""


class OracleAgent(Agent):
    """Follows the true shortest route (ground truth): the upper bound of the scripted agents.

    Args:
        stall_steps: Re-plan after this many steps with less than ``stall_m`` of progress.
        stall_m: Progress that counts, metres.
    """

    name = "oracle"

    def __init__(self, stall_steps: int = 30, stall_m: float = 0.1) -> None:
        super().__init__()
        self.stall_steps = stall_steps
        self.stall_m = stall_m
        self._route: Route | None = None
        self._follower: PathFollower | None = None
        self._anchor = np.zeros(2)
        self._anchor_step = 0

    def _reset(self, seed: int | None) -> None:
        limits = control_limits(self.env)
        self._follower = PathFollower(
            max_speed_mps=limits.max_speed_m_s,
            max_turn_rate_rps=limits.max_turn_rate_rad_s,
            dt_s=limits.dt_s,
            lookahead_m=0.25,
        )
        self._route = true_shortest_route(self.env, margins_m=ORACLE_MARGINS_M)
        x, y, _, _ = robot_pose(self.env)
        self._anchor = np.array([x, y])
        self._anchor_step = 0

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        assert self._follower is not None
        x, y, heading, _ = robot_pose(self.env)
        here = np.array([x, y])
        if np.linalg.norm(here - self._anchor) > self.stall_m:
            self._anchor, self._anchor_step = here, self.steps
        elif self.steps - self._anchor_step > self.stall_steps:
            self._route = true_shortest_route(self.env, margins_m=ORACLE_MARGINS_M)
            self._anchor, self._anchor_step = here, self.steps
        if self._route is None:
            goal = goal_xy(self.env)
            waypoints = np.array([here, goal])
        else:
            waypoints = self._route.waypoints
        forward, turn = self._follower.command((x, y, heading), waypoints)
        return np.array([forward, turn, 0.0])
