"""The episode rules: v0 unchanged, v1 (collisions go on, small contact penalty), the stuck
truncation, the presets and the rules every result records."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.config import RULE_FIELDS, RULES, EnvConfig, RewardConfig
from stereo_nav_env.rewards import StuckTimer

TINY = {"width_px": 64, "height_px": 48, "focal_px": 52.0, "diagnostics": False}
# four steps forward-left, then backwards into the west wall of the default map (seed 3)
ACTIONS = [np.array([0.5, 0.5, 0.2], np.float32)] * 4 + [
    np.array([-1.0, -0.3, 0.0], np.float32)
] * 30
# the rewards of that rollout under StereoNav-v0 as it was before the v1 rules (commit 830a84b)
V0_REWARDS = [
    0.014769543991, 0.014161260391, 0.013404014587, 0.012502475251, -0.054457084807,
    -0.055620120869, -0.056681868846, -0.057639971392, -0.05849230128, -0.059236966123,
    -0.05987231258, -0.060396930022, -0.060809653667, -0.061109567167, -0.061296004636,
    -0.061368552139, -0.061327048601, -0.06117158617, -0.060902510012, -10.033821170171,
]  # fmt: skip
CONTACT_PROGRESS = -0.023821170171  # the progress term of the contact step


def _rollout(env_id: str, steps: int, **kwargs: object) -> list[tuple[float, bool, bool, dict]]:
    env = gym.make(env_id, **TINY, **kwargs)
    env.reset(seed=3)
    out = []
    try:
        for action in ACTIONS[:steps]:
            _, reward, terminated, truncated, info = env.step(action)
            out.append((reward, terminated, truncated, info))
            if terminated or truncated:
                break
    finally:
        env.close()
    return out


def test_v0_rewards_and_termination_are_unchanged_on_a_rollout_with_a_collision() -> None:
    steps = _rollout("StereoNav-v0", len(ACTIONS))
    assert [r for r, *_ in steps] == pytest.approx(V0_REWARDS, abs=1e-9)
    assert [info["collision"] for *_, info in steps] == [False] * 19 + [True]
    assert [t for _, t, _, _ in steps] == [False] * 19 + [True]  # the contact ends it
    assert not any(tr for _, _, tr, _ in steps)
    assert steps[-1][3]["reward_components"] == pytest.approx(
        {"goal": 0.0, "collision": -10.0, "time": -0.01, "progress": CONTACT_PROGRESS}
    )


def test_v1_goes_on_after_a_contact_and_charges_it_per_contact_step() -> None:
    steps = _rollout("StereoNav-v1", 24)
    assert len(steps) == 24 and not any(t or tr for _, t, tr, _ in steps)
    # the same physics: the steps before the contact pay as under v0
    assert [r for r, *_ in steps[:19]] == pytest.approx(V0_REWARDS[:19], abs=1e-9)
    contact = steps[19][3]
    assert contact["collision"] and contact["reward_components"] == pytest.approx(
        {"goal": 0.0, "collision": -0.1, "time": -0.01, "progress": CONTACT_PROGRESS}
    )
    for reward, _, _, info in steps[20:]:  # pushing on against the wall: a contact every step
        assert info["collision"] and info["reward_components"]["collision"] == -0.1
        assert reward == pytest.approx(sum(info["reward_components"].values()))


def test_the_discrete_v1_id_has_the_v1_rules_and_eleven_actions() -> None:
    env = gym.make("StereoNavDiscrete-v1", **TINY)
    try:
        assert env.unwrapped.config.rules_dict()["preset"] == "v1"
        assert env.action_space == gym.spaces.Discrete(11)
    finally:
        env.close()


def test_standing_still_is_truncated_after_stuck_steps() -> None:
    env = gym.make("StereoNav-v1", stuck_steps=5, stuck_progress_m=0.2, **TINY)
    env.reset(seed=0)
    flags = [env.step(np.zeros(3, np.float32))[3] for _ in range(5)]
    env.close()
    assert flags == [False, False, False, False, True]


def test_stuck_timer_counts_from_the_last_progress() -> None:
    timer = StuckTimer(window_steps=3, progress_m=0.5, reference_m=5.0)
    # 4.7 and 4.6 are not 0.5 m closer than 5.0; 4.4 is (the count restarts from 4.4)
    assert [timer.update(g) for g in (4.7, 4.6, 4.4, 4.3, 4.2)] == [False] * 5
    assert timer.reference_m == 4.4 and timer.steps == 2
    assert timer.update(4.5) is True  # moving away does not count as progress
    off = StuckTimer(window_steps=0, progress_m=0.5, reference_m=5.0)
    assert not any(off.update(5.0) for _ in range(1000))


def test_presets_set_the_rules_and_explicit_keywords_override_them() -> None:
    assert EnvConfig().rules_dict() == {"preset": "v0", **RULES["v0"]}
    v1 = EnvConfig.from_kwargs(rules="v1")
    assert v1.rules_dict() == {"preset": "v1", **RULES["v1"]}
    assert not v1.terminate_on_collision and v1.rewards.collision_penalty == 0.1
    assert gym.spec("StereoNav-v1").kwargs == {"rules": "v1", "observation_mode": "policy"}
    custom = EnvConfig.from_kwargs(rules="v1", collision_penalty=1.0, stuck_steps=50)
    assert custom.rules_dict()["preset"] == "custom"
    assert custom.rewards.collision_penalty == 1.0 and custom.stuck_steps == 50
    assert not custom.terminate_on_collision
    whole = EnvConfig.from_kwargs(rules="v1", rewards=RewardConfig(collision_penalty=3.0))
    assert whole.rewards.collision_penalty == 3.0  # a whole rewards keeps its own weights
    assert set(RULE_FIELDS) == set(RULES["v1"])
    assert next(iter(EnvConfig().rules_dict())) == "preset"


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"rules": "v9"}, "rules"),
        ({"stuck_steps": -1}, "stuck_steps"),
        ({"stuck_progress_m": 0.0}, "stuck_progress_m"),
    ],
)
def test_bad_rules_are_value_errors_naming_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        EnvConfig.from_kwargs(**kwargs)
