"""The shipped learned policy: it loads from the package, acts, and reaches a goal."""

from __future__ import annotations

import json
import pathlib

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.evaluation.suite import SuiteConfig, suite_rules
from agents.learning.egomap import OBSERVATION_VERSION
from agents.learning.finetune import FinetuneConfig
from agents.learning.imitation import ImitationConfig
from agents.learning.learned import SHIPPED_POLICY, LearnedAgent


def test_the_shipped_policy_is_small_and_says_how_it_was_made() -> None:
    assert SHIPPED_POLICY.is_file()
    assert SHIPPED_POLICY.stat().st_size < 5 * 2**20
    meta = json.loads(SHIPPED_POLICY.with_suffix(".json").read_text())
    assert meta["observation_version"] == OBSERVATION_VERSION
    assert meta["rules"] == suite_rules(SuiteConfig())  # trained under the suite's rules
    assert meta["command"].startswith("python scripts/train.py --teacher planner")
    rounds = ImitationConfig(out_dir=pathlib.Path("x")).rounds  # the recipe's, as shipped
    assert meta["config"]["rounds"] == rounds
    assert [row["phase"] for row in meta["record"]] == [
        "demonstrations",
        *(f"dagger {k}" for k in range(1, rounds + 1)),
    ]
    recipe = ImitationConfig(out_dir=pathlib.Path("x")).to_dict()
    for key in (
        "demo_steps",
        "round_steps",
        "betas",
        "epochs",
        "bins",
        "width",
        "families",
        "mirror_share",
    ):
        assert meta["config"][key] == recipe[key], key
    # then the recipe's PPO fine-tuning, with its settings
    finetune = FinetuneConfig(out_dir=pathlib.Path("x"), policy=pathlib.Path("x")).to_dict()
    assert meta["finetune"]["steps"] >= finetune["timesteps"]
    for key in ("learning_rate", "clip_range", "target_kl", "n_steps", "critic_warmup_rollouts"):
        assert meta["finetune"]["config"][key] == finetune[key], key


def test_make_agent_learned_acts_on_a_fresh_env_deterministically() -> None:
    runs = []
    for _ in range(2):
        env = gym.make("StereoNav-v1", scenario="room")  # the rendered pair, stereo
        agent = make_agent("learned", env)
        assert isinstance(agent, LearnedAgent)
        obs, info = env.reset(seed=4)
        agent.reset(env, seed=4)
        actions = []
        for _ in range(8):
            action = agent.act(obs, info)
            assert action.shape == (3,) and action.dtype == np.float32
            assert np.all(np.abs(action) <= 1.0)
            actions.append(action)
            obs, *_, info = env.step(action)
        env.close()
        runs.append(np.array(actions))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[0][:, 0]).max() > 0.1  # it drives


@pytest.mark.parametrize("seed", [0, 1])
def test_the_shipped_policy_reaches_the_goal_of_an_open_scene(seed: int) -> None:
    env = gym.make("StereoNav-v1", scenario="open", perception="surrogate", diagnostics=False)
    agent = make_agent("learned", env)
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed=seed)
    for _ in range(500):
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        if terminated or truncated:
            break
    env.close()
    assert info["is_success"]


def test_the_fixed_head_variant_never_pans() -> None:
    env = gym.make("StereoNav-v1", scenario="office", perception="surrogate")
    agent = make_agent("learned-fixed-head", env)
    obs, info = env.reset(seed=2)
    agent.reset(env, seed=2)
    for _ in range(20):
        action = agent.act(obs, info)
        assert action[2] == 0.0
        obs, *_, info = env.step(action)
    assert agent.looks == 0
    env.close()
