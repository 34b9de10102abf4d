"""The agent interface, the registry, and every scripted agent on a small fixed map."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import AGENT_NAMES, Agent, is_look, make_agent
from agents.base import ControlLimits, control_limits, goal_xy, robot_pose, room_bounds


def _episode(name: str, scenario: str, max_steps: int) -> tuple[dict, int, Agent]:
    env = gym.make(
        "StereoNav-v0",
        scenario=scenario,
        terminate_on_collision=False,
        diagnostics=False,
        max_episode_steps=max_steps,
    )
    try:
        obs, info = env.reset(seed=0)
        agent = make_agent(name, env)
        agent.reset(env, seed=0)
        for steps in range(1, max_steps + 1):  # noqa: B007
            action = agent.act(obs, info)
            assert action.shape == (3,) and action.dtype == np.float32
            assert np.all(np.abs(action) <= 1.0)
            obs, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                break
    finally:
        env.close()
    return info, steps, agent


@pytest.mark.parametrize("name", ["oracle", "greedy", "cautious", "planner"])
def test_scripted_agent_reaches_the_goal_on_a_small_map(name: str, small_map) -> None:
    info, steps, agent = _episode(name, str(small_map), 260)
    assert info["is_success"], f"{name} did not reach the goal in {steps} steps"
    assert agent.steps == steps
    if name == "oracle":
        assert steps < 90  # about 3.9 m of route at 0.05 m a step, plus turning


def test_random_agent_completes_an_episode(small_map) -> None:
    info, steps, agent = _episode("random", str(small_map), 30)
    assert steps == 30 and not info["is_success"]
    assert 0 < agent.looks <= 30  # it pans its head at random


def test_registry_names_and_errors() -> None:
    assert set(AGENT_NAMES) == {
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
    }
    for name in ("random", "greedy", "cautious", "planner", "oracle", "learned"):
        agent = make_agent(name)
        assert isinstance(agent, Agent) and agent.name == name
    with pytest.raises(ValueError, match="unknown agent 'nope'"):
        make_agent("nope")
    with pytest.raises(ValueError, match="path must name a saved PPO model"):
        make_agent("ppo:/no/such/model.zip")
    with pytest.raises(FileNotFoundError, match="no trained policy"):
        make_agent("learned:/no/such/policy.pt")


def test_looks_are_counted_from_the_pan_target() -> None:
    assert not is_look(np.array([1.0, 0.0, 0.0]))
    assert not is_look(np.array([1.0, 0.5, 0.04]))
    assert is_look(np.array([0.0, 0.0, -0.3]))

    class Panning(Agent):
        def _act(self, obs, info):
            return np.array([0.0, 0.0, 0.5 if self.steps % 2 else 0.0])

    agent = Panning()
    agent.reset(None)
    for _ in range(6):
        agent.act({}, {})
    assert agent.steps == 6 and agent.looks == 3


def test_environment_access(small_map) -> None:
    env = gym.make(
        "StereoNav-v0",
        scenario=str(small_map),
        diagnostics=False,
        max_speed_m_s=0.4,
        goal_radius_m=0.25,
        focal_px=200.0,
    )
    env.reset(seed=0)
    try:
        assert robot_pose(env) == pytest.approx((0.8, 1.5, 0.0, 0.0))
        env.step(np.array([0.0, 0.0, 1.0], np.float32))
        assert robot_pose(env)[3] == pytest.approx(np.pi / 20)  # 9 degrees a step
        assert goal_xy(env) == pytest.approx([4.2, 1.5])
        assert room_bounds(env) == (0.0, 0.0, 5.0, 3.0)
        limits = control_limits(env)
        assert limits == ControlLimits(
            max_speed_m_s=0.4,
            max_turn_rate_rad_s=np.pi / 2,
            pan_limit_rad=np.pi / 2,
            max_pan_rate_rad_s=np.pi / 2,
            dt_s=0.1,
            robot_width_m=0.5,
            goal_radius_m=0.25,
            fov_rad=limits.fov_rad,
        )
        assert limits.fov_rad == pytest.approx(2 * np.arctan2(160, 200))
    finally:
        env.close()
