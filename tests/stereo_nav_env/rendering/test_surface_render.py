"""Surface detail in the rendered pair, where the scene says and nowhere else (issue 42).

A room of the ``open`` family (walls only) with its surface detail, seen face-on from 2.5 m in
front of the wall side that carries the most features. Every feature on that side is projected
into the left image at a height in view: the rendered grey level departs from the plain wall's
inside the projected strip, and the image with the switch off is flat across it; halfway between
two features the two renderings agree.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import ObstacleKind, Scene, load_scenario

SEED = 3
DISTANCE_M = 2.5
HEIGHT_M = 0.4  # a height in view 2.5 m away (the head is at 0.8 m)


def _grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.int64)


@pytest.fixture(scope="module")
def setup(rig: StereoRig) -> Iterator[tuple[Scene, HeadPose, np.ndarray, np.ndarray, list]]:
    scene = load_scenario("open", SEED, surface_detail=True)
    plain = load_scenario("open", SEED)
    walls = [(o, ob) for o, ob in enumerate(scene.obstacles) if ob.kind is ObstacleKind.WALL]
    _o, ob, face = max(
        ((o, ob, f.face) for o, ob in walls for f in ob.detail),
        key=lambda t: sum(f.face == t[2] for f in t[1].detail),
    )
    fp = ob.footprint
    a, b = fp[face], fp[(face + 1) % fp.shape[0]]
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([t[1], -t[0]])
    mid = (a + b) / 2
    eye = mid + DISTANCE_M * n
    head = HeadPose(
        x_m=float(eye[0]),
        y_m=float(eye[1]),
        heading_rad=float(np.arctan2(-n[1], -n[0])),
        height_m=0.8,
    )
    images = []
    for sc in (scene, plain):
        renderer = StereoRenderer(rig, sc)
        images.append(_grey(renderer.render_stereo(head)[0]))
        renderer.close()
    features = sorted((f for f in ob.detail if f.face == face), key=lambda f: f.offset_m)
    columns = []
    for f in features:
        ends = [a + (f.offset_m + s * f.width_m / 2) * t + 0.003 * n for s in (-1.0, 1.0)]
        P = np.array([[e[0], e[1], HEIGHT_M] for e in ends])
        uv, _ = rig.project(head.world_to_cam(P))
        columns.append((f, np.sort(uv[:, 0]), float(uv[:, 1].mean())))
    yield scene, head, images[0], images[1], columns


def test_each_feature_is_drawn_where_the_scene_puts_it(setup, rig: StereoRig) -> None:
    _, _, detail, plain, columns = setup
    inside = [c for c in columns if 4 <= c[1][0] and c[1][1] <= rig.width_px - 5]
    assert len(inside) >= 3
    for f, (u0, u1), v in inside:
        row = round(v)
        lo, hi = int(np.floor(u0)), int(np.ceil(u1))
        band_detail = detail[row, lo : hi + 1]
        band_plain = plain[row, lo - 3 : hi + 4]
        wall = int(np.median(band_plain))
        assert np.ptp(band_plain) <= 1, f"plain wall not flat at {f}"
        assert np.abs(band_detail - wall).max() >= 6, f"no edge where {f} lies"
        # the step is at the strip: the columns 3 px beyond its sides are the wall's
        assert abs(detail[row, lo - 3] - wall) <= 1 and abs(detail[row, hi + 3] - wall) <= 1


def test_nothing_changes_between_features(setup, rig: StereoRig) -> None:
    _, _, detail, plain, columns = setup
    checked = 0
    for (_, (_, a1), v), (_, (b0, _), _) in itertools.pairwise(columns):
        if b0 - a1 < 8 or a1 < 0 or b0 > rig.width_px - 1:
            continue
        row, mid = round(v), round((a1 + b0) / 2)
        np.testing.assert_array_equal(detail[row, mid - 2 : mid + 3], plain[row, mid - 2 : mid + 3])
        checked += 1
    assert checked >= 2
