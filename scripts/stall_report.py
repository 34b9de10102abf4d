"""Why an agent stalls or detours: per episode of the suite, its outcome and wasteful patterns.

    python scripts/stall_report.py [--agent NAME] --episodes N [--seed S] [--only I [I ...]]
        [--json FILE] [--families F [F ...]] [--max-steps N]

Runs episodes of the suite of ``scripts/evaluate.py`` (the same env, seeds and rules; dev split by
default) one by one with a model-based agent and prints, per episode, the counts of
:func:`agents.evaluation.stall.stall_patterns` (revisits, route flips, gate retries, back-offs,
stalls, lost progress, looks, approaches). ``--only`` runs those episode indices alone.
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from evaluate import add_suite_arguments, add_trace_arguments, chosen_episodes, suite_of

from agents.evaluation.stall import stall_patterns, trace_episode


def main(argv: list[str] | None = None) -> list[dict[str, object]]:
    """Trace the chosen episodes, print one line each, write the JSON asked for."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", default="planner", help="greedy, cautious or planner")
    add_suite_arguments(parser)
    add_trace_arguments(parser, json_help="per-episode JSON file")
    args = parser.parse_args(argv)
    cfg = suite_of(parser, args, env_kwargs={"diagnostics": False, "perception": args.perception})
    rows = []
    for spec in chosen_episodes(cfg, args.only):
        row = {"index": spec.index, **stall_patterns(trace_episode(args.agent, spec, cfg))}
        rows.append(row)
        print(json.dumps(row), flush=True)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return rows


if __name__ == "__main__":
    main()
