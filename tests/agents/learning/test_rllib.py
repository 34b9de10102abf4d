"""A 256-step RLlib PPO smoke run on 2 env runners: it trains, checkpoints, logs, loads as an agent.

ray is installed by ``make test`` (the ``rllib`` extra): nothing here is skipped.
"""

from __future__ import annotations

import json
import os

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.learning.rllib.agent import MODULE_PATH, RLlibAgent
from agents.learning.rllib.backend import CHECKPOINT_DIR, RLlibOptions, train_rllib
from agents.learning.training import TrainConfig


def _flat(obs: dict[str, np.ndarray]) -> np.ndarray:
    """The documented flattening by hand: keys sorted, uint8 over 255, each array raveled."""
    parts = [
        obs[k].astype(np.float32).ravel() / (255.0 if obs[k].dtype == np.uint8 else 1.0)
        for k in sorted(obs)
    ]
    return np.concatenate(parts).astype(np.float32)


def test_rllib_smoke_run_trains_checkpoints_and_acts(tmp_path, small_map) -> None:
    import torch
    from ray.rllib.core.columns import Columns

    env_kwargs = {
        "scenario": str(small_map),
        "diagnostics": False,
        "memory": False,
        "max_episode_steps": 50,
    }
    cfg = TrainConfig(
        timesteps=256,
        out_dir=tmp_path / "rllib",
        rollout_steps=128,
        batch_size=64,
        n_epochs=1,
        net_arch=(16,),
        checkpoint_freq=128,
        env_kwargs=env_kwargs,
        progress=False,
    )
    result = train_rllib(cfg, RLlibOptions(num_env_runners=2, log_to_driver=False))

    # Two iterations of 2 runners x 64 steps, in two fresh processes with one torch thread each.
    assert result.timesteps == 256 and result.iterations == 2
    assert result.episodes >= 4  # 50-step episodes: each runner ends at least two in 128 steps
    assert len(set(result.runner_pids)) == 2 and os.getpid() not in result.runner_pids
    assert result.runner_torch_threads == (1, 1)
    out = tmp_path / "rllib"
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert [r["timesteps"] for r in rows] == [128.0, 256.0]
    assert all(r["steps_per_s"] > 0 for r in rows)
    rules = json.loads((out / "rules.json").read_text())
    assert rules["env_id"] == "StereoNav-v1" and rules["preset"] == "v1"
    assert rules["max_episode_steps"] == 50 and rules["terminate_on_collision"] is False
    assert any((out / "tb").rglob("events.out.tfevents.*"))
    assert [p.name for p in (out / "checkpoints").iterdir()] == ["iter_000001"]
    checkpoint = out / CHECKPOINT_DIR
    assert result.checkpoint == checkpoint and checkpoint.joinpath(*MODULE_PATH).is_dir()

    # The checkpoint acts on a real env, greedily: the clipped mean of the policy's Gaussian.
    agent = make_agent(f"rllib:{checkpoint}")
    assert isinstance(agent, RLlibAgent) and agent.name == f"rllib:{checkpoint}"
    env = gym.make("StereoNav-v1", **env_kwargs)
    try:
        obs, info = env.reset(seed=5)
        agent.reset(env, seed=0)
        for _ in range(4):
            action = agent.act(obs, info)
            assert action.dtype == np.float32 and env.action_space.contains(action)
            np.testing.assert_array_equal(agent.act(obs, info), action)  # deterministic
            with torch.no_grad():
                batch = {Columns.OBS: torch.from_numpy(_flat(obs))[None]}
                inputs = agent.module.forward_inference(batch)[Columns.ACTION_DIST_INPUTS]
            mean = np.clip(inputs.numpy()[0, :3], -1.0, 1.0)
            np.testing.assert_allclose(action, mean, rtol=1e-5, atol=1e-6)
            obs, _, terminated, truncated, info = env.step(action)
            assert not (terminated or truncated)
    finally:
        env.close()
    assert agent.steps == 8
