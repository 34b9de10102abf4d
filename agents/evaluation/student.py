"""How a learned student drives against its teacher: one suite episode traced step by step.

:func:`trace_student` runs one episode of the suite (:mod:`agents.evaluation.suite`: the same env,
reset seed and step limit) with a learned agent (``learned``, ``learned:PATH``; any agent may
drive, a model-based one to compare two teachers) and, beside it, a teacher whose memory follows
the student's trajectory
(:class:`~agents.learning.wrappers.PlannerTeacher`, as the DAgger rounds of
:mod:`agents.learning.imitation` label states): at every step, the command the student sent and
the one the teacher would have sent, the pose, the contact flag and the true geodesic distance to
the goal. :func:`student_patterns` sums up how the student drives and where it parts from its
teacher:

* ``in_place_share``: steps whose forward command is below ``0.15`` (turning or looking on the
  spot);
* ``turn_flips_per_100``: changes of the sign of the student's turn (among its turns stronger
  than ``0.2``) per 100 steps: dithering between left and right;
* ``opposite_turn_share``: of the steps where both turn by more than ``0.2``, the share where
  they turn opposite ways;
* ``forward_excess``: the student's forward command less the teacher's, averaged (positive: it
  drives faster than its teacher would);
* ``collision_steps``, the true geodesic distance to the goal at the start, its least value and
  at the end (``geodesic_start_m``, ``geodesic_min_m``, ``geodesic_end_m``), and
  ``last_radius_m``: the largest distance of the robot, over its last 200 steps, from their mean
  position (near 0: it stays where it is).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.evaluation.suite import EpisodeSpec, SuiteConfig

__all__ = ["StudentTrace", "student_patterns", "trace_student"]

IN_PLACE_FORWARD = 0.15
"""A forward command below this is a step on the spot."""
STRONG_TURN = 0.2
"""A turn command stronger than this (in magnitude) is a turn to one side."""
LAST_STEPS = 200
"""The window of ``last_radius_m``, steps."""


@dataclass(frozen=True, slots=True, kw_only=True)
class StudentTrace:
    """A traced episode of a student beside its teacher.

    Attributes:
        family: Scene family.
        seed: Reset seed.
        success: Reached the goal.
        sent: (T, 3) the student's commands (forward, turn, pan), one row per step.
        teacher: (T, 3) the teacher's commands for the same states.
        xy: (T, 2) the robot's position before each step, world metres.
        collided: (T,) the step ended in a contact.
        geodesic_m: (T,) true geodesic distance to the goal after each step, metres.
    """

    family: str
    seed: int
    success: bool
    sent: NDArray[np.float64]
    teacher: NDArray[np.float64]
    xy: NDArray[np.float64]
    collided: NDArray[np.bool_]
    geodesic_m: NDArray[np.float64]


def trace_student(
    agent_name: str,
    spec: EpisodeSpec,
    cfg: SuiteConfig,
    *,
    teacher: str = "planner",
    teacher_settings: Mapping[str, Any] | None = None,
) -> StudentTrace:
    """Run ``agent_name`` (a learned agent, or any other) for episode ``spec`` of suite ``cfg``
    (as :func:`agents.evaluation.suite.run_episode` does), with ``teacher`` labelling each state
    (``teacher_settings``: fields of its :class:`~agents.planning.config.NavigatorConfig`, e.g.
    ``{"replan_every": 1}``; a model-based driver takes ``cfg.navigator``)."""
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from agents.base import robot_pose
    from agents.evaluation.suite import ENV_ID, _agent
    from agents.learning.wrappers import PlannerTeacher
    from agents.planning.config import NavigatorConfig
    from modeling.validation import with_overrides

    # with_overrides names a bad field or value
    labeller = with_overrides(None, NavigatorConfig, dict(teacher_settings or {}))
    agent = _agent(agent_name, cfg.navigator)  # the suite's agent of that name and settings
    env: gym.Env[Any, Any] = PlannerTeacher(
        gym.make(ENV_ID, scenario=spec.family, **cfg.env_kwargs), teacher, labeller
    )
    rows: list[list[float]] = []
    success = False
    try:
        obs, info = env.reset(seed=spec.seed)
        agent.reset(env, seed=spec.seed)
        for _ in range(cfg.max_steps):
            label = np.asarray(info["teacher_action"], dtype=np.float64)
            action = np.asarray(agent.act(obs, info), dtype=np.float64)
            x, y, _, _ = robot_pose(env)
            obs, _, terminated, truncated, info = env.step(action)
            success = bool(info.get("is_success", False))
            rows.append(
                [
                    *action,
                    *label,
                    x,
                    y,
                    float(bool(info.get("collision", False))),
                    float(info.get("geodesic_distance_m", np.nan)),
                ]
            )
            if terminated or truncated:
                break
    finally:
        agent.close()
        env.close()
    r = np.array(rows, dtype=np.float64).reshape(-1, 10)
    return StudentTrace(
        family=spec.family,
        seed=spec.seed,
        success=success,
        sent=r[:, 0:3],
        teacher=r[:, 3:6],
        xy=r[:, 6:8],
        collided=r[:, 8] > 0.5,
        geodesic_m=r[:, 9],
    )


def student_patterns(trace: StudentTrace) -> dict[str, Any]:
    """The figures of the module doc for ``trace``, with its outcome (NaN where a figure has no
    steps to count: an empty trace, or no step where both turn)."""
    n = trace.sent.shape[0]
    forward, turn = trace.sent[:, 0], trace.sent[:, 1]
    sides = np.sign(turn[np.abs(turn) > STRONG_TURN])
    both = (np.abs(turn) > STRONG_TURN) & (np.abs(trace.teacher[:, 1]) > STRONG_TURN)
    last = trace.xy[-LAST_STEPS:]
    geodesic = trace.geodesic_m

    def share(mask: NDArray[np.bool_]) -> float:
        return float(mask.mean()) if mask.size else float("nan")

    return {
        "family": trace.family,
        "seed": trace.seed,
        "success": trace.success,
        "steps": n,
        "in_place_share": share(forward < IN_PLACE_FORWARD),
        "turn_flips_per_100": 100.0 * float(np.count_nonzero(np.diff(sides))) / n
        if n
        else float("nan"),
        "opposite_turn_share": share(np.sign(turn[both]) != np.sign(trace.teacher[both, 1])),
        "forward_excess": float(np.mean(forward - trace.teacher[:, 0])) if n else float("nan"),
        "collision_steps": int(trace.collided.sum()),
        "geodesic_start_m": float(geodesic[0]) if n else float("nan"),
        "geodesic_min_m": float(np.nanmin(geodesic)) if n else float("nan"),
        "geodesic_end_m": float(geodesic[-1]) if n else float("nan"),
        "last_radius_m": float(np.hypot(*(last - last.mean(axis=0)).T).max())
        if n
        else float("nan"),
    }
