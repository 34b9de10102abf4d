"""``rllib:PATH``: a policy saved by RLlib (``scripts/train.py --backend rllib``) as an agent.

``PATH`` is an RLlib checkpoint folder (``OUT/checkpoint`` of :func:`agents.learning.rllib.backend
.train_rllib`, or a periodic one under ``OUT/checkpoints``). Three of its components are restored,
as RLlib documents for inference without an ``Algorithm``:

* the policy: ``RLModule.from_checkpoint(PATH/learner_group/learner/rl_module/default_policy)``,
* the env-to-module connector pipeline (``PATH/env_runner/env_to_module_connector``): the
  observation preprocessing of training (``Dict`` to one vector) and the batching,
* the module-to-env connector pipeline (``PATH/env_runner/module_to_env_connector``): the action
  from the module's distribution inputs; with ``explore=False`` the greedy (mean) action.

The policy is a feed-forward MLP, so each step is one fresh single-step episode.

ray and torch are imported when the agent is built, never when ``agents`` is.
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import Agent

__all__ = ["MODULE_PATH", "RLlibAgent"]

MODULE_PATH = ("learner_group", "learner", "rl_module", "default_policy")
"""Where the policy's RLModule lies in a checkpoint folder."""


class RLlibAgent(Agent):
    """Acts with the RLModule of an RLlib checkpoint.

    Args:
        path: The checkpoint folder (``OUT/checkpoint``), or ``OUT`` itself.
        explore: Sample from the policy's action distribution instead of its mean.

    Raises:
        ValueError: When ``path`` holds no RLlib checkpoint.
    """

    name = "rllib"

    def __init__(self, path: str | pathlib.Path, *, explore: bool = False):
        super().__init__()
        from agents.learning.rllib.backend import CHECKPOINT_DIR

        p = pathlib.Path(path)
        if not (p / "rllib_checkpoint.json").is_file() and (p / CHECKPOINT_DIR).is_dir():
            p = p / CHECKPOINT_DIR
        if not (p / "rllib_checkpoint.json").is_file() or not p.joinpath(*MODULE_PATH).is_dir():
            raise ValueError(f"path must name an RLlib checkpoint folder, got {str(path)!r}")
        from ray.rllib.connectors.env_to_module import EnvToModulePipeline
        from ray.rllib.connectors.module_to_env import ModuleToEnvPipeline
        from ray.rllib.core.rl_module.rl_module import RLModule

        self.path = p
        self.explore = explore
        self.module = RLModule.from_checkpoint(str(p.joinpath(*MODULE_PATH)))
        self.env_to_module = EnvToModulePipeline.from_checkpoint(
            str(p / "env_runner" / "env_to_module_connector")
        )
        self.module_to_env = ModuleToEnvPipeline.from_checkpoint(
            str(p / "env_runner" / "module_to_env_connector")
        )

    @property
    def observation_space(self) -> Any:
        """The env's observation space the policy was trained on (the pipeline's input)."""
        return self.env_to_module.input_observation_space

    @property
    def action_space(self) -> Any:
        """The env's action space the policy was trained on."""
        return self.env_to_module.input_action_space

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        import torch
        from ray.rllib.core.columns import Columns
        from ray.rllib.env.single_agent_episode import SingleAgentEpisode

        episode = SingleAgentEpisode(
            observations=[obs],
            observation_space=self.observation_space,
            action_space=self.action_space,
        )
        shared: dict[str, Any] = {}
        batch = self.env_to_module(
            episodes=[episode], rl_module=self.module, explore=self.explore, shared_data=shared
        )
        with torch.no_grad():
            if self.explore:
                out = self.module.forward_exploration(batch)
            else:
                out = self.module.forward_inference(batch)
        to_env = self.module_to_env(
            batch=out,
            episodes=[episode],
            rl_module=self.module,
            explore=self.explore,
            shared_data=shared,
        )
        action = to_env.get(Columns.ACTIONS_FOR_ENV, to_env[Columns.ACTIONS])[0]
        return np.asarray(action, dtype=np.float32).reshape(3)
