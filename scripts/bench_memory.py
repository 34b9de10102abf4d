"""Benchmark of the fused model memory: the time of one ``fuse`` on a realistic sequence of views.

    python scripts/bench_memory.py [--steps N] [--scenario NAME] [--seed S] [--rounds R]
                                   [--synthetic] [--json FILE] [--cache FILE]

The sequence is recorded once: ``StereoNav-v0`` (``scenario``, default ``office``, collisions not
terminating) runs the scripted drive of ``bench_env.py`` (forward with a slow weave, the head
panning) for ``steps`` steps and keeps each step's ``info["model"].observation`` (a
``FloorObservation``, world frame). With ``--synthetic`` (no renderer needed) the views are
generated instead: a robot driving along x and seeing 30 segments and 2 ambiguous ones ahead,
half of them seen again (with small noise) in the next view. Then, ``rounds`` times, the whole
sequence is fused into an empty memory (``--cache FILE``: the views are read from that pickle
when it exists, written to it otherwise), each ``fuse`` timed; and ``build_memory_model`` is timed
on the memory of every tenth view.

Figures: ``memory_fuse_ms`` (median over rounds of the per-round median of one fuse, wall
time), ``memory_fuse_p90_ms``, ``memory_fuse_cpu_ms`` (the same in process CPU time: less
sensitive to a shared machine's other jobs), ``single_view_model_ms`` (``build_model`` on each
view, timed beside each fuse: the env's single-view modeling stage) and
``memory_fuse_over_single_model_ratio`` (per round, then the median),
``memory_build_model_ms`` (median of ``build_memory_model``),
``view_segments_mean`` (unambiguous segments per view), ``view_ambiguous_mean``,
``memory_segments_mean`` and ``memory_segments_max`` (remembered segments over the sequence),
``memory_ambiguous_mean``, ``memory_seen_vertices_max``.
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import pickle
import statistics
import sys
import time

import numpy as np
import shapely
from _figures import print_figures, write_figures

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

from modeling import (
    AmbiguousSegment,
    FloorObservation,
    FloorSegment,
    ModelMemory,
    build_memory_model,
    build_model,
    fuse,
)


def scripted_action(i: int) -> np.ndarray:
    """The drive of ``bench_env.py``: forward at 60 %, a slow weave, the head panning."""
    return np.array([0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)], dtype=np.float32)


def recorded_views(steps: int, scenario: str, seed: int) -> list[FloorObservation]:
    """The observations of ``steps`` steps of the scripted drive in the env (reset at the end of
    an episode)."""
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)

    env = gym.make(
        "StereoNav-v0", scenario=scenario, terminate_on_collision=False, diagnostics=False
    )
    views: list[FloorObservation] = []
    try:
        _, info = env.reset(seed=seed)
        views.append(info["model"].observation)
        for i in range(steps - 1):
            _, _, terminated, truncated, info = env.step(scripted_action(i))
            views.append(info["model"].observation)
            if terminated or truncated:
                break  # one episode: the memory is of one scene
    finally:
        env.close()
    return views


def synthetic_views(steps: int, seed: int) -> list[FloorObservation]:
    """Views of a robot driving along x: 30 segments and 2 ambiguous ones ahead, half of the
    segments seen again (with 1 cm noise) in the next view."""
    rng = np.random.default_rng(seed)
    cov = np.tile(np.diag([0.05**2, 0.02**2]), (2, 1, 1))
    views: list[FloorObservation] = []
    previous = np.zeros((0, 2, 2))
    for k in range(steps):
        x = 0.1 * k
        fresh = rng.uniform([x + 2, -2.5], [x + 7, 2.5], size=(30 - previous.shape[0], 2))
        ends = np.concatenate(
            [previous, np.stack([fresh, fresh + rng.normal(0, 0.3, fresh.shape)], 1)]
        )
        ends = ends + rng.normal(0.0, 0.01, ends.shape)
        segs = tuple(FloorSegment(endpoints=e, cov=cov) for e in ends)
        ambs = tuple(
            AmbiguousSegment(
                candidates=(
                    FloorSegment(endpoints=np.array([p, p + 0.3]), cov=cov),
                    FloorSegment(endpoints=np.array([p + 1.0, p + 1.4]), cov=cov),
                ),
                probabilities=(0.6, 0.4),
            )
            for p in rng.uniform([x + 2, -2], [x + 5, 2], size=(2, 2))
        )
        views.append(
            FloorObservation(segments=segs, ambiguous=ambs, viewpoint=np.array([x, 0.0, 0.0]))
        )
        previous = ends[:15]
    return views


def measure(views: list[FloorObservation], rounds: int) -> dict[str, float]:
    """The figures (see the module docstring)."""
    fuse_medians, fuse_p90, fuse_cpu, single, build_ms = [], [], [], [], []
    sizes, amb_sizes, vertices = [], [], []
    for r in range(rounds):
        memory = ModelMemory.empty()
        times, cpu, single_times = [], [], []
        for k, obs in enumerate(views):
            t0, c0 = time.perf_counter(), time.process_time()
            memory = fuse(memory, obs)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            t0 = time.perf_counter()
            build_model(obs, 0.5)
            single_times.append(time.perf_counter() - t0)
            if r == 0:
                sizes.append(len(memory.segments))
                amb_sizes.append(len(memory.ambiguous))
                vertices.append(shapely.get_num_coordinates(memory.seen))
                if k % 10 == 9:
                    t0 = time.perf_counter()
                    build_memory_model(memory, 0.5)
                    build_ms.append(time.perf_counter() - t0)
        fuse_medians.append(1e3 * statistics.median(times))
        fuse_cpu.append(1e3 * statistics.median(cpu))
        single.append(1e3 * statistics.median(single_times))
        fuse_p90.append(1e3 * float(np.percentile(times, 90)))
    return {
        "memory_fuse_ms": statistics.median(fuse_medians),
        "memory_fuse_p90_ms": statistics.median(fuse_p90),
        "memory_fuse_cpu_ms": statistics.median(fuse_cpu),
        "single_view_model_ms": statistics.median(single),
        "memory_fuse_over_single_model_ratio": statistics.median(
            f / m for f, m in zip(fuse_medians, single, strict=True)
        ),
        "memory_build_model_ms": 1e3 * statistics.median(build_ms) if build_ms else math.nan,
        "view_segments_mean": float(np.mean([len(v.segments) for v in views])),
        "view_ambiguous_mean": float(np.mean([len(v.ambiguous) for v in views])),
        "memory_segments_mean": float(np.mean(sizes)),
        "memory_segments_max": float(np.max(sizes)),
        "memory_ambiguous_mean": float(np.mean(amb_sizes)),
        "memory_seen_vertices_max": float(np.max(vertices)),
        "views": float(len(views)),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--scenario", default="office")
    parser.add_argument("--seed", type=int, default=16)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--synthetic", action="store_true")
    parser.add_argument("--json", type=pathlib.Path, default=None)
    parser.add_argument(
        "--cache", type=pathlib.Path, default=None, help="pickle of the views: read, or written"
    )
    args = parser.parse_args(argv)
    if args.cache is not None and args.cache.exists():
        views = pickle.loads(args.cache.read_bytes())
    elif args.synthetic:
        views = synthetic_views(args.steps, args.seed)
    else:
        views = recorded_views(args.steps, args.scenario, args.seed)
    if args.cache is not None and not args.cache.exists():
        args.cache.write_bytes(pickle.dumps(views))
    figures = measure(views, args.rounds)
    source = "synthetic" if args.synthetic else f"{args.scenario} seed {args.seed}"
    if args.cache is not None:
        source = f"{source}, views of {args.cache}"
    print(f"fuse over {len(views)} views ({source}), {args.rounds} rounds")
    print_figures(figures)
    write_figures(figures, args.json)


if __name__ == "__main__":
    main()
