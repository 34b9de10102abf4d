"""Named reward components."""

from __future__ import annotations

import pytest

from stereo_nav_env.config import RewardConfig
from stereo_nav_env.rewards import REWARD_COMPONENTS, reward_components


def test_components_are_named_weighted_and_summable() -> None:
    w = RewardConfig(goal_reward=5.0, collision_penalty=2.0, time_penalty=0.1, progress_weight=3.0)
    c = reward_components(
        w, geodesic_before_m=4.0, geodesic_after_m=3.75, collided=False, reached_goal=False
    )
    assert tuple(c) == REWARD_COMPONENTS
    assert c == pytest.approx({"goal": 0.0, "collision": 0.0, "time": -0.1, "progress": 0.75})
    c = reward_components(
        w, geodesic_before_m=1.0, geodesic_after_m=1.2, collided=True, reached_goal=True
    )
    assert c == pytest.approx({"goal": 5.0, "collision": -2.0, "time": -0.1, "progress": -0.6})


def test_zero_weights_switch_components_off() -> None:
    w = RewardConfig(goal_reward=0.0, collision_penalty=0.0, time_penalty=0.0, progress_weight=0.0)
    c = reward_components(
        w, geodesic_before_m=2.0, geodesic_after_m=1.0, collided=True, reached_goal=True
    )
    assert sum(c.values()) == 0.0
