"""A 256-step PPO smoke run: it trains, checkpoints, writes its curve, saves, loads as an agent."""

from __future__ import annotations

import csv
import json

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.training import TrainConfig, train_ppo


def _small_map_env(small_map) -> dict[str, object]:
    """``gym.make`` keywords of the tests' small fixed map, with 50-step episodes."""
    return {"scenario": str(small_map), "diagnostics": False, "max_episode_steps": 50}


def _tiny_run(tmp_path, small_map, **config: object) -> TrainConfig:
    """A one-env training configuration on the small map writing under ``tmp_path / "ppo"``."""
    return TrainConfig(
        n_envs=1,
        out_dir=tmp_path / "ppo",
        batch_size=32,
        env_kwargs=_small_map_env(small_map),
        progress=False,
        **config,
    )


def test_ppo_smoke_run_trains_saves_and_acts(tmp_path, small_map) -> None:
    kwargs = _small_map_env(small_map)
    result = train_ppo(
        _tiny_run(
            tmp_path,
            small_map,
            timesteps=256,
            n_steps=64,
            n_epochs=1,
            eval_freq=128,
            eval_episodes=1,
            checkpoint_freq=128,
        )
    )
    assert result.model_path.is_file() and result.timesteps == 256
    rules = json.loads((tmp_path / "ppo" / "rules.json").read_text())
    assert rules["env_id"] == "StereoNav-v1" and rules["preset"] == "v1"
    assert rules["max_episode_steps"] == 50 and rules["terminate_on_collision"] is False
    assert sorted(p.name for p in (tmp_path / "ppo" / "checkpoints").iterdir()) == [
        "ppo_128_steps.zip",
        "ppo_256_steps.zip",
    ]
    assert (tmp_path / "ppo" / "eval" / "evaluations.npz").is_file()
    assert any((tmp_path / "ppo" / "tb").rglob("events.out.tfevents.*"))
    assert result.curve_png.is_file()
    with result.curve_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == result.episodes >= 256 // 50
    assert all(float(r["length"]) <= 50 for r in rows)

    env = gym.make("StereoNav-v1", **kwargs)
    obs, info = env.reset(seed=0)
    agent = make_agent(f"ppo:{result.model_path}", env)
    agent.reset(env, seed=0)
    action = agent.act(obs, info)
    env.close()
    assert action.shape == (3,) and np.all(np.abs(action) <= 1)
    assert agent.name == f"ppo:{result.model_path}"


def test_train_config_rejects_bad_values(tmp_path) -> None:
    with pytest.raises(ValueError, match="timesteps must be a positive integer"):
        TrainConfig(timesteps=0, out_dir=tmp_path)
    with pytest.raises(ValueError, match="resume must name an existing checkpoint"):
        TrainConfig(timesteps=10, out_dir=tmp_path, resume=tmp_path / "missing.zip")
    with pytest.raises(ValueError, match="max_minutes must be a positive number"):
        TrainConfig(timesteps=10, out_dir=tmp_path, max_minutes=0)


def test_a_spent_time_budget_stops_training_and_still_saves(tmp_path, small_map) -> None:
    result = train_ppo(
        _tiny_run(
            tmp_path,
            small_map,
            timesteps=100_000,
            n_steps=32,
            eval_freq=0,
            checkpoint_freq=0,
            max_minutes=1e-6,
        )
    )
    assert result.timesteps < 32  # stopped within the first rollout, long before 100 000
    assert result.model_path.is_file() and result.curve_png.is_file()
