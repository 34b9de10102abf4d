"""Compare the surrogate perception with the stereo pipeline on the same poses.

    python scripts/compare_perception.py [--family office] [--scenes 4] [--steps 120]
                                         [--json FILE] [--plot FILE] [--surface-detail]

Both envs (``perception="stereo"`` and ``"surrogate"``) are reset with the same seeds and driven
by the same scripted actions, so the robot takes the same poses (the physics does not depend on
perception; a terminated episode restarts from the same seed). Per view: the obstacles and the
critical regions of the most probable situation, the situations, and the diagnostics'
``coverage_95`` (pooled over the endpoints: each view weighs by its ``endpoints``). Printed for
both pipelines with the surrogate's ratio to the stereo's; ``--plot`` draws both pipelines'
``p_passable`` distributions (every critical region of every situation). ``ambiguous_share`` is
the ambiguous segments over all measured floor segments (ambiguous and certain, faces left out),
pooled over the views. ``--surface-detail`` runs both in the world with surface detail
(``EnvConfig.surface_detail``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import sys
import time
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.stereo.faces import FACE_SOURCE

PERCEPTIONS = ("stereo", "surrogate")


def drive_action(i: int) -> np.ndarray:
    """The scripted drive of step ``i`` (forward, a slow weave, the head panning)."""
    return np.array([0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)], dtype=np.float32)


def rollout(
    perception: str, family: str, scenes: int, steps: int, seed: int, surface_detail: bool = False
) -> dict[str, Any]:
    """The per-view figures of ``scenes`` drives of ``steps`` steps with one perception."""
    env = gym.make(
        "StereoNav-v0", scenario=family, perception=perception, surface_detail=surface_detail
    )
    obstacles, regions, situations, ambiguous, segments, faces = [], [], [], [], [], []
    covered, endpoints = 0.0, 0.0
    p_passable: list[float] = []
    poses: list[tuple[float, float, float]] = []
    seconds = 0.0
    try:
        for k in range(scenes):
            env.reset(seed=seed + k)
            for i in range(steps):
                t0 = time.perf_counter()
                _, _, terminated, truncated, info = env.step(drive_action(i))
                seconds += time.perf_counter() - t0
                model = info["model"]
                best = model.situations[0] if model.situations else None
                obstacles.append(len(best.obstacles) if best else 0)
                regions.append(len(best.critical_regions) if best else 0)
                situations.append(len(model.situations))
                ambiguous.append(len(model.observation.ambiguous))
                segs = model.observation.segments
                faces.append(sum(seg.source == FACE_SOURCE for seg in segs))
                segments.append(len(segs) - faces[-1])
                p_passable.extend(
                    r.p_passable for s in model.situations for r in s.critical_regions
                )
                diag = info["diagnostics"]
                if "coverage_95" in diag:
                    covered += diag["coverage_95"] * diag["endpoints"]
                    endpoints += diag["endpoints"]
                poses.append(env.unwrapped.robot_pose)  # type: ignore[attr-defined]
                if terminated or truncated:
                    env.reset(seed=seed + k)
    finally:
        env.close()
    return {
        "obstacles_per_view": float(np.mean(obstacles)),
        "critical_regions_per_view": float(np.mean(regions)),
        "situations_per_view": float(np.mean(situations)),
        "ambiguous_segments_per_view": float(np.mean(ambiguous)),
        "segments_per_view": float(np.mean(segments)),
        "face_segments_per_view": float(np.mean(faces)),
        "ambiguous_share": float(np.sum(ambiguous) / max(1, np.sum(ambiguous) + np.sum(segments))),
        "coverage_95": covered / endpoints if endpoints else math.nan,
        "views": len(obstacles),
        "steps_per_s": len(obstacles) / seconds,
        "p_passable": p_passable,
        "poses": poses,
    }


def plot(results: dict[str, dict[str, Any]], path: pathlib.Path, family: str) -> None:
    """Both pipelines' ``p_passable`` histograms, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    bins = np.linspace(0.0, 1.0, 21).tolist()
    for name, colour in zip(PERCEPTIONS, ("tab:blue", "tab:orange"), strict=True):
        values = np.asarray(results[name]["p_passable"])
        weights = np.full(values.size, 1.0 / results[name]["views"])
        ax.hist(
            values,
            bins=bins,
            weights=weights,
            histtype="step",
            linewidth=2,
            color=colour,
            label=f"{name} ({values.size} regions)",
        )
    ax.set_xlabel("p_passable of a critical region")
    ax.set_ylabel("regions per view")
    ax.set_title(f"p_passable, {family} family, the same poses")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--family", default="office")
    parser.add_argument("--scenes", type=int, default=4)
    parser.add_argument("--steps", type=int, default=120)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=pathlib.Path, default=None)
    parser.add_argument("--plot", type=pathlib.Path, default=None)
    parser.add_argument("--surface-detail", action="store_true")
    args = parser.parse_args(argv)
    results = {
        name: rollout(name, args.family, args.scenes, args.steps, args.seed, args.surface_detail)
        for name in PERCEPTIONS
    }
    stereo, surrogate = results["stereo"], results["surrogate"]
    if stereo["poses"] != surrogate["poses"]:
        print("warning: the two rollouts took different poses", file=sys.stderr)
    figures: dict[str, float] = {}
    print(f"{'figure':<30s} {'stereo':>10s} {'surrogate':>10s} {'ratio':>8s}")
    for name in (
        "obstacles_per_view",
        "critical_regions_per_view",
        "situations_per_view",
        "ambiguous_segments_per_view",
        "segments_per_view",
        "face_segments_per_view",
        "ambiguous_share",
        "coverage_95",
        "steps_per_s",
    ):
        a, b = stereo[name], surrogate[name]
        ratio = b / a if a else math.nan
        print(f"{name:<30s} {a:10.3f} {b:10.3f} {ratio:8.3f}")
        figures[f"stereo_{name}"] = a
        figures[f"surrogate_{name}"] = b
        figures[f"{name}_ratio"] = ratio
    same = stereo["poses"] == surrogate["poses"]
    print(f"views per pipeline: {stereo['views']}, same poses: {same}")
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
    if args.plot is not None:
        plot(results, args.plot, args.family)
    return 0


if __name__ == "__main__":
    sys.exit(main())
