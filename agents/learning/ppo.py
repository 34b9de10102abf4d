"""``ppo:PATH``: a stable-baselines3 PPO (or sb3-contrib RecurrentPPO) policy as an
:class:`~agents.base.Agent`.

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
    """Acts with a saved PPO or RecurrentPPO model (``model.predict``; a recurrent policy's
    LSTM state is carried from step to step and cleared at every episode's start).

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
        from stable_baselines3.common.save_util import load_from_zip_file

        data, _, _ = load_from_zip_file(p, device=device, load_data=True)
        policy = (data or {}).get("policy_class")
        self.recurrent = "Recurrent" in getattr(policy, "__name__", "")
        if self.recurrent:
            from sb3_contrib import RecurrentPPO

            self.model: Any = RecurrentPPO.load(str(p), device=device)
        else:
            from stable_baselines3 import PPO

            self.model = PPO.load(str(p), device=device)
        self.path = p
        self.deterministic = deterministic
        self._state: Any = None
        self._start = np.ones((1,), dtype=bool)

    def _reset(self, seed: int | None) -> None:
        self._state, self._start = None, np.ones((1,), dtype=bool)

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        if self.recurrent:
            action, self._state = self.model.predict(
                obs, state=self._state, episode_start=self._start, deterministic=self.deterministic
            )
            self._start = np.zeros((1,), dtype=bool)
        else:
            action, _ = self.model.predict(obs, deterministic=self.deterministic)
        return np.asarray(action, dtype=np.float32).reshape(3)
