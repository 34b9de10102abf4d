"""The surrogate knows the surface detail: its segments include the strips' edges (issue 42).

A wall of an ``open`` room seen face-on from 2.5 m, its ends out of view: plain, it shows
segment stereo no vertical edge; with its surface detail, each strip has two. The surrogate's
left-image segments are compared with the strips' projected sides, and with what the segment
extraction finds in the rendered image of the same view.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from modeling.stereo.matching import match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import extract_segments
from modeling.stereo.triangulation import triangulate_to_floor
from stereo_nav_env.perception.surrogate.rates import default_rates
from stereo_nav_env.perception.surrogate.sensor import surrogate_segments
from stereo_nav_env.perception.surrogate.visibility import SceneEdges
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import ObstacleKind, Scene, load_scenario

SEED = 3
TOL_PX = 1.5


def _face_on(scene: Scene) -> tuple[HeadPose, list[float]]:
    """A head 2.5 m in front of the wall side with the most features; their sides' columns."""
    ob, face = max(
        ((ob, f.face) for ob in scene.obstacles if ob.kind is ObstacleKind.WALL for f in ob.detail),
        key=lambda t: sum(f.face == t[1] for f in t[0].detail),
    )
    fp = ob.footprint
    a, b = fp[face], fp[(face + 1) % fp.shape[0]]
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([t[1], -t[0]])
    eye = (a + b) / 2 + 2.5 * n
    head = HeadPose(
        x_m=float(eye[0]),
        y_m=float(eye[1]),
        heading_rad=float(np.arctan2(-n[1], -n[0])),
        height_m=0.8,
    )
    rig = StereoRig()
    columns = []
    for f in ob.detail:
        if f.face != face:
            continue
        for side in (-1.0, 1.0):
            e = a + (f.offset_m + side * f.width_m / 2) * t + 0.003 * n
            uv, _ = rig.project(head.world_to_cam(np.array([[e[0], e[1], 0.5]])))
            if 3 <= uv[0, 0] <= rig.width_px - 4:
                columns.append(float(uv[0, 0]))
    return head, columns


def _vertical_columns(segments) -> np.ndarray:  # (n,) columns of the near-vertical segments
    return segments.u_center[np.abs(segments.slope) < 0.1]


def _found(columns: list[float], seg_u: np.ndarray) -> float:
    return float(np.mean([np.abs(seg_u - u).min(initial=np.inf) <= TOL_PX for u in columns]))


@pytest.fixture(scope="module")
def scenes() -> tuple[Scene, Scene]:
    return load_scenario("open", SEED, surface_detail=True), load_scenario("open", SEED)


def test_surrogate_segments_include_the_strips_edges(scenes, rig: StereoRig) -> None:
    detail, plain = scenes
    head, columns = _face_on(detail)
    assert len(columns) >= 6
    found = []
    for k in range(5):
        left, _ = surrogate_segments(
            SceneEdges.of(detail), rig, head, np.random.default_rng(k), default_rates()
        )
        found.append(_found(columns, _vertical_columns(left)))
    assert np.mean(found) >= 0.6  # the stereo's rates: a strip's crease side is found less often
    left, right = surrogate_segments(
        SceneEdges.of(plain), rig, head, np.random.default_rng(0), default_rates()
    )
    assert len(left) == 0 and len(right) == 0  # the plain wall face-on: nothing to segment


def test_rendered_stereo_finds_them_too(scenes, rig: StereoRig) -> None:
    detail, plain = scenes
    head, columns = _face_on(detail)
    rendered = []
    for scene in (detail, plain):
        renderer = StereoRenderer(rig, scene)
        rendered.append(cv2.cvtColor(renderer.render_view(head), cv2.COLOR_RGB2GRAY))
        renderer.close()
    assert _found(columns, _vertical_columns(extract_segments(rendered[0]))) >= 0.7
    assert _vertical_columns(extract_segments(rendered[1])).size == 0


def test_surrogate_puts_the_strips_on_the_wall(scenes, rig: StereoRig) -> None:
    """The strips' matches put floor points on the wall's line, as the stereo's do; look-alike
    seams of one wall are ambiguous for both (each keeps the true candidate among several)."""
    detail, _ = scenes
    head, _ = _face_on(detail)
    left, right = surrogate_segments(
        SceneEdges.of(detail), rig, head, np.random.default_rng(0), default_rates()
    )
    assert left.horizontal.shape[0] >= 1  # the wall's bottom edge between two strips
    floor = triangulate_to_floor(match_segments(left, right, rig), rig, head, max_height_m=1.0)
    assert len(floor.segments) + len(floor.ambiguous) >= 3
    # the most probable reading of each strip lies on the face: distance from the head ~2.5 m
    eye = np.array([head.x_m, head.y_m])
    best = [s.endpoints for s in floor.segments] + [
        a.candidates[int(np.argmax(a.probabilities))].endpoints for a in floor.ambiguous
    ]
    ahead = np.array([np.cos(head.heading_rad), np.sin(head.heading_rad)])
    depth = np.array([float((e.mean(axis=0) - eye) @ ahead) for e in best])
    assert np.median(np.abs(depth - 2.5)) < 0.1


def test_floor_lines_between_strips_only_with_detail(scenes) -> None:
    detail, plain = scenes
    assert SceneEdges.of(detail).line_detail.sum() > 0
    assert SceneEdges.of(plain).line_detail.sum() == 0
