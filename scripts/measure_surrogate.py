"""Measure the stereo pipeline against the true scene, and write the surrogate's rates.

    python scripts/measure_surrogate.py [--scenes N] [--steps N] [--seed S] [--out FILE]
                                        [--dry-run]

The method is :mod:`stereo_nav_env.perception.surrogate.calibration`'s docstring. Run it twice after
a change to the surrogate, so that the figures stored for the surrogate are those of the rates
written.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.perception.surrogate.calibration import calibrate
from stereo_nav_env.perception.surrogate.rates import RATES_FILE

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    """Parse the arguments, measure, print the table and write it (unless ``--dry-run``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--scenes", type=int, default=3, help="scenes per family")
    parser.add_argument("--steps", type=int, default=40, help="steps of each drive")
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        default=ROOT / "stereo_nav_env" / "perception" / "surrogate" / "data" / RATES_FILE,
        help="the rates table to write",
    )
    parser.add_argument("--dry-run", action="store_true", help="print, write nothing")
    args = parser.parse_args(argv)
    table = calibrate(args.scenes, args.steps, args.seed)
    text = json.dumps(table, indent=2) + "\n"
    print(text)
    if not args.dry_run:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
