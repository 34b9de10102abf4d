"""Model-based scripted agents: ``greedy``, ``cautious`` and the expected-cost ``planner``.

A :class:`ModelBasedAgent` composes four parts, each in a module of its own:

* the planner (:mod:`agents.planning.planner`, :class:`PlannerCore`): the map of what was seen
  and bumped into, and the route (expected cost over situations for the ``planner``; the three
  policies differ only in how they treat an undecided critical region);
* the looking rule (:mod:`agents.planning.looking`): whether to look at or approach an undecided
  region before committing (``planner`` only);
* the recovery (:mod:`agents.planning.recovery`): backing off after a bump, escaping along the
  contact normals, and the stall and progress watches;
* the follower (:mod:`agents.planning.follower`): pure pursuit of the route, and where the head
  points.

Every agent re-plans every few steps, at once after a bump and when a look is done. Its
parameters are one :class:`NavigatorConfig` (:mod:`agents.planning.config`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import (
    Agent,
    control_limits,
    goal_xy,
    memory_model_of,
    model_of,
    robot_pose,
    room_bounds,
)
from agents.planning.config import NavigatorConfig, Policy
from agents.planning.follower import PathFollower, RouteDriver
from agents.planning.planner import Decision, Mode, PlannerCore
from agents.planning.recovery import Recovery, RecoveryEvents

__all__ = ["Decision", "Mode", "ModelBasedAgent", "NavigatorConfig", "PlannerCore", "Policy"]

_LOOK_TIMEOUT_STEPS = 15
"""A look ends after this many steps even when the point has not come into view."""


class ModelBasedAgent(Agent):
    """``greedy``, ``cautious`` or ``planner``: planner + follower + recovery.

    Args:
        policy: Which of the three.
        config: Further parameters (its ``policy`` is replaced by ``policy``).

    Attributes:
        config: The parameters, with ``policy``.
        core: The planner and occupancy map of the episode (``None`` before :meth:`reset`).
        decision: The decision being carried out (``None`` while backing off or before a plan).
        events: What the recovery noticed at the last step (``None`` before the first).
        escaping: Whether the last action was a back-off's (:mod:`agents.planning.recovery`).
    """

    def __init__(self, policy: Policy | str, config: NavigatorConfig | None = None) -> None:
        super().__init__()
        base = config or NavigatorConfig()
        kw = {f: getattr(base, f) for f in base.__dataclass_fields__}
        kw["policy"] = Policy(policy)
        self.config = NavigatorConfig(**kw)
        self.name = self.config.policy.value
        self.core: PlannerCore | None = None
        self.decision: Decision | None = None
        self._driver: RouteDriver | None = None
        self._recovery: Recovery | None = None
        self.events: RecoveryEvents | None = None
        self.escaping = False
        self._since_plan = 0
        self._look_steps = 0
        self._last_xy = np.zeros(2)

    def _reset(self, seed: int | None) -> None:
        limits = control_limits(self.env)
        goal = goal_xy(self.env)
        self.core = PlannerCore(room_bounds(self.env), goal, limits, self.config)
        pursuit = PathFollower(
            max_speed_mps=limits.max_speed_m_s,
            max_turn_rate_rps=limits.max_turn_rate_rad_s,
            dt_s=limits.dt_s,
            lookahead_m=0.35,
            shortcut_m=self.config.shortcut_m,
        )
        self._driver = RouteDriver(
            pursuit=pursuit, limits=limits, gaze_ahead_m=self.config.gaze_ahead_m
        )
        x, y, heading, _ = robot_pose(self.env)
        distance = float(np.hypot(*(np.array([x, y]) - goal)))
        self._recovery = Recovery(self.config, limits, (x, y, heading), distance)
        self.decision = None
        self.events = None
        self.escaping = False
        self._since_plan = 0
        self._look_steps = 0
        self._last_xy = np.array([x, y])

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        assert self.core is not None and self._driver is not None and self._recovery is not None
        cfg, core, recovery = self.config, self.core, self._recovery
        pose = robot_pose(self.env)
        x, y, heading, _ = pose
        here = np.array([x, y])
        core.observe(model_of(self.env, info), self.steps, fused=memory_model_of(info))
        core.gates.note_motion(self._last_xy, here)
        self._last_xy = here
        replan = self.decision is None or self._since_plan >= cfg.replan_every
        goal_distance_m = float(np.hypot(*(here - core.goal)))
        events = recovery.update(
            (x, y, heading),
            self.steps,
            collided=bool(info.get("collision", False)),
            goal_distance_m=goal_distance_m,
        )
        self.events = events
        if events.bump is not None:
            bump = events.bump
            core.bump(pose, backwards=bump.backwards, step=self.steps, normal=bump.normal)
        if events.lost:
            core.occupancy.forget(self.steps - cfg.keep_bumps_steps)
            core.forget_route()
        if events.stalled:
            core.bump(pose, backwards=False, step=self.steps)
        replan = replan or events.replan
        escape = recovery.escape_command(heading, self.steps)
        self.escaping = escape is not None
        if escape is not None:
            self.decision = None
            forward, turn = escape
            recovery.commanded(forward)
            return np.array([forward, turn, 0.0])
        if self.decision is not None and self.decision.mode is Mode.LOOK:
            replan = replan or self._look_done(pose)
        if replan:
            self._plan(pose)
            assert self.decision is not None
            recovery.route_cost(self.decision.expected_cost_m, self.steps, goal_distance_m)
        self._since_plan += 1
        d = self.decision
        assert d is not None
        if d.mode is Mode.LOOK and d.look_at is not None:
            forward, turn, pan = self._driver.look(pose, d.waypoints, d.look_at)
            self._look_steps += 1
        else:
            gaze = cfg.policy is Policy.PLANNER and d.mode is not Mode.LOOK
            forward, turn, pan = self._driver.follow(pose, d.waypoints, gaze=gaze)
        recovery.commanded(forward)
        return np.array([forward, turn, pan])

    def executed(self, action: NDArray[np.floating]) -> None:
        """Record the command actually sent after this agent's last :meth:`act`, when another
        policy drove (a teacher relabelling a student's states, ``agents.learning.wrappers``):
        the bump and stall watches measure the motion that command should have made."""
        if self._recovery is None:
            raise RuntimeError("executed() before reset()")
        sent = np.asarray(action, dtype=np.float64).reshape(-1)
        self._recovery.commanded(float(np.clip(sent[0], -1.0, 1.0)))

    def _plan(self, pose: tuple[float, float, float, float]) -> None:
        """A fresh decision from ``pose``; a look it starts is counted."""
        assert self.core is not None
        core = self.core
        self.decision = core.plan(pose)
        if self.decision.mode is Mode.NONE:
            # No route at all: relax the map and plan again, rather than drive straight at
            # the goal into what it already knows is there.
            core.relax(self.steps - self.config.relax_keep_steps)
            self.decision = core.plan(pose)
        self._since_plan = 0
        if self.decision.mode is Mode.LOOK and self.decision.gate is not None:
            core.looks_at[self.decision.gate] = core.looks_at.get(self.decision.gate, 0) + 1
            self._look_steps = 0

    def _look_done(self, pose: tuple[float, float, float, float]) -> bool:
        """The looked-at point has been in the field of view for a step (or the look timed out);
        in view, it updates the gate's nearest view."""
        d = self.decision
        assert d is not None and d.look_at is not None
        assert self.core is not None and self._driver is not None
        in_view = self._driver.sees(d.look_at, pose)
        gates = self.core.gates.gates
        if in_view and d.gate is not None and d.gate < len(gates):
            distance = float(np.hypot(*(d.look_at - np.array(pose[:2]))))
            gates[d.gate].viewed_distance_m = min(gates[d.gate].viewed_distance_m, distance)
        return in_view or self._look_steps > _LOOK_TIMEOUT_STEPS
