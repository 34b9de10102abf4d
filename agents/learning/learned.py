"""``learned``: a policy trained by imitation of the planner, as an :class:`~agents.base.Agent`.

``make_agent("learned", env)`` loads the policy shipped with the package
(:data:`SHIPPED_POLICY`, trained by the recipe of ``docs/training.md`` for one seed);
``make_agent("learned:PATH")`` loads the ``policy.pt`` that ``scripts/train.py --teacher planner``
wrote. ``learned-fixed-head`` (and ``learned-fixed-head:PATH``) is the same policy with the head
held straight ahead (pan 0): the looking report compares the two on the same episodes.

The agent builds the policy's observation itself (:class:`~agents.learning.egomap.EgoMap`) from
what every agent reads (``info``, the pose, the room outline and the goal), so it drives any
``StereoNav`` env, whatever its observation mode. torch is imported when the agent is built.
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import Agent
from agents.learning.egomap import EgoMap

__all__ = ["SHIPPED_POLICY", "FixedHeadLearnedAgent", "LearnedAgent"]

SHIPPED_POLICY = pathlib.Path(__file__).parent / "data" / "learned_policy.pt"
"""The policy shipped as package data (its metadata: rules, observation version, command and
training record; ``agents.learning.imitation.load_policy(SHIPPED_POLICY).meta``)."""


class LearnedAgent(Agent):
    """Acts with a policy of :func:`agents.learning.imitation.train_imitation`.

    Args:
        path: The ``policy.pt`` to load (default: :data:`SHIPPED_POLICY`).
        fixed_head: Hold the head straight ahead whatever the policy says.
        torch_threads: torch's threads (1: evaluation runs one agent per process).

    Raises:
        FileNotFoundError: When there is no policy at ``path``.
        ValueError: When it was trained on another observation version.
    """

    name = "learned"

    def __init__(
        self,
        path: str | pathlib.Path | None = None,
        *,
        fixed_head: bool = False,
        torch_threads: int = 1,
    ) -> None:
        import torch

        from agents.learning.imitation import load_policy

        super().__init__()
        torch.set_num_threads(torch_threads)
        self.path = pathlib.Path(path) if path else SHIPPED_POLICY
        self.policy = load_policy(self.path)
        self.egomap = EgoMap(self.policy.egomap)
        self.fixed_head = fixed_head
        self._sent: NDArray[np.float32] | None = None

    def _reset(self, seed: int | None) -> None:
        self._sent = None

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        if self._sent is None:
            own = self.egomap.reset(self.env, info)
        else:
            own = self.egomap.step(self.env, info, self._sent)
        action = self.policy.act(own["map"][None], own["state"][None])[0]
        if self.fixed_head:
            action[2] = 0.0
        self._sent = np.clip(action, -1.0, 1.0).astype(np.float32)
        return self._sent


class FixedHeadLearnedAgent(LearnedAgent):
    """:class:`LearnedAgent` with the head held straight ahead (``learned-fixed-head``)."""

    name = "learned-fixed-head"

    def __init__(self, path: str | pathlib.Path | None = None, **kwargs: Any) -> None:
        super().__init__(path, fixed_head=True, **kwargs)
