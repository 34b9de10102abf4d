"""What perception costs an agent: the same suite episodes with each perception, paired.

Issue 17's question: how much does the uncertainty of real segment stereo cost a policy, against
the surrogate (:mod:`stereo_nav_env.perception.surrogate.sensor`: the same model built from the true
scene and the stereo's error model)? :func:`perception_cost` takes one agent's results on the same
episodes (the same seeds, so the same scenes, starts and goals) under each perception and gives,
besides each perception's :func:`~agents.evaluation.suite.summarize` figures, the paired differences
``stereo - surrogate`` of success and SPL per episode, with 95 % bootstrap intervals of their
means (:func:`~agents.evaluation.suite.bootstrap_ci`): the pairing removes the spread between
scenes, so the interval is of the perception's effect alone.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from agents.evaluation.suite import EpisodeResult, bootstrap_ci, summarize

__all__ = ["PERCEPTIONS", "perception_cost", "perception_markdown"]

PERCEPTIONS = ("stereo", "surrogate")
"""The env's perceptions, in the order of the comparison (the difference is the first minus the
second)."""


def _paired(
    stereo: Sequence[EpisodeResult], surrogate: Sequence[EpisodeResult], agent: str
) -> tuple[list[float], list[float]]:
    """Per-episode differences ``stereo - surrogate`` of success and SPL, matched by seed."""
    by_seed = {e.seed: e for e in surrogate}
    if sorted(by_seed) != sorted(e.seed for e in stereo) or len(by_seed) != len(surrogate):
        raise ValueError(
            f"results[{agent!r}] must hold the same episodes (seeds) under each perception"
        )
    success = [float(e.success) - float(by_seed[e.seed].success) for e in stereo]
    spl = [e.spl - by_seed[e.seed].spl for e in stereo]
    return success, spl


def perception_cost(
    results: Mapping[str, Mapping[str, Sequence[EpisodeResult]]],
) -> dict[str, dict[str, Any]]:
    """Each agent's figures under each perception and the paired cost of stereo.

    Args:
        results: ``results[perception][agent]``: the episodes of
            :func:`agents.evaluation.suite.evaluate`
            under that perception; both of :data:`PERCEPTIONS`, the same agents and episodes.

    Returns:
        ``{agent: {"stereo": summary, "surrogate": summary, "success_cost": d, "success_cost_ci":
        [lo, hi], "spl_cost": d, "spl_cost_ci": [lo, hi]}}``, where a summary is
        :func:`~agents.evaluation.suite.summarize`'s and ``d`` the mean of ``stereo - surrogate``
        over the paired episodes (positive: stereo does better).
    """
    if sorted(results) != sorted(PERCEPTIONS):
        raise ValueError(f"results must be keyed by {list(PERCEPTIONS)}, got {sorted(results)}")
    stereo, surrogate = (results[p] for p in PERCEPTIONS)
    if sorted(stereo) != sorted(surrogate):
        raise ValueError(
            f"results must hold the same agents under each perception, got {sorted(stereo)} "
            f"and {sorted(surrogate)}"
        )
    out: dict[str, dict[str, Any]] = {}
    for agent in stereo:
        success, spl = _paired(stereo[agent], surrogate[agent], agent)
        out[agent] = {
            "stereo": summarize({agent: stereo[agent]})[agent],
            "surrogate": summarize({agent: surrogate[agent]})[agent],
            "success_cost": float(np.mean(success)) if success else 0.0,
            "success_cost_ci": bootstrap_ci(success),
            "spl_cost": float(np.mean(spl)) if spl else 0.0,
            "spl_cost_ci": bootstrap_ci(spl),
        }
    return out


def perception_markdown(cost: Mapping[str, Mapping[str, Any]]) -> str:
    """A Markdown table of :func:`perception_cost`: per agent, success, collision rate, collision
    steps per episode and SPL as ``stereo / surrogate``, and the paired SPL difference."""
    header = (
        "| agent | episodes | success | collision | collisions / episode | SPL | "
        "SPL stereo - surrogate |\n|---|---|---|---|---|---|---|\n"
    )

    def pair(figures: Mapping[str, Any], key: str, digits: int) -> str:
        a, b = (float(figures[p][key]) for p in PERCEPTIONS)
        return f"{a:.{digits}f} / {b:.{digits}f}"

    rows = []
    for agent, figures in cost.items():
        lo, hi = figures["spl_cost_ci"]
        rows.append(
            f"| {agent} | {figures['stereo']['episodes']} | {pair(figures, 'success_rate', 2)} | "
            f"{pair(figures, 'collision_rate', 2)} | {pair(figures, 'mean_collisions', 2)} | "
            f"{pair(figures, 'spl', 3)} | {figures['spl_cost']:+.3f} [{lo:+.3f}, {hi:+.3f}] |"
        )
    return header + "\n".join(rows) + "\n"
