"""The v1 ``"policy"`` observation: five raster channels, the blind band never seen at the start,
the floor seen earlier remembered, a contact flag, the previous action, a normalised goal."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.config import EnvConfig, ObservationConfig
from stereo_nav_env.observation.packing import policy_goal
from stereo_nav_env.observation.raster import (
    UNSEEN_VALUE,
    view_masks,
    visible_mask,
    world_to_raster,
)

SEEN_FREE, OCCLUDED, NEVER_SEEN = 2, 3, 4


def _v1(**kwargs: object) -> gym.Env:
    kw = {"scenario": "open", "perception": "surrogate", "memory": False, "diagnostics": False}
    return gym.make("StereoNav-v1", **(kw | kwargs))


def _ahead(raster: np.ndarray, metres: float, cfg: ObservationConfig) -> np.ndarray:
    """The raster's channels at the pixel ``metres`` straight ahead of the robot's centre."""
    size = cfg.raster_size_px
    centre = size / 2.0 - 0.5
    row = round(centre - metres / cfg.raster_cell_m)
    return raster[row, round(centre)]


def test_v1_observes_the_policy_keys_in_their_documented_ranges() -> None:
    env = _v1()
    obs, _ = env.reset(seed=3)
    assert set(obs) == {
        "raster",
        "situation_probs",
        "critical_regions",
        "goal",
        "head_pan",
        "contact",
        "prev_action",
    }
    space = env.observation_space
    assert space["raster"].shape == (64, 64, 5)
    for key in ("critical_regions", "goal", "head_pan", "contact", "prev_action"):
        assert space[key].low.min() >= -1.0 and space[key].high.max() <= 1.0, key
    assert space.contains(obs)
    np.testing.assert_array_equal(obs["prev_action"], np.zeros(3, np.float32))
    assert obs["contact"][0] == 0.0


def test_the_blind_band_is_never_seen_until_a_view_covered_it() -> None:
    env = _v1()
    cfg = env.unwrapped.config
    assert cfg.blind_range_m == pytest.approx(0.8 / math.tan(math.atan(120 / 260)))
    obs, _ = env.reset(seed=0)
    near, far = (
        _ahead(obs["raster"], 0.8, cfg.observation),
        _ahead(obs["raster"], 3.0, cfg.observation),
    )
    assert near[NEVER_SEEN] == 255 and near[SEEN_FREE] == 0  # in the blind band: never seen
    assert far[NEVER_SEEN] == 0 and far[SEEN_FREE] == 255  # in view, free: seen now
    start = env.unwrapped.robot_pose
    for _ in range(200):  # straight ahead at full speed until the floor 3 m out is 1.2 m out
        obs, *_ = env.step(np.array([1.0, 0.0, 0.0], np.float32))
        pose = env.unwrapped.robot_pose
        if math.hypot(pose[0] - start[0], pose[1] - start[1]) >= 1.8:
            break
    moved = math.hypot(pose[0] - start[0], pose[1] - start[1])
    assert moved >= 1.8
    then = _ahead(obs["raster"], 3.0 - moved, cfg.observation)
    assert then[SEEN_FREE] == 0  # in the blind band now: not seen by this view
    assert then[NEVER_SEEN] == 0  # but an earlier view saw it


def test_the_model_raster_counts_the_blind_band_as_unobserved() -> None:
    env = gym.make(
        "StereoNav-v0", scenario="open", perception="surrogate", memory=False, diagnostics=False
    )
    obs, _ = env.reset(seed=0)
    cfg = env.unwrapped.config.observation
    assert _ahead(obs["raster"], 0.8, cfg)[2] == UNSEEN_VALUE
    assert _ahead(obs["raster"], 3.0, cfg)[2] == 0


def test_contact_flag_and_previous_action_follow_the_steps() -> None:
    env = _v1(scenario="open")
    env.reset(seed=1)
    obs, *_ = env.step(np.array([2.0, -0.25, 0.5], np.float32))  # clipped to [-1, 1]
    np.testing.assert_array_equal(obs["prev_action"], np.array([1.0, -0.25, 0.5], np.float32))
    contacts = []
    for _ in range(400):  # the room's wall is a few metres away: drive until touching it
        obs, _, terminated, truncated, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
        contacts.append((obs["contact"][0], info["collision"]))
        if info["collision"] or terminated or truncated:
            break
    assert all(flag == float(hit) for flag, hit in contacts)
    assert contacts[-1] == (1.0, True) or terminated


def test_policy_goal_is_distance_over_range_with_the_bearing_as_cos_and_sin() -> None:
    goal = policy_goal((3.0, 4.0), (0.0, 0.0, 0.0), 10.0)
    np.testing.assert_allclose(goal, [0.5, 0.6, 0.8], atol=1e-6)
    far = policy_goal((-30.0, 0.0), (0.0, 0.0, 0.0), 10.0)
    np.testing.assert_allclose(far, [1.0, -1.0, 0.0], atol=1e-6)
    # either side of the bearing's +-pi cut the features are nearly equal
    a = policy_goal((-5.0, 1e-3), (0.0, 0.0, 0.0), 10.0)
    b = policy_goal((-5.0, -1e-3), (0.0, 0.0, 0.0), 10.0)
    assert np.max(np.abs(a - b)) < 1e-3


def test_set_scenario_changes_the_family_of_the_next_reset() -> None:
    env = _v1(scenario="open")
    env.reset(seed=0)
    env.unwrapped.set_scenario("sparse")
    _, info = env.reset(seed=0)
    assert info["scene"].startswith("sparse")
    with pytest.raises(ValueError, match="scenario"):
        env.unwrapped.set_scenario("nowhere")


def test_goal_range_must_be_positive() -> None:
    with pytest.raises(ValueError, match="goal_range_m"):
        EnvConfig.from_kwargs(goal_range_m=0.0)


def test_the_visible_mask_is_view_masks_visible_on_the_grid_and_the_raster() -> None:
    env = _v1(scenario="office")
    env.reset(seed=2)
    base = env.unwrapped
    occluded_views = 0
    for i in range(40):
        env.step(np.array([0.5, 0.3 * math.sin(i / 5.0), 0.8 * math.sin(i / 4.0)], np.float32))
        model, near = base.model, base.config.blind_range_m
        occluded_views += bool(model.occluded)
        grid = base._seen
        maps = [grid._grid_map, world_to_raster(base.robot_pose, base.config.observation)]
        for (A, b), shape in zip(maps, [grid.grid.shape, (64, 64)], strict=True):
            visible, _ = view_masks(model, A, b, shape, near)
            np.testing.assert_array_equal(visible_mask(model, A, b, shape, near), visible)
    assert occluded_views > 10
