"""A tilted head (``HeadPose.tilt_rad``): a rendered box seen looking down triangulates to its true
footprint. Ground truth: the box's footprint in the scene."""

from __future__ import annotations

import os

import numpy as np
import shapely

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from modeling.stereo.matching import match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import extract_segment_pair
from modeling.stereo.triangulation import triangulate_to_floor
from stereo_nav_env.diagnostics import normalised_outline_errors
from stereo_nav_env.sim.scenes import Scene, make_obstacle
from tests.integration.rendering import noisy_grey_pair

RIG = StereoRig()
FOOTPRINT = np.array([[1.6, -0.3], [2.2, -0.3], [2.2, 0.35], [1.6, 0.35]])


def _floor_of_box(tilt_rad: float):  # type: ignore[no-untyped-def]
    box = make_obstacle("box", FOOTPRINT.tolist(), height_m=0.6, color=(0.55, 0.35, 0.2))
    scene = Scene(name="t", bounds=(-1, -5, 12, 5), obstacles=(box,), start=(0, 0, 0), goal=(11, 0))
    head = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8, tilt_rad=tilt_rad)
    grey = noisy_grey_pair(scene, RIG, head)
    segs_l, segs_r = extract_segment_pair(*grey, rig=RIG)
    return triangulate_to_floor(match_segments(segs_l, segs_r, RIG), RIG, head)


def test_a_box_seen_with_the_head_tilted_lands_on_its_true_footprint() -> None:
    floor = _floor_of_box(0.3)
    assert len(floor.segments) >= 2
    points = np.concatenate([s.endpoints for s in floor.segments])
    cov = np.concatenate([s.cov for s in floor.segments])
    edges = np.stack([FOOTPRINT, np.roll(FOOTPRINT, -1, axis=0)], axis=1)
    z = normalised_outline_errors(points, cov, edges)
    assert np.all(np.abs(z) <= 3.0), z  # within 3 sigma across the true outline
    outline = shapely.LinearRing(FOOTPRINT)
    assert max(outline.distance(shapely.Point(p)) for p in points) <= 0.1
    heights = np.concatenate([s.height_m for s in floor.segments])
    assert np.all((heights >= 0.05 - 1e-9) & (heights <= 1.0 + 1e-9))
    # the tilted head sees the box's foot (a vertical edge down to the floor band's bottom);
    # the level head cannot (its lowest ray meets the floor 1.7 m ahead)
    assert heights.min() <= 0.06
    level = _floor_of_box(0.0)
    level_heights = [h for s in level.segments for h in s.height_m]
    assert not level_heights or min(level_heights) > 0.06
