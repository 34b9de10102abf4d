"""Soak test: long random driving, create/close cycles and vector envs; leaks and hangs.

    python scripts/soak.py [--steps 10000] [--cycles 1000] [--vector-rounds 5] [--json FILE]

Prints a Markdown table (resident memory and open descriptors after a warm-up and at the end of
each phase, iteration times, whether the phase finished before its deadline) and exits non-zero
when a phase hung, grew by more than ``--max-rss-growth-mb`` or gained descriptors. The logic is
in :mod:`agents.evaluation.soak`.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.evaluation.soak import create_close_cycles, format_table, random_steps, vector_steps


def main(argv: list[str] | None = None) -> int:
    """Run the phases, print the table, write the JSON; the exit status (0: no leak, no hang)."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--steps", type=int, default=10_000, help="random steps in one env")
    parser.add_argument("--cycles", type=int, default=1_000, help="create/step/close cycles")
    parser.add_argument("--vector-rounds", type=int, default=5, help="AsyncVectorEnv rounds")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--deadline-s", type=float, default=3600.0, help="per phase")
    parser.add_argument("--max-rss-growth-mb", type=float, default=30.0)
    parser.add_argument("--json", type=pathlib.Path, help="write the figures here")
    args = parser.parse_args(argv)
    for name in ("steps", "cycles", "vector_rounds"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1")
    results = [
        random_steps(args.steps, seed=args.seed, deadline_s=args.deadline_s),
        create_close_cycles(args.cycles, seed=args.seed, deadline_s=args.deadline_s),
        vector_steps(args.vector_rounds, seed=args.seed, deadline_s=args.deadline_s),
    ]
    print(format_table(results))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([r.as_dict() for r in results], indent=2) + "\n")
    bad = [
        r.phase
        for r in results
        if not r.finished or r.rss_growth_mb > args.max_rss_growth_mb or r.fd_growth > 0
    ]
    if bad:
        print(f"FAILED: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
