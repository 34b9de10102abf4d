"""Agents for the StereoNav environments: scripted baselines, the expected-cost planner, learners.

``make_agent(name, env)`` builds an agent by its registry name (ARCHITECTURE.md):

=============  ===============================================================================
``random``     smoothed uniform random actions (the floor)
``greedy``     most probable situation, undecided critical regions taken as passable
``cautious``   most probable situation, undecided critical regions taken as impassable
``planner``    expected cost over situations, with looking / approaching by value of information
``oracle``     shortest route on the true obstacle outlines (the ceiling)
``ppo:PATH``   a stable-baselines3 PPO model saved at ``PATH`` (torch imported only then)
``rllib:PATH`` an RLlib checkpoint folder at ``PATH`` (``train.py --backend rllib``; ray
               imported only then)
``learned``    the policy shipped with the package, trained by imitation of the planner
               (``docs/training.md``; torch imported only then); ``learned:PATH`` a
               ``policy.pt`` of ``train.py --teacher planner``; ``learned-fixed-head`` (and
               ``learned-fixed-head:PATH``) the same with the head held straight ahead
=============  ===============================================================================

The package: :mod:`.base` (the :class:`Agent` interface and what agents read from the env),
:mod:`.baselines` (``random``, ``oracle``), :mod:`agents.planning` (the model-based agents),
:mod:`agents.learning` (training and the agents of trained policies) and
:mod:`agents.evaluation` (the suite, the demo and the measuring tools).
"""

from __future__ import annotations

import importlib
from typing import Any

from agents.base import Agent, is_look

__all__ = ["AGENT_NAMES", "Agent", "is_look", "make_agent"]

AGENT_NAMES = (
    "random",
    "greedy",
    "cautious",
    "planner",
    "oracle",
    "learned",
    "learned-fixed-head",
    "learned:PATH",
    "learned-fixed-head:PATH",
    "ppo:PATH",
    "rllib:PATH",
)

_REGISTRY: dict[str, tuple[str, str, bool]] = {
    "random": ("agents.baselines", "RandomAgent", False),
    "oracle": ("agents.baselines", "OracleAgent", False),
    "greedy": ("agents.planning.navigator", "ModelBasedAgent", True),
    "cautious": ("agents.planning.navigator", "ModelBasedAgent", True),
    "planner": ("agents.planning.navigator", "ModelBasedAgent", True),
    "ppo:": ("agents.learning.ppo", "PPOAgent", True),
    "rllib:": ("agents.learning.rllib.agent", "RLlibAgent", True),
    "learned": ("agents.learning.learned", "LearnedAgent", False),
    "learned:": ("agents.learning.learned", "LearnedAgent", True),
    "learned-fixed-head": ("agents.learning.learned", "FixedHeadLearnedAgent", False),
    "learned-fixed-head:": ("agents.learning.learned", "FixedHeadLearnedAgent", True),
}
"""Name (or ``prefix:``) -> (module, class, whether the class takes the name's argument first:
the policy for the model-based agents, the path for the trained ones). Modules are imported on
use, so that torch and ray load only for the agents that need them."""


def make_agent(name: str, env: Any = None, **kwargs: Any) -> Agent:
    """The agent called ``name`` (see the module docstring).

    Args:
        name: A registry name.
        env: The environment it will drive (optional here: :meth:`Agent.reset` takes it too).
        **kwargs: Passed to the agent's constructor.

    Raises:
        ValueError: For an unknown name (the message lists the known ones).
    """
    if not isinstance(name, str):
        raise ValueError(f"name must be a string, got {name!r}")
    key, argument = name, name
    if ":" in name:
        prefix, argument = name.split(":", 1)
        key = prefix + ":" if argument else name
    if key not in _REGISTRY:
        raise ValueError(f"unknown agent {name!r}; known: {list(AGENT_NAMES)}")
    module, cls_name, takes_argument = _REGISTRY[key]
    cls = getattr(importlib.import_module(module), cls_name)
    agent: Agent = cls(argument, **kwargs) if takes_argument else cls(**kwargs)
    agent.name = name
    agent.env = env
    return agent
