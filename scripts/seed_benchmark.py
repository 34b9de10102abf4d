"""Evaluate trained policies over their training seeds, per family and pooled, beside baselines.

    python scripts/seed_benchmark.py --run DIR [--run DIR ...] [--baseline NAME ...]
        [--families F [F ...]] [--episodes N] [--split dev|test] [--seed S] [--workers K]
        [--perception P] --json FILE [--markdown FILE] [--plot FILE]

Each DIR is a train.py output: PPO's (``ppo_final.zip``) or the imitation recipe's
(``policy.pt``, ``train.py --teacher planner``); every run's policy and every ``--baseline``
agent (``greedy``, ``planner``, ...) play the same suite episodes of each family (``--episodes``
per family; StereoNav-v1 rules, stereo perception by default). ``--split``/``--seed`` choose the
suite seed as in ``evaluate.py`` (the test split for reported figures). The JSON holds, per
family and pooled over the families, the mean over seeds with 95 % bootstrap intervals and each
seed's figures (:func:`agents.learning.seeds.seed_summary`), the baselines' summaries on the same
episodes, and the runs' training records. ``--plot`` draws the runs' learning curves (rolling
success of the training episodes) with the band over seeds.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.evaluation.suite import (
    EpisodeResult,
    Split,
    SuiteConfig,
    default_seed,
    evaluate,
    split_of,
    suite_rules,
    summarize,
)
from agents.learning.seeds import plot_seed_curves, seed_summary, seed_table

STANDARD = ("room", "corridor", "cluttered", "office")


def agent_of_run(run: pathlib.Path) -> str:
    """The registry name of a train.py output folder's policy.

    Raises:
        ValueError: When ``run`` holds neither ``policy.pt`` nor ``ppo_final.zip``.
    """
    if (run / "policy.pt").is_file():
        return f"learned:{run / 'policy.pt'}"
    if (run / "ppo_final.zip").is_file():
        return f"ppo:{run / 'ppo_final.zip'}"
    raise ValueError(f"--run must be a train.py output (policy.pt or ppo_final.zip), got {run}")


def _training_record(run: pathlib.Path) -> dict[str, Any]:
    for name in ("record.json", "summary.json"):
        if (run / name).is_file():
            record: dict[str, Any] = json.loads((run / name).read_text())
            return record
    return {}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Parse the arguments, evaluate every run and baseline on every family, write the outputs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", action="append", type=pathlib.Path, required=True)
    parser.add_argument("--baseline", action="append", default=[], help="agent name (repeat)")
    parser.add_argument("--families", nargs="+", default=list(STANDARD))
    parser.add_argument("--episodes", type=int, default=16, help="episodes per family")
    parser.add_argument("--split", choices=[s.value for s in Split], default=Split.DEV.value)
    parser.add_argument("--seed", type=int, default=None, help="suite seed (within the split)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--perception", choices=("stereo", "surrogate"), default="stereo")
    parser.add_argument("--json", type=pathlib.Path, required=True)
    parser.add_argument("--markdown", type=pathlib.Path)
    parser.add_argument("--plot", type=pathlib.Path, help="learning curves of the seeds (PNG)")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    seed = default_seed(args.split) if args.seed is None else args.seed
    if split_of(seed).value != args.split:
        parser.error(f"--seed {seed} is a {split_of(seed).value} seed, not of --split {args.split}")
    names = {str(run): agent_of_run(run) for run in args.run}
    kwargs = {"diagnostics": False, "memory": False, "perception": args.perception}
    per_family: dict[str, dict[str, list[EpisodeResult]]] = {}
    out: dict[str, Any] = {"families": {}, "baselines": {}, "training": {}}
    for family in args.families:
        cfg = SuiteConfig(episodes=args.episodes, seed=seed, families=(family,), env_kwargs=kwargs)
        agents = [*names.values(), *args.baseline]
        per_family[family] = evaluate(
            agents, cfg, workers=args.workers, progress=not args.no_progress
        )
        results = per_family[family]
        out["families"][family] = seed_summary({run: results[n] for run, n in names.items()})
        out["baselines"][family] = summarize({b: results[b] for b in args.baseline})
        out["rules"] = suite_rules(cfg)
    pooled = {
        name: [e for family in args.families for e in per_family[family][name]]
        for name in [*names.values(), *args.baseline]
    }
    out["families"]["pooled"] = seed_summary({run: pooled[n] for run, n in names.items()})
    out["baselines"]["pooled"] = summarize({b: pooled[b] for b in args.baseline})
    out["split"], out["suite_seed"] = split_of(seed).value, seed
    for run in args.run:
        out["training"][str(run)] = _training_record(run)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2) + "\n")
    rows = {f"learned / {f}": s for f, s in out["families"].items()}
    for family, summary in out["baselines"].items():
        for name, s in summary.items():
            rows[f"{name} / {family}"] = {
                "seeds": 1,
                "episodes": s["episodes"],
                "success_rate": s["success_rate"],
                "success_rate_ci": s["success_rate_ci"],
                "per_seed": {name: s},
                "spl": s["spl"],
                "collision_rate": s["collision_rate"],
                "collision_steps": s["mean_collisions"],
            }
    table = seed_table(rows)
    print(table)
    if args.markdown is not None:
        args.markdown.write_text(table)
    if args.plot is not None:
        curves = {run.name: run / "curve.csv" for run in args.run if (run / "curve.csv").is_file()}
        plot_seed_curves(curves, args.plot, title="training success of the driving policy")
    return out


if __name__ == "__main__":
    main()
