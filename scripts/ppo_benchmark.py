"""Evaluate trained policies over their training seeds, per family; plot the seeds' curves.

    python scripts/ppo_benchmark.py --run DIR [--run DIR ...] [--families F [F ...]]
        [--episodes N] [--seed S] [--workers K] [--perception P] --json FILE
        [--markdown FILE] [--plot FILE]

Each DIR is a train.py output (its ppo_final.zip, curve.csv, summary.json); every run's policy
plays the same suite episodes of each family (StereoNav-v1 rules, stereo perception by
default). The JSON holds, per family, the mean over seeds with 95 % bootstrap intervals and
each seed's figures, and the runs' training budgets. The logic is in :mod:`agents.learning.seeds`.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.evaluation.suite import SuiteConfig, evaluate
from agents.learning.seeds import plot_seed_curves, seed_summary, seed_table


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Parse the arguments, evaluate every run on every family, write the outputs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", action="append", type=pathlib.Path, required=True)
    parser.add_argument("--families", nargs="+", default=["open", "sparse"])
    parser.add_argument("--episodes", type=int, default=100, help="episodes per family")
    parser.add_argument("--seed", type=int, default=0, help="suite seed")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--perception", choices=("stereo", "surrogate"), default="stereo")
    parser.add_argument("--json", type=pathlib.Path, required=True)
    parser.add_argument("--markdown", type=pathlib.Path)
    parser.add_argument("--plot", type=pathlib.Path, help="learning curves of the seeds (PNG)")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    for run in args.run:
        if not (run / "ppo_final.zip").is_file():
            raise ValueError(f"--run must be a train.py output with ppo_final.zip, got {run}")
    names = {str(run): f"ppo:{run / 'ppo_final.zip'}" for run in args.run}
    kwargs = {"diagnostics": False, "memory": False, "perception": args.perception}
    out: dict[str, Any] = {"families": {}, "training": {}}
    for family in args.families:
        cfg = SuiteConfig(
            episodes=args.episodes, seed=args.seed, families=(family,), env_kwargs=kwargs
        )
        results = evaluate(
            list(names.values()), cfg, workers=args.workers, progress=not args.no_progress
        )
        out["families"][family] = seed_summary({run: results[n] for run, n in names.items()})
    for run in args.run:
        summary = run / "summary.json"
        out["training"][str(run)] = json.loads(summary.read_text()) if summary.is_file() else {}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    table = seed_table({f"PPO / {f}": s for f, s in out["families"].items()})
    print(table)
    if args.markdown is not None:
        args.markdown.write_text(table)
    if args.plot is not None:
        curves = {run.name: run / "curve.csv" for run in args.run if (run / "curve.csv").is_file()}
        plot_seed_curves(curves, args.plot)
    return out


if __name__ == "__main__":
    main()
