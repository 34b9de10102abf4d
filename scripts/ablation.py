"""Does modeling the uncertainty pay? Agents on the suite under each perception (issue 43).

    python scripts/ablation.py [--agent NAME ...] [--perception P ...] [--episodes N]
        [--split dev|test] [--seed S] [--families F [F ...]] [--max-steps N] [--workers K]
        [--out DIR] [--step-steps N] [--step-scenario FAMILY] [--view-scenario NAME]
        [--view-seed N] [--view-steps N] [--no-progress]

Runs the evaluation suite of ``scripts/evaluate.py`` (the same options for the episodes, the split
and the seed; ``--agent`` default ``planner`` and ``greedy``) once per perception (``--perception``,
default ``stereo``, ``stereo_means``, ``dense``, ``truth``), times each perception's env step over
one scripted drive (``--step-steps`` steps in ``--step-scenario``, seed ``--view-seed``), and
writes to ``--out`` (default ``out/ablation``):

* ``ablation.json``: per agent and perception, success rate, SPL, collision rate and collision
  steps per episode with 95 % bootstrap intervals, and each perception's mean step time;
* ``ablation.md``: the Markdown table (also printed);
* ``ablation_plot.png``: the table as bars (one panel per figure, groups by perception);
* ``ablation_views.png``: what each perception sees of one view (``--view-scenario``, seed
  ``--view-seed``, after ``--view-steps`` scripted steps);
* ``ablation_details.json``: every episode.

The logic is in :mod:`agents.evaluation.ablation`; docs/ablation.md describes the method.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from evaluate import add_suite_arguments, suite_of

from agents.evaluation.ablation import (
    ABLATION_PERCEPTIONS,
    ablation_markdown,
    ablation_summary,
    perception_step_times,
    plot_ablation,
    plot_views,
    run_ablation,
)
from agents.evaluation.suite import episode_records
from stereo_nav_env.perception.base import PerceptionName

DEFAULT_AGENTS = ("planner", "greedy")


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Parse the arguments, run the ablation, print its table, write its files; returns the
    summary (the JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--agent",
        action="append",
        default=None,
        help="agent name (repeat; default: planner, greedy)",
    )
    parser.add_argument(
        "--perception",
        action="append",
        default=None,
        choices=[p.value for p in PerceptionName],
        help=f"perception (repeat; default: {', '.join(ABLATION_PERCEPTIONS)})",
    )
    add_suite_arguments(parser)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/ablation"))
    parser.add_argument("--step-steps", type=int, default=100, help="timed steps per perception")
    parser.add_argument("--step-scenario", default="office", help="the timed drive's family")
    parser.add_argument("--view-scenario", default="default", help="the figure's map or family")
    parser.add_argument("--view-seed", type=int, default=0, help="the figure's and drive's seed")
    parser.add_argument("--view-steps", type=int, default=0, help="scripted steps before it")
    args = parser.parse_args(argv)
    cfg = suite_of(parser, args, env_kwargs={"diagnostics": False})
    agents = args.agent or list(DEFAULT_AGENTS)
    perceptions = args.perception or list(ABLATION_PERCEPTIONS)

    results = run_ablation(
        agents, perceptions, cfg, workers=args.workers, progress=not args.no_progress
    )
    step_ms = perception_step_times(
        perceptions, scenario=args.step_scenario, seed=args.view_seed, steps=args.step_steps
    )
    summary = ablation_summary(results, step_ms, cfg)
    table = ablation_markdown(summary)
    print(table)
    out: pathlib.Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    (out / "ablation.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "ablation.md").write_text(table)
    details = [
        {"perception": p, **record}
        for p, by_agent in results.items()
        for record in episode_records(by_agent)
    ]
    (out / "ablation_details.json").write_text(json.dumps(details, indent=1) + "\n")
    plot_ablation(summary, out / "ablation_plot.png")
    plot_views(
        perceptions,
        out / "ablation_views.png",
        scenario=args.view_scenario,
        seed=args.view_seed,
        steps=args.view_steps,
    )
    return summary


if __name__ == "__main__":
    main()
