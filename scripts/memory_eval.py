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

* ``p_true_candidate`` / ``memory_p_true_candidate``: mean probability of the true choice of the
  ambiguous segments of the view: the view's own, and the memory's belief in it once the view is
  fused (resolved ambiguities included; :func:`stereo_nav_env.diagnostics.memory_beliefs`),
* ``passability_brier`` / ``memory_passability_brier``: Brier score of the doubtful gaps in view,
* ``coverage_95`` / ``memory_coverage_95``: fraction of endpoints within their 95 % ellipse,

with the steps counted (``*_steps``), and ``memory_open_p_true_candidate``: the fused model's own
figure over the ambiguities it still holds open, over every step that has one (an ambiguity
leaves it when it resolves, at ``resolve_probability`` 0.95, so it measures the ambiguities the
memory could not decide). Issue 16's target: mean ``memory_p_true_candidate`` >= 0.9 and
``memory_passability_brier`` <= ``passability_brier``.
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import statistics
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
from _figures import print_figures, write_figures

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent

PAIRS = ("p_true_candidate", "passability_brier", "coverage_95")
"""The figures compared, single view against the memory."""


def episode_diagnostics(
    seed: int, *, agent_name: str = "oracle", max_steps: int = 300, scenario: str = "office"
) -> list[dict[str, float]]:
    """Every step's ``info["diagnostics"]`` (the reset's first) of one episode of ``seed``."""
    env = gym.make("StereoNav-v0", scenario=scenario, memory=True, max_episode_steps=max_steps)
    agent = make_agent(agent_name)
    try:
        obs, info = env.reset(seed=seed)
        agent.reset(env, seed=seed)
        out = [dict(info["diagnostics"])]
        for _ in range(max_steps):
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            out.append(dict(info["diagnostics"]))
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
    both = [d for d in steps if "memory_p_true_candidate" in d]
    out["view_ambiguities"] = float(sum(d["ambiguous_segments"] for d in both))
    name = "memory_open_p_true_candidate"
    only = [d[name] for d in steps if name in d]
    out[name] = statistics.fmean(only) if only else math.nan
    out[f"{name}_steps"] = float(len(only))
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
    for seed in range(first_seed, first_seed + seeds):
        steps = episode_diagnostics(seed, **kwargs)
        every.extend(steps)
        figures = figures_of(steps)
        per_episode.append(figures)
        print(
            f"seed {seed}: {len(steps)} steps  "
            + "  ".join(f"{n} {figures[n]:.3f}/{figures['memory_' + n]:.3f}" for n in PAIRS),
            flush=True,
        )
    return figures_of(every), per_episode


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
