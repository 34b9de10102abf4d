"""The paired comparison of perceptions (issue 17: what perception costs each agent)."""

from __future__ import annotations

import dataclasses

import pytest

from agents.evaluation.perception_cost import perception_cost, perception_markdown
from agents.evaluation.suite import EpisodeResult, summarize
from tests.agents.episodes import episode


def _episode(seed: int, *, success: bool, spl: float, collisions: int = 0) -> EpisodeResult:
    return episode(seed, success=success, spl=spl, collisions=collisions)


def test_the_cost_is_the_mean_paired_difference_matched_by_seed() -> None:
    stereo = [_episode(1, success=True, spl=0.8), _episode(2, success=False, spl=0.0)]
    # the surrogate's episodes in another order: pairing goes by seed, not by position
    surrogate = [
        _episode(2, success=True, spl=0.9, collisions=3),
        _episode(1, success=True, spl=0.6),
    ]
    cost = perception_cost({"stereo": {"greedy": stereo}, "surrogate": {"greedy": surrogate}})
    g = cost["greedy"]
    assert g["spl_cost"] == pytest.approx(((0.8 - 0.6) + (0.0 - 0.9)) / 2)
    assert g["success_cost"] == pytest.approx(-0.5)
    assert g["stereo"] == summarize({"greedy": stereo})["greedy"]
    assert g["surrogate"]["mean_collisions"] == pytest.approx(1.5)
    lo, hi = g["spl_cost_ci"]
    assert lo <= g["spl_cost"] <= hi
    table = perception_markdown(cost)
    assert (
        "| greedy | 2 | 0.50 / 1.00 | 0.00 / 0.50 | 0.00 / 1.50 | 0.400 / 0.750 | -0.350" in table
    )


def test_identical_results_cost_nothing() -> None:
    eps = [_episode(s, success=s % 2 == 0, spl=0.1 * s) for s in range(6)]
    cost = perception_cost({"stereo": {"a": eps}, "surrogate": {"a": list(eps)}})
    assert cost["a"]["spl_cost"] == 0.0 and cost["a"]["spl_cost_ci"] == [0.0, 0.0]


def test_mismatched_results_are_refused_naming_what_differs() -> None:
    eps = [_episode(1, success=True, spl=0.5)]
    other = [dataclasses.replace(eps[0], seed=7)]
    with pytest.raises(ValueError, match="same episodes"):
        perception_cost({"stereo": {"a": eps}, "surrogate": {"a": other}})
    with pytest.raises(ValueError, match="same agents"):
        perception_cost({"stereo": {"a": eps}, "surrogate": {"b": eps}})
    with pytest.raises(ValueError, match="keyed by"):
        perception_cost({"stereo": {"a": eps}})
