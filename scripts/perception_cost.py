"""Evaluate agents on the same suite episodes with each perception: what stereo costs each agent.

    python scripts/perception_cost.py --agent NAME [--agent NAME ...] --episodes N --seed S
        --json FILE [--markdown FILE] [--families F [F ...]] [--max-steps N] [--workers K]
    python scripts/perception_cost.py --agent NAME [...] --from-details STEREO SURROGATE --json FILE

Runs the suite of ``scripts/evaluate.py`` (the same arguments, the same env) once with
``perception="stereo"`` and once with ``"surrogate"``, and writes per agent both summaries and the
paired differences of success and SPL with their 95 % bootstrap intervals
(:mod:`agents.evaluation.perception_cost`). ``--from-details`` runs nothing: it pairs the
per-episode files that two ``scripts/evaluate.py --details FILE`` runs wrote, one with
``--perception stereo`` and one with ``--perception surrogate`` (run them at once on two cores),
with the same suite arguments.
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

from agents.evaluation.perception_cost import PERCEPTIONS, perception_cost, perception_markdown
from agents.evaluation.suite import EpisodeResult, evaluate


def _read_details(path: pathlib.Path, agents: list[str]) -> dict[str, list[EpisodeResult]]:
    """The episodes of ``agents`` in an ``evaluate.py --details`` file."""
    records = json.loads(path.read_text())
    out = {a: [EpisodeResult(**r) for r in records if r["agent"] == a] for a in agents}
    missing = [a for a, eps in out.items() if not eps]
    if missing:
        raise ValueError(f"--from-details {path} holds no episodes of {missing}")
    return out


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
    parser.add_argument(
        "--from-details",
        nargs=2,
        type=pathlib.Path,
        metavar=("STEREO", "SURROGATE"),
        help="pair two evaluate.py --details files instead of running the suite",
    )
    args = parser.parse_args(argv)

    common = [f"--agent={a}" for a in args.agent]
    common += ["--episodes", str(args.episodes), "--seed", str(args.seed), "--json", "-"]
    common += ["--max-steps", str(args.max_steps)]
    if args.families is not None:
        common += ["--families", *args.families]
    results: dict[str, dict[str, list[EpisodeResult]]] = {}
    if args.from_details is not None:
        for perception, path in zip(PERCEPTIONS, args.from_details, strict=True):
            results[perception] = _read_details(path, args.agent)
        suite: Any = {"details": [str(p) for p in args.from_details]}
    else:
        for perception in PERCEPTIONS:
            cfg = suite_config([*common, "--perception", perception])
            results[perception] = evaluate(
                args.agent, cfg, workers=args.workers, progress=not args.no_progress
            )
        suite = dataclasses.asdict(suite_config(common))
        suite.pop("env_kwargs")
    cost = perception_cost(results)
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
