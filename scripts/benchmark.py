"""Benchmarks of stereo-nav: rendering, stereo, modeling and the whole env step.

A script that prints figures, not a test: these machines are shared and noisy, so where a speed
target matters the figure is also given as a ratio against a reference measured in the same run.

    python scripts/benchmark.py [--json FILE] [--only render,stereo,modeling,env] [--quick]

The JSON is a flat object of named figures, each name saying its unit (``_ms``, ``_per_s``,
``_ratio``, ``_px``, ``_m``, ``_count``, ``_fraction``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import pathlib
import platform
import sys

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from _figures import print_figures, write_figures

SECTIONS = ("render", "stereo", "modeling", "env")


def machine_description() -> str:
    """A one-line description of the machine the figures were measured on."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument(
        "--only", default=",".join(SECTIONS), help=f"comma-separated sections of {SECTIONS}"
    )
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    args = parser.parse_args(argv)
    wanted = [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = sorted(set(wanted) - set(SECTIONS))
    if unknown:
        parser.error(f"--only: unknown section(s) {unknown}; choose from {SECTIONS}")

    print(f"machine: {machine_description()}")
    figures: dict[str, float] = {}
    for section in wanted:
        module = importlib.import_module(f"bench_{section}")
        print(f"\n== {section}")
        result = module.run(quick=args.quick)
        print_figures(result)
        figures.update(result)
    if args.json:
        write_figures({"machine": machine_description(), **figures}, args.json)
        print(f"\nwrote {args.json}")
    return figures


if __name__ == "__main__":
    main()
