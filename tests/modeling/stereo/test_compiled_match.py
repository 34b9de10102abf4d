"""The compiled decision of the matching equals its readable reference (section 3.1; Eq. 1 of 3.3).

``modeling.stereo._kernels.match.decide`` against ``modeling.stereo.disparity_histograms.
decide_matches_reference``: exactly equal on the region histograms of seeded rendered pairs (four
option sets) and on seeded random histograms with ties and flat tops. Likewise
``histogram_inputs`` (the compiled ``histogram_rows``) against ``histogram_inputs_reference``, bit
for bit, on the candidates of rendered pairs and on seeded random candidates.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from modeling.stereo._kernels.match import Candidates, Decision, HistogramInputs, PeakRule, decide
from modeling.stereo.disparity_histograms import (
    Splat,
    decide_matches_reference,
    histogram_inputs,
    histogram_inputs_reference,
    region_histograms,
)
from modeling.stereo.matching import MatchOptions, candidates_reference, match_candidates
from modeling.stereo.rig import StereoRig
from modeling.stereo.segments import extract_segment_pair
from tests.modeling.synth import render_pair

RIG = StereoRig()


def _assert_same(got: Decision, want: Decision) -> None:
    for name in Decision._fields:
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def _decision_inputs(
    cand: Candidates, slope_l: np.ndarray, mid_of_left: np.ndarray, opts: MatchOptions
) -> tuple[np.ndarray, HistogramInputs, PeakRule]:
    inputs = histogram_inputs(cand, slope_l, opts.splat())
    hist = region_histograms(
        inputs, mid_of_left[inputs.rows], opts.region_sigma_px, opts.self_weight
    )
    return hist, inputs, opts.peak_rule(inputs.n_bins, slope_l.size)


def _rendered_pair(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Boards at random depths, some repeated (ambiguous), with pixel noise."""
    rng = np.random.default_rng(seed)
    rects = []
    for _ in range(5):
        x0 = rng.uniform(-1.2, 0.8)
        rects.append(
            (
                x0,
                x0 + rng.uniform(0.05, 0.3),
                -0.6,
                rng.uniform(0.2, 0.8),
                rng.uniform(1.2, 3.5),
                rng.uniform(30, 230),
            )
        )
    left, right, _ = render_pair(RIG, rects, noise=2.0, rng=rng, ss=4)
    return left, right


OPTION_SETS: list[dict[str, Any]] = [
    {},
    {"unique_right": False},
    {"rel_peak": 0.2, "self_weight": 0.5},
    {"max_grey_diff": np.inf, "max_near_grey_diff": np.inf, "min_peak_sep_px": 1.0},
]


@pytest.mark.parametrize("seed", range(4))
def test_decide_equals_reference_on_rendered_pairs(seed: int) -> None:
    sl, sr = extract_segment_pair(*_rendered_pair(seed))
    mid = 0.5 * (sl.endpoints[:, 0] + sl.endpoints[:, 1])
    kept = 0
    for overrides in OPTION_SETS:
        opts = MatchOptions(**overrides)
        c = match_candidates(sl, sr, RIG, opts)
        if len(c) == 0:
            continue
        cand = Candidates(
            li=c.left_index,
            rj=c.right_index,
            rows=c.rows_px,
            overlap=c.overlap_px,
            disparity=c.disparity_px,
            opposite=c.opposite_polarity,
        )
        hist, inputs, rule = _decision_inputs(cand, sl.slope, mid, opts)
        got = decide(hist, cand, inputs, rule)
        _assert_same(got, decide_matches_reference(hist, cand, inputs, rule))
        kept += got.sel.size
    assert kept > 0  # the pairs do exercise the rule


GRID_OPTION_SETS: list[dict[str, Any]] = [
    *OPTION_SETS,
    {"allow_opposite": False},
    {"min_overlap_px": 40.0, "min_overlap_frac": 0.9},
    {"max_angle_diff_deg": 0.5, "agree_px": 0.5},
]


@pytest.mark.parametrize("seed", range(4))
def test_candidate_grid_equals_reference_on_rendered_pairs(seed: int) -> None:
    sl, sr = extract_segment_pair(*_rendered_pair(seed))
    found = 0
    for left, right in ((sl, sr), (sr, sl)):  # swapped: mostly negative disparities
        for overrides in GRID_OPTION_SETS:
            opts = MatchOptions(**overrides)
            got = match_candidates(left, right, RIG, opts)
            want = candidates_reference(left, right, RIG, opts)
            np.testing.assert_array_equal(got.left_index, want.li)
            np.testing.assert_array_equal(got.right_index, want.rj)
            np.testing.assert_array_equal(got.rows_px, want.rows)
            np.testing.assert_array_equal(got.overlap_px, want.overlap)
            np.testing.assert_array_equal(got.disparity_px, want.disparity)
            np.testing.assert_array_equal(got.opposite_polarity, want.opposite)
            found += len(got)
    assert found > 0


def _random_candidates(rng: np.random.Generator, n_left: int, n_right: int, k: int) -> Candidates:
    li = np.sort(rng.integers(0, n_left, k))
    lo = rng.integers(0, 150, k).astype(float)
    d = rng.integers(5, 40, k).astype(float) + rng.choice([0.0, 0.5], k)
    return Candidates(
        li=li,
        rj=rng.integers(0, n_right, k),
        rows=np.stack([lo, lo + rng.integers(8, 60, k)], axis=1),
        overlap=rng.integers(8, 60, k).astype(float),  # equal weights: the ties are exercised
        disparity=np.stack([d, d + rng.choice([-1.0, 0.0, 1.0], k)], axis=1),
        opposite=rng.random(k) < 0.3,
    )


@pytest.mark.parametrize("seed", range(12))
def test_decide_equals_reference_on_random_histograms(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n_left = int(rng.integers(1, 7))
    cand = _random_candidates(rng, n_left, int(rng.integers(1, 6)), int(rng.integers(1, 25)))
    opts = MatchOptions(
        rel_peak=float(rng.choice([0.3, 0.5, 1.0])),
        min_peak_sep_px=float(rng.choice([1.0, 2.5, 4.0])),
        agree_px=float(rng.choice([1.0, 2.5])),
        unique_right=bool(rng.random() < 0.7),
    )
    slope = rng.choice([0.0, 0.1], n_left)
    mid = rng.uniform(0, 240, (n_left, 2))
    smooth, inputs, rule = _decision_inputs(cand, slope, mid, opts)
    # the smooth region histograms, and coarse integer ones (flat tops, equal peaks, empty rows)
    coarse = rng.integers(0, 4, smooth.shape).astype(float)
    for hist in (smooth, coarse):
        _assert_same(
            decide(hist, cand, inputs, rule), decide_matches_reference(hist, cand, inputs, rule)
        )


def test_decide_keeps_one_candidate_per_peak_with_eq1_probabilities() -> None:
    # one left segment, two candidates at disparities 10 and 30 under two equal-shaped peaks of
    # heights 3 and 1: both kept, probabilities 3/4 and 1/4 (Eq. 1), the higher peak first
    cand = Candidates(
        li=np.array([0, 0]),
        rj=np.array([0, 1]),
        rows=np.array([[0.0, 50.0], [0.0, 50.0]]),
        overlap=np.array([50.0, 50.0]),
        disparity=np.array([[10.0, 10.0], [30.0, 30.0]]),
        opposite=np.array([False, False]),
    )
    opts = MatchOptions(rel_peak=0.2, unique_right=False)
    _, inputs, rule = _decision_inputs(cand, np.zeros(1), np.zeros((1, 2)), opts)
    hist = np.zeros((1, inputs.n_bins))
    for d, height in ((10.0, 3.0), (30.0, 1.0)):
        b = round(d - inputs.d_base)
        hist[0, b - 1 : b + 2] = [0.5 * height, height, 0.5 * height]
    for got in (
        decide(hist, cand, inputs, rule),
        decide_matches_reference(hist, cand, inputs, rule),
    ):
        assert got.sel.tolist() == [0, 1]
        np.testing.assert_allclose(got.probability, [0.75, 0.25])
        np.testing.assert_allclose(got.peak_disparity, [10.0, 30.0])
        np.testing.assert_allclose(got.peak_height, [3.0, 1.0])


def _assert_same_inputs(got: HistogramInputs, want: HistogramInputs) -> None:
    assert type(got) is HistogramInputs
    for name in ("d_base", "n_bins"):
        a, b = getattr(got, name), getattr(want, name)
        assert type(a) is type(b) and a == b, name
        assert np.signbit(a) == np.signbit(b), name
    for name in HistogramInputs._fields:
        a, b = np.atleast_1d(getattr(got, name)), np.atleast_1d(getattr(want, name))
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)
        bits_a, bits_b = (
            np.ascontiguousarray(a).view(np.uint8),
            np.ascontiguousarray(b).view(np.uint8),
        )
        np.testing.assert_array_equal(bits_a, bits_b, err_msg=name)  # -0.0 and the NaN payloads


@pytest.mark.parametrize("seed", range(4))
def test_histogram_inputs_equal_their_reference_on_rendered_pairs(seed: int) -> None:
    sl, sr = extract_segment_pair(*_rendered_pair(seed))
    compared = 0
    for left, right in ((sl, sr), (sr, sl)):  # swapped: mostly negative disparities
        for overrides in GRID_OPTION_SETS:
            opts = MatchOptions(**overrides, opposite_weight=0.3)
            cand = candidates_reference(left, right, RIG, opts)
            if cand.li.size == 0:
                continue
            splat = opts.splat()
            _assert_same_inputs(
                histogram_inputs(cand, left.slope, splat),
                histogram_inputs_reference(cand, left.slope, splat),
            )
            compared += 1
    assert compared > 0


def _random_histogram_case(rng: np.random.Generator) -> tuple[Candidates, np.ndarray, Splat]:
    """Candidates with one or many per left segment, opposite polarities, half-integer mid
    disparities (ties of the rounding), negative disparities and steep slopes."""
    n_left = int(rng.integers(1, 9))
    k = int(rng.choice([1, 2, int(rng.integers(3, 80))]))
    li = np.sort(rng.integers(0, n_left, k))
    if rng.random() < 0.3:
        li = np.full(k, int(rng.integers(0, n_left)))  # all on one left segment
    shift = float(rng.choice([0.0, -40.0, -200.5, 1e3]))
    if rng.random() < 0.5:  # integer ends: mid disparities on bins and half bins
        d = rng.integers(-30, 60, (k, 2)).astype(float) + shift
    else:
        d = rng.uniform(-30.0, 60.0, (k, 2)) + shift
    slope = rng.choice([0.0, 0.1, -0.7, 5.0, -40.0, 1e3], n_left) * rng.uniform(0.5, 1.5, n_left)
    sigma = float(rng.choice([0.3, 1.0, 2.5, 3.7]))
    bin_px = float(rng.choice([1.0, 0.5, 0.25, 2.0]))
    rows = np.sort(rng.uniform(0.0, 200.0, (k, 2)), axis=1)
    cand = Candidates(
        li=li,
        rj=rng.integers(0, 6, k),
        rows=rows,
        overlap=rng.choice([rows[:, 1] - rows[:, 0], np.full(k, 17.0)]),
        disparity=d,
        opposite=rng.random(k) < float(rng.choice([0.0, 0.4, 1.0])),
    )
    splat = Splat(
        opposite_weight=float(rng.choice([0.0, 0.5, 1.0, 0.37])),
        sigma_bins=sigma,
        radius=max(1, math.ceil(3.0 * sigma)),
        bin_px=bin_px,
        norm=math.sqrt(2.0 * math.pi) * sigma,
    )
    return cand, slope, splat


@pytest.mark.parametrize("seed", range(8))
def test_histogram_inputs_equal_their_reference_on_random_candidates(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(40):
        cand, slope, splat = _random_histogram_case(rng)
        _assert_same_inputs(
            histogram_inputs(cand, slope, splat), histogram_inputs_reference(cand, slope, splat)
        )


def test_histogram_inputs_round_half_bins_to_even() -> None:
    # mid disparities 0.5, 1.5, 2.5 and -0.5 (bin 0 at -radius - 3 = -4): ties go to even bins
    cand = Candidates(
        li=np.array([0, 0, 1, 3]),
        rj=np.zeros(4, np.int64),
        rows=np.zeros((4, 2)),
        overlap=np.ones(4),
        disparity=np.array([[0.0, 1.0], [1.0, 2.0], [2.0, 3.0], [-1.0, 0.0]]),
        opposite=np.array([False, True, False, True]),
    )
    splat = Splat(opposite_weight=0.5, sigma_bins=0.3, radius=1, bin_px=1.0, norm=1.0)
    got = histogram_inputs(cand, np.zeros(4), splat)
    _assert_same_inputs(got, histogram_inputs_reference(cand, np.zeros(4), splat))
    assert got.d_base == -4.0
    assert got.bins[:, 1].tolist() == [4, 6, 6, 4]
    assert got.cand_row.tolist() == [0, 0, 1, 2] and got.rows.tolist() == [0, 1, 3]
    np.testing.assert_array_equal(got.scale, [1.0, 0.5, 1.0, 0.5])
