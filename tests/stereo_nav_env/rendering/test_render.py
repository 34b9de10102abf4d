"""The stereo renderer against geometry the simulator knows.

A single white box stands in front of the camera on an empty floor; its front face is
fronto-parallel at a known depth, so its vertical edges, top edge and corners have exact image
positions under the rig. Edge positions are read to sub-pixel precision from the anti-aliased
(4x multisampled) intensity profile across the edge.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
import trimesh

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.rendering.renderer import StereoRenderer, build_scene_mesh
from stereo_nav_env.rendering.shading import BACKGROUND_COLOR, FLOOR_COLOR, SIDE_SHADES
from stereo_nav_env.sim.scenes import Scene, make_obstacle, oriented_rect

HEAD = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
BOX_HEIGHT = 1.2
HALF_WIDTH = 0.5


def _box_scene(depth_m: float) -> Scene:
    box = make_obstacle(
        "box",
        oriented_rect([depth_m + 0.3, 0.0], 0.6, 2 * HALF_WIDTH),
        height_m=BOX_HEIGHT,
        color=(1.0, 1.0, 1.0),
    )
    return Scene(
        name="box", bounds=(-1, -4, 12, 4), obstacles=(box,), start=(0, 0, 0), goal=(11, 0)
    )


@pytest.fixture(scope="module")
def box_renderer(rig: StereoRig) -> Iterator[StereoRenderer]:
    renderer = StereoRenderer(rig, _box_scene(3.0))
    yield renderer
    renderer.close()


def _gray(img: np.ndarray) -> np.ndarray:
    grey: np.ndarray = img.astype(np.float64).mean(axis=2)
    return grey


def _step_position(profile: np.ndarray, approx: float, half: int = 4) -> float:
    """Sub-pixel position of the single intensity step near ``approx`` in a 1-D profile.

    Pixel k covers [k - 0.5, k + 0.5]; the fraction of the window on the first side of the step
    is read from each pixel's value between the two plateau levels.
    """
    k0 = math.floor(approx) - half
    k1 = math.floor(approx) + half + 1
    window = profile[k0 : k1 + 1]
    a, b = window[0], window[-1]
    assert abs(a - b) > 20, "no step in the window"
    return k0 - 0.5 + float(np.sum((window - b) / (a - b)))


def test_box_corner_projects_onto_the_rendered_edges(
    box_renderer: StereoRenderer, rig: StereoRig
) -> None:
    box_renderer.set_scene(_box_scene(3.0))
    left = _gray(box_renderer.render_view(HEAD))
    corner = np.array([[3.0, HALF_WIDTH, BOX_HEIGHT]])  # top-front-left corner, world
    uv_left, _ = rig.project(HEAD.world_to_cam(corner))
    u_c, v_c = float(uv_left[0, 0]), float(uv_left[0, 1])
    for v in range(math.ceil(v_c) + 3, math.ceil(v_c) + 12, 4):  # the vertical edge below it
        assert _step_position(left[v], u_c) == pytest.approx(u_c, abs=0.3)
    for u in range(math.ceil(u_c) + 3, math.ceil(u_c) + 30, 9):  # the top edge right of it
        assert _step_position(left[:, u], v_c) == pytest.approx(v_c, abs=0.3)


@pytest.mark.parametrize("depth_m", [2.0, 3.0, 5.0])
def test_vertical_edge_disparity_is_fb_over_z(
    box_renderer: StereoRenderer, rig: StereoRig, depth_m: float
) -> None:
    box_renderer.set_scene(_box_scene(depth_m))
    left, right = (_gray(img) for img in box_renderer.render_stereo(HEAD))
    assert rig.cx_px is not None and rig.cy_px is not None  # the default rig's centre
    v = round(rig.cy_px + rig.focal_px * (0.8 - 0.4) / depth_m)  # a row 0.4 m above the floor
    u_left = rig.cx_px - rig.focal_px * HALF_WIDTH / depth_m
    u_right = u_left - rig.fb / depth_m
    measured_left = _step_position(left[v], u_left)
    measured_right = _step_position(right[v], u_right)
    assert measured_left == pytest.approx(u_left, abs=0.3)
    assert measured_left - measured_right == pytest.approx(rig.fb / depth_m, abs=0.5)
    # the right edge of the face too
    u_left_r = rig.cx_px + rig.focal_px * HALF_WIDTH / depth_m
    d = _step_position(left[v], u_left_r) - _step_position(right[v], u_left_r - rig.fb / depth_m)
    assert d == pytest.approx(rig.fb / depth_m, abs=0.5)


def test_rows_are_aligned(box_renderer: StereoRenderer, rig: StereoRig) -> None:
    box_renderer.set_scene(_box_scene(3.0))
    left, right = (_gray(img) for img in box_renderer.render_stereo(HEAD))
    assert rig.cy_px is not None
    v_top = rig.cy_px - rig.focal_px * (BOX_HEIGHT - 0.8) / 3.0
    for u in (150, 160, 170):
        top_left = _step_position(left[:, u], v_top)
        top_right = _step_position(right[:, u], v_top)
        assert top_left == pytest.approx(v_top, abs=0.3)
        assert top_right == pytest.approx(top_left, abs=0.05)


def test_flat_shading_gives_the_baked_colours(box_renderer: StereoRenderer, rig: StereoRig) -> None:
    box_renderer.set_scene(_box_scene(3.0))
    img = box_renderer.render_view(HEAD).astype(int)
    face = img[140, 160]  # the box's front face, facing world -x
    np.testing.assert_allclose(face, [round(255 * SIDE_SHADES[2])] * 3, atol=1)
    np.testing.assert_allclose(img[230, 5], np.round(255 * np.array(FLOOR_COLOR)), atol=1)
    np.testing.assert_allclose(img[2, 160], np.round(255 * np.array(BACKGROUND_COLOR)), atol=1)


def test_depth_is_along_the_optical_axis(box_renderer: StereoRenderer, rig: StereoRig) -> None:
    box_renderer.set_scene(_box_scene(3.0))
    depth = box_renderer.render_depth(HEAD)
    assert depth.shape == (rig.height_px, rig.width_px)
    assert depth[140, 160] == pytest.approx(3.0, abs=1e-3)
    assert depth[140, 120] == pytest.approx(3.0, abs=1e-3)  # off-centre: still Z, not range
    assert np.isinf(depth[2, 160])  # background
    v = rig.height_px - 1
    assert rig.cy_px is not None
    # floor; depth comes from one of the 4 samples, up to ~0.4 px off the pixel centre
    assert depth[v, 5] == pytest.approx(0.8 * rig.focal_px / (v - rig.cy_px), rel=5e-3)
    right = box_renderer.render_depth(HEAD, right=True)
    assert right[140, 150] == pytest.approx(3.0, abs=1e-3)


def test_default_scene_pair(
    default_renderer: StereoRenderer, default_scene: Scene, rig: StereoRig
) -> None:
    x, y, heading = default_scene.start
    head = HeadPose(x_m=x, y_m=y + 0.06, heading_rad=heading, height_m=0.8)
    left, right = default_renderer.render_stereo(head)
    for img in (left, right):
        assert img.dtype == np.uint8 and img.shape == (240, 320, 3)
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 8  # floor, walls, furniture faces
    assert not np.array_equal(left, right)
    again = default_renderer.render_stereo(head)
    assert np.array_equal(again[0], left) and np.array_equal(again[1], right)
    other = StereoRenderer(rig, default_scene)
    try:
        assert np.array_equal(other.render_view(head), left)
    finally:
        other.close()
    assert np.array_equal(default_renderer.render_view(head), left)  # still usable after that


def test_static_geometry_is_one_mesh(default_scene: Scene) -> None:
    mesh = build_scene_mesh(default_scene)
    n_parts = sum(len(ob.parts) for ob in default_scene.obstacles)
    # floor: 2 triangles; each rectangular part: 8 side + 2 top (+ 2 bottom if off the floor)
    assert 2 + 10 * n_parts <= len(mesh.faces) <= 2 + 12 * n_parts
    assert isinstance(mesh.visual, trimesh.visual.ColorVisuals)
    assert mesh.visual.face_colors.shape == (len(mesh.faces), 4)
    renderer = StereoRenderer(StereoRig(), default_scene)
    assert len(renderer._pr_scene.mesh_nodes) == 1
    renderer.close()


def test_close_is_idempotent_and_rendering_reopens(box_renderer: StereoRenderer) -> None:
    renderer = StereoRenderer(StereoRig(width_px=64, height_px=48, focal_px=52.0), _box_scene(3.0))
    first = renderer.render_view(HEAD)
    renderer.close()
    renderer.close()
    assert np.array_equal(renderer.render_view(HEAD), first)
    renderer.close()
    assert box_renderer.render_view(HEAD).shape == (240, 320, 3)  # other contexts unaffected


def test_invalid_arguments_are_named(rig: StereoRig) -> None:
    with pytest.raises(ValueError, match="rig"):
        StereoRenderer("rig", _box_scene(3.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="scene"):
        StereoRenderer(rig, None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="znear_m"):
        StereoRenderer(rig, _box_scene(3.0), znear_m=0.0)
