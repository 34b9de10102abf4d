"""StereoNav-v0 and StereoNavDiscrete-v0: registration, API checkers, determinism, pickling,
vector envs, resource release, action validation, observation and info contents."""

from __future__ import annotations

import gc
import math
import os
import pickle
import warnings
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.model.records import EnvironmentModel
from stereo_nav_env.actions import DISCRETE_ACTIONS
from stereo_nav_env.config import REGION_FEATURES
from stereo_nav_env.env import StereoNavEnv
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.rewards import REWARD_COMPONENTS

SMALL: dict[str, Any] = {
    "width_px": 160,
    "height_px": 120,
    "focal_px": 130.0,
}  # the default field of view
TINY: dict[str, Any] = {"width_px": 64, "height_px": 48, "focal_px": 52.0}
IDS = sorted(
    env_id
    for env_id, spec in gym.registry.items()
    if isinstance(spec.entry_point, str) and spec.entry_point.startswith("stereo_nav_env")
)


def _u(env: gym.Env[Any, Any]) -> StereoNavEnv:
    """The :class:`StereoNavEnv` under ``env``'s wrappers."""
    base = env.unwrapped
    assert isinstance(base, StereoNavEnv)
    return base


@pytest.fixture(scope="module")
def continuous_env() -> Iterator[gym.Env]:
    env = gym.make("StereoNav-v0", diagnostics=False, **TINY)
    env.reset(seed=0)
    yield env
    env.close()


@pytest.fixture(scope="module")
def discrete_env() -> Iterator[gym.Env]:
    env = gym.make("StereoNavDiscrete-v0", diagnostics=False, **TINY)
    env.reset(seed=0)
    yield env
    env.close()


def test_both_ids_are_registered_with_string_entry_points_and_time_limits() -> None:
    assert IDS == ["StereoNav-v0", "StereoNav-v1", "StereoNavDiscrete-v0", "StereoNavDiscrete-v1"]
    for env_id in IDS:
        spec = gym.spec(env_id)
        assert isinstance(spec.entry_point, str) and spec.max_episode_steps == 500


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize(
    ("mode", "perception"), [("model", "stereo"), ("images", "stereo"), ("model", "surrogate")]
)
def test_gymnasium_and_sb3_checkers_pass_without_warnings(
    env_id: str, mode: str, perception: str
) -> None:
    env = gym.make(env_id, observation_mode=mode, perception=perception, **SMALL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(_u(env))  # also makes an rgb_array env from the spec and renders it
            sb3_check_env(_u(env))
    finally:
        env.close()


def test_checkers_pass_with_both_observation_kinds_and_rgb_array_rendering() -> None:
    env = gym.make("StereoNav-v0", observation_mode="both", render_mode="rgb_array", **SMALL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(_u(env))
            sb3_check_env(_u(env))
    finally:
        env.close()


def _equal(a: object, b: object) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b)
    return bool(a == b)


@pytest.mark.parametrize("perception", ["stereo", "surrogate"])
def test_same_seed_gives_identical_observations_rewards_and_infos_over_50_steps(
    perception: str,
) -> None:
    def rollout() -> list[tuple[Any, ...]]:
        env = gym.make("StereoNav-v0", scenario="random", perception=perception, **SMALL)
        obs, info = env.reset(seed=7)
        out: list[tuple[Any, ...]] = [
            (obs, info["diagnostics"], info["model"].probabilities.tolist(), info["scene"])
        ]
        rng = np.random.default_rng(3)
        for _ in range(50):
            action = rng.uniform(-1, 1, 3).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            out.append(
                (
                    obs,
                    reward,
                    terminated,
                    info["diagnostics"],
                    info["reward_components"],
                    info["model"].probabilities.tolist(),
                    info["model"],
                )
            )
            if terminated or truncated:
                obs, info = env.reset()
                out.append((obs, info["diagnostics"], info["scene"]))
        env.close()
        return out

    a, b = rollout(), rollout()
    assert len(a) == len(b) >= 51
    for x, y in zip(a, b, strict=True):
        assert len(x) == len(y) and all(_equal(u, v) for u, v in zip(x, y, strict=True))
    # the model changes as the robot moves: the comparison above is not vacuous
    assert len({x[0]["raster"].tobytes() for x in a}) > 10


def test_different_seeds_differ_through_pixel_noise() -> None:
    env = gym.make("StereoNav-v0", **SMALL)
    env.reset(seed=1)
    left1 = _u(env).render_stereo()[0]
    env.reset(seed=2)
    left2 = _u(env).render_stereo()[0]
    env.close()
    assert not np.array_equal(left1, left2)


@pytest.mark.parametrize("perception", ["stereo", "surrogate"])
def test_env_survives_a_pickle_round_trip_and_continues_identically(perception: str) -> None:
    env = gym.make("StereoNav-v0", perception=perception, **SMALL)
    env.reset(seed=5)
    env.step(np.array([1.0, 0.2, 0.5], np.float32))
    clone = pickle.loads(pickle.dumps(_u(env)))
    action = np.array([0.5, -0.3, -0.2], np.float32)
    obs_a, r_a, *_, info_a = _u(env).step(action)
    obs_b, r_b, *_, info_b = clone.step(action)
    assert _equal(obs_a, obs_b) and r_a == r_b
    assert info_a["model"] == info_b["model"]
    env.close()
    clone.close()


def test_async_vector_env_with_two_workers_runs_100_steps() -> None:
    # "spawn": each worker starts a fresh interpreter and makes its own OpenGL context on first
    # render (an EGL display inherited through fork is not safe to use); "module:id" imports
    # stereo_nav_env in the worker so that the id is registered there.
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make("stereo_nav_env:StereoNav-v0", **TINY)] * 2, context="spawn"
    )
    try:
        envs.action_space.seed(0)
        obs, infos = envs.reset(seed=[0, 1])
        assert obs["raster"].shape == (2, 64, 64, 3)
        for _ in range(100):
            obs, rewards, _, _, infos = envs.step(envs.action_space.sample())
            assert rewards.shape == (2,) and np.all(np.isfinite(rewards))
        assert isinstance(infos["model"][0], EnvironmentModel)
    finally:
        envs.close()


def _open_contexts() -> int:
    gc.collect()
    return sum(1 for o in gc.get_objects() if type(o) is StereoRenderer and o._renderer is not None)


def _offscreen_renderers() -> int:
    import pyrender

    gc.collect()
    return sum(1 for o in gc.get_objects() if type(o) is pyrender.OffscreenRenderer)


def test_50_create_step_close_cycles_leave_no_renderer_or_file_behind() -> None:
    def cycle() -> None:
        env = gym.make("StereoNav-v0", diagnostics=False, **TINY)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        assert _u(env).perception._renderer is not None
        env.close()
        assert _u(env).perception._renderer is None

    cycle()  # the first one loads the GL libraries
    # pyrender's close runs gc.collect(); freezing what exists now keeps that cheap, and the
    # counts below then see only what the cycles made
    gc.freeze()
    try:
        base_contexts, base_offscreen = _open_contexts(), _offscreen_renderers()
        base_fds = len(os.listdir("/proc/self/fd"))
        for _ in range(50):
            cycle()
        assert _open_contexts() == base_contexts == 0
        assert _offscreen_renderers() == base_offscreen == 0
        assert len(os.listdir("/proc/self/fd")) <= base_fds
    finally:
        gc.unfreeze()


@pytest.mark.parametrize(
    "action",
    [
        np.array([np.nan, 0.0, 0.0], np.float32),
        np.array([0.0, np.inf, 0.0]),
        np.zeros(2, np.float32),
        np.zeros((1, 3), np.float32),
        np.zeros(4),
        "forward",
    ],
)
def test_nan_infinite_or_wrongly_shaped_continuous_actions_are_value_errors(
    continuous_env: gym.Env[Any, Any], action: Any
) -> None:
    with pytest.raises(ValueError, match="action"):
        _u(continuous_env).step(action)


@pytest.mark.parametrize("action", [-1, 11, 2.0, True, np.array([1, 2]), np.float32(3.0)])
def test_invalid_discrete_actions_are_value_errors(
    discrete_env: gym.Env[Any, Any], action: Any
) -> None:
    with pytest.raises(ValueError, match="action"):
        _u(discrete_env).step(action)


def test_out_of_range_actions_are_clipped_to_the_box() -> None:
    def after(action: np.ndarray) -> tuple[float, ...]:
        env = gym.make("StereoNav-v0", diagnostics=False, **TINY)
        env.reset(seed=0)
        _, reward, *_ = _u(env).step(action)
        world = _u(env).world
        assert world is not None
        state = world.state
        env.close()
        return (state.x_m, state.y_m, state.heading_rad, state.pan_rad, reward)

    assert after(np.array([5.0, -7.0, 3.0], np.float32)) == after(
        np.array([1.0, -1.0, 1.0], np.float32)
    )


def test_discrete_macro_actions_move_and_look_as_tabled() -> None:
    env = gym.make("StereoNavDiscrete-v0", diagnostics=False, **TINY)
    assert env.action_space == gym.spaces.Discrete(len(DISCRETE_ACTIONS))
    env.reset(seed=0)
    world = _u(env).world
    assert world is not None
    x0 = world.state.x_m
    env.step(0)  # forward: 0.5 m/s for 0.1 s along +x (the default start faces +x)
    assert world.state.x_m - x0 == pytest.approx(0.05, abs=1e-6)
    env.step(np.int64(5))  # stop, look left: the head pans 9 degrees towards +45
    assert world.state.pan_rad == pytest.approx(math.radians(9.0))
    assert world.state.x_m - x0 == pytest.approx(0.05, abs=1e-6)
    env.close()


def test_observation_fields_hold_the_model_in_the_robot_frame() -> None:
    env = gym.make("StereoNav-v0", **SMALL)
    obs, info = env.reset(seed=0)
    model = info["model"]
    K, R, F = 8, 8, len(REGION_FEATURES)
    assert obs["goal"] == pytest.approx([7.0, 0.0, 7.0, 0.0], abs=1e-5)  # start (1,3,0), goal (8,3)
    assert obs["head_pan"] == pytest.approx([0.0])
    probs = model.probabilities[:K]
    np.testing.assert_allclose(obs["situation_probs"][: len(probs)], probs, rtol=1e-6)
    assert np.all(obs["situation_probs"][len(probs) :] == 0)
    table = obs["critical_regions"].reshape(K, R, F)
    regions = model.situations[0].critical_regions
    n = min(len(regions), R)
    assert np.all(table[0, :n, 0] == 1) and np.all(table[0, n:] == 0)
    assert np.all(np.diff(table[0, :n, 7]) >= 0)  # nearest first
    # the nearest region of the best situation, by hand: the robot is at (1, 3) facing +x
    nearest = min(regions, key=lambda r: np.hypot(*(r.narrowest.mean(axis=0) - [1.0, 3.0])))
    cx, cy = nearest.narrowest.mean(axis=0) - [1.0, 3.0]
    assert table[0, 0, 1:3] == pytest.approx([cx, cy], abs=1e-5)
    assert table[0, 0, 5] == pytest.approx(nearest.p_passable, abs=1e-6)
    assert obs["raster"].dtype == np.uint8 and obs["raster"].shape == (64, 64, 3)
    assert obs["raster"][..., 0].max() > 0  # obstacles ahead
    assert env.observation_space.contains(obs)
    env.close()


def test_info_holds_model_diagnostics_reward_components_success_and_collision() -> None:
    env = gym.make("StereoNav-v0")  # 320 x 240: the bookshelf's edges are ambiguous
    _, info = env.reset(seed=0)
    assert isinstance(info["model"], EnvironmentModel)
    for name in ("nees_mean", "coverage_95", "p_true_candidate"):
        assert name in info["diagnostics"]  # the start view has segments and ambiguous ones
    assert info["diagnostics"]["gaps_in_view"] >= 1
    _, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
    assert tuple(info["reward_components"]) == REWARD_COMPONENTS
    assert reward == pytest.approx(sum(info["reward_components"].values()))
    assert info["reward_components"]["progress"] == pytest.approx(0.05, abs=0.01)
    assert info["is_success"] is False and info["collision"] is False
    assert not terminated and not truncated
    env.close()


def test_driving_into_a_wall_is_a_terminating_collision() -> None:
    env = gym.make("StereoNav-v0", diagnostics=False, **TINY)
    env.reset(seed=0)  # start (1, 3) facing +x; the west wall's inner face is at x = 0.1
    for _ in range(30):
        _, _, terminated, _, info = env.step(np.array([-1.0, 0.0, 0.0], np.float32))
        if terminated:
            break
    assert terminated and info["collision"] and not info["is_success"]
    assert info["reward_components"]["collision"] == -10.0
    env.close()


def test_reaching_the_goal_is_success() -> None:
    env = gym.make("StereoNav-v0", diagnostics=False, goal_radius_m=0.5, **TINY)
    env.reset(seed=0)
    world = _u(env).world
    assert world is not None
    world.reset((7.42, 3.0, 0.0))  # 0.58 m before the goal, facing it
    _, _, terminated, _, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
    assert not terminated
    _, _, terminated, _, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
    assert terminated and info["is_success"] and info["reward_components"]["goal"] == 10.0
    env.close()


def test_images_mode_observes_the_noisy_pair_render_stereo_returns() -> None:
    env = gym.make("StereoNav-v0", observation_mode="images", pixel_noise_std=4.0, **SMALL)
    obs, _ = env.reset(seed=1)
    assert set(obs) == {"left", "right", "goal", "head_pan"}
    left, right = _u(env).render_stereo()
    assert np.array_equal(obs["left"], left) and np.array_equal(obs["right"], right)
    assert left.shape == (120, 160, 3) and left.dtype == np.uint8
    env.close()


def test_pixel_noise_comes_from_the_env_generator() -> None:
    clean = gym.make("StereoNav-v0", pixel_noise_std=0.0, **SMALL)
    noisy = gym.make("StereoNav-v0", pixel_noise_std=4.0, **SMALL)
    clean.reset(seed=1)
    noisy.reset(seed=1)
    a = _u(clean).render_stereo()[0].astype(float)
    b = _u(noisy).render_stereo()[0].astype(float)
    assert 3.7 < np.std(b - a) < 4.3
    assert (
        np.array_equal(b[..., 0] - a[..., 0], b[..., 1] - a[..., 1])
        or np.mean((b[..., 0] - a[..., 0]) == (b[..., 1] - a[..., 1])) > 0.99
    )  # one value per pixel (channels differ only where saturated)
    clean.close()
    noisy.close()


def test_rgb_array_render_is_a_frame_with_the_left_image_inset() -> None:
    env = gym.make("StereoNav-v0", render_mode="rgb_array", **SMALL)
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray)
    assert frame.shape == (480, 960, 3) and frame.dtype == np.uint8
    left = _u(env).render_stereo()[0]
    import cv2

    inset = cv2.resize(left, (320, 240), interpolation=cv2.INTER_AREA)
    assert np.array_equal(frame[:240, 640:], inset)
    env.close()
    plain = gym.make("StereoNav-v0", **TINY)
    plain.reset(seed=0)
    assert plain.render() is None
    plain.close()


def test_unknown_or_invalid_options_are_value_errors_naming_them() -> None:
    with pytest.raises(ValueError, match="bogus"):
        gym.make("StereoNav-v0", bogus=1)
    with pytest.raises(ValueError, match="scenario"):
        gym.make("StereoNav-v0", scenario="moon")
    with pytest.raises(ValueError, match="baseline_m"):
        gym.make("StereoNav-v0", baseline_m=-0.1)
    with pytest.raises(ValueError, match="observation_mode"):
        gym.make("StereoNav-v0", observation_mode="pixels")
    with pytest.raises(ValueError, match="num_regions"):
        gym.make("StereoNav-v0", num_regions=0)
    with pytest.raises(ValueError, match="goal_reward"):
        gym.make("StereoNav-v0", goal_reward=float("nan"))
    with pytest.raises(ValueError, match="render_mode"):
        StereoNavEnv(render_mode="ansi")


def test_unwrapped_exposes_rig_head_pose_and_ground_truth() -> None:
    env = gym.make("StereoNav-v0", **SMALL)
    env.reset(seed=0)
    u = _u(env)
    assert (u.rig.width_px, u.rig.height_px) == (160, 120)
    assert u.head_pose.heading_rad == 0.0 and u.head_pose.y_m == pytest.approx(3.06)
    fps = u.ground_truth_footprints()
    assert u.scene is not None
    assert len(fps) == len(u.scene.obstacles) and all(f.shape[1] == 2 for f in fps)
    env.close()
    env.close()  # idempotent


@pytest.mark.parametrize("env_id", [i for i in IDS if i.endswith("-v0")])  # v1: same spaces
def test_stable_baselines3_multi_input_policy_trains_on_the_observation(env_id: str) -> None:
    from stable_baselines3 import PPO

    env = gym.make(env_id, observation_mode="both", diagnostics=False, **TINY)
    try:
        agent = PPO("MultiInputPolicy", env, n_steps=16, batch_size=16, n_epochs=1, seed=0)
        agent.learn(total_timesteps=32)
        obs, _ = env.reset(seed=0)
        action, _ = agent.predict(obs, deterministic=True)
        assert env.action_space.contains(action)
    finally:
        env.close()


def test_the_camera_tilt_reaches_the_head_pose() -> None:
    level = gym.make("StereoNav-v0", diagnostics=False, **TINY)
    tilted = gym.make("StereoNav-v0", diagnostics=False, tilt_rad=0.3, **TINY)
    try:
        level.reset(seed=0)
        tilted.reset(seed=0)
        pose = tilted.unwrapped.head_pose
        assert pose.tilt_rad == 0.3 and level.unwrapped.head_pose.tilt_rad == 0.0
        assert (pose.x_m, pose.y_m) == pytest.approx(
            (level.unwrapped.head_pose.x_m, level.unwrapped.head_pose.y_m)
        )
        np.testing.assert_allclose(pose.R_cam2world[2, 2], -math.sin(0.3))  # looking down
    finally:
        level.close()
        tilted.close()


def test_ground_lines_add_floor_segments_on_the_true_outlines_of_a_room() -> None:
    """``ground_lines=True``: the model's ground-line segments lie on the true outlines (most of
    them within 0.15 m) and the model without them has none."""
    import shapely

    from modeling.stereo.ground_lines import GROUND_SOURCE

    found = {}
    for on in (False, True):
        env = gym.make("StereoNav-v1", scenario="room", ground_lines=on, diagnostics=False)
        env.reset(seed=1)
        outline = shapely.union_all(
            [shapely.Polygon(o.footprint).exterior for o in env.unwrapped.scene.obstacles]
        )
        segs = []
        for t in range(12):
            _, _, term, trunc, info = env.step(np.array([0.0, 0.6, 0.0], np.float32) * (t % 2))
            segs += [s for s in info["model"].observation.segments if s.source == GROUND_SOURCE]
            if term or trunc:
                break
        env.close()
        found[on] = [shapely.distance(shapely.points(s.endpoints), outline).max() for s in segs]
    assert found[False] == []
    assert len(found[True]) >= 5
    assert np.mean(np.array(found[True]) <= 0.15) >= 0.9
