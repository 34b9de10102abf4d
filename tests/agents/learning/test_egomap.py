"""The learned agents' observation: legal information only, and what each channel shows."""

from __future__ import annotations

import json
import math
import pathlib
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.base import robot_pose
from agents.learning.egomap import (
    CHANNELS,
    MIRROR_ODD_FEATURES,
    STATE_FEATURES,
    EgoMap,
    EgoMapConfig,
    grid_cost_to_go,
    mirrored,
)
from agents.learning.wrappers import EgoMapObservation
from stereo_nav_env.sim.scenes import load_scenario
from stereo_nav_env.sim.scenes.map_io import scene_to_json

STEPS = 40
FOV_RAD = math.radians(70.0)  # wider than the camera's: a safety margin


def _box(cx: float, cy: float, half: float = 0.3) -> dict[str, Any]:
    square = [
        [cx - half, cy - half],
        [cx + half, cy - half],
        [cx + half, cy + half],
        [cx - half, cy + half],
    ]
    return {"kind": "box", "footprint": square, "height": 0.8, "color": [0.6, 0.3, 0.2]}


def _drive(path: pathlib.Path, perception: str, actions: list[Any] | None = None) -> Any:
    """Observations of an episode on the map at ``path``: the planner drives (``actions``
    None), or ``actions`` are replayed. Returns (observations, actions, head poses)."""
    env = EgoMapObservation(
        gym.make("StereoNav-v1", scenario=str(path), perception=perception, diagnostics=False)
    )
    planner = make_agent("planner")
    obs, info = env.reset(seed=5)
    planner.reset(env, seed=5)
    observations, sent, heads = [obs], [], []
    for t in range(STEPS if actions is None else len(actions)):
        u: Any = env.unwrapped
        heads.append((*robot_pose(env)[:2], float(u.head_pose.heading_rad)))
        action = planner.act(obs, info) if actions is None else actions[t]
        sent.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        observations.append(obs)
        if terminated or truncated:
            break
    env.close()
    return observations, sent, heads


def _outside_every_view(point: np.ndarray, heads: list[tuple[float, float, float]]) -> bool:
    for x, y, heading in heads:
        d = point - np.array([x, y])
        bearing = math.remainder(math.atan2(d[1], d[0]) - heading, 2 * math.pi)
        if abs(bearing) <= FOV_RAD or float(np.hypot(*d)) < 1.5:
            return False
    return True


@pytest.mark.parametrize("perception", ["surrogate", "stereo"])
def test_a_change_outside_everything_seen_leaves_the_observation_unchanged(
    tmp_path: pathlib.Path, perception: str
) -> None:
    scene = load_scenario("room", 11)
    base = scene_to_json(scene)
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps(base))
    first, actions, heads = _drive(plain, perception)
    # A box where no view of the episode ever looked (behind every camera pose, > 1.5 m away).
    xmin, ymin, xmax, ymax = scene.bounds
    candidates = [
        np.array([x, y])
        for x in np.arange(xmin + 0.6, xmax - 0.6, 0.25)
        for y in np.arange(ymin + 0.6, ymax - 0.6, 0.25)
    ]
    hidden = next(p for p in candidates if _outside_every_view(p, heads))
    changed = dict(base, obstacles=[*base["obstacles"], _box(*hidden)])
    path = tmp_path / "hidden.json"
    path.write_text(json.dumps(changed))
    second, _, _ = _drive(path, perception, actions)
    assert len(second) == len(first)
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a["map"], b["map"])
        np.testing.assert_array_equal(a["state"], b["state"])
    # The control: the same box in front of the robot's first view changes what it sees.
    x, y, heading = heads[0]
    ahead = np.array([x, y]) + 1.6 * np.array([math.cos(heading), math.sin(heading)])
    visible = dict(base, obstacles=[*base["obstacles"], _box(*ahead, half=0.25)])
    path = tmp_path / "visible.json"
    path.write_text(json.dumps(visible))
    third, _, _ = _drive(path, perception, actions[:1])
    assert not np.array_equal(third[0]["map"], first[0]["map"])


def test_the_observation_fits_its_space_and_every_channel_has_a_meaning() -> None:
    env = EgoMapObservation(gym.make("StereoNav-v1", scenario="office", perception="surrogate"))
    obs, _ = env.reset(seed=2)
    for _ in range(30):
        obs, *_ = env.step(np.array([0.6, 0.2, 0.5], np.float32))
        assert env.observation_space.contains(obs)
    assert obs["map"].shape == (len(CHANNELS), 64, 64)
    assert obs["state"].shape == (len(STATE_FEATURES),)
    assert (obs["map"][CHANNELS.index("seen")] == 255).any()  # it has seen floor
    assert (obs["map"][CHANNELS.index("outline")] == 255).any()
    env.close()


def test_the_goal_channel_and_bearing_follow_the_robot_frame() -> None:
    """Heading up: a goal straight ahead is above the centre, one to the left left of it."""
    env = EgoMapObservation(gym.make("StereoNav-v1", scenario="open", perception="surrogate"))
    obs, _ = env.reset(seed=0)
    u: Any = env.unwrapped
    x, y, heading = (float(v) for v in u.robot_pose)
    goal = np.asarray(u.scene.goal, float)
    fwd = math.cos(heading) * (goal[0] - x) + math.sin(heading) * (goal[1] - y)
    left = -math.sin(heading) * (goal[0] - x) + math.cos(heading) * (goal[1] - y)
    cfg = env.egomap.config
    state = obs["state"]
    bearing = math.atan2(left, fwd)
    assert state[1] == pytest.approx(math.cos(bearing), abs=1e-5)
    assert state[2] == pytest.approx(math.sin(bearing), abs=1e-5)
    if max(abs(fwd), abs(left)) < 0.5 * cfg.size_px * cfg.cell_m - 0.5:
        rows, cols = np.nonzero(obs["map"][CHANNELS.index("goal")])
        row = 0.5 * cfg.size_px - fwd / cfg.cell_m
        col = 0.5 * cfg.size_px - left / cfg.cell_m
        assert abs(rows.mean() + 0.5 - row) < 1.5 and abs(cols.mean() + 0.5 - col) < 1.5
    env.close()


def test_the_mirror_image_puts_the_goal_on_the_other_side() -> None:
    """In the mirror of an observation the goal's pixels and its bearing change side together,
    the robot's position is unchanged, and mirroring twice gives the observation back."""
    env = EgoMapObservation(gym.make("StereoNav-v1", scenario="open", perception="surrogate"))
    for seed in range(20):
        obs, _ = env.reset(seed=seed)
        goal = obs["map"][CHANNELS.index("goal")]
        if goal.any() and abs(float(obs["state"][2])) > 0.2:
            break
    else:
        pytest.fail("no start in 20 with the goal in the map and to one side")
    env.close()
    maps, states = mirrored(obs["map"][None], obs["state"][None])
    size = obs["map"].shape[-1]
    cols = np.nonzero(goal)[1].mean() + 0.5
    mirror_cols = np.nonzero(maps[0, CHANNELS.index("goal")])[1].mean() + 0.5
    assert mirror_cols == pytest.approx(size - cols)  # left m -> right m of the centre
    assert np.sign(mirror_cols - 0.5 * size) == -np.sign(cols - 0.5 * size)
    assert states[0, 2] == -obs["state"][2] and states[0, 1] == obs["state"][1]
    odd = [STATE_FEATURES.index(n) for n in MIRROR_ODD_FEATURES]
    even = [k for k in range(len(STATE_FEATURES)) if k not in odd]
    np.testing.assert_array_equal(states[0, odd], -obs["state"][odd])
    np.testing.assert_array_equal(states[0, even], obs["state"][even])
    again = mirrored(maps, states)
    np.testing.assert_array_equal(again[0][0], obs["map"])
    np.testing.assert_array_equal(again[1][0], obs["state"])
    with pytest.raises(ValueError, match="mirrored needs"):
        mirrored(obs["map"], obs["state"])


def test_cost_to_go_is_the_grid_distance_around_a_wall() -> None:
    free = np.ones((20, 30), bool)
    free[0:15, 15] = False  # a wall with a way round below it
    value = grid_cost_to_go(free, np.ones(free.shape), (5, 25), 0.1)
    assert value[5, 25] == 0.0
    assert value[5, 24] == pytest.approx(0.1)
    assert math.isfinite(value[5, 5]) and value[5, 5] > 2.0 + 0.5  # around the wall, not through
    walled = free.copy()
    walled[:, 15] = False
    assert math.isinf(grid_cost_to_go(walled, np.ones(free.shape), (5, 25), 0.1)[5, 5])


def test_bad_settings_are_named() -> None:
    with pytest.raises(ValueError, match="size_px"):
        EgoMapConfig(size_px=4)
    with pytest.raises(ValueError, match="cell_m"):
        EgoMapConfig(cell_m=-1.0)
    with pytest.raises(ValueError, match="goal_range_m"):
        EgoMapConfig(goal_range_m=True)
    with pytest.raises(ValueError, match="did you mean"):
        EgoMapConfig.from_dict({"size_pxx": 32})
    with pytest.raises(RuntimeError, match="before reset"):
        EgoMap().step(None, {}, np.zeros(3))
