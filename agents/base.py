"""The agent interface and what agents read from the environment.

An :class:`Agent` is reset with the environment it will drive (``reset(env, seed=...)``) and then
asked for one action per step (``act(obs, info)``): a ``(3,)`` float32 array in ``[-1, 1]``
(forward speed, turn rate, head pan target, as ``StereoNav-v0`` takes them).

The environment access of the scripted agents goes through the few functions of this module
(:func:`robot_pose`, :func:`goal_xy`, :func:`room_bounds`, :func:`control_limits`,
:func:`model_of`), which read the env's public API: ``env.unwrapped.robot_pose``, ``head_pose``,
``scene`` and ``config`` (an ``EnvConfig``), and ``info["model"]``.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from modeling.model.records import EnvironmentModel
from modeling.types import FloatArray

if TYPE_CHECKING:
    from stereo_nav_env.config import EnvConfig

__all__ = [
    "LOOK_THRESHOLD",
    "Agent",
    "ControlLimits",
    "control_limits",
    "goal_xy",
    "is_look",
    "memory_model_of",
    "model_of",
    "robot_pose",
    "room_bounds",
]


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
    """How the env scales normalised actions, and the robot's size (from its configuration).

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

    max_speed_m_s: float
    max_turn_rate_rad_s: float
    pan_limit_rad: float
    max_pan_rate_rad_s: float
    dt_s: float
    robot_width_m: float
    goal_radius_m: float
    fov_rad: float

    @classmethod
    def from_config(cls, config: EnvConfig) -> ControlLimits:
        """The limits of an env configured by ``config`` (``env.unwrapped.config``)."""
        world = config.world
        return cls(
            max_speed_m_s=float(world.max_speed_m_s),
            max_turn_rate_rad_s=float(world.max_turn_rate_rad_s),
            pan_limit_rad=float(world.pan_limit_rad),
            max_pan_rate_rad_s=float(world.max_pan_rate_rad_s),
            dt_s=float(world.dt_s),
            robot_width_m=float(world.robot_width_m),
            goal_radius_m=float(config.goal_radius_m),
            fov_rad=float(config.rig.hfov_rad),
        )


def _scene(env: Any) -> Any:
    scene = env.unwrapped.scene
    if scene is None:
        raise RuntimeError("the environment has no scene yet; reset it first")
    return scene


def robot_pose(env: Any) -> tuple[float, float, float, float]:
    """``(x_m, y_m, heading_rad, pan_rad)`` of the robot now, world frame.

    Reads the public ``env.unwrapped.robot_pose`` (x, y, heading) and ``head_pose`` (its heading
    minus the body's is the pan).
    """
    u = env.unwrapped
    x, y, heading = (float(v) for v in u.robot_pose)
    pan = math.remainder(float(u.head_pose.heading_rad) - heading, 2 * math.pi)
    return x, y, heading, pan


def goal_xy(env: Any) -> FloatArray:
    """(2,) the goal, world frame, metres."""
    return np.asarray(_scene(env).goal, dtype=np.float64).reshape(2)


def room_bounds(env: Any) -> tuple[float, float, float, float]:
    """``(xmin, ymin, xmax, ymax)`` of the floor: the rough map the agents are given."""
    xmin, ymin, xmax, ymax = (float(v) for v in _scene(env).bounds)
    return xmin, ymin, xmax, ymax


def control_limits(env: Any) -> ControlLimits:
    """The action scales and robot size of ``env``'s configuration (``env.unwrapped.config``)."""
    return ControlLimits.from_config(env.unwrapped.config)


def model_of(env: Any, info: dict[str, Any]) -> EnvironmentModel:
    """The environment model of the latest observation: ``info["model"]`` (the env's contract),
    or ``env.unwrapped.model`` when the env leaves the models out of ``info``
    (``info_models=False``).

    Raises:
        ValueError: When neither holds a model.
    """
    model = info["model"] if "model" in info else getattr(env.unwrapped, "model", None)
    if not isinstance(model, EnvironmentModel):
        raise ValueError(f"info['model'] must be an EnvironmentModel, got {type(model).__name__}")
    return model


def memory_model_of(info: dict[str, Any]) -> EnvironmentModel | None:
    """The fused model of the episode so far, ``info["memory_model"]``, or ``None`` when the env
    keeps no memory (``memory=False``).

    Raises:
        ValueError: When ``info["memory_model"]`` is neither ``None`` nor an EnvironmentModel.
    """
    model = info.get("memory_model")
    if model is not None and not isinstance(model, EnvironmentModel):
        raise ValueError(
            f"info['memory_model'] must be an EnvironmentModel or None, got {type(model).__name__}"
        )
    return model
