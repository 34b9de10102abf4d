"""Environment benchmark: one ``StereoNav-v0`` step against rendering the stereo pair alone.

    python scripts/bench_env.py [--steps N] [--rounds R] [--json FILE] [--quick]

The default configuration (320x240, the ``default`` scene, pixel noise 2 grey levels) runs a fixed
scripted drive (forward with a slow weave, the head panning side to side; reset on termination).
Steps are timed in blocks of 20; after each block the env's own renderer renders the 20 head poses
of that block again, alone, so the pair render time is measured in the same run, on the same
views, at the same moments (the machine is shared and its speed drifts). ``rounds`` repeats the
whole measurement; each figure is the median over rounds of the per-round medians.

Figures (flat, units in the names): ``env_step_ms`` (median wall time of ``env.step`` through the
``gym.make`` wrappers) and ``env_step_p90_ms`` (its 90th percentile), ``env_steps_per_s`` (steps
over their total time: slow outliers, such as views with many situations or the machine's other
jobs, weigh in), ``env_steps_per_s_at_median`` (1000 / ``env_step_ms``), ``env_render_pair_ms``
(the pair alone, same poses), ``env_step_over_render_ratio`` (step / pair, per round, then the
median), ``env_reset_ms`` (a reset of the fixed map, its OpenGL context and distance field made
already), and ``env_stage_<stage>_ms`` for each stage the env times
(``physics``, ``noise`` (the grey images plus their noise), ``render`` (the pair; the pixel noise
is drawn meanwhile in the worker thread), ``segments`` (both images), ``matching``,
``triangulation``, ``modeling``
(``build_model``), ``packing``, ``rewards``, ``diagnostics``).
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import statistics
import sys
import time

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import gymnasium as gym
import numpy as np
from _figures import print_figures, write_figures

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.env import STAGES

BLOCK = 20


def scripted_action(i: int) -> np.ndarray:
    """The drive of step ``i``: forward at 60 %, a slow weave, the head panning side to side."""
    return np.array(
        [0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)],
        dtype=np.float32,
    )


def _round(steps: int, seed: int) -> dict[str, float]:
    env = gym.make("StereoNav-v0")
    base = env.unwrapped
    step_ms: list[float] = []
    render_ms: list[float] = []
    reset_ms: list[float] = []
    stages: dict[str, list[float]] = {name: [] for name in STAGES}
    try:
        env.reset(seed=seed)  # the first reset also makes the OpenGL context: not timed
        for i in range(5):  # warm up (first-call costs, the passive checker)
            env.step(scripted_action(i))
        i = 0
        while i < steps:
            poses = []
            for _ in range(min(BLOCK, steps - i)):
                t0 = time.perf_counter()
                _, _, terminated, truncated, _ = env.step(scripted_action(i))
                step_ms.append((time.perf_counter() - t0) * 1e3)
                for name in STAGES:
                    stages[name].append(base.last_timings_ms.get(name, 0.0))
                poses.append(base.head_pose)
                i += 1
                if terminated or truncated:
                    t0 = time.perf_counter()
                    env.reset()
                    reset_ms.append((time.perf_counter() - t0) * 1e3)
            renderer = base._get_renderer()
            for pose in poses:
                t0 = time.perf_counter()
                renderer.render_stereo(pose)
                render_ms.append((time.perf_counter() - t0) * 1e3)
        for _ in range(5):
            t0 = time.perf_counter()
            env.reset()
            reset_ms.append((time.perf_counter() - t0) * 1e3)
    finally:
        env.close()
    step = statistics.median(step_ms)
    render = statistics.median(render_ms)
    out = {
        "env_step_ms": step,
        "env_step_p90_ms": float(np.percentile(step_ms, 90)),
        "env_steps_per_s": 1e3 * len(step_ms) / sum(step_ms),
        "env_steps_per_s_at_median": 1e3 / step,
        "env_render_pair_ms": render,
        "env_step_over_render_ratio": step / render,
        "env_reset_ms": statistics.median(reset_ms),
    }
    for name, values in stages.items():
        out[f"env_stage_{name}_ms"] = statistics.median(values)
    return out


def run(steps: int = 200, rounds: int = 3, *, quick: bool = False) -> dict[str, float]:
    """The figures of the module docstring, keyed by name.

    Args:
        steps: Timed steps per round (after 5 warm-up steps).
        rounds: Repetitions of the whole measurement.
        quick: Smoke run: 40 steps, 1 round.
    """
    if steps < 1 or rounds < 1:
        raise ValueError(f"steps and rounds must be positive, got {steps}, {rounds}")
    if quick:
        steps, rounds = 40, 1
    results = [_round(steps, seed=r) for r in range(rounds)]
    return {name: statistics.median(r[name] for r in results) for name in results[0]}


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Print the figures as a table; write them as JSON with ``--json FILE``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="timed steps per round")
    parser.add_argument("--rounds", type=int, default=3, help="repetitions of the measurement")
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument("--quick", action="store_true", help="40 steps, 1 round (smoke run)")
    args = parser.parse_args(argv)
    figures = run(steps=args.steps, rounds=args.rounds, quick=args.quick)
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
