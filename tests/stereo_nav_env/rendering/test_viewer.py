"""The rgb_array frame: layout and what is drawn where."""

from __future__ import annotations

import numpy as np
import pytest

from modeling.model.build import build_model
from modeling.observation import FloorObservation, FloorSegment
from stereo_nav_env.rendering.viewer import (
    FRAME_HEIGHT,
    FRAME_WIDTH,
    MapView,
    draw_background,
    draw_frame,
    passability_color,
)
from stereo_nav_env.sim.scenes import load_scenario


def test_passability_colours_run_red_yellow_green() -> None:
    assert passability_color(0.0) == (230, 0, 40)
    assert passability_color(0.5) == (230, 200, 40)
    assert passability_color(1.0) == (0, 200, 40)


def test_map_view_fits_the_scene_and_puts_north_up() -> None:
    scene = load_scenario("default")  # 9 x 6 m
    view = MapView.of(scene)
    corners = view.pixels(np.array([[0.0, 6.0], [9.0, 0.0]]))
    assert corners[0].tolist() == pytest.approx([12.0, 12.0])
    assert corners[1, 0] <= 640 - 12 + 1e-9 and corners[1, 1] <= 480 - 12 + 1e-9


def test_frame_shows_goal_robot_regions_and_the_left_image() -> None:
    scene = load_scenario("default")
    view = MapView.of(scene)
    background = draw_background(scene, view)
    cov = np.tile(np.eye(2) * 9e-4, (2, 1, 1))
    segs = (
        FloorSegment(endpoints=np.array([[3.0, 3.3], [3.0, 4.3]]), cov=cov),
        FloorSegment(endpoints=np.array([[3.0, 2.75], [3.0, 1.75]]), cov=cov),
    )
    model = build_model(FloorObservation(segments=segs, viewpoint=np.array([1.0, 3.0, 0.0])), 0.5)
    left = np.full((240, 320, 3), 77, dtype=np.uint8)
    frame = draw_frame(
        background,
        view,
        scene=scene,
        model=model,
        robot_pose=(1.0, 3.0, 0.0),
        gaze_rad=0.0,
        robot_radius_m=0.25,
        goal_radius_m=0.3,
        left_image=left,
        caption="hello",
    )
    assert frame.shape == (FRAME_HEIGHT, FRAME_WIDTH, 3) and frame.dtype == np.uint8
    assert background.shape == frame.shape and not np.array_equal(background, frame)
    assert np.all(frame[:240, 640:] == 77)  # the left image, inset at the top right
    gu, gv = view.pixels(np.array(scene.goal)).round().astype(int)
    assert tuple(frame[gv, gu]) == (40, 170, 60)  # the goal disc
    # the critical region between the two pieces, tinted by its passability colour
    (region,) = model.situations[0].critical_regions
    cu, cv = view.pixels(region.narrowest.mean(axis=0)).round().astype(int)
    r, g, _ = frame[cv, cu].astype(int)
    expected = passability_color(region.p_passable)
    assert abs(r - expected[0]) < 60 and abs(g - expected[1]) < 60
    assert (
        draw_frame(
            background,
            view,
            scene=scene,
            model=None,
            robot_pose=(1.0, 3.0, 0.0),
            gaze_rad=0.5,
            robot_radius_m=0.25,
            goal_radius_m=0.3,
            left_image=None,
        ).shape
        == frame.shape
    )
