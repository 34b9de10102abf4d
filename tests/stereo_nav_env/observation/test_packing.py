"""Observation packing and the egocentric raster, on hand-made models with known geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.geometry import to_robot_frame
from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from modeling.stereo.rig import StereoRig
from stereo_nav_env.config import REGION_FEATURES, ObservationConfig, ObservationMode
from stereo_nav_env.observation.packing import goal_features, observation_space, pack_model
from stereo_nav_env.observation.raster import UNSEEN_VALUE, rasterize_model, world_to_raster

SIGMA = 0.03
COV = np.tile(np.diag([SIGMA**2, SIGMA**2]), (2, 1, 1))


def _seg(a: tuple[float, float], b: tuple[float, float]) -> FloorSegment:
    return FloorSegment(endpoints=np.array([a, b], dtype=float), cov=COV)


@pytest.fixture(scope="module")
def gap_model() -> EnvironmentModel:
    """Two collinear wall pieces at x = 2 m with a 0.55 m gap (undecided for a 0.5 m robot)."""
    obs = FloorObservation(
        segments=(_seg((2.0, 0.3), (2.0, 1.3)), _seg((2.0, -0.25), (2.0, -1.25))),
        viewpoint=np.zeros(3),
    )
    return build_model(obs, 0.5)


def test_to_robot_frame_rotates_and_translates() -> None:
    pts = np.array([[2.0, 0.025], [1.0, 1.0]])
    np.testing.assert_allclose(to_robot_frame(pts, (0.0, 0.0, 0.0)), pts)
    np.testing.assert_allclose(
        to_robot_frame(pts, (0.0, 0.0, math.pi / 2)), [[0.025, -2.0], [1.0, -1.0]], atol=1e-12
    )
    np.testing.assert_allclose(
        to_robot_frame(pts, (1.0, 1.0, math.pi)), [[-1.0, 0.975], [0.0, 0.0]]
    )


def test_goal_features_are_position_distance_and_bearing_in_the_robot_frame() -> None:
    g = goal_features((8.0, 3.0), (1.0, 3.0, 0.0))
    assert g.dtype == np.float32 and g.tolist() == pytest.approx([7.0, 0.0, 7.0, 0.0])
    g = goal_features((1.0, 5.0), (1.0, 3.0, 0.0))  # 2 m to the left
    assert g.tolist() == pytest.approx([0.0, 2.0, 2.0, math.pi / 2], abs=1e-6)
    g = goal_features((0.0, 3.0), (1.0, 3.0, math.pi))  # straight ahead after turning round
    assert g.tolist() == pytest.approx([1.0, 0.0, 1.0, 0.0], abs=1e-6)


def test_region_features_match_the_critical_region_exactly(gap_model: EnvironmentModel) -> None:
    cfg = ObservationConfig(num_situations=2, num_regions=3)
    (region,) = gap_model.situations[0].critical_regions
    pose = (0.0, 0.0, math.pi / 2)  # facing +y: the region lies to the right
    packed = pack_model(gap_model, pose, cfg)
    table = packed["critical_regions"].reshape(2, 3, len(REGION_FEATURES))
    row = dict(zip(REGION_FEATURES, table[0, 0].tolist(), strict=True))
    centre = region.narrowest.mean(axis=0)  # (2.0, 0.025)
    p = region.p_passable
    assert 0.05 < p < 0.95  # undecided
    expected = {
        "valid": 1.0,
        "x_m": centre[1],
        "y_m": -centre[0],
        "width_mean_m": region.width_mean_m,
        "width_std_m": region.width_std_m,
        "p_passable": p,
        "doubt": 4 * p * (1 - p),
        "distance_m": math.hypot(*centre),
        "bearing_rad": math.atan2(-centre[0], centre[1]),
        "axis_x": 0.0,
        "axis_y": 0.0,
        "radius_m": float(np.max(np.hypot(*(region.polygon - centre).T))),
    }
    across = to_robot_frame(region.narrowest, pose)
    expected["axis_x"], expected["axis_y"] = (across[1] - across[0]) / 0.55
    assert row == pytest.approx(expected, abs=1e-5)
    assert np.all(table[0, 1:] == 0) and np.all(table[1] == 0)  # padding
    assert packed["situation_probs"].tolist() == [1.0, 0.0]


def test_regions_are_sorted_nearest_first_and_cut_at_r() -> None:
    # four pieces along x = 2 with three 0.55 m gaps at y = 0.3, 1.55, 2.8 (nearest to the robot
    # at the origin: the first)
    ys = [(-1.25, -0.25), (0.3, 1.0), (1.55, 2.25), (2.8, 3.5)]
    obs = FloorObservation(
        segments=tuple(_seg((2.0, a), (2.0, b)) for a, b in ys), viewpoint=np.zeros(3)
    )
    model = build_model(obs, 0.5)
    assert len(model.situations[0].critical_regions) == 3
    cfg = ObservationConfig(num_situations=1, num_regions=2)
    table = pack_model(model, (0.0, 0.0, 0.0), cfg)["critical_regions"].reshape(1, 2, -1)
    assert table[0, :, 2].tolist() == pytest.approx([0.025, 1.275], abs=1e-6)  # y of centres


def test_situation_probs_follow_the_models_situations() -> None:
    far = _seg((4.0, -1.0), (4.0, 1.0))
    amb = AmbiguousSegment(
        candidates=(_seg((2.0, 0.3), (2.0, 1.3)), _seg((3.0, 0.3), (3.0, 1.3))),
        probabilities=(0.7, 0.3),
    )
    obs = FloorObservation(
        segments=(_seg((2.0, -0.25), (2.0, -1.25)), far), ambiguous=(amb,), viewpoint=np.zeros(3)
    )
    model = build_model(obs, 0.5)
    probs = pack_model(model, (0.0, 0.0, 0.0), ObservationConfig(num_situations=4))[
        "situation_probs"
    ]
    expected = np.zeros(4)
    expected[: len(model.situations)] = model.probabilities
    np.testing.assert_allclose(probs, expected, rtol=1e-6)
    assert len(model.situations) == 2 and probs[0] == pytest.approx(0.7)


def test_raster_channels_show_obstacles_doubt_and_unobserved_area(
    gap_model: EnvironmentModel,
) -> None:
    cfg = ObservationConfig()  # 64 px over +-5 m: 0.15625 m per pixel, robot at (31.5, 31.5)
    raster = rasterize_model(gap_model, (0.0, 0.0, 0.0), cfg)
    assert raster.shape == (64, 64, 3) and raster.dtype == np.uint8
    occ, doubt, unseen = np.moveaxis(raster, -1, 0)
    # the wall pieces at x = 2 m (forward) lie on row 31.5 - 2 / 0.15625 = 18.7
    rows = np.flatnonzero(occ.max(axis=1))
    assert set(rows.tolist()) <= {17, 18, 19, 20} and occ[18:20, 26].max() > 100
    assert occ[40:].max() == 0  # nothing behind the robot
    # the critical region (the gap between them, around column 31.3) at 255 * 4 p (1 - p)
    p = gap_model.situations[0].critical_regions[0].p_passable
    assert doubt[19, 31] == round(255 * 4 * p * (1 - p))
    assert doubt[19, 10] == 0 and doubt[40, 31] == 0
    # seen floor between the robot and the wall, occluded behind the wall, unseen behind the robot
    assert unseen[25, 32] == 0 and unseen[5, 26] == 255 and unseen[60, 32] == UNSEEN_VALUE


def test_raster_rotates_with_the_robot(gap_model: EnvironmentModel) -> None:
    cfg = ObservationConfig()
    ahead = np.moveaxis(rasterize_model(gap_model, (0.0, 0.0, 0.0), cfg), -1, 0)
    # facing -y, the wall at x = 2 is on the robot's left: the raster turns by 90 degrees
    left = np.moveaxis(rasterize_model(gap_model, (0.0, 0.0, -math.pi / 2), cfg), -1, 0)
    turned = np.rot90(ahead[:2], k=1, axes=(1, 2)).astype(int)
    diff = np.abs(turned - left[:2])
    assert diff.max() <= 16 and np.count_nonzero(diff) <= 40  # anti-aliasing is not symmetric
    assert abs(int(left[0].sum()) - int(ahead[0].sum())) <= 0.01 * int(ahead[0].sum())


def test_world_to_raster_puts_the_robot_in_the_centre_and_forward_up() -> None:
    cfg = ObservationConfig(raster_size_px=64, raster_half_extent_m=5.0)
    A, b = world_to_raster((1.0, 2.0, 0.3), cfg)
    assert (np.array([1.0, 2.0]) @ A.T + b).tolist() == pytest.approx([31.5, 31.5])
    ahead = np.array([1.0 + math.cos(0.3), 2.0 + math.sin(0.3)])
    assert (ahead @ A.T + b).tolist() == pytest.approx([31.5, 31.5 - 6.4])


def test_observation_space_holds_packed_observations_and_the_mode_keys(
    gap_model: EnvironmentModel,
) -> None:
    rig = StereoRig()
    cfg = ObservationConfig(observation_mode=ObservationMode.BOTH, num_situations=3, num_regions=2)
    space = observation_space(cfg, rig)
    assert set(space.spaces) == {
        "situation_probs",
        "critical_regions",
        "raster",
        "goal",
        "head_pan",
        "left",
        "right",
    }
    assert space["critical_regions"].shape == (3 * 2 * len(REGION_FEATURES),)
    assert space["left"].shape == (240, 320, 3) and space["raster"].shape == (64, 64, 3)
    obs = pack_model(gap_model, (0.0, 0.0, 0.0), cfg)
    obs["goal"] = goal_features((8.0, 3.0), (0.0, 0.0, 1.0))
    obs["head_pan"] = np.zeros(1, np.float32)
    obs["left"] = obs["right"] = np.zeros((240, 320, 3), np.uint8)
    assert space.contains(obs)
    images = observation_space(ObservationConfig(observation_mode=ObservationMode.IMAGES), rig)
    assert set(images.spaces) == {"left", "right", "goal", "head_pan"}


def test_far_features_are_clipped_to_the_box(gap_model: EnvironmentModel) -> None:
    cfg = ObservationConfig(feature_range_m=1.0)
    table = pack_model(gap_model, (0.0, 0.0, 0.0), cfg)["critical_regions"].reshape(8, 8, -1)
    assert table[0, 0, 1] == 1.0 and table[0, 0, 7] == 2.0  # x 2 m and distance clipped
    assert observation_space(cfg, StereoRig())["critical_regions"].contains(
        pack_model(gap_model, (0.0, 0.0, 0.0), cfg)["critical_regions"]
    )
