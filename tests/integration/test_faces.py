"""Plain faces on rendered scenes (``modeling.stereo.faces``): a face between two vertical edges is
closed, a real gap between two obstacles is not. Ground truth: the obstacles' footprints."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest
import shapely

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from modeling.model.build import build_model
from modeling.observation import FloorObservation, FloorSegment
from modeling.stereo.faces import FACE_SOURCE, FaceOptions, close_faces, face_pairs
from modeling.stereo.ground_lines import GROUND_SOURCE, add_ground_lines
from modeling.stereo.matching import match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments, extract_segment_pair
from modeling.stereo.triangulation import triangulate_to_floor
from stereo_nav_env.sim.scenes import Scene, make_obstacle, oriented_rect
from tests.integration.rendering import noisy_grey_pair

RIG = StereoRig()
HEAD = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
ROBOT_WIDTH_M = 0.5


def _observe(
    obstacles: tuple[Any, ...],
) -> tuple[ImageSegments, FloorObservation, shapely.Geometry]:
    """Render the scene from ``HEAD`` with seeded pixel noise; the left segments, the floor
    observation and the union of the true footprints."""
    scene = Scene(
        name="t", bounds=(-1, -5, 12, 5), obstacles=obstacles, start=(0, 0, 0), goal=(11, 0)
    )
    grey = noisy_grey_pair(scene, RIG, HEAD)
    segs_l, segs_r = extract_segment_pair(*grey)
    floor = triangulate_to_floor(match_segments(segs_l, segs_r, RIG), RIG, HEAD)
    truth = shapely.union_all([shapely.Polygon(o.footprint) for o in obstacles])
    return segs_l, floor, truth


def _box(
    y0: float,
    y1: float,
    x_front: float = 3.0,
    color: tuple[float, float, float] = (0.55, 0.35, 0.2),
    height_m: float = 1.5,
) -> object:
    """A plain box (by default 1.5 m tall: above the robot, only its bottom edge can close it)
    whose front face, at ``x_front``, spans ``y0 .. y1``."""
    fp = [[x_front, y0], [x_front + 0.6, y0], [x_front + 0.6, y1], [x_front, y1]]
    return make_obstacle("box", fp, height_m=height_m, color=color)


def _added(before: FloorObservation, after: FloorObservation) -> list[FloorSegment]:
    return list(after.segments[len(before.segments) :])


def test_a_face_wider_than_the_robot_is_closed_along_its_true_outline() -> None:
    segs_l, floor, _ = _observe((_box(-0.6, 0.6),))
    assert len(segs_l.horizontal) >= 1  # the face's bottom edge
    closed = close_faces(segs_l, floor)
    added = _added(floor, closed)
    assert len(added) == 1
    ends = added[0].endpoints
    # the two front corners, (3.0, -0.6) and (3.0, 0.6), in some order
    true_corners = np.array([[3.0, -0.6], [3.0, 0.6]])
    err = np.abs(np.sort(ends, axis=0) - np.sort(true_corners, axis=0))
    assert err.max() <= 0.1
    assert added[0].source == FACE_SOURCE
    # without it the two edges are two vertical edges (kept: long in 3D) with a passable gap
    # between them, the face taken for a way through; with it, one obstacle across the face
    apart = build_model(floor, ROBOT_WIDTH_M).most_probable
    assert len(apart.obstacles) == 2 and apart.critical_regions == ()
    assert len(build_model(closed, ROBOT_WIDTH_M).most_probable.obstacles) == 1


def test_a_real_gap_between_two_boxes_is_not_closed() -> None:
    far_wall = make_obstacle(
        "wall", oriented_rect([7.0, 0.0], 0.1, 8.0, 0.0), color=(0.8, 0.8, 0.75)
    )
    boxes = (_box(-1.3, -0.5, color=(0.2, 0.3, 0.6)), _box(0.5, 1.3))
    segs_l, floor, truth = _observe((*boxes, far_wall))
    closed = close_faces(segs_l, floor)
    added = _added(floor, closed)
    # edges on both sides of the gap were seen (a join across it was possible) ...
    sides = [s.endpoints[1] for s in floor.segments if 2.5 < s.endpoints[1, 0] < 4.0]
    assert any(p[1] > 0.4 for p in sides) and any(p[1] < -0.4 for p in sides)
    assert added, "the left box's face is closed"
    for seg in added:  # every added segment lies on a true obstacle, none across the gap
        line = shapely.LineString(seg.endpoints)
        samples = [line.interpolate(t, normalized=True) for t in np.linspace(0, 1, 11)]
        assert max(p.distance(truth) for p in samples) <= 0.12
    # ... and none was made
    gap = shapely.box(2.9, -0.45, 3.9, 0.45)  # the free space between the boxes
    assert not any(shapely.LineString(s.endpoints).intersects(gap) for s in added)


def test_the_top_edge_of_a_low_box_joins_its_tops_when_asked() -> None:
    segs_l, floor, _ = _observe((_box(-0.6, 0.6, height_m=0.7),))  # below the robot's 1 m
    bottoms = face_pairs(segs_l, floor)
    both = face_pairs(segs_l, floor, tops=True)
    assert [p for p in both if p[2] == 1] == bottoms
    tops = [p for p in both if p[2] == 0]
    assert len(tops) == 1 and set(tops[0][:2]) == set(bottoms[0][:2])
    seg_a, seg_b = floor.segments[tops[0][0]], floor.segments[tops[0][1]]
    assert abs(seg_a.height_m.max() - 0.7) <= 0.05 and abs(seg_b.height_m.max() - 0.7) <= 0.05
    # joined once even when both ends are found
    assert len(close_faces(segs_l, floor, tops=True).segments) == len(floor.segments) + 1
    # the options as a FaceOptions, the keywords overriding its fields
    assert face_pairs(segs_l, floor, FaceOptions(tops=True)) == both
    assert face_pairs(segs_l, floor, FaceOptions(tops=True), tops=False) == bottoms


def test_nothing_to_close_returns_the_observation_itself() -> None:
    floor = FloorObservation()
    assert close_faces(ImageSegments.empty((240, 320)), floor) is floor
    assert face_pairs(ImageSegments.empty((240, 320)), floor) == []


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"tol_px": -1.0}, "tol_px"),
        ({"min_cover": 0.0}, "min_cover"),
        ({"max_length_m": float("nan")}, "max_length_m"),
        ({"tops": 1}, "tops"),
        ({"bogus": 1.0}, "bogus"),
    ],
)
def test_bad_options_name_themselves(kwargs: dict[str, Any], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        face_pairs(ImageSegments.empty((240, 320)), FloorObservation(), **kwargs)


def test_bad_inputs_name_themselves() -> None:
    with pytest.raises(ValueError, match="left"):
        face_pairs(np.zeros((3, 3)), FloorObservation())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="floor"):
        face_pairs(ImageSegments.empty((240, 320)), None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="horizontal"):
        ImageSegments.empty((240, 320), horizontal=np.zeros((2, 4)))


def test_ground_lines_put_a_face_on_wall_and_a_low_box_on_their_true_outlines() -> None:
    """A wall seen face-on across the whole image has no vertical edge: segment stereo measures
    nothing of it. Its bottom edge, and the low box's, become floor segments on their true
    outlines; the box's top edge (0.4 m high, whose floor point would fall at 4 m, behind the
    wall) lies above its bottom edge in the image and is dropped."""
    wall = make_obstacle("wall", oriented_rect([3.55, 0.0], 0.1, 12.0, 0.0), color=(0.8, 0.8, 0.75))
    box = _box(-0.4, 0.4, x_front=2.0, height_m=0.4)
    segs_l, floor, truth = _observe((wall, box))
    assert not any(abs(s.endpoints[:, 0] - 3.5).max() < 0.2 for s in floor.segments)
    added = _added(floor, add_ground_lines(segs_l, floor, RIG, HEAD))
    assert all(s.source == GROUND_SOURCE for s in added)
    on_wall = [s for s in added if abs(s.endpoints[:, 0] - 3.5).max() <= 0.1]
    on_box = [s for s in added if abs(s.endpoints[:, 0] - 2.0).max() <= 0.1]
    assert sum(abs(s.endpoints[1, 1] - s.endpoints[0, 1]) for s in on_wall) >= 2.0
    assert on_box
    outline = truth.boundary
    dist = [shapely.distance(shapely.points(s.endpoints), outline).max() for s in added]
    assert max(dist) <= 0.1
