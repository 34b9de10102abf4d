"""How a learned policy drives against its teacher: per episode of the suite, and by outcome.

    python scripts/student_report.py [--agent NAME] --episodes N [--split dev|test] [--seed S]
        [--perception P] [--teacher T] [--teacher-setting NAME=VALUE ...] [--workers K]
        [--only I [I ...]] [--json FILE] [--families F [F ...]] [--max-steps N]

Runs episodes of the suite of ``scripts/evaluate.py`` (the same env, seeds and rules; dev split by
default) with a learned agent (``learned``: the shipped policy, or ``learned:PATH``) while a
teacher whose memory follows the student's trajectory labels every state, and prints, per
episode, the figures of :func:`agents.evaluation.student.student_patterns` (steps on the spot,
turn flips, turns opposite to the teacher's, forward excess, contacts, geodesic distances), then
their means over the successful and the failed episodes. ``--only`` runs those episode indices.
``--teacher-setting`` changes a field of the teacher's ``NavigatorConfig`` (repeatable); with a
model-based ``--agent`` (``planner``) the report compares two teachers on the same drives, e.g.
``--agent planner --teacher-setting replan_every=1``: how much of the planner's command depends
on when it last planned.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np
from evaluate import (
    add_navigator_settings,
    add_suite_arguments,
    add_trace_arguments,
    chosen_episodes,
    navigator_settings,
    suite_of,
)

from agents.evaluation.student import student_patterns, trace_student
from agents.evaluation.suite import EpisodeSpec, SuiteConfig

MEANS = (
    "steps",
    "in_place_share",
    "turn_flips_per_100",
    "opposite_turn_share",
    "forward_excess",
    "collision_steps",
    "geodesic_min_m",
    "geodesic_end_m",
    "last_radius_m",
)
"""The figures averaged by outcome."""


def _row(job: tuple[str, str, dict[str, Any], EpisodeSpec, SuiteConfig]) -> dict[str, Any]:
    agent, teacher, settings, spec, cfg = job
    trace = trace_student(agent, spec, cfg, teacher=teacher, teacher_settings=settings)
    return {"index": spec.index, **student_patterns(trace)}


def by_outcome(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """The mean of each of :data:`MEANS` over the successful and over the failed ``rows``
    (``{"success": {...}, "failed": {...}}``, each with its ``episodes``)."""
    out: dict[str, dict[str, float]] = {}
    for name, success in (("success", True), ("failed", False)):
        chosen = [r for r in rows if r["success"] == success]
        means = {k: float(np.nanmean([r[k] for r in chosen])) for k in MEANS} if chosen else {}
        out[name] = {"episodes": float(len(chosen)), **means}
    return out


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    """Trace the chosen episodes, print one line each and the means, write the JSON asked for."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", default="learned", help="learned or learned:PATH")
    parser.add_argument("--teacher", default="planner", help="planner, greedy or cautious")
    add_navigator_settings(parser, "--teacher-setting", "the teacher's")
    add_suite_arguments(parser)
    add_trace_arguments(parser, json_help="per-episode and mean JSON file")
    args = parser.parse_args(argv)
    cfg = suite_of(parser, args, env_kwargs={"diagnostics": False, "perception": args.perception})
    settings = navigator_settings(parser, args.teacher_setting)
    specs = chosen_episodes(cfg, args.only)
    jobs = [(args.agent, args.teacher, settings, spec, cfg) for spec in specs]
    if args.workers == 1:
        rows = [_row(job) for job in jobs]
    else:
        with multiprocessing.get_context("forkserver").Pool(args.workers) as pool:
            rows = pool.map(_row, jobs, chunksize=1)
    for row in rows:
        print(json.dumps(row), flush=True)
    means = by_outcome(rows)
    for name, figures in means.items():
        print(name, json.dumps({k: round(v, 3) for k, v in figures.items()}))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"episodes": rows, "by_outcome": means}, indent=1) + "\n")
    return rows


if __name__ == "__main__":
    main()
