"""Segment-based stereo against rendered ground truth and against OpenCV's StereoSGBM.

    python scripts/bench_stereo.py [--json FILE] [--n-scenes N] [--seed S] [--noise SIGMA] [--quick]

Prints the figures that :mod:`agents.evaluation.stereo_accuracy` defines, measured on 20 seeded
scenes of every family by default, the stage times the median of 5 runs per view (``--quick``: at
most 4 scenes, timed once).
"""

from __future__ import annotations

import argparse
import os
import pathlib

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from _figures import print_figures, write_figures

from agents.evaluation.stereo_accuracy import evaluate, summarise


def run(
    n_scenes: int = 20, *, seed: int = 0, noise_sigma: float = 2.0, quick: bool = False
) -> dict[str, float]:
    """The figures of ``n_scenes`` rendered scenes (at most 4, each timed once, with ``quick``)."""
    if quick:
        n_scenes = min(n_scenes, 4)
    results = evaluate(n_scenes, seed=seed, noise_sigma=noise_sigma, repeats=1 if quick else 5)
    return summarise(results)


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Print the figures as a table; write them as JSON with ``--json FILE``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument("--n-scenes", type=int, default=20, help="seeded scenes (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the scenes and the noise")
    parser.add_argument("--noise", type=float, default=2.0, help="pixel noise sigma, grey levels")
    parser.add_argument("--quick", action="store_true", help="4 scenes, timed once (smoke run)")
    args = parser.parse_args(argv)
    figures = run(args.n_scenes, seed=args.seed, noise_sigma=args.noise, quick=args.quick)
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
