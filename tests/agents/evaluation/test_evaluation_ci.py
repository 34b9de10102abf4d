"""The 95 % bootstrap intervals of the benchmark: known samples, fixed seeds, the summary keys."""

from __future__ import annotations

import numpy as np

from agents.evaluation.suite import bootstrap_ci


def test_a_constant_sample_has_a_point_interval() -> None:
    assert bootstrap_ci([1.0] * 40) == [1.0, 1.0]
    assert bootstrap_ci([0.0] * 7) == [0.0, 0.0]
    assert bootstrap_ci([]) == [0.0, 0.0]


def test_a_50_50_sample_interval_holds_one_half_inside_the_unit_interval() -> None:
    lo, hi = bootstrap_ci([1.0, 0.0] * 50)
    assert 0.0 <= lo < 0.5 < hi <= 1.0
    # the normal approximation of the 95 % interval of a proportion: 0.5 +- 1.96 * 0.05
    assert abs(lo - 0.402) < 0.02 and abs(hi - 0.598) < 0.02


def test_a_fixed_seed_gives_a_fixed_interval_and_another_seed_may_differ() -> None:
    values = np.random.default_rng(1).random(30).tolist()
    assert bootstrap_ci(values, seed=3) == bootstrap_ci(values, seed=3)
    lo, hi = bootstrap_ci(values)
    assert lo < float(np.mean(values)) < hi
