"""The first StereoNav-v0: registration, API checks, determinism, ground truth, noise, close."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import stereo_nav_env  # noqa: F401  (registers the ids)


def test_check_env_passes_without_warnings() -> None:
    env = gym.make("StereoNav-v0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
    assert env.spec is not None and env.spec.max_episode_steps == 500


def test_unwrapped_exposes_rig_head_pose_images_and_footprints() -> None:
    env = gym.make("StereoNav-v0", render_mode="rgb_array")
    obs, info = env.reset(seed=0)
    u = env.unwrapped
    assert obs["goal"] == pytest.approx([7.0, 0.0])
    assert u.head_pose.heading_rad == 0.0 and u.head_pose.y_m == pytest.approx(3.06)
    left, right = u.render_stereo()
    assert left.shape == right.shape == (u.rig.height_px, u.rig.width_px, 3)
    assert env.render().shape == (240, 640, 3)
    fps = u.ground_truth_footprints()
    assert len(fps) == len(u.scene.obstacles) and all(f.shape[1] == 2 for f in fps)
    obs, reward, terminated, _, info = env.step(np.array([1.0, 0.0, 1.0], np.float32))
    assert not terminated
    assert obs["head_pan"] == pytest.approx([0.1])  # 9 deg of 90 deg in one step
    assert info["reward_components"]["progress"] == pytest.approx(0.05)
    assert reward == pytest.approx(sum(info["reward_components"].values()))
    env.close()
    env.close()


def test_same_seed_same_rollout_for_generated_scenes() -> None:
    def rollout(seed: int) -> list:
        env = gym.make("StereoNav-v0", scenario="random", pixel_noise_std=3.0)
        obs, info = env.reset(seed=seed)
        out = [info["scene"], obs["goal"].tolist()]
        rng = np.random.default_rng(0)
        for _ in range(5):
            obs, reward, *_ = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
            out.append((obs["goal"].tolist(), reward))
        out.append(env.unwrapped.render_stereo()[0].tobytes())
        env.close()
        return out

    assert rollout(3) == rollout(3)
    assert rollout(3)[0] != rollout(4)[0]


def test_pixel_noise_comes_from_the_env_generator() -> None:
    clean = gym.make("StereoNav-v0")
    noisy = gym.make("StereoNav-v0", pixel_noise_std=4.0)
    clean.reset(seed=1)
    noisy.reset(seed=1)
    a = clean.unwrapped.render_stereo()[0].astype(float)
    b = noisy.unwrapped.render_stereo()[0].astype(float)
    assert 3.0 < np.std(b - a) < 5.0
    clean.close()
    noisy.close()


def test_unknown_or_bad_options_are_errors() -> None:
    with pytest.raises(ValueError, match="bogus"):
        gym.make("StereoNav-v0", bogus=1)
    with pytest.raises(ValueError, match="scenario"):
        gym.make("StereoNav-v0", scenario="moon")
    with pytest.raises(ValueError, match="baseline_m"):
        gym.make("StereoNav-v0", baseline_m=-0.1)
