"""EnvConfig and its sub-configurations: keyword mapping, validation, derived values."""

from __future__ import annotations

import dataclasses
import math

import pytest

from stereo_nav_env.config import (
    CameraConfig,
    EnvConfig,
    ObservationConfig,
    ObservationMode,
    RewardConfig,
    WorldConfig,
)


def test_flat_keywords_reach_the_sub_configuration_that_owns_them() -> None:
    cfg = EnvConfig.from_kwargs(
        scenario="two_gaps", num_situations=4, goal_reward=3.0, pixel_noise_std=1.5
    )
    assert cfg.scenario == "two_gaps" and cfg.camera.pixel_noise_std == 1.5
    assert cfg.camera.tilt_rad == 0.0
    assert EnvConfig.from_kwargs(tilt_rad=0.3).camera.tilt_rad == 0.3
    assert cfg.observation.num_situations == 4 and cfg.observation.num_regions == 8
    assert cfg.rewards.goal_reward == 3.0 and cfg.rewards.time_penalty == 0.01


def test_whole_sub_configurations_are_accepted_and_flat_keys_override_them() -> None:
    cfg = EnvConfig.from_kwargs(
        observation={"num_regions": 3, "raster_size_px": 48}, raster_size_px=40
    )
    assert cfg.observation.num_regions == 3 and cfg.observation.raster_size_px == 40
    rewards = RewardConfig(progress_weight=2.0)
    assert EnvConfig.from_kwargs(rewards=rewards).rewards is not rewards
    assert EnvConfig.from_kwargs(rewards=rewards).rewards.progress_weight == 2.0


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"bogus": 1}, "bogus"),
        ({"observation": {"bogus": 1}}, "bogus"),
        ({"observation": 3}, "observation"),
        ({"world": {"bogus": 1}}, "bogus"),
        ({"camera": "wide"}, "camera"),
        ({"focal_px": 0.0}, "focal_px"),
        ({"scenario": "moon"}, "scenario"),
        ({"robot_width_m": 0.0}, "robot_width_m"),
        ({"baseline_m": -1.0}, "baseline_m"),
        ({"pixel_noise_std": -1.0}, "pixel_noise_std"),
        ({"tilt_rad": 1.6}, "tilt_rad"),
        ({"eps": 0.5}, "eps"),
        ({"width_px": 10}, "width_px"),
        ({"model_max_situations": 0}, "model_max_situations"),
        ({"diagnostics": 1}, "diagnostics"),
        ({"memory": "no"}, "memory"),
        ({"memory": False, "observation_mode": "memory"}, "memory"),
        ({"terminate_on_collision": "yes"}, "terminate_on_collision"),
        ({"observation_mode": "pixels"}, "observation_mode"),
        ({"num_situations": 0}, "num_situations"),
        ({"num_regions": 2.5}, "num_regions"),
        ({"raster_size_px": 32}, "raster_size_px"),
        ({"raster_half_extent_m": math.inf}, "raster_half_extent_m"),
        ({"collision_penalty": -1.0}, "collision_penalty"),
        ({"progress_weight": True}, "progress_weight"),
        ({"geodesic_cell_m": 0.0}, "geodesic_cell_m"),
        ({"max_speed_m_s": 100.0}, "substeps"),  # the world refuses tunnelling speeds
    ],
)
def test_unknown_or_invalid_values_are_value_errors_naming_them(
    kwargs: dict[str, object], name: str
) -> None:
    with pytest.raises(ValueError, match=name):
        EnvConfig.from_kwargs(**kwargs)


def test_a_misspelt_keyword_gets_a_suggestion() -> None:
    with pytest.raises(ValueError) as err:
        EnvConfig.from_kwargs(robot_widht_m=0.6)
    message = str(err.value)
    assert message.startswith(
        "unknown StereoNav option(s) ['robot_widht_m'] (did you mean 'robot_width_m'?); known: ["
    )
    assert "'tilt_rad'" in message  # the known names are still listed
    with pytest.raises(ValueError, match=r"\['tilt_rd'\] \(did you mean 'tilt_rad'\?\)"):
        EnvConfig.from_kwargs(camera={"tilt_rd": 0.1})
    with pytest.raises(ValueError) as err:
        EnvConfig.from_kwargs(zzz=1)
    assert "did you mean" not in str(err.value) and "['zzz']" in str(err.value)


def test_configs_are_frozen_slotted_and_keyword_only() -> None:
    cfg = EnvConfig()
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.scenario = "two_gaps"  # type: ignore[misc]
    classes: tuple[type, ...] = (
        EnvConfig,
        WorldConfig,
        CameraConfig,
        ObservationConfig,
        RewardConfig,
    )
    for cls in classes:
        assert hasattr(cls, "__slots__")
        with pytest.raises(TypeError):
            cls(1)


def test_derived_values_are_properties() -> None:
    cfg = EnvConfig.from_kwargs(width_px=160, height_px=120, focal_px=130.0, robot_width_m=0.6)
    assert (cfg.rig.width_px, cfg.rig.height_px, cfg.rig.focal_px) == (160, 120, 130.0)
    assert cfg.rig.baseline_m == cfg.camera.baseline_m == 0.12
    assert cfg.world.robot_width_m == 0.6 and cfg.world.robot_radius_m == 0.3
    assert cfg.observation.raster_cell_m == pytest.approx(10.0 / 64)
    assert cfg.observation.num_features == 12
    assert not cfg.is_generated and EnvConfig(scenario="office").is_generated
    names = {f.name for f in dataclasses.fields(EnvConfig)}
    assert names == {
        "scenario",
        "goal_radius_m",
        "terminate_on_collision",
        "stuck_steps",
        "stuck_progress_m",
        "eps",
        "model_max_situations",
        "close_faces",
        "ground_lines",
        "surface_detail",
        "perception",
        "memory",
        "diagnostics",
        "info_models",
        "world",
        "camera",
        "observation",
        "rewards",
    }


def test_each_value_has_one_home_and_whole_sub_configurations_nest() -> None:
    world = WorldConfig(max_speed_m_s=0.4)
    cfg = EnvConfig.from_kwargs(world=world, dt_s=0.05, camera={"width_px": 160}, height_px=120)
    assert cfg.world.max_speed_m_s == 0.4 and cfg.world.dt_s == 0.05
    assert (cfg.camera.width_px, cfg.camera.height_px) == (160, 120)
    assert (cfg.rig.width_px, cfg.rig.height_px) == (160, 120)
    leaves = [
        f.name
        for sub in (WorldConfig, CameraConfig, ObservationConfig, RewardConfig, EnvConfig)
        for f in dataclasses.fields(sub)
        if f.name not in ("world", "camera", "observation", "rewards")
    ]
    assert len(leaves) == len(set(leaves))  # flat keywords are unambiguous


def test_observation_mode_is_an_enum_that_accepts_its_strings() -> None:
    for text, mode in (("model", ObservationMode.MODEL), ("images", ObservationMode.IMAGES)):
        cfg = ObservationConfig(observation_mode=text)  # type: ignore[arg-type]
        assert cfg.observation_mode is mode and cfg.observation_mode == text
    both = EnvConfig.from_kwargs(observation_mode=ObservationMode.BOTH).observation
    assert both.has_model and both.has_images
    images = EnvConfig.from_kwargs(observation_mode="images").observation
    assert images.has_images and not images.has_model
