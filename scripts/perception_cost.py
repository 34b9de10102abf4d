"""Evaluate agents on the same suite episodes with each perception: what stereo costs each agent.

    python scripts/perception_cost.py --agent NAME [--agent NAME ...] --episodes N --seed S
        --json FILE [--markdown FILE] [--families F [F ...]] [--max-steps N] [--workers K]

Runs the suite of ``scripts/evaluate.py`` (the same arguments, the same env) once with
``perception="stereo"`` and once with ``"surrogate"``, and writes per agent both summaries and the
paired differences of success and SPL with their 95 % bootstrap intervals
(:mod:`agents.perception_cost`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from evaluate import suite_config

from agents.evaluation import evaluate
from agents.perception_cost import PERCEPTIONS, perception_cost, perception_markdown


def main(argv: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """Parse the arguments, run the suite under each perception, write the outputs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", action="append", required=True, help="agent name (repeat)")
    parser.add_argument("--episodes", type=int, default=32, help="episodes per agent")
    parser.add_argument("--seed", type=int, default=0, help="suite seed")
    parser.add_argument("--json", type=pathlib.Path, required=True, help="output JSON file")
    parser.add_argument("--markdown", type=pathlib.Path, help="Markdown table file")
    parser.add_argument("--families", nargs="+", default=None, help="scene families")
    parser.add_argument("--max-steps", type=int, default=500, help="steps at most per episode")
    parser.add_argument("--workers", type=int, default=1, help="parallel processes")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)

    common = [f"--agent={a}" for a in args.agent]
    common += ["--episodes", str(args.episodes), "--seed", str(args.seed), "--json", "-"]
    common += ["--max-steps", str(args.max_steps)]
    if args.families is not None:
        common += ["--families", *args.families]
    results = {}
    for perception in PERCEPTIONS:
        cfg = suite_config([*common, "--perception", perception])
        results[perception] = evaluate(
            args.agent, cfg, workers=args.workers, progress=not args.no_progress
        )
    cost = perception_cost(results)
    suite = dataclasses.asdict(suite_config(common))
    suite.pop("env_kwargs")
    out = {"suite": suite, "agents": cost}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    table = perception_markdown(cost)
    print(table)
    if args.markdown is not None:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(table)
    return cost


if __name__ == "__main__":
    main()
