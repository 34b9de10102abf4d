"""The main job: one episode of the expected-cost planner, as a GIF, a model figure and a summary.

    python scripts/demo.py [--scenario NAME] [--seed N] [--out DIR]

Writes ``episode.gif``, ``model_steps.png`` and ``summary.json`` into ``--out`` (default
``out/demo``), printing one line per step. The logic is in :mod:`agents.evaluation.demo`.
"""

from __future__ import annotations

import argparse
import os
import pathlib

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
from agents.evaluation.demo import DemoResult, run_demo


def main(argv: list[str] | None = None) -> DemoResult:
    """Parse the arguments and run the demo episode."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="default", help="map name, .json path or family")
    parser.add_argument("--seed", type=int, default=0, help="seed of the episode")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/demo"))
    parser.add_argument("--agent", default="planner", help="agent name (default: planner)")
    parser.add_argument("--max-steps", type=int, default=500, help="steps at most")
    args = parser.parse_args(argv)
    result = run_demo(
        args.out,
        scenario=args.scenario,
        seed=args.seed,
        agent_name=args.agent,
        max_steps=args.max_steps,
    )
    for name, path in (("gif", result.gif), ("figure", result.figure), ("summary", result.summary)):
        print(f"{name:>8s}: {path}")
    return result


if __name__ == "__main__":
    main()
