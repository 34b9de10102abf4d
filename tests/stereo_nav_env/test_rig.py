"""StereoRig and HeadPose: validation, projection, triangulation, frames."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from modeling.stereo.rig import HeadPose, StereoRig


def test_defaults_use_pixel_centre_principal_point() -> None:
    rig = StereoRig()
    assert (rig.width_px, rig.height_px, rig.focal_px, rig.baseline_m) == (320, 240, 260.0, 0.12)
    assert rig.cx_px == 159.5 and rig.cy_px == 119.5
    assert rig.principal_point_px == (159.5, 119.5)
    assert StereoRig(cx_px=100.0, cy_px=80.0).principal_point_px == (100.0, 80.0)
    assert StereoRig().sigma_px == 0.5
    np.testing.assert_array_equal(rig.K, [[260, 0, 159.5], [0, 260, 119.5], [0, 0, 1]])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"focal_px": 0.0}, "focal_px"),
        ({"focal_px": -5.0}, "focal_px"),
        ({"baseline_m": 0.0}, "baseline_m"),
        ({"baseline_m": float("nan")}, "baseline_m"),
        ({"width_px": 4}, "width_px"),
        ({"height_px": 10.5}, "height_px"),
        ({"cx_px": 400.0}, "cx_px"),
        ({"cy_px": -1.0}, "cy_px"),
        ({"sigma_px": 0.0}, "sigma_px"),
        ({"min_depth_m": 5.0, "max_depth_m": 2.0}, "max_depth_m"),
    ],
)
def test_invalid_rig_names_the_field(kwargs: dict[str, Any], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        StereoRig(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"height_m": 0.0}, "height_m"),
        ({"x_m": float("inf")}, "x_m"),
        ({"heading_rad": float("nan")}, "heading_rad"),
        ({"tilt_rad": 1.6}, "tilt_rad"),
        ({"tilt_rad": float("nan")}, "tilt_rad"),
    ],
)
def test_invalid_head_pose_names_the_field(kwargs: dict[str, Any], name: str) -> None:
    base = {"x_m": 0.0, "y_m": 0.0, "heading_rad": 0.0, "height_m": 0.8}
    with pytest.raises(ValueError, match=name):
        HeadPose(**{**base, **kwargs})


def test_projection_and_disparity() -> None:
    rig = StereoRig()
    P = np.array([[0.0, 0.0, 2.0], [0.5, -0.25, 4.0], [0.0, 0.0, -1.0]])
    uv_l, uv_r = rig.project(P)
    np.testing.assert_allclose(uv_l[0], [159.5, 119.5])
    np.testing.assert_allclose(uv_l[1], [159.5 + 260 * 0.5 / 4, 119.5 - 260 * 0.25 / 4])
    np.testing.assert_allclose(uv_l[:2, 0] - uv_r[:2, 0], [260 * 0.12 / 2, 260 * 0.12 / 4])
    np.testing.assert_array_equal(uv_l[:2, 1], uv_r[:2, 1])  # rectified: same rows
    assert np.all(np.isnan(uv_l[2])) and np.all(np.isnan(uv_r[2]))  # behind the camera
    np.testing.assert_allclose(rig.disparity_px([2.0, 4.0]), [15.6, 7.8])
    np.testing.assert_allclose(rig.depth_m([15.6, 7.8]), [2.0, 4.0])
    assert np.isnan(rig.depth_m(0.0)) and np.isnan(rig.disparity_px(-1.0))
    assert rig.fb == pytest.approx(31.2)
    assert rig.min_disparity_px == pytest.approx(31.2 / 8.0)


def test_triangulate_inverts_project() -> None:
    rng = np.random.default_rng(0)
    rig = StereoRig()
    P = np.c_[rng.uniform(-2, 2, 50), rng.uniform(-1, 1, 50), rng.uniform(0.5, 8, 50)]
    uv_l, uv_r = rig.project(P)
    back = rig.triangulate(uv_l[:, 0], uv_l[:, 1], uv_l[:, 0] - uv_r[:, 0])
    np.testing.assert_allclose(back, P, rtol=1e-12, atol=1e-12)


def test_field_of_view() -> None:
    rig = StereoRig.from_fov(width_px=320, height_px=240, hfov_deg=64.0)
    assert math.degrees(rig.hfov_rad) == pytest.approx(64.0)
    assert StereoRig().in_image([[0.0, 0.0], [319.4, 239.4], [-0.6, 3.0]]).tolist() == [
        True,
        True,
        False,
    ]


def test_head_pose_frames() -> None:
    pose = HeadPose(x_m=1.0, y_m=2.0, heading_rad=math.pi / 2, height_m=0.8)  # looking along +y
    # ahead (world +y), to the right (world +x) and above the head
    P_world = np.array([[1.0, 5.0, 0.8], [2.0, 2.0, 0.8], [1.0, 3.0, 1.8]])
    P_cam = pose.world_to_cam(P_world)
    np.testing.assert_allclose(P_cam, [[0, 0, 3], [1, 0, 0], [0, -1, 1]], atol=1e-12)
    np.testing.assert_allclose(pose.cam_to_world(P_cam), P_world, atol=1e-12)
    T = pose.cam2world
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
    np.testing.assert_allclose(pose.right_camera_position(StereoRig()), [1.12, 2.0, 0.8])


def test_a_tilted_head_looks_down_about_its_baseline() -> None:
    t = 0.3
    pose = HeadPose(x_m=0.0, y_m=0.0, heading_rad=math.pi / 2, height_m=0.8, tilt_rad=t)
    R = pose.R_cam2world
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(
        R[:, 0], HeadPose(x_m=0, y_m=0, heading_rad=math.pi / 2, height_m=1).R_cam2world[:, 0]
    )
    np.testing.assert_allclose(R[:, 2], [0.0, math.cos(t), -math.sin(t)], atol=1e-15)  # forward
    # the optical axis meets the floor height_m / tan(tilt) ahead
    ahead = 0.8 / math.tan(t)
    P_cam = pose.world_to_cam(np.array([[0.0, ahead, 0.0]]))
    np.testing.assert_allclose(P_cam[0, :2], [0.0, 0.0], atol=1e-12)
