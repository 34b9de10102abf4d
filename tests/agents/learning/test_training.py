"""256-step smoke runs of PPO and RecurrentPPO: each trains, checkpoints, writes its curve and
summary, saves and loads as an agent; the curriculum advances on the rolling success rate."""

from __future__ import annotations

import csv
import json

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.learning.training import TrainConfig, train_ppo


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


@pytest.mark.parametrize("algo", ["ppo", "recurrent-ppo"])
def test_smoke_run_trains_saves_and_acts(tmp_path, small_map, algo: str) -> None:
    kwargs = _small_map_env(small_map)
    result = train_ppo(
        _tiny_run(
            tmp_path,
            small_map,
            algo=algo,
            timesteps=256,
            rollout_steps=64,
            n_epochs=1,
            net_arch=(32, 32),
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
    summary = json.loads((tmp_path / "ppo" / "summary.json").read_text())
    assert summary["algo"] == algo and summary["timesteps"] == 256
    assert summary["steps_per_s"] > 0 and summary["episodes"] == len(rows)

    env = gym.make("StereoNav-v1", **kwargs)
    obs, info = env.reset(seed=0)
    agent = make_agent(f"ppo:{result.model_path}", env)
    agent.reset(env, seed=0)
    action = agent.act(obs, info)
    env.close()
    assert action.shape == (3,) and np.all(np.abs(action) <= 1)
    assert agent.name == f"ppo:{result.model_path}"
    assert agent.recurrent == (algo == "recurrent-ppo")
    assert (agent._state is not None) == agent.recurrent  # the LSTM state carried on
    agent.reset(env, seed=0)
    assert agent._state is None


class _FakeVecEnv:
    """Records ``env_method`` calls (the curriculum's ``set_scenario``)."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, tuple[object, ...]]] = []

    def env_method(self, name: str, *args: object) -> None:
        self.calls.append((name, args))


class _FakeModel:
    def __init__(self, env: _FakeVecEnv) -> None:
        self.num_timesteps = 0
        self.logger = None
        self._env = env

    def get_env(self) -> _FakeVecEnv:
        return self._env


def test_the_curriculum_advances_when_the_rolling_success_rate_passes_the_bar(tmp_path) -> None:
    from agents.learning.training import _callbacks

    cfg = TrainConfig(
        timesteps=10,
        out_dir=tmp_path,
        curriculum=("open", "sparse", "room"),
        curriculum_threshold=0.75,
        curriculum_window=4,
    )
    assert cfg.gym_kwargs["scenario"] == "open" and cfg.env_config().scenario == "open"
    stages: list[dict[str, object]] = []
    train_env, eval_env = _FakeVecEnv(), _FakeVecEnv()
    (callback,) = [
        c for c in _callbacks(cfg, [], stages, eval_env) if "Curriculum" in type(c).__name__
    ]
    model = _FakeModel(train_env)
    callback.init_callback(model)
    callback.on_training_start({}, {})

    def episodes(*successes: bool) -> None:
        for ok in successes:
            model.num_timesteps += 10
            callback.update_locals({"infos": [{"episode": {"r": 0.0}, "is_success": ok}]})
            callback.on_step()

    episodes(True, True, False)  # 3 episodes: the window is not full yet
    assert train_env.calls == [] and len(stages) == 1
    episodes(False)  # 2 of 4 = 0.5 < 0.75
    episodes(True, True)  # the last 4: F, F, T, T = 0.5
    assert train_env.calls == []
    episodes(True)  # F, T, T, T = 0.75: advance
    assert train_env.calls == [("set_scenario", ("sparse",))] == eval_env.calls
    assert [s["scenario"] for s in stages] == ["open", "sparse"] and stages[1]["timesteps"] == 70
    episodes(True, True, True)  # a new stage starts with an empty window
    assert len(stages) == 2
    episodes(True)
    assert [s["scenario"] for s in stages] == ["open", "sparse", "room"]
    episodes(*[True] * 8)  # the last stage stays
    assert len(train_env.calls) == 2


def test_train_config_defaults_fit_this_machine(tmp_path) -> None:
    cfg = TrainConfig(timesteps=10, out_dir=tmp_path, n_envs=2)
    assert (cfg.n_steps, cfg.batch_size, cfg.n_epochs, cfg.ent_coef) == (1024, 256, 4, 0.01)
    assert cfg.net_arch == (128, 128) and cfg.normalize_reward and cfg.torch_threads == 1
    with pytest.raises(ValueError, match="algo"):
        TrainConfig(timesteps=10, out_dir=tmp_path, algo="dqn")
    with pytest.raises(ValueError, match="curriculum"):
        TrainConfig(timesteps=10, out_dir=tmp_path, curriculum=("open", "moon"))
    with pytest.raises(ValueError, match="curriculum_threshold"):
        TrainConfig(timesteps=10, out_dir=tmp_path, curriculum_threshold=0.0)


def test_train_config_rejects_bad_values(tmp_path) -> None:
    with pytest.raises(ValueError, match="timesteps must be a positive integer"):
        TrainConfig(timesteps=0, out_dir=tmp_path)
    with pytest.raises(ValueError, match="resume must name an existing checkpoint"):
        TrainConfig(timesteps=10, out_dir=tmp_path, resume=tmp_path / "missing.zip")
    with pytest.raises(ValueError, match="max_minutes must be a positive number"):
        TrainConfig(timesteps=10, out_dir=tmp_path, max_minutes=0)
    for field, value in (("ent_coef", True), ("ent_coef", -0.1), ("curriculum_threshold", True)):
        with pytest.raises(ValueError, match=field):
            TrainConfig(timesteps=10, out_dir=tmp_path, **{field: value})


def test_a_spent_time_budget_stops_training_and_still_saves(tmp_path, small_map) -> None:
    result = train_ppo(
        _tiny_run(
            tmp_path,
            small_map,
            timesteps=100_000,
            rollout_steps=32,
            eval_freq=0,
            checkpoint_freq=0,
            max_minutes=1e-6,
        )
    )
    assert result.timesteps < 32  # stopped within the first rollout, long before 100 000
    assert result.model_path.is_file() and result.curve_png.is_file()
