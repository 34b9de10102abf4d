"""Issue 3 acceptance on rendered scenes: 20 seeded scenes (every family, start views and views of
bookshelf fronts), 320x240, Gaussian pixel noise (sigma 2 grey levels), ground truth from the
renderer's depth and the scenes' obstacle footprints. The measuring code and the definitions of the
figures are in :mod:`agents.evaluation.stereo_accuracy` (``scripts/bench_stereo.py`` prints the same
figures). Speed is a benchmark figure only: wall-clock time under a parallel test run is not
deterministic.

Definitions in short (see that module's docstring):

* a match is *correct* when its disparity is within 1 px of the truth at the midpoint;
* an ambiguous left segment's true partner is *available* when a segment of the right image's
  extraction, paired with it, passes the matching constraints (``match_candidates``: before the
  histograms decide) and is correct. "Included when available" therefore measures the histogram
  decision only, not whether the right image happens to contain the partner;
* calibration: across-outline errors of floor endpoints over the standard deviation their
  covariance gives (within 1.96: ideal 95 %), and the 2-D NEES of the endpoints of vertical
  obstacle edges, whose true floor point is the rendered part's corner (ideal mean 2, 95 % below
  5.99), over the correct matches.
"""

from __future__ import annotations

import pytest

from agents.evaluation.stereo_accuracy import evaluate, summarise


@pytest.fixture(scope="module")
def figures() -> dict[str, float]:
    return summarise(evaluate(20, seed=0, noise_sigma=2.0, sgbm=False, repeats=1))


def test_enough_views_and_matches(figures: dict[str, float]) -> None:
    assert figures["stereo_views_count"] >= 20
    assert figures["stereo_certain_matches_count"] >= 500


def test_certain_matches_are_within_one_pixel(figures: dict[str, float]) -> None:
    assert figures["stereo_certain_within_1px_fraction"] >= 0.95


def test_ambiguous_segments_include_the_true_candidate(figures: dict[str, float]) -> None:
    # among left segments whose true partner passed the constraints (was a candidate)
    assert figures["stereo_ambiguous_true_available_count"] >= 100
    assert figures["stereo_ambiguous_true_included_when_available_fraction"] >= 0.95
    # over all ambiguous left segments, partners missing from the right image included
    assert figures["stereo_ambiguous_true_included_fraction"] >= 0.9


def test_bookshelves_produce_ambiguous_segments(figures: dict[str, float]) -> None:
    assert figures["stereo_ambiguous_segments_bookshelf_count"] >= 20


def test_floor_endpoints_are_calibrated_across_outlines(figures: dict[str, float]) -> None:
    assert figures["stereo_outline_endpoints_count"] >= 300
    assert 0.90 <= figures["stereo_outline_within_1p96_fraction"] <= 0.98
    assert 0.90 <= figures["stereo_outline_correct_within_1p96_fraction"] <= 0.98


def test_nees_of_correct_matches_is_near_two(figures: dict[str, float]) -> None:
    # neither over-confident (NEES >> 2) nor far too cautious (NEES << 2)
    assert figures["stereo_nees_correct_endpoints_count"] >= 300
    assert 1.0 <= figures["stereo_nees_mean_correct_matches"] <= 3.0
    assert 0.90 <= figures["stereo_nees_within_5p99_correct_fraction"] <= 0.99
