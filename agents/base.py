"""The agent interface and what agents read from the environment.

An :class:`Agent` is reset with the environment it will drive (``reset(env, seed=...)``) and then
asked for one action per step (``act(obs, info)``): a ``(3,)`` float32 array in ``[-1, 1]``
(forward speed, turn rate, head pan target, as ``StereoNav-v0`` takes them).

The environment access of the scripted agents goes through the few functions of this module
(:func:`robot_pose`, :func:`goal_xy`, :func:`room_bounds`, :func:`control_limits`,
:func:`model_of`), so that when the environment's public API grows (a public robot pose,
``info["model"]``) only this module changes. :func:`model_of` contains the one temporary fallback:
while ``info`` has no ``"model"`` it renders the stereo pair itself and runs the modeling pipeline.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.model import EnvironmentModel, build_model

__all__ = [
    "LOOK_THRESHOLD",
    "Agent",
    "ControlLimits",
    "control_limits",
    "goal_xy",
    "is_look",
    "model_of",
    "robot_pose",
    "room_bounds",
]

FloatArray = NDArray[np.float64]

LOOK_THRESHOLD = 0.05
"""A step is a *look* when ``|head pan target| > LOOK_THRESHOLD`` (normalised; 4.5 deg of 90)."""


def is_look(action: NDArray[np.floating]) -> bool:
    """Whether ``action`` (3,) points the head away from straight ahead (a *look*)."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    return bool(a.shape[0] >= 3 and abs(a[2]) > LOOK_THRESHOLD)


class Agent(abc.ABC):
    """A policy for ``StereoNav-v0``.

    Subclasses implement :meth:`act`, and :meth:`_reset` when they keep per-episode state.

    Attributes:
        name: The registry name (``"planner"``, ``"ppo:PATH"``, ...).
        env: The environment given to the last :meth:`reset` (``None`` before).
        looks: Number of look steps (:func:`is_look`) since the last reset.
        steps: Number of :meth:`act` calls since the last reset.
    """

    name: str = "agent"

    def __init__(self) -> None:
        self.env: Any = None
        self.looks = 0
        self.steps = 0

    def reset(self, env: Any = None, *, seed: int | None = None) -> None:
        """Start an episode in ``env`` (already reset); ``seed`` seeds the agent's randomness."""
        self.env = env
        self.looks = 0
        self.steps = 0
        self._reset(seed)

    def _reset(self, seed: int | None) -> None:  # noqa: B027 (optional hook)
        """Per-episode set-up of a subclass."""

    def act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.float32]:
        """The action for observation ``obs`` and info ``info`` of the step just taken.

        Returns:
            (3,) float32 in [-1, 1]: forward speed, turn rate, head pan target.
        """
        action = np.clip(np.asarray(self._act(obs, info), dtype=np.float32).reshape(3), -1, 1)
        self.steps += 1
        self.looks += int(is_look(action))
        return action

    @abc.abstractmethod
    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        """The subclass's action (clipped to [-1, 1] by :meth:`act`)."""

    def close(self) -> None:
        """Release resources; the agent lets go of its environment (``reset`` gives it one)."""
        self.env = None


# ---------------------------------------------------------------------------- environment access
@dataclass(frozen=True, slots=True, kw_only=True)
class ControlLimits:
    """How the env scales normalised actions.

    Attributes:
        max_speed_m_s: Forward speed at action[0] = 1, m/s.
        max_turn_rate_rad_s: Turn rate at action[1] = 1, rad/s.
        pan_limit_rad: Head pan at action[2] = 1, radians.
        max_pan_rate_rad_s: Largest head pan rate, rad/s.
        dt_s: Seconds per step.
        robot_width_m: Robot diameter, metres.
        goal_radius_m: Success distance, metres.
        fov_rad: Horizontal field of view of the cameras, radians.
    """

    max_speed_m_s: float = 0.5
    max_turn_rate_rad_s: float = math.pi / 2
    pan_limit_rad: float = math.pi / 2
    max_pan_rate_rad_s: float = math.pi / 2
    dt_s: float = 0.1
    robot_width_m: float = 0.5
    goal_radius_m: float = 0.3
    fov_rad: float = math.radians(64.0)


def _base(env: Any) -> Any:
    return getattr(env, "unwrapped", env)


def robot_pose(env: Any) -> tuple[float, float, float, float]:
    """``(x_m, y_m, heading_rad, pan_rad)`` of the robot now, world frame.

    Reads the public ``env.unwrapped.robot_pose`` (x, y, heading) and ``head_pose`` (its heading
    minus the body's is the pan); falls back to the simulator's state for older environments.
    """
    u = _base(env)
    pose = getattr(u, "robot_pose", None)
    if pose is not None and not callable(pose):
        x, y, heading = (float(v) for v in tuple(pose)[:3])
        head = getattr(u, "head_pose", None)
        pan = (
            0.0 if head is None else math.remainder(float(head.heading_rad) - heading, 2 * math.pi)
        )
        return x, y, heading, pan
    world = getattr(u, "world", None) or getattr(u, "_world", None)
    if world is None:
        raise RuntimeError("the environment exposes no robot pose; reset it first")
    return _pose_tuple(world.state)


def _pose_tuple(state: Any) -> tuple[float, float, float, float]:
    if hasattr(state, "x_m"):
        return (
            float(state.x_m),
            float(state.y_m),
            float(state.heading_rad),
            float(getattr(state, "pan_rad", 0.0)),
        )
    arr = np.asarray(state, dtype=np.float64).reshape(-1)
    pan = float(arr[3]) if arr.shape[0] > 3 else 0.0
    return float(arr[0]), float(arr[1]), float(arr[2]), pan


def _scene(env: Any) -> Any:
    u = _base(env)
    scene = getattr(u, "scene", None) or getattr(u, "_scene", None)
    if scene is None:
        raise RuntimeError("the environment exposes no scene; reset it first")
    return scene


def goal_xy(env: Any) -> FloatArray:
    """(2,) the goal, world frame, metres."""
    goal = getattr(_base(env), "goal", None)
    if goal is None or callable(goal):
        goal = _scene(env).goal
    return np.asarray(goal, dtype=np.float64).reshape(2)


def room_bounds(env: Any) -> tuple[float, float, float, float]:
    """``(xmin, ymin, xmax, ymax)`` of the floor: the rough map the agents are given."""
    return tuple(float(v) for v in _scene(env).bounds)  # type: ignore[return-value]


def control_limits(env: Any) -> ControlLimits:
    """The action scales and robot size of ``env``'s configuration."""
    u = _base(env)
    cfg = getattr(u, "config", None)
    rig = getattr(u, "rig", None)
    fov = rig.hfov_rad if rig is not None else None
    if cfg is None:
        return ControlLimits() if fov is None else ControlLimits(fov_rad=fov)
    kw: dict[str, float] = {
        name: float(getattr(cfg, name))
        for name in (
            "max_speed_m_s",
            "max_turn_rate_rad_s",
            "pan_limit_rad",
            "max_pan_rate_rad_s",
            "dt_s",
            "robot_width_m",
            "goal_radius_m",
        )
        if hasattr(cfg, name)
    }
    if fov is not None:
        kw["fov_rad"] = fov
    return ControlLimits(**kw)


def model_of(env: Any, info: dict[str, Any]) -> EnvironmentModel:
    """The environment model of the latest observation: ``info["model"]`` (the contract).

    Until the environment puts it there, the model is computed here from the current stereo pair
    (:func:`_model_from_stereo`); remove that fallback once ``info["model"]`` always exists.
    """
    model = info.get("model") if isinstance(info, dict) else None
    if isinstance(model, EnvironmentModel):
        return model
    return _model_from_stereo(env)


def _model_from_stereo(env: Any) -> EnvironmentModel:
    """Fallback while ``info["model"]`` is missing: render, match, triangulate, build the model."""
    from modeling.pipeline import stereo_to_floor

    u = _base(env)
    left, right = u.render_stereo()
    observation = stereo_to_floor(left, right, u.rig, u.head_pose)
    return build_model(observation, control_limits(env).robot_width_m)
