"""Environment benchmark: one ``StereoNav-v0`` step against rendering the stereo pair alone.

    python scripts/bench_env.py [--steps N] [--rounds R] [--json FILE] [--quick] [--baseline DIR]

The full step (:data:`FULL_KWARGS`: the default configuration, 320x240, the ``default`` scene,
pixel noise 2 grey levels, with the fused memory on, so that every stage is timed) runs a fixed
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
already), and ``env_stage_<stage>_ms`` for each stage the env times in ``last_timings_ms``
(physics, noise, render, segments, matching, triangulation, modeling, fusion: the view and any
contact fused into the episode's memory, memory_model: the fused model built, packing, rewards,
diagnostics: of both models).

The surrogate row: in every round, the same drive and seed through ``perception="surrogate"``
(:mod:`stereo_nav_env.perception.surrogate.sensor`, nothing rendered) side by side with a second
stereo env (``v0_stereo_env_step_ms``, ``v0_stereo_env_steps_per_s``): ``surrogate_env_step_ms``,
``surrogate_env_steps_per_s`` and ``surrogate_over_stereo_steps_per_s`` (its steps per second
over that stereo env's, per round, then the median). The training pair: the same drive through
the env ``train.py`` builds (``StereoNav-v1``, ``memory=False``, ``diagnostics=False``) with each
perception, ``train_stereo_env_*``, ``train_surrogate_env_*`` and
``train_surrogate_over_stereo_steps_per_s``. The two envs of a pair run side by side, in
alternating blocks of 20 steps (each env its own drive and resets, as if alone), so that both are
timed at the same moments: the machine's speed drifts by tens of percent within seconds, and a
ratio of two envs timed one after the other moves with it.

``--baseline DIR`` compares this checkout's env with another checkout's (DIR, e.g. the code
before a change) in one run: the rounds alternate between the two trees (this, DIR, DIR, this,
this, DIR, ...), each round in a fresh subprocess with its tree first on ``sys.path``, the same
drive and seed for both. It prints each figure for both trees and their ratio (this / DIR); the
JSON has ``<figure>``, ``baseline_<figure>`` and ``<figure>_vs_baseline_ratio``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from typing import TYPE_CHECKING, Any, cast

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np
from _figures import print_figures, write_figures

import stereo_nav_env  # noqa: F401  (registers the ids)

if TYPE_CHECKING:
    from stereo_nav_env.env import StereoNavEnv

ROOT = pathlib.Path(__file__).resolve().parents[1]
"""The checkout this script belongs to."""

BLOCK = 20


def scripted_action(i: int) -> np.ndarray:
    """The drive of step ``i``: forward at 60 %, a slow weave, the head panning side to side."""
    return np.array(
        [0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)],
        dtype=np.float32,
    )


FULL_KWARGS: dict[str, Any] = {"memory": True}
"""The full step: ``StereoNav-v0``'s defaults with the memory on (every stage runs; the default
env's memory was on until issue 40, so checkouts before it measure the same configuration)."""


def one_round(steps: int, seed: int) -> dict[str, float]:
    """The figures of one round of ``steps`` timed steps of the drive, reset with ``seed``."""
    env = gym.make("StereoNav-v0", **FULL_KWARGS)
    base = cast("StereoNavEnv", env.unwrapped)
    step_ms: list[float] = []
    render_ms: list[float] = []
    reset_ms: list[float] = []
    timings: list[dict[str, float]] = []  # the env's stage timings of each step
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
                timings.append(dict(base.last_timings_ms))
                poses.append(base.head_pose)
                i += 1
                if terminated or truncated:
                    t0 = time.perf_counter()
                    env.reset()
                    reset_ms.append((time.perf_counter() - t0) * 1e3)
            # stereo_renderer() is public since the refactor; older checkouts (--baseline) had
            # only the private _get_renderer().
            get_renderer = getattr(base, "stereo_renderer", None) or getattr(
                base, "_get_renderer", None
            )
            assert get_renderer is not None
            renderer = get_renderer()
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
    for name in dict.fromkeys(name for t in timings for name in t):
        out[f"env_stage_{name}_ms"] = statistics.median(t.get(name, 0.0) for t in timings)
    return out


def side_by_side(
    steps: int, seed: int, env_id: str, rows: dict[str, dict[str, Any]]
) -> dict[str, float]:
    """``<prefix>env_step_ms`` and ``<prefix>env_steps_per_s`` of one env per ``rows`` entry
    (``prefix: kwargs``, the env ``gym.make(env_id, **kwargs)``), each driven ``steps`` timed
    steps of the drive (its own resets), the envs in turn for :data:`BLOCK` steps at a time (the
    same moments for all)."""
    envs = [gym.make(env_id, **kw) for kw in rows.values()]
    step_ms: list[list[float]] = [[] for _ in envs]
    try:
        for env in envs:
            env.reset(seed=seed)
            for i in range(5):
                env.step(scripted_action(i))
        for start in range(0, steps, BLOCK):
            for env, times in zip(envs, step_ms, strict=True):
                for i in range(start, min(start + BLOCK, steps)):
                    t0 = time.perf_counter()
                    _, _, terminated, truncated, _ = env.step(scripted_action(i))
                    times.append((time.perf_counter() - t0) * 1e3)
                    if terminated or truncated:
                        env.reset()
    finally:
        for env in envs:
            env.close()
    out: dict[str, float] = {}
    for prefix, times in zip(rows, step_ms, strict=True):
        out[f"{prefix}env_step_ms"] = statistics.median(times)
        out[f"{prefix}env_steps_per_s"] = 1e3 * len(times) / sum(times)
    return out


def surrogate_round(steps: int, seed: int) -> dict[str, float]:
    """The surrogate row of ``steps`` timed steps of the drive: the default env with each
    perception, side by side (``v0_stereo_*``, ``surrogate_*`` and their ratio)."""
    out = side_by_side(
        steps, seed, "StereoNav-v0", {"v0_stereo_": {}, "surrogate_": {"perception": "surrogate"}}
    )
    out["surrogate_over_stereo_steps_per_s"] = (
        out["surrogate_env_steps_per_s"] / out["v0_stereo_env_steps_per_s"]
    )
    return out


TRAINING_KWARGS: dict[str, Any] = {"scenario": "default", "memory": False, "diagnostics": False}
"""The env as ``train.py`` builds it (``StereoNav-v1``, no memory, no diagnostics)."""


def _with_surrogate(stereo: dict[str, float], steps: int, seed: int) -> dict[str, float]:
    """``stereo``'s figures, the surrogate row of the same round, and the training pair: both
    perceptions in the env ``train.py`` builds (``train_stereo_*``, ``train_surrogate_*``)."""
    out = {**stereo, **surrogate_round(steps, seed)}
    out |= side_by_side(
        steps,
        seed,
        "StereoNav-v1",
        {f"train_{p}_": {"perception": p, **TRAINING_KWARGS} for p in ("stereo", "surrogate")},
    )
    out["train_surrogate_over_stereo_steps_per_s"] = (
        out["train_surrogate_env_steps_per_s"] / out["train_stereo_env_steps_per_s"]
    )
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
    return _medians(
        [_with_surrogate(one_round(steps, seed=r), steps, seed=r) for r in range(rounds)]
    )


def _medians(results: list[dict[str, float]]) -> dict[str, float]:
    """Each figure's median over the rounds that have it."""
    names = dict.fromkeys(name for r in results for name in r)
    return {name: statistics.median(r[name] for r in results if name in r) for name in names}


def _round_in(tree: pathlib.Path, steps: int, seed: int) -> dict[str, float]:
    """One round in a fresh subprocess whose ``stereo_nav_env`` (and ``modeling``, ``agents``)
    come from the checkout ``tree``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tree), *filter(None, [env.get("PYTHONPATH")])])
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "round.json"
        command = [sys.executable, __file__, "--steps", str(steps), "--seed", str(seed)]
        subprocess.run([*command, "--round-json", str(out)], env=env, cwd=tree, check=True)
        figures: dict[str, float] = json.loads(out.read_text())
    return figures


def run_against(
    baseline: pathlib.Path, steps: int = 200, rounds: int = 3, *, quick: bool = False
) -> tuple[dict[str, float], dict[str, float]]:
    """The figures of this checkout and of the checkout ``baseline``, measured in one run.

    Round ``r`` (seed ``r``) runs in both trees, this one first when ``r`` is even (so drift of
    the machine's speed weighs on both alike); each round is a fresh subprocess.

    Returns:
        ``(this, baseline)``: each figure's median over the rounds, per tree.
    """
    if not (baseline / "stereo_nav_env" / "__init__.py").is_file():
        raise ValueError(f"--baseline {baseline}: not a checkout (no stereo_nav_env/ package)")
    if quick:
        steps, rounds = 40, 1
    trees = (ROOT, baseline.resolve())
    results: dict[pathlib.Path, list[dict[str, float]]] = {tree: [] for tree in trees}
    for r in range(rounds):
        for tree in trees if r % 2 == 0 else trees[::-1]:
            print(f"round {r + 1}/{rounds}: {tree}", flush=True)
            results[tree].append(_round_in(tree, steps, seed=r))
    return _medians(results[ROOT]), _medians(results[trees[1]])


def compared(this: dict[str, float], baseline: dict[str, float]) -> dict[str, float]:
    """Both trees' figures and their ratios (this / baseline), flat."""
    out = dict(this)
    out.update({f"baseline_{name}": value for name, value in baseline.items()})
    for name in this:
        if name in baseline:
            out[f"{name}_vs_baseline_ratio"] = this[name] / baseline[name]
    return out


def print_comparison(this: dict[str, float], baseline: dict[str, float]) -> None:
    """A table: each figure for this tree, the baseline and their ratio."""
    print(f"  {'figure':<32s} {'this':>10s} {'baseline':>10s} {'ratio':>8s}")
    for name in dict.fromkeys([*this, *baseline]):
        a, b = this.get(name, math.nan), baseline.get(name, math.nan)
        print(f"  {name:<32s} {a:10.4g} {b:10.4g} {a / b:8.3f}")


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Print the figures as a table; write them as JSON with ``--json FILE``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="timed steps per round")
    parser.add_argument("--rounds", type=int, default=3, help="repetitions of the measurement")
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument("--quick", action="store_true", help="40 steps, 1 round (smoke run)")
    parser.add_argument(
        "--baseline", type=pathlib.Path, help="another checkout to measure against, in one run"
    )
    parser.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--round-json", type=pathlib.Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.round_json is not None:  # one round, in a subprocess of --baseline
        figures = _with_surrogate(one_round(args.steps, args.seed), args.steps, args.seed)
        args.round_json.write_text(json.dumps(figures))
        return figures
    if args.baseline is not None:
        this, base = run_against(args.baseline, args.steps, args.rounds, quick=args.quick)
        print_comparison(this, base)
        figures = compared(this, base)
    else:
        figures = run(steps=args.steps, rounds=args.rounds, quick=args.quick)
        print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
