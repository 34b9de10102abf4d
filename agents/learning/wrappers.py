"""Gymnasium wrappers of the learned agents' training envs.

* :class:`EgoMapObservation`: the observation becomes :mod:`agents.learning.egomap`'s (the
  egocentric map and features of the robot's own memory), the same the learned agent builds
  when it drives a plain env;
* :class:`PlannerTeacher`: ``info["teacher_action"]`` is what the planner would do in the state
  just observed; the planner keeps its memory along the trajectory actually driven (it sees every
  view and contact, and is told each command that was really sent), so its label for a student's
  state is the label it would give had it driven there itself (DAgger's relabelling);
* :class:`FamilyMix`: each episode's scene family drawn from a list (the whole curriculum).

Stack them on an env made with ``info_models=False`` (the models stay in the env's process:
the wrappers read them through :func:`agents.base.model_of`): :func:`make_training_env`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from agents.learning.egomap import EgoMap, EgoMapConfig
from agents.planning.config import NavigatorConfig
from modeling.validation import with_overrides

__all__ = ["EgoMapObservation", "FamilyMix", "PlannerTeacher", "make_training_env"]


class EgoMapObservation(gym.Wrapper[Any, Any, Any, Any]):
    """The env with :class:`~agents.learning.egomap.EgoMap`'s observation.

    Args:
        env: A ``StereoNav`` env (any observation mode: only ``info`` and the pose are read).
        config: The observation's geometry.
    """

    def __init__(self, env: gym.Env[Any, Any], config: EgoMapConfig | None = None) -> None:
        super().__init__(env)
        self.egomap = EgoMap(config)
        self.observation_space = self.egomap.observation_space()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        _, info = self.env.reset(seed=seed, options=options)
        return self.egomap.reset(self.env, info), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        _, reward, terminated, truncated, info = self.env.step(action)
        return self.egomap.step(self.env, info, action), float(reward), terminated, truncated, info


class PlannerTeacher(gym.Wrapper[Any, Any, Any, Any]):
    """``info["teacher_action"]``: the model-based agent's (3,) action for the state observed.

    Args:
        env: A ``StereoNav`` env whose ``info`` (or ``env.unwrapped``) holds the model.
        policy: ``"planner"`` (default), ``"greedy"`` or ``"cautious"``.
        navigator: The agent's parameters.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        policy: str = "planner",
        navigator: NavigatorConfig | None = None,
    ) -> None:
        from agents.planning.navigator import ModelBasedAgent

        super().__init__(env)
        self.teacher = ModelBasedAgent(policy, navigator)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self.teacher.reset(self.env, seed=seed)
        info["teacher_action"] = self.teacher.act(obs, info)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self.teacher.executed(np.asarray(action, dtype=np.float64))
        obs, reward, terminated, truncated, info = self.env.step(action)
        info["teacher_action"] = self.teacher.act(obs, info)
        return obs, float(reward), terminated, truncated, info


class FamilyMix(gym.Wrapper[Any, Any, Any, Any]):
    """Each episode in a scene family drawn from ``families`` (``weights``: their shares).

    The draw uses the wrapper's own generator, seeded by the first seeded ``reset``.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        families: Sequence[str],
        weights: Sequence[float] | None = None,
    ) -> None:
        super().__init__(env)
        if not families:
            raise ValueError("families must name at least one scene family")
        self.families = tuple(families)
        w = np.ones(len(self.families)) if weights is None else np.asarray(weights, float)
        if w.shape != (len(self.families),) or (w < 0).any() or w.sum() <= 0:
            raise ValueError(
                f"weights must be {len(self.families)} non-negative numbers, got {weights}"
            )
        self.weights = w / w.sum()
        self._rng = np.random.default_rng(0)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        family = str(self._rng.choice(self.families, p=self.weights))
        self.env.unwrapped.set_scenario(family)  # type: ignore[attr-defined]
        return self.env.reset(seed=seed, options=options)


def make_training_env(
    env_kwargs: dict[str, Any],
    *,
    families: Sequence[str],
    weights: Sequence[float] | None = None,
    teacher: str | None = "planner",
    teacher_settings: Mapping[str, Any] | None = None,
    egomap: EgoMapConfig | None = None,
) -> gym.Env[Any, Any]:
    """``StereoNav-v1`` with ``env_kwargs`` (``info_models=False`` added), the families mixed,
    the teacher's labels (unless ``teacher`` is ``None``; ``teacher_settings``: fields of its
    :class:`~agents.planning.config.NavigatorConfig`) and the egocentric observation."""
    import stereo_nav_env  # noqa: F401  (registers the ids)

    env: gym.Env[Any, Any] = gym.make("StereoNav-v1", **{**env_kwargs, "info_models": False})
    env = FamilyMix(env, families, weights)
    if teacher is not None:
        navigator = with_overrides(None, NavigatorConfig, dict(teacher_settings or {}))
        env = PlannerTeacher(env, teacher, navigator)
    return EgoMapObservation(env, egomap)
