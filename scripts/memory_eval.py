"""The fused model against the model of one view, driving past bookshelves (issue 16's figure).

    python scripts/memory_eval.py [--seeds N] [--first-seed S] [--agent NAME] [--max-steps N]
                                  [--json FILE]

Each seed is one episode of ``StereoNav-v0`` in the ``office`` family (a partition with two
doorways, a bookshelf beside a box beyond it, chairs, tables; a new scene per seed), driven by
the ``oracle`` agent by default: the true shortest route to the goal, followed with the head
level, so the drive does not depend on either model and both are measured on the same views.
Every step's ``info["diagnostics"]`` holds the single-view figures and the fused model's
(``memory_<name>``); a figure is averaged over the steps that have both it and its memory twin
(the same steps), so the two means compare like with like:

* ``p_true_candidate`` / ``memory_p_true_candidate``: mean probability of the true candidate of
  the ambiguous segments (the single view's in that view; the memory's among those still open),
* ``passability_brier`` / ``memory_passability_brier``: Brier score of the doubtful gaps in view,
* ``coverage_95`` / ``memory_coverage_95``: fraction of endpoints within their 95 % ellipse,

with the steps counted (``*_steps``), and ``memory_only_p_true_candidate`` over every step the
memory has an open ambiguity (also those the view has none). Issue 16's target: mean
``memory_p_true_candidate`` >= 0.9 and ``memory_passability_brier`` <= ``passability_brier``.

``memory_p_true_candidate`` counts only the ambiguities still open: one the memory resolves (a
candidate or the none mass at ``resolve_probability``, 0.95) leaves the figure, so it measures the
ambiguities the memory could not decide, and it moves with the resolve threshold as much as with
the evidence. Beside it, over every ambiguity of every view (``view_ambiguities``),
``view_p_true_candidate`` is the view's probability of the true choice and
``memory_view_p_true_candidate`` the memory's after fusing that view, resolved ones included: the
largest existence (at least ``report_existence``) of a remembered segment, or probability of an
open candidate, within the association gate of the true candidate; for an ambiguity with no true
candidate, 1 minus the largest such belief over its candidates.
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import statistics
from typing import TYPE_CHECKING, Any, cast

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np
from _figures import print_figures, write_figures
from scipy.stats import chi2

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from modeling.memory import ModelMemory
from modeling.memory_association import gated_pairs, stack_of
from modeling.records import EnvironmentModel
from stereo_nav_env.diagnostics import GroundTruth, normalised_outline_errors

if TYPE_CHECKING:
    from stereo_nav_env.env import StereoNavEnv

PAIRS = ("p_true_candidate", "passability_brier", "coverage_95")
"""The figures compared, single view against the memory."""


_ON_OUTLINE = float(chi2.ppf(0.99, 2))  # the diagnostics' test of a candidate on a true outline


def view_beliefs(
    model: EnvironmentModel, memory: ModelMemory, truth: GroundTruth, gate_chi2: float
) -> list[tuple[float, float]]:
    """``(view's, memory's)`` probability of the true choice of each ambiguity of ``model``'s
    view (see the module docstring), the truth chosen as :mod:`stereo_nav_env.diagnostics` does."""
    segs = memory.segment_arrays
    cands = memory.candidate_arrays
    assert segs is not None and cands is not None
    existence = np.asarray(memory.existence)
    reported = existence >= memory.report_existence
    out: list[tuple[float, float]] = []
    for amb in model.observation.ambiguous:
        st = stack_of(list(amb.candidates))
        z = normalised_outline_errors(st.ends.reshape(-1, 2), st.cov.reshape(-1, 2, 2), truth.edges)
        score = (z**2).reshape(-1, 2).mean(axis=1)
        best = int(np.argmin(score))
        real = bool(score[best] <= _ON_OUTLINE)
        belief = np.zeros(len(amb.candidates))
        for ends, cov, p in (
            (segs.ends[reported], segs.cov[reported], existence[reported]),
            (cands.stack.ends, cands.stack.cov, cands.prob),
        ):
            pairs = gated_pairs(st.ends, st.cov, ends, cov, gate_chi2)
            np.maximum.at(belief, pairs.rows, p[pairs.cols])
        view = amb.probabilities[best] if real else amb.p_none
        out.append((view, float(belief[best]) if real else 1.0 - float(belief.max())))
    return out


def episode_diagnostics(
    seed: int,
    *,
    agent_name: str = "oracle",
    max_steps: int = 300,
    scenario: str = "office",
    beliefs: list[tuple[float, float]] | None = None,
) -> list[dict[str, float]]:
    """Every step's ``info["diagnostics"]`` (the reset's first) of one episode of ``seed``; each
    step's :func:`view_beliefs` appended to ``beliefs`` when given."""
    env = gym.make("StereoNav-v0", scenario=scenario, max_episode_steps=max_steps)
    base = cast("StereoNavEnv", env.unwrapped)
    agent = make_agent(agent_name)

    def note(info: dict[str, Any]) -> None:
        if beliefs is not None:
            assert base.memory is not None  # the env fuses every view (memory=True)
            beliefs.extend(view_beliefs(info["model"], base.memory, truth, gate))

    try:
        obs, info = env.reset(seed=seed)
        world = base.config.world
        assert base.scene is not None
        truth = GroundTruth.of(base.scene, world.robot_width_m, max_height_m=world.robot_height_m)
        gate = base.memory_options.gate_chi2
        agent.reset(env, seed=seed)
        out = [dict(info["diagnostics"])]
        note(info)
        for _ in range(max_steps):
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            out.append(dict(info["diagnostics"]))
            note(info)
            if terminated or truncated:
                break
    finally:
        agent.close()
        env.close()
    return out


def figures_of(steps: list[dict[str, float]]) -> dict[str, float]:
    """The figures of the module docstring from per-step diagnostics."""
    out: dict[str, float] = {"steps": float(len(steps))}
    for name in PAIRS:
        both = [d for d in steps if name in d and f"memory_{name}" in d]
        out[f"{name}_steps"] = float(len(both))
        out[name] = statistics.fmean(d[name] for d in both) if both else math.nan
        out[f"memory_{name}"] = (
            statistics.fmean(d[f"memory_{name}"] for d in both) if both else math.nan
        )
    only = [d["memory_p_true_candidate"] for d in steps if "memory_p_true_candidate" in d]
    out["memory_only_p_true_candidate"] = statistics.fmean(only) if only else math.nan
    out["memory_only_p_true_candidate_steps"] = float(len(only))
    return out


def run(
    seeds: int = 8, first_seed: int = 1000, **kwargs: Any
) -> tuple[dict[str, float], list[dict[str, float]]]:
    """The figures over ``seeds`` episodes (seeds ``first_seed``, ``first_seed + 1``, ...).

    Returns:
        ``(figures over all steps of all episodes, each episode's figures)``.
    """
    if seeds < 1:
        raise ValueError(f"seeds must be positive, got {seeds}")
    per_episode: list[dict[str, float]] = []
    every: list[dict[str, float]] = []
    beliefs: list[tuple[float, float]] = []
    for seed in range(first_seed, first_seed + seeds):
        steps = episode_diagnostics(seed, beliefs=beliefs, **kwargs)
        every.extend(steps)
        figures = figures_of(steps)
        per_episode.append(figures)
        print(
            f"seed {seed}: {len(steps)} steps  "
            + "  ".join(f"{n} {figures[n]:.3f}/{figures['memory_' + n]:.3f}" for n in PAIRS),
            flush=True,
        )
    figures = figures_of(every)
    figures["view_ambiguities"] = float(len(beliefs))
    for k, name in enumerate(("view_p_true_candidate", "memory_view_p_true_candidate")):
        figures[name] = statistics.fmean(b[k] for b in beliefs) if beliefs else math.nan
    return figures, per_episode


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Print the figures (single view / memory per seed, then over all); ``--json`` writes them."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="episodes (one scene each)")
    parser.add_argument("--first-seed", type=int, default=1000, help="seed of the first episode")
    parser.add_argument("--agent", default="oracle", help="agent that drives (default: oracle)")
    parser.add_argument("--max-steps", type=int, default=300, help="steps per episode at most")
    parser.add_argument("--scenario", default="office", help="family or map (default: office)")
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    figures, _ = run(
        args.seeds,
        args.first_seed,
        agent_name=args.agent,
        max_steps=args.max_steps,
        scenario=args.scenario,
    )
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
