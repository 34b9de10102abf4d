"""Matching: exact disparities of synthetic edges, ambiguous repeated patterns, the candidate set,
the photometric and uniqueness constraints, degenerate input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modeling.stereo.matching import (
    MatchCandidates,
    MatchOptions,
    StereoMatches,
    match_candidates,
    match_segments,
)
from modeling.stereo.rig import StereoRig
from modeling.stereo.segments import ImageSegments, extract_segments
from tests.modeling.synth import render_pair

RIG = StereoRig()


def _match(rects, noise=0.0, seed=0, **kw):
    rng = np.random.default_rng(seed)
    left, right, depth = render_pair(RIG, rects, noise=noise, rng=rng)
    sl, sr = extract_segments(left), extract_segments(right)
    return sl, sr, match_segments(sl, sr, RIG, **kw), depth


def test_single_bar_gives_exact_disparity_with_certainty() -> None:
    # a bright board 0.3 m wide at 2 m in front of a uniform background: disparity f b / Z = 15.6
    sl, sr, m, _ = _match([(-0.4, -0.1, -0.6, 0.8, 2.0, 200.0)], noise=2.0)
    assert len(sl) == 2 and len(sr) == 2
    assert len(m) == 2 and set(m.left_index.tolist()) == {0, 1}
    np.testing.assert_allclose(m.probability, 1.0)
    np.testing.assert_allclose(m.disparity_px, RIG.fb / 2.0, atol=0.1)
    # the overlapping part's endpoints lie on the true edges (u = f X / Z + cx)
    u_true = sorted(RIG.focal_px * np.array([-0.4, -0.1]) / 2.0 + RIG.cx_px)
    np.testing.assert_allclose(np.sort(m.left_endpoints[:, :, 0].mean(axis=1)), u_true, atol=0.1)
    assert np.all(m.left_endpoints[:, 0, 1] <= m.left_endpoints[:, 1, 1])
    # disparity variance = var u_left + var u_right, u_left variance is the left fit's
    np.testing.assert_allclose(
        m.u_left_var, sl.u_var_at(m.left_index[:, None], m.left_endpoints[:, :, 1])
    )
    assert np.all(m.disparity_var > m.u_left_var)
    # the arrays are read-only and of the documented dtypes and shapes
    for name, dtype, shape in (
        ("left_index", np.int64, (2,)),
        ("right_index", np.int64, (2,)),
        ("probability", np.float64, (2,)),
        ("left_endpoints", np.float64, (2, 2, 2)),
        ("disparity_px", np.float64, (2, 2)),
        ("disparity_var", np.float64, (2, 2)),
        ("u_left_var", np.float64, (2, 2)),
        ("v_var", np.float64, (2, 2)),
        ("peak_disparity_px", np.float64, (2,)),
        ("peak_height", np.float64, (2,)),
        ("opposite_polarity", np.bool_, (2,)),
    ):
        arr = getattr(m, name)
        assert arr.dtype == dtype and arr.shape == shape and not arr.flags.writeable, name
    assert m.n_candidates >= 2


def test_objects_at_several_depths_each_get_their_disparity() -> None:
    rects = [
        (-2.5, 2.5, -2.0, 0.8, 6.0, 120.0),
        (-0.55, -0.25, -0.5, 0.8, 1.5, 210.0),
        (0.3, 0.45, -0.3, 0.8, 3.0, 30.0),
    ]
    _sl, _, m, depth = _match(rects, noise=2.0, seed=1)
    certain = m.probability >= 0.99
    assert certain.sum() >= 4
    mids = m.left_endpoints.mean(axis=1)
    for k in np.flatnonzero(certain):
        u, v = np.rint(mids[k]).astype(int)
        z = depth[v, max(u - 1, 0) : u + 2].min()
        assert abs(m.disparity_px[k].mean() - RIG.fb / z) < 0.5


def test_repeated_stripes_are_ambiguous_with_eq1_probabilities() -> None:
    # bookshelf-like: 7 boards 0.06 m wide every 0.2 m at 2.5 m (period 20.8 px, disparity 12.5 px)
    z = 2.5
    rects = [(-0.7 + 0.2 * k, -0.64 + 0.2 * k, -0.6, 0.8, z, 220.0) for k in range(7)]
    _, _, m, _ = _match(rects, noise=2.0, seed=2)
    d_true = RIG.fb / z
    assert len(m) > 0
    amb = m.ambiguous
    assert amb.sum() >= 4  # several left segments have several candidates
    for li in np.unique(m.left_index[amb]):
        rows = m.left_index == li
        np.testing.assert_allclose(m.probability[rows].sum(), 1.0)
        # Eq. 1: probability proportional to the peak height
        np.testing.assert_allclose(
            m.probability[rows], m.peak_height[rows] / m.peak_height[rows].sum()
        )
        assert np.any(np.abs(m.disparity_px[rows].mean(axis=1) - d_true) < 0.5)
    # every left segment's probabilities sum to 1
    sums = np.bincount(m.left_index, weights=m.probability)
    np.testing.assert_allclose(sums[np.unique(m.left_index)], 1.0)


def test_disparity_outside_rig_range_is_rejected() -> None:
    # an object beyond max_depth (disparity below the rig's minimum) gives no match
    far = StereoRig(max_depth_m=3.0)
    rng = np.random.default_rng(0)
    left, right, _ = render_pair(far, [(-1.0, -0.2, -1.5, 1.0, 5.0, 200.0)], rng=rng)
    m = match_segments(extract_segments(left), extract_segments(right), far)
    assert len(m) == 0


def test_degenerate_inputs() -> None:
    empty = ImageSegments.empty((240, 320))
    blank = np.zeros((240, 320), dtype=np.uint8)
    sl = extract_segments(blank)
    m = match_segments(sl, sl, RIG)
    assert isinstance(m, StereoMatches) and len(m) == 0
    assert m.left_endpoints.shape == (0, 2, 2) and m.ambiguous.shape == (0,)
    # one side empty
    sl_bar, _, _, _ = _match([(-0.4, -0.1, -0.6, 0.8, 2.0, 200.0)])
    assert len(match_segments(sl_bar, empty, RIG)) == 0
    assert len(match_segments(empty, sl_bar, RIG)) == 0
    # no vertical overlap: a bar in the top half of the left image, the bottom half of the right
    top = np.full((240, 320), 80, dtype=np.uint8)
    top[10:100, 150:190] = 200
    bottom = np.full((240, 320), 80, dtype=np.uint8)
    bottom[140:230, 140:180] = 200
    assert len(match_segments(extract_segments(top), extract_segments(bottom), RIG)) == 0
    # pure noise: many segments, and a valid result whose pairs all satisfy the constraints
    rng = np.random.default_rng(4)
    a = rng.integers(0, 256, (240, 320)).astype(np.uint8)
    b = rng.integers(0, 256, (240, 320)).astype(np.uint8)
    sa, sb = extract_segments(a), extract_segments(b)
    m = match_segments(sa, sb, RIG)
    assert len(m) <= m.n_candidates <= len(sa) * len(sb)
    if len(m):
        assert np.all((m.left_index >= 0) & (m.left_index < len(sa)))
        assert np.all((m.right_index >= 0) & (m.right_index < len(sb)))
        assert np.all(np.diff(m.left_index) >= 0)
        assert np.all((m.probability > 0) & (m.probability <= 1))
        sums = np.bincount(m.left_index, weights=m.probability)
        np.testing.assert_allclose(sums[np.unique(m.left_index)], 1.0)
        lo = RIG.min_disparity_px - 2.5
        assert np.all((m.disparity_px >= lo) & (m.disparity_px <= RIG.max_disparity_px + 2.5))


def test_single_segment_each_side() -> None:
    img_l = np.full((240, 320), 80, dtype=np.uint8)
    img_l[:, 170:] = 200
    img_r = np.full((240, 320), 80, dtype=np.uint8)
    img_r[:, 150:] = 200
    m = match_segments(extract_segments(img_l), extract_segments(img_r), RIG)
    assert len(m) == 1
    np.testing.assert_allclose(m.disparity_px, 20.0, atol=1e-6)
    assert m.probability[0] == 1.0


def test_wrong_arguments_raise_naming_them() -> None:
    sl = ImageSegments.empty((240, 320))
    with pytest.raises(ValueError, match="left"):
        match_segments(np.zeros((3, 2, 2)), sl, RIG)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="right"):
        match_segments(sl, "x", RIG)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="rig"):
        match_segments(sl, sl, None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="rel_peak"):
        match_segments(sl, sl, RIG, rel_peak=0.0)
    with pytest.raises(ValueError, match="max_near_grey_diff"):
        match_segments(sl, sl, RIG, max_near_grey_diff=-1.0)
    with pytest.raises(ValueError, match="region_sigma_px"):
        match_segments(sl, sl, RIG, region_sigma_px=(0.0, 10.0))
    with pytest.raises(ValueError, match="left"):
        match_candidates([], sl, RIG)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="rig"):
        match_candidates(sl, sl, "rig")  # type: ignore[arg-type]


def test_candidates_are_the_pairs_before_the_histograms() -> None:
    # repeated stripes: every kept pair is a candidate, and each left edge's true partner is one
    z = 2.5
    rects = [(-0.7 + 0.2 * k, -0.64 + 0.2 * k, -0.6, 0.8, z, 220.0) for k in range(7)]
    sl, sr, m, _ = _match(rects, noise=2.0, seed=2)
    c = match_candidates(sl, sr, RIG)
    assert isinstance(c, MatchCandidates) and len(c) == m.n_candidates > len(m)
    pairs = set(zip(c.left_index.tolist(), c.right_index.tolist(), strict=True))
    kept = set(zip(m.left_index.tolist(), m.right_index.tolist(), strict=True))
    assert kept <= pairs
    d_true = RIG.fb / z
    true_ok = np.abs(c.disparity_px.mean(axis=1) - d_true) < 0.5
    assert set(c.left_index[true_ok].tolist()) == set(range(len(sl)))
    assert np.all(c.rows_px[:, 1] - c.rows_px[:, 0] == c.overlap_px)
    empty = match_candidates(ImageSegments.empty((240, 320)), sr, RIG)
    assert len(empty) == 0 and empty.disparity_px.shape == (0, 2)


def _box_with_side_face(side_grey: float) -> tuple[np.ndarray, np.ndarray]:
    """A bright box face on a dark background; the right camera also sees a 2-px side face right of
    it (a view-dependent contour): its right edge in the left image (u = 139.5, the front corner,
    true disparity 15) and in the right image (u = 126.5, the back corner) are different 3D lines.
    The side face is too close in grey to the front face for its inner edge to be detected.
    """
    left = np.full((240, 320), 60, dtype=np.uint8)
    left[40:200, 100:140] = 200
    right = np.full((240, 320), 60, dtype=np.uint8)
    right[40:200, 85:125] = 200
    right[40:200, 125:127] = side_grey
    return left, right


def test_view_dependent_contour_is_not_matched() -> None:
    left, right = _box_with_side_face(170.0)
    sl, sr = extract_segments(left), extract_segments(right)
    np.testing.assert_allclose(np.sort(sr.endpoints[:, 0, 0]), [84.5, 126.5], atol=1e-6)
    m = match_segments(sl, sr, RIG)
    # the left edge of the face: d = 15 exactly; the right edge: no match (its partner is hidden)
    assert len(m) == 1 and m.probability[0] == 1.0
    np.testing.assert_allclose(m.disparity_px, 15.0, atol=1e-6)
    np.testing.assert_allclose(m.left_endpoints[0, :, 0], 99.5, atol=1e-6)
    # without the near-edge photometric check it is matched to the back corner, 2 px off
    loose = match_segments(sl, sr, RIG, max_near_grey_diff=np.inf)
    right_edge = np.abs(loose.left_endpoints[:, 0, 0] - 139.5) < 0.1
    assert right_edge.sum() == 1
    np.testing.assert_allclose(loose.disparity_px[right_edge], 13.0, atol=1e-6)


def _segments(u: list[float], rows: list[tuple[float, float]]) -> ImageSegments:
    """Vertical segments at columns ``u`` over ``rows``, bright on their right."""
    n = len(u)
    one = np.ones(n)
    v0 = np.array([r[0] for r in rows])
    v1 = np.array([r[1] for r in rows])
    ends = np.stack([np.stack([u, v0], axis=-1), np.stack([u, v1], axis=-1)], axis=1)
    return ImageSegments(
        endpoints=ends,
        u_center=np.asarray(u, dtype=float),
        v_center=0.5 * (v0 + v1),
        slope=0 * one,
        point_var=0.25 * one,
        n_points=(v1 - v0 + 1).astype(int),
        s_vv=(v1 - v0 + 1) ** 3 / 12.0,
        bias_var=0.01 * one,
        polarity=np.ones(n, dtype=np.int8),
        contrast=50 * one,
        grey_left=60 * one,
        grey_right=200 * one,
        image_shape=(240, 320),
    )


def test_uniqueness_drops_the_weaker_certain_claim() -> None:
    # left edges at 100 (rows 40-200) and 160 (rows 60-140), one right edge at 85 (rows 40-200):
    # both would be certain of it, at disparities 15 and 75; the longer claim (higher peak) wins
    left = _segments([100.0, 160.0], [(40.0, 200.0), (60.0, 140.0)])
    right = _segments([85.0], [(40.0, 200.0)])
    m = match_segments(left, right, RIG)
    assert m.left_index.tolist() == [0] and m.probability.tolist() == [1.0]
    np.testing.assert_allclose(m.disparity_px, 15.0)
    both = match_segments(left, right, RIG, unique_right=False)
    assert both.left_index.tolist() == [0, 1]
    np.testing.assert_allclose(both.disparity_px[:, 0], [15.0, 75.0])
    # collinear pieces of one edge at the same disparity are not in conflict
    pieces = _segments([100.0, 100.0], [(40.0, 110.0), (120.0, 200.0)])
    m2 = match_segments(pieces, right, RIG)
    assert m2.left_index.tolist() == [0, 1]


def test_candidates_without_weight_give_no_match() -> None:
    # the only candidate is of opposite polarity and such pairs weigh nothing: its histogram is
    # empty, so there is no peak to agree with (an empty result, not an error)
    left = _segments([100.0], [(40.0, 200.0)])
    right = dataclasses.replace(
        _segments([85.0], [(40.0, 200.0)]), polarity=np.array([-1], dtype=np.int8)
    )
    assert len(match_candidates(left, right, RIG, max_grey_diff=np.inf)) == 1
    m = match_segments(left, right, RIG, max_grey_diff=np.inf, opposite_weight=0.0)
    assert len(m) == 0 and m.n_candidates == 1
    assert len(match_segments(left, right, RIG, max_grey_diff=np.inf)) == 1


def test_options_as_a_dataclass_or_flat_keywords() -> None:
    sl, sr, m, _ = _match([(-0.4, -0.1, -0.6, 0.8, 2.0, 200.0)], noise=2.0)
    # the defaults, an options instance and the flat keywords give the same matches
    for other in (
        match_segments(sl, sr, RIG, MatchOptions()),
        match_segments(sl, sr, RIG, options=MatchOptions(rel_peak=0.5)),
        match_segments(sl, sr, RIG, MatchOptions(rel_peak=0.9), rel_peak=0.5),
    ):
        for f in dataclasses.fields(StereoMatches):
            np.testing.assert_array_equal(getattr(other, f.name), getattr(m, f.name))
    # an override takes effect: no pair overlaps by 1,000 rows
    assert len(match_candidates(sl, sr, RIG, min_overlap_px=1000.0)) == 0 < len(m)
    assert len(match_segments(sl, sr, RIG, min_overlap_px=1000.0)) == 0
    with pytest.raises(ValueError, match="rel_peek"):
        match_segments(sl, sr, RIG, rel_peek=0.5)
    with pytest.raises(ValueError, match="MatchOptions"):
        match_segments(sl, sr, RIG, options={"rel_peak": 0.5})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="opposite_weight"):
        MatchOptions(opposite_weight=2.0)
    opts = MatchOptions(region_sigma_px=(10, 20))
    assert opts.region_sigma_px == (10.0, 20.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.rel_peak = 0.1  # type: ignore[misc]
