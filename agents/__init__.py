"""Agents for StereoNav-v0: scripted baselines, the expected-cost planner and the PPO glue.

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
=============  ===============================================================================
"""

from __future__ import annotations

from typing import Any

from agents.base import Agent, is_look

__all__ = ["AGENT_NAMES", "Agent", "is_look", "make_agent"]

AGENT_NAMES = ("random", "greedy", "cautious", "planner", "oracle", "ppo:PATH", "rllib:PATH")


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
    if name == "random":
        from agents.baselines import RandomAgent

        agent: Agent = RandomAgent(**kwargs)
    elif name == "oracle":
        from agents.baselines import OracleAgent

        agent = OracleAgent(**kwargs)
    elif name in ("greedy", "cautious", "planner"):
        from agents.planning.navigator import ModelBasedAgent

        agent = ModelBasedAgent(name, **kwargs)
    elif name.startswith("ppo:") and len(name) > 4:
        from agents.learning.ppo import PPOAgent

        agent = PPOAgent(name[4:], **kwargs)
    elif name.startswith("rllib:") and len(name) > 6:
        from agents.learning.rllib.agent import RLlibAgent

        agent = RLlibAgent(name[6:], **kwargs)
    else:
        raise ValueError(f"unknown agent {name!r}; known: {list(AGENT_NAMES)}")
    agent.name = name
    agent.env = env
    return agent
