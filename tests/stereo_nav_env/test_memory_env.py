"""The fused memory in the env: ``info["memory_model"]``, the ``memory`` observation modes and
their unknown channel, the ``memory_*`` diagnostics, contacts, a region narrowing on approach, a
bounded memory over a long episode."""

from __future__ import annotations

import json
import math
import pathlib
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import shapely
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.memory.fusion import ModelMemory
from modeling.model.records import EnvironmentModel
from modeling.stereo.rig import StereoRig
from stereo_nav_env.config import ObservationConfig
from stereo_nav_env.env import STAGES, StereoNavEnv
from stereo_nav_env.observation.packing import observation_space
from stereo_nav_env.observation.raster import UNKNOWN_VALUE, unknown_channel

SMALL: dict[str, Any] = {"width_px": 160, "height_px": 120, "focal_px": 130.0}
CFG = ObservationConfig()


def _u(env: gym.Env[Any, Any]) -> StereoNavEnv:
    base = env.unwrapped
    assert isinstance(base, StereoNavEnv)
    return base


def _map(tmp_path: pathlib.Path, name: str, obstacles: list[dict[str, Any]], **kw: Any) -> str:
    """A JSON map of a 10 m x 6 m room with ``obstacles`` inside; its path."""
    data = {
        "format": "stereo-nav-map/1",
        "name": name,
        "bounds": [0.0, 0.0, 10.0, 6.0],
        "start": kw.get("start", [1.0, 3.0, 0.0]),
        "goal": kw.get("goal", [9.0, 3.0]),
        "obstacles": [
            {"kind": "wall", "rect": {"center": [5.0, 0.05], "size": [10.0, 0.1], "yaw_deg": 0}},
            {"kind": "wall", "rect": {"center": [5.0, 5.95], "size": [10.0, 0.1], "yaw_deg": 0}},
            {"kind": "wall", "rect": {"center": [0.05, 3.0], "size": [5.8, 0.1], "yaw_deg": 90}},
            {"kind": "wall", "rect": {"center": [9.95, 3.0], "size": [5.8, 0.1], "yaw_deg": 90}},
            *obstacles,
        ],
    }
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    return str(path)


def _pixel(pose: tuple[float, float, float], forward_m: float, left_m: float) -> tuple[int, int]:
    """(row, column) of the raster pixel ``forward_m`` ahead and ``left_m`` left of the robot."""
    cell = CFG.raster_cell_m
    centre = CFG.raster_size_px / 2.0 - 0.5
    return round(centre - forward_m / cell), round(centre - left_m / cell)


# ---------------------------------------------------------------------------- the raster channel
def test_unknown_channel_is_255_outside_the_seen_floor_and_0_inside_it() -> None:
    pose = (2.0, 1.0, math.pi / 2)  # facing +y: forward is world +y, left is world -x
    seen = shapely.Point(2.0, 1.0).buffer(4.0).difference(shapely.Point(2.0, 1.0).buffer(1.5))
    out = unknown_channel(seen, pose, CFG)
    assert out.shape == (64, 64) and out.dtype == np.uint8
    assert out[_pixel(pose, 0.0, 0.0)] == UNKNOWN_VALUE  # the hole: the robot's own place
    assert out[_pixel(pose, 1.0, 0.5)] == UNKNOWN_VALUE
    for forward, left in ((3.0, 0.0), (-3.0, 0.0), (0.0, 2.0), (2.0, -2.0)):  # in the ring
        assert out[_pixel(pose, forward, left)] == 0, (forward, left)
    assert out[_pixel(pose, 4.6, 0.0)] == UNKNOWN_VALUE  # beyond it
    assert out[_pixel(pose, 3.5, 3.5)] == UNKNOWN_VALUE  # the raster's corner
    # the boundary's pixels count as unknown: at most the area, within a pixel of it
    area = np.count_nonzero(out == 0) * CFG.raster_cell_m**2
    assert seen.area - seen.length * CFG.raster_cell_m <= area <= seen.area
    assert np.all(unknown_channel(shapely.Polygon(), pose, CFG) == UNKNOWN_VALUE)


def test_memory_modes_declare_their_keys_and_keep_the_model_mode_unchanged() -> None:
    rig = StereoRig()
    model = observation_space(ObservationConfig(), rig)
    memory = observation_space(ObservationConfig(observation_mode="memory"), rig)
    both = observation_space(ObservationConfig(observation_mode="model_memory"), rig)
    assert set(model.spaces) == {
        "situation_probs",
        "critical_regions",
        "raster",
        "goal",
        "head_pan",
    }
    assert set(memory.spaces) == {
        "memory_situation_probs", "memory_critical_regions", "memory_raster", "goal", "head_pan",
    }  # fmt: skip
    assert set(both.spaces) == set(model.spaces) | set(memory.spaces)
    assert memory["memory_raster"].shape == (64, 64, 4)
    assert memory["memory_raster"].dtype == np.uint8
    assert memory["memory_critical_regions"] == model["critical_regions"]
    assert memory["memory_situation_probs"] == model["situation_probs"]


@pytest.mark.parametrize("env_id", ["StereoNav-v0", "StereoNavDiscrete-v0"])
@pytest.mark.parametrize("mode", ["memory", "model_memory"])
def test_gymnasium_and_sb3_checkers_pass_in_the_memory_modes(env_id: str, mode: str) -> None:
    env = gym.make(env_id, observation_mode=mode, **SMALL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(_u(env))
            sb3_check_env(_u(env))
    finally:
        env.close()


# ---------------------------------------------------------------------------- the env
def test_info_holds_the_memory_model_every_step_with_its_stages_and_diagnostics() -> None:
    env = gym.make("StereoNav-v0", scenario="two_gaps", memory=True, **SMALL)
    base = _u(env)
    try:
        _, info = env.reset(seed=0)
        infos = [info]
        for i in range(6):
            infos.append(env.step(np.array([0.6, 0.0, 0.5 * math.sin(i)], np.float32))[4])
        for info in infos:
            assert isinstance(info["memory_model"], EnvironmentModel)
            assert "memory_situations" in info["diagnostics"]
            assert "memory_endpoints" in info["diagnostics"]
        assert infos[-1]["memory_model"] is base.memory_model
        assert isinstance(base.memory, ModelMemory) and base.memory.views == len(infos)
        assert set(base.last_timings_ms) == set(STAGES)
        assert base.last_timings_ms["fusion"] > 0 and base.last_timings_ms["memory_model"] > 0
        # a new episode starts from an empty memory
        env.reset(seed=1)
        assert base.memory is not None and base.memory.views == 1
    finally:
        env.close()


def test_memory_false_skips_the_fusion_and_keeps_the_single_view_results() -> None:
    """``memory=False``: no fusion, no memory model, no ``memory_*`` diagnostics; the single-view
    observation, reward and diagnostics are those of the env with memory (same seed, actions)."""
    envs = [gym.make("StereoNav-v0", scenario="two_gaps", memory=m, **SMALL) for m in (True, False)]
    try:
        runs = []
        for env in envs:
            obs, info = env.reset(seed=3)
            steps = [(obs, 0.0, info)]
            for i in range(4):
                obs, reward, _, _, info = env.step(np.array([0.5, 0.2, 0.3 * i], np.float32))
                steps.append((obs, reward, info))
            runs.append(steps)
        for (obs_m, r_m, info_m), (obs_n, r_n, info_n) in zip(*runs, strict=True):
            assert info_n["memory_model"] is None and isinstance(
                info_m["memory_model"], EnvironmentModel
            )
            assert not any(k.startswith("memory_") for k in info_n["diagnostics"])
            assert info_n["diagnostics"] == {
                k: v for k, v in info_m["diagnostics"].items() if not k.startswith("memory_")
            }
            assert r_n == r_m and obs_m.keys() == obs_n.keys()
            for key in obs_m:
                np.testing.assert_array_equal(obs_m[key], obs_n[key])
        timings = _u(envs[1]).last_timings_ms
        assert "fusion" not in timings and "memory_model" not in timings
    finally:
        for env in envs:
            env.close()


def test_unknown_channel_covers_the_blind_band_at_reset_and_the_floor_behind(
    tmp_path: pathlib.Path,
) -> None:
    path = _map(tmp_path, "open", [])  # an empty room: nothing occludes the floor ahead
    env = gym.make("StereoNav-v0", scenario=path, observation_mode="memory", **SMALL)
    try:
        obs, _ = env.reset(seed=0)
        unknown = obs["memory_raster"][..., 3]
        pose = _u(env).robot_pose
        for forward in (0.0, 0.5, 1.0, 1.4):  # the blind band: below the image's lower edge
            assert unknown[_pixel(pose, forward, 0.0)] == UNKNOWN_VALUE, forward
        assert unknown[_pixel(pose, 3.5, 0.0)] == 0  # seen, ahead
        assert unknown[_pixel(pose, -1.0, 0.0)] == UNKNOWN_VALUE  # behind
        for _ in range(20):  # 1 m forward, looking ahead: the start's floor stays unseen
            obs, *_ = env.step(np.array([1.0, 0.0, 0.0], np.float32))
        pose = _u(env).robot_pose
        unknown = obs["memory_raster"][..., 3]
        assert unknown[_pixel(pose, -1.0, 0.0)] == UNKNOWN_VALUE  # the start, never in view
        assert unknown[_pixel(pose, 0.5, 0.0)] == UNKNOWN_VALUE  # still within the band
        assert unknown[_pixel(pose, 2.5, 0.0)] == 0
    finally:
        env.close()


def test_a_contact_enters_the_memory_as_an_obstacle(tmp_path: pathlib.Path) -> None:
    # a box 0.45 m ahead: its floor outline lies in the blind band, no view sees it
    box = {"kind": "box", "rect": {"center": [1.8, 3.0], "size": [0.2, 1.0], "yaw_deg": 0}}
    path = _map(tmp_path, "bump", [box])
    env = gym.make(
        "StereoNav-v0", scenario=path, terminate_on_collision=False, memory=True, **SMALL
    )
    base = _u(env)
    try:
        env.reset(seed=0)
        assert base.memory is not None and base.memory.contacts == ()
        for _ in range(30):
            *_, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
            if info["collision"]:
                break
        assert info["collision"]
        assert base.memory is not None and len(base.memory.contacts) >= 1
        contact = base.memory.contacts[0]
        assert np.allclose(contact.midpoint, [1.7, 3.0], atol=0.05)  # on the box's face
        ends = contact.endpoints  # across the normal (-1, 0): along the face
        assert np.allclose(ends[:, 0], 1.7, atol=0.01) and abs(ends[1, 1] - ends[0, 1]) > 0.1
        # the fused model has it as an obstacle in every situation
        for situation in info["memory_model"].situations:
            points = np.concatenate([ob.points for ob in situation.obstacles])
            near = points[np.hypot(*(points - [1.7, 3.0]).T) < 0.2]
            assert near.shape[0] >= 2 and np.allclose(near[:, 0], 1.7, atol=0.01)
    finally:
        env.close()


def _doorway_std(model: EnvironmentModel) -> float | None:
    """The least width std of the critical regions of the most probable situation whose narrowest
    relation's centre is near the gap's mouth (5.7, 3.0); ``None`` if there is none."""
    stds = [
        r.width_std_m
        for r in model.most_probable.critical_regions
        if np.hypot(*(r.narrowest.mean(axis=0) - [5.7, 3.0])) < 0.2
    ]
    return min(stds) if stds else None


def test_a_doubtful_gaps_width_std_narrows_as_the_robot_approaches(tmp_path: pathlib.Path) -> None:
    # two 0.6 m boxes with a gap of exactly the robot's width (0.5 m) between them, straight ahead
    boxes = [
        {"kind": "box", "rect": {"center": [6.0, 2.45], "size": [0.6, 0.6], "yaw_deg": 0}},
        {"kind": "box", "rect": {"center": [6.0, 3.55], "size": [0.6, 0.6], "yaw_deg": 0}},
    ]
    path = _map(tmp_path, "gap", boxes, start=[1.5, 3.0, 0.0])
    env = gym.make("StereoNav-v0", scenario=path, memory=True, **SMALL)
    try:
        env.reset(seed=0)
        first: float | None = None
        for _ in range(40):  # 2 m closer: from 4.2 m to 2.2 m before the boxes' faces
            *_, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
            first = first if first is not None else _doorway_std(info["memory_model"])
        last = _doorway_std(info["memory_model"])
        single = _doorway_std(info["model"])
        assert first is not None and last is not None and single is not None
        assert last < 0.5 * first
        assert last < single  # narrower than the latest view alone: the views are fused
    finally:
        env.close()


def test_the_memory_stays_bounded_over_500_steps() -> None:
    env = gym.make(
        "StereoNav-v0",
        scenario="two_gaps",
        terminate_on_collision=False,
        memory=True,
        diagnostics=False,
        max_episode_steps=600,
        **SMALL,
    )
    base = _u(env)
    try:
        env.reset(seed=0)
        sizes = []
        for i in range(500):  # a weave around the room, the head panning
            action = np.array([0.7, 0.8 * math.sin(i / 15.0), math.sin(i / 7.0)], np.float32)
            env.step(action)
            assert base.memory is not None
            sizes.append(len(base.memory.segments) + len(base.memory.ambiguous))
        assert base.memory is not None and base.memory.views == 501
        late = max(sizes[250:])
        assert late <= 2 * max(sizes[:250]) + 5
        assert len(base.memory.contacts) <= 64
    finally:
        env.close()
