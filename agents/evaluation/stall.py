"""Why a model-based agent stalls or detours: one suite episode traced step by step.

:func:`trace_episode` runs one episode of the suite (:mod:`agents.evaluation.suite`: the same env,
reset seed and step limit) with a model-based agent (``greedy``, ``cautious``, ``planner``) and
records, per step, the robot's pose, the contact flag, what the agent did (follow, look, approach,
a back-off) and what its recovery noticed (a bump, a stall, lost progress).
:func:`stall_patterns` counts the patterns that waste steps:

* ``revisit_steps``: steps at a place (within ``0.3 m``) where the robot already was at least 50
  steps before (a loop, or oscillating between two ways round);
* ``route_flips``: re-plans whose route heads off more than 90 degrees from the last plan's, 1 m
  ahead (switching between ways round);
* ``gate_retries``: bumps within ``0.6 m`` of an earlier bump more than 20 steps before (a place
  it keeps trying);
* ``backoff_steps``, ``stalls``, ``lost``: steps spent in back-offs, stall and lost-progress
  events of the recovery;
* ``look_steps``, ``approach_steps``: steps spent looking at or approaching an undecided gate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.evaluation.suite import EpisodeSpec, SuiteConfig

__all__ = ["EpisodeTrace", "StepRecord", "stall_patterns", "trace_episode"]


@dataclass(frozen=True, slots=True, kw_only=True)
class StepRecord:
    """One step of a traced episode.

    Attributes:
        step: Step number (1 first).
        x_m: Robot x after the step, world metres.
        y_m: Robot y after the step, world metres.
        collided: The step ended in a contact.
        mode: ``"escape"`` (a back-off) or the decision's mode (``follow``, ``look``, ...).
        ahead_rad: Bearing of the route 1 m ahead of the robot when the action was chosen
            (nan when backing off).
        replanned: The agent planned at this step.
        bump: The recovery saw a bump at this step.
        stalled: The stall watch fired.
        lost: The lost-progress watch fired.
        gate: Gate looked at or approached, else -1.
    """

    step: int
    x_m: float
    y_m: float
    collided: bool
    mode: str
    ahead_rad: float
    replanned: bool
    bump: bool
    stalled: bool
    lost: bool
    gate: int


@dataclass(frozen=True, slots=True, kw_only=True)
class EpisodeTrace:
    """A traced episode: its outcome and its steps.

    Attributes:
        family: Scene family.
        seed: Reset seed.
        success: Reached the goal.
        steps: The per-step records.
        path_length_m: Distance driven, metres.
        reference_m: True shortest route length to the goal region, metres.
    """

    family: str
    seed: int
    success: bool
    steps: tuple[StepRecord, ...]
    path_length_m: float
    reference_m: float


def _ahead_bearing(xy: np.ndarray, waypoints: np.ndarray, distance_m: float = 1.0) -> float:
    """Bearing (radians) from ``xy`` of the point ``distance_m`` along ``waypoints`` (n, 2)."""
    pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
    left = distance_m
    point = pts[0]
    for nxt in pts[1:]:
        step = float(np.hypot(*(nxt - point)))
        if step >= left:
            point = point + (nxt - point) * (left / max(step, 1e-12))
            break
        left -= step
        point = nxt
    d = point - xy
    return math.atan2(float(d[1]), float(d[0])) if float(np.hypot(*d)) > 1e-6 else math.nan


def trace_episode(agent_name: str, spec: EpisodeSpec, cfg: SuiteConfig) -> EpisodeTrace:
    """Run ``agent_name`` (a model-based agent) for episode ``spec`` of suite ``cfg``, step by
    step (as :func:`agents.evaluation.suite.run_episode` does)."""
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from agents import make_agent
    from agents.base import robot_pose
    from agents.evaluation.suite import ENV_ID, reference_length_m
    from agents.planning.config import NavigatorConfig
    from agents.planning.navigator import ModelBasedAgent

    env = gym.make(ENV_ID, scenario=spec.family, **cfg.env_kwargs)
    agent = make_agent(agent_name, config=NavigatorConfig(**cfg.navigator))
    if not isinstance(agent, ModelBasedAgent):
        raise ValueError(f"{agent_name!r} is not a model-based agent")
    records: list[StepRecord] = []
    try:
        obs, info = env.reset(seed=spec.seed)
        reference = reference_length_m(env)
        agent.reset(env, seed=spec.seed)
        x, y, _, _ = robot_pose(env)
        last, path, success = np.array([x, y]), 0.0, False
        previous: object = None
        for step in range(1, cfg.max_steps + 1):
            action = agent.act(obs, info)
            d, events = agent.decision, agent.events
            replanned = d is not None and d is not previous
            previous = d
            ahead = math.nan
            if d is not None and not agent.escaping:
                ahead = _ahead_bearing(last, d.waypoints)
            obs, _, terminated, truncated, info = env.step(action)
            x, y, _, _ = robot_pose(env)
            here = np.array([x, y])
            path += float(np.hypot(*(here - last)))
            last = here
            success = bool(info.get("is_success", False))
            records.append(
                StepRecord(
                    step=step,
                    x_m=x,
                    y_m=y,
                    collided=bool(info.get("collision", False)),
                    mode="escape" if agent.escaping or d is None else d.mode.value,
                    ahead_rad=ahead,
                    replanned=replanned and not agent.escaping,
                    bump=events is not None and events.bump is not None,
                    stalled=events is not None and events.stalled,
                    lost=events is not None and events.lost,
                    gate=-1 if d is None or d.gate is None else int(d.gate),
                )
            )
            if terminated or truncated:
                break
    finally:
        agent.close()
        env.close()
    return EpisodeTrace(
        family=spec.family,
        seed=spec.seed,
        success=success,
        steps=tuple(records),
        path_length_m=path,
        reference_m=float(reference),
    )


def stall_patterns(trace: EpisodeTrace) -> dict[str, Any]:
    """The counts of the module doc for ``trace``, with its outcome."""
    steps = trace.steps
    xy = np.array([[s.x_m, s.y_m] for s in steps]).reshape(-1, 2)
    revisit = 0
    for k in range(50, len(steps)):
        if bool((np.hypot(*(xy[: k - 49] - xy[k]).T) < 0.3).any()):
            revisit += 1
    flips = 0
    prev = math.nan
    for s in steps:
        if not s.replanned or math.isnan(s.ahead_rad):
            continue
        if not math.isnan(prev) and abs(math.remainder(s.ahead_rad - prev, 2 * math.pi)) > 1.6:
            flips += 1
        prev = s.ahead_rad
    bumps = [(s.step, xy[i]) for i, s in enumerate(steps) if s.bump]
    retries = sum(
        1
        for i, (k, p) in enumerate(bumps)
        if any(k - k0 > 20 and float(np.hypot(*(p - p0))) < 0.6 for k0, p0 in bumps[:i])
    )
    modes = [s.mode for s in steps]
    return {
        "family": trace.family,
        "seed": trace.seed,
        "success": trace.success,
        "steps": len(steps),
        "collision_steps": sum(s.collided for s in steps),
        "path_m": round(trace.path_length_m, 2),
        "reference_m": round(trace.reference_m, 2),
        "revisit_steps": revisit,
        "route_flips": flips,
        "gate_retries": retries,
        "backoff_steps": modes.count("escape"),
        "stalls": sum(s.stalled for s in steps),
        "lost": sum(s.lost for s in steps),
        "look_steps": modes.count("look"),
        "approach_steps": modes.count("approach"),
    }
