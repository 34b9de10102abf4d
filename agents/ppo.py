"""``ppo:PATH``: a stable-baselines3 PPO policy as an :class:`~agents.base.Agent`.

torch and stable-baselines3 are imported when the agent is built, never when ``agents`` is.
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import Agent

__all__ = ["PPOAgent"]


class PPOAgent(Agent):
    """Acts with a saved PPO model (``model.predict``).

    Args:
        path: The ``.zip`` written by ``PPO.save`` (the suffix may be left out).
        deterministic: Use the policy's mean action instead of sampling.
        device: torch device.

    Raises:
        ValueError: When no model file exists at ``path``.
    """

    name = "ppo"

    def __init__(
        self, path: str | pathlib.Path, *, deterministic: bool = True, device: str = "cpu"
    ):
        super().__init__()
        p = pathlib.Path(path)
        if not p.exists() and p.with_suffix(".zip").exists():
            p = p.with_suffix(".zip")
        if not p.is_file():
            raise ValueError(f"path must name a saved PPO model (.zip), got {str(path)!r}")
        from stable_baselines3 import PPO

        self.path = p
        self.deterministic = deterministic
        self.model = PPO.load(str(p), device=device)

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        action, _ = self.model.predict(obs, deterministic=self.deterministic)
        return np.asarray(action, dtype=np.float32).reshape(3)
