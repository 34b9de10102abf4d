"""Issue 3, degenerate input: blank images, pure noise, no overlap, a single segment give an empty
or valid result, without exception, with a bounded amount of output (no match without a segment
on each side, at most one floor segment or ambiguous set per left segment), and the same result
through ``stereo_to_floor``; wrong shapes or dtypes give a ValueError that names the argument
(extract_segments, match_segments, triangulate_to_floor, stereo_to_floor)."""

from __future__ import annotations

import numpy as np
import pytest

from modeling.observation import FloorObservation
from modeling.stereo.matching import StereoMatches, match_segments
from modeling.stereo.pipeline import stereo_to_floor
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments, extract_segments
from modeling.stereo.triangulation import triangulate_to_floor

RIG = StereoRig()
POSE = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
H, W = RIG.height_px, RIG.width_px


def _step(col: int, rows: slice = slice(None)) -> np.ndarray:
    img = np.full((H, W), 70, dtype=np.uint8)
    img[rows, col:] = 190
    return img


def _pairs() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(7)
    top = np.full((H, W), 80, dtype=np.uint8)
    top[10:100, 150:190] = 200
    bottom = np.full((H, W), 80, dtype=np.uint8)
    bottom[140:230, 140:180] = 200
    return {
        "blank": (np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)),
        "saturated": (np.full((H, W), 255, np.uint8), np.full((H, W), 255, np.uint8)),
        "noise": (
            rng.integers(0, 256, (H, W)).astype(np.uint8),
            rng.integers(0, 256, (H, W)).astype(np.uint8),
        ),
        "no_overlap": (top, bottom),
        "one_side_blank": (_step(170), np.zeros((H, W), np.uint8)),
        "single_segment": (_step(170), _step(150)),
        "negative_disparity": (_step(150), _step(170)),
    }


@pytest.mark.parametrize("name", list(_pairs()))
def test_degenerate_pairs_give_a_bounded_valid_observation(name: str) -> None:
    left, right = _pairs()[name]
    sl, sr = extract_segments(left), extract_segments(right)
    m = match_segments(sl, sr, RIG)
    obs = triangulate_to_floor(m, RIG, POSE)
    rgb = stereo_to_floor(
        np.dstack([left] * 3), np.dstack([right] * 3), RIG, POSE, close_faces=False
    )
    assert isinstance(sl, ImageSegments) and isinstance(m, StereoMatches)
    assert isinstance(obs, FloorObservation) and isinstance(rgb, FloorObservation)
    # bounded: every match pairs a left and a right segment, every floor segment or ambiguous
    # set comes from a distinct left segment
    assert len(m) <= len(sl) * len(sr)
    sources = [s.source for s in obs.segments] + [a.candidates[0].source for a in obs.ambiguous]
    assert len(set(sources)) == len(sources) and set(sources) <= set(range(len(sl)))
    # the end-to-end helper on the RGB pair gives the stages' result on the grey one
    assert len(rgb.segments) == len(obs.segments) and len(rgb.ambiguous) == len(obs.ambiguous)
    for a, b in zip(rgb.segments, obs.segments, strict=True):
        np.testing.assert_array_equal(a.endpoints, b.endpoints)
        np.testing.assert_array_equal(a.cov, b.cov)
    if len(m):
        sums = np.bincount(m.left_index, weights=m.probability)
        np.testing.assert_allclose(sums[np.unique(m.left_index)], 1.0)
        assert np.all(m.disparity_px > 0)
    for seg in obs.segments:
        assert np.all(np.isfinite(seg.endpoints)) and np.all(np.linalg.eigvalsh(seg.cov) > 0)
    if name == "single_segment":
        # one step edge, disparity 20 px (Z = 1.56 m): one certain match, its floor segment at
        # world x = Z (heading 0), the part of the edge between 0.05 m and 1 m high
        assert len(sl) == len(sr) == len(m) == 1 and m.probability[0] == 1.0
        np.testing.assert_allclose(m.disparity_px, 20.0, atol=1e-6)
        assert len(obs.segments) == 1 and obs.ambiguous == ()
        np.testing.assert_allclose(obs.segments[0].endpoints[:, 0], RIG.fb / 20.0, atol=1e-6)
    elif name != "noise":
        assert len(m) == 0 and obs.segments == () and obs.ambiguous == ()


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((H, W), dtype=np.float32),
        np.zeros((H, W), dtype=np.uint16),
        np.zeros((H, W, 3), dtype=np.uint8),
        np.zeros((H,), dtype=np.uint8),
        np.zeros((4, 4), dtype=np.uint8),
        [[0, 1], [2, 3]],
        None,
    ],
)
def test_extract_segments_names_gray(bad: object) -> None:
    with pytest.raises(ValueError, match="gray"):
        extract_segments(bad)  # type: ignore[arg-type]


def test_match_segments_names_its_arguments() -> None:
    segs = extract_segments(_step(170))
    for args, name in (
        ((None, segs, RIG), "left"),
        ((np.zeros((2, 2, 2)), segs, RIG), "left"),
        ((segs, [1, 2], RIG), "right"),
        ((segs, segs, (260.0, 0.12)), "rig"),
    ):
        with pytest.raises(ValueError, match=name):
            match_segments(*args)


def test_triangulate_to_floor_names_its_arguments() -> None:
    m = StereoMatches.empty()
    for args, name in (
        ((np.zeros((3, 2, 2)), RIG, POSE), "matches"),
        ((m, {"focal_px": 260.0}, POSE), "rig"),
        ((m, RIG, np.zeros(4)), "head_pose"),
    ):
        with pytest.raises(ValueError, match=name):
            triangulate_to_floor(*args)
    with pytest.raises(ValueError, match="left_endpoints"):
        StereoMatches(**{**{k: getattr(m, k) for k in m.__dataclass_fields__}, "left_endpoints": 0})


def test_stereo_to_floor_names_its_arguments() -> None:
    img = _step(170)
    for args, name in (
        ((img.astype(np.float64), img, RIG, POSE), "left"),
        ((img[:, :, None], img, RIG, POSE), "left"),
        ((img, img[:100], RIG, POSE), "right"),
        ((img, np.dstack([img] * 4), RIG, POSE), "right"),
        ((img, img.astype(np.int16), RIG, POSE), "right"),
        ((img, img, None, POSE), "rig"),
        ((img, img, RIG, None), "head_pose"),
    ):
        with pytest.raises(ValueError, match=name):
            stereo_to_floor(*args)
