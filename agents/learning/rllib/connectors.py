"""The env-to-module connectors of the RLlib backend: the ``Dict`` observation to one vector.

This module imports ray at the top: only :mod:`agents.learning.rllib.backend` (when training) and
the checkpoints it writes (when restored) import it.

* :class:`ScaleBytes`: every ``uint8`` box of the observation, at any depth of a ``Dict``, to
  float32 in ``[0, 1]`` (what stable-baselines3 does to images); other spaces pass unchanged.
* RLlib's ``FlattenObservations``: every component to one float32 vector (keys in sorted order).

Neither names an observation key: a new key or a changed shape needs no change here.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from ray.rllib.connectors.env_to_module import FlattenObservations
from ray.rllib.connectors.env_to_module.observation_preprocessor import (
    SingleAgentObservationPreprocessor,
)

__all__ = ["ScaleBytes", "env_to_module", "scaled", "scaled_space"]


def _is_bytes(space: gym.Space[Any]) -> bool:
    return isinstance(space, gym.spaces.Box) and space.dtype == np.uint8


def scaled_space(space: gym.Space[Any]) -> gym.Space[Any]:
    """``space`` with every ``uint8`` box replaced by a float32 box on ``[0, 1]``."""
    if isinstance(space, gym.spaces.Dict):
        return gym.spaces.Dict({k: scaled_space(s) for k, s in space.spaces.items()})
    if _is_bytes(space):
        return gym.spaces.Box(0.0, 1.0, space.shape, np.float32)
    return space


def scaled(value: Any, space: gym.Space[Any]) -> Any:
    """``value`` (an element of ``space``) with every ``uint8`` array divided by 255."""
    if isinstance(space, gym.spaces.Dict):
        return {k: scaled(value[k], s) for k, s in space.spaces.items()}
    if _is_bytes(space):
        return np.asarray(value, dtype=np.float32) / np.float32(255.0)
    return value


class ScaleBytes(SingleAgentObservationPreprocessor):
    """Env-to-module connector: every ``uint8`` box of the observation to ``[0, 1]`` float32."""

    def recompute_output_observation_space(
        self, input_observation_space: gym.Space[Any], input_action_space: gym.Space[Any]
    ) -> gym.Space[Any]:
        """The input space with its ``uint8`` boxes scaled (:func:`scaled_space`)."""
        return scaled_space(input_observation_space)

    def preprocess(self, observation: Any, episode: Any) -> Any:
        """The observation with its ``uint8`` arrays scaled (:func:`scaled`)."""
        return scaled(observation, self.input_observation_space)


def env_to_module(env: Any = None, spaces: Any = None, device: Any = None) -> list[Any]:
    """The connector pieces (``config.env_runners(env_to_module_connector=...)``)."""
    return [ScaleBytes(), FlattenObservations()]
