"""Floor lines from the lowest near-horizontal image lines (modeling.stereo.ground_lines)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.observation import FloorObservation
from modeling.stereo.ground_lines import (
    GROUND_SOURCE,
    GroundLineOptions,
    add_ground_lines,
    add_line_ground_segments,
    floor_point_jacobians,
    floor_points,
    ground_segments,
    line_ground_segments,
    lowest_lines,
)
from modeling.stereo.pipeline import stereo_to_floor
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments

RIG = StereoRig()
LEVEL = HeadPose(x_m=1.0, y_m=-0.5, heading_rad=0.3, height_m=0.8)
TILTED = HeadPose(x_m=-2.0, y_m=1.5, heading_rad=-2.0, height_m=0.8, tilt_rad=0.25)


def _pixels(points_xyz: np.ndarray, head: HeadPose) -> np.ndarray:
    """(n, 2) left-image pixels of world points."""
    uv_left, _ = RIG.project(head.world_to_cam(points_xyz))
    return uv_left


def _floor_line(head: HeadPose, depth_m: float, half_width_m: float) -> np.ndarray:
    """(2, 3) world ends of a floor line across the optical axis, ``depth_m`` ahead."""
    c, s = math.cos(head.heading_rad), math.sin(head.heading_rad)
    centre = np.array([head.x_m, head.y_m]) + depth_m * np.array([c, s])
    across = half_width_m * np.array([s, -c])
    return np.array([[*(centre - across), 0.0], [*(centre + across), 0.0]])


@pytest.mark.parametrize("head", [LEVEL, TILTED])
def test_floor_points_are_where_the_pixels_of_floor_points_came_from(head: HeadPose) -> None:
    rng = np.random.default_rng(3)
    c, s = math.cos(head.heading_rad), math.sin(head.heading_rad)
    ahead = rng.uniform(1.5, 6.0, 20)
    side = rng.uniform(-0.5, 0.5, 20) * ahead
    truth = np.array([head.x_m, head.y_m]) + ahead[:, None] * [c, s] + side[:, None] * [s, -c]
    uv = _pixels(np.column_stack([truth, np.zeros(20)]), head)
    got, hits = floor_points(uv, RIG, head)
    assert hits.all()
    np.testing.assert_allclose(got, truth, atol=1e-9)


def test_rays_at_or_above_the_horizon_do_not_meet_the_floor() -> None:
    cy = RIG.principal_point_px[1]
    got, hits = floor_points(
        np.array([[100.0, cy], [100.0, cy - 20.0], [100.0, cy + 20]]), RIG, LEVEL
    )
    assert hits.tolist() == [False, False, True]
    assert np.isnan(got[:2]).all()


@pytest.mark.parametrize("head", [LEVEL, TILTED])
def test_the_jacobians_are_the_derivatives_of_the_floor_points(head: HeadPose) -> None:
    uv = np.array([[40.0, 180.0], [160.0, 150.0], [300.0, 230.0]])
    J = floor_point_jacobians(uv, RIG, head)
    h = 1e-4
    for k, step in enumerate(([h, 0.0], [0.0, h])):
        plus, _ = floor_points(uv + step, RIG, head)
        minus, _ = floor_points(uv - step, RIG, head)
        np.testing.assert_allclose(J[:, :, k], (plus - minus) / (2 * h), rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("depth_m", [1.5, 3.0, 4.5])
def test_depth_std_grows_as_z_squared_over_f_h(depth_m: float) -> None:
    line = _pixels(_floor_line(LEVEL, depth_m, 0.1), LEVEL)
    (seg,) = ground_segments(
        ImageSegments.empty((240, 320), horizontal=line[None]), RIG, LEVEL, end_sigma_px=1.0
    )
    c, s = math.cos(LEVEL.heading_rad), math.sin(LEVEL.heading_rad)
    forward = np.array([c, s])
    std = math.sqrt(forward @ seg.cov[0] @ forward)
    assert std == pytest.approx(depth_m**2 / (RIG.focal_px * LEVEL.height_m), rel=1e-3)


def test_a_wall_bottom_seen_face_on_becomes_its_floor_segment() -> None:
    truth = _floor_line(LEVEL, 3.0, 1.0)
    line = _pixels(truth, LEVEL)
    assert abs(line[0, 1] - line[1, 1]) < 1e-9  # along one row: no stereo match possible
    floor = FloorObservation(viewpoint=np.array([LEVEL.x_m, LEVEL.y_m, LEVEL.heading_rad]))
    got = add_ground_lines(
        ImageSegments.empty((240, 320), horizontal=line[None]), floor, RIG, LEVEL
    )
    (seg,) = got.segments
    assert seg.source == GROUND_SOURCE
    np.testing.assert_allclose(seg.endpoints, truth[:, :2], atol=1e-9)
    np.testing.assert_array_equal(seg.height_m, [0.0, 0.0])


def test_lines_given_as_an_array_give_the_segments_of_image_segments() -> None:
    """``line_ground_segments`` (the surrogate's entry) is ``ground_segments`` of the lines."""
    lines = np.stack(
        [_pixels(_floor_line(LEVEL, d, 0.4), LEVEL) for d in (2.0, 3.0)]
        + [_pixels(_floor_line(LEVEL, 2.0, 0.4), LEVEL) - [0.0, 30.0]]  # a top edge: dropped
    )
    left = ImageSegments.empty((240, 320), horizontal=lines)
    want = ground_segments(left, RIG, LEVEL)
    got = line_ground_segments(lines, RIG, LEVEL)
    assert len(want) == len(got) == 1  # the 3 m line lies above the 2 m one: dropped too
    np.testing.assert_array_equal(got[0].endpoints, want[0].endpoints)
    np.testing.assert_array_equal(got[0].cov, want[0].cov)
    floor = FloorObservation(viewpoint=np.array([LEVEL.x_m, LEVEL.y_m, LEVEL.heading_rad]))
    added = add_line_ground_segments(lines, floor, RIG, LEVEL)
    assert len(added.segments) == 1 and added.segments[0].source == GROUND_SOURCE
    assert add_line_ground_segments(np.zeros((0, 2, 2)), floor, RIG, LEVEL) is floor
    with pytest.raises(ValueError, match="lines"):
        line_ground_segments(np.zeros((3, 4)), RIG, LEVEL)


def test_a_top_edge_above_its_own_bottom_edge_is_dropped() -> None:
    bottom = _pixels(_floor_line(LEVEL, 2.0, 0.5), LEVEL)
    top = bottom - [0.0, 40.0]  # the same columns, higher in the image
    far_right = np.array([[280.0, 130.0], [315.0, 131.0]])  # nothing below it
    kept = lowest_lines(np.stack([top, bottom, far_right]))
    np.testing.assert_array_equal(kept, np.stack([bottom, far_right]))


def test_a_line_partly_above_another_stays_unless_most_of_it_is() -> None:
    line = np.array([[0.0, 150.0], [100.0, 150.0]])
    lower = np.array([[60.0, 170.0], [200.0, 170.0]])  # below 40 of its 100 columns
    assert lowest_lines(np.stack([line, lower])).shape[0] == 2
    assert lowest_lines(np.stack([line, lower]), GroundLineOptions(max_covered=0.3)).shape[0] == 1


def test_lines_beyond_range_or_above_the_horizon_give_nothing() -> None:
    far = _pixels(_floor_line(LEVEL, 6.0, 1.0), LEVEL)
    cy = RIG.principal_point_px[1]
    sky = np.array([[10.0, cy - 30.0], [200.0, cy - 30.0]])
    left = ImageSegments.empty((240, 320), horizontal=np.stack([far, sky]))
    assert ground_segments(left, RIG, LEVEL) == []
    assert len(ground_segments(left, RIG, LEVEL, ground_range_m=7.0)) == 1
    assert ground_segments(ImageSegments.empty((240, 320)), RIG, LEVEL) == []


@pytest.mark.parametrize(
    ("field", "value"),
    [("ground_range_m", 0.0), ("end_sigma_px", -1.0), ("below_px", -0.5), ("max_covered", 1.0)],
)
def test_bad_options_are_value_errors_naming_them(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        GroundLineOptions(**{field: value})


def test_bad_arguments_are_value_errors_naming_them() -> None:
    left = ImageSegments.empty((240, 320))
    with pytest.raises(ValueError, match="left"):
        ground_segments("segments", RIG, LEVEL)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="head_pose"):
        ground_segments(left, RIG, (0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ground_lines"):
        grey = np.zeros((240, 320), np.uint8)
        stereo_to_floor(grey, grey, RIG, LEVEL, ground_lines=1)  # type: ignore[arg-type]
