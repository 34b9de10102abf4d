"""The main job (``make demo``): one episode of the planner, as a GIF, a model figure and a summary.

:func:`run_demo` drives the ``planner`` agent through one episode of ``StereoNav-v0`` (collisions
do not end it, so a bump and the recovery are visible), printing one line per step, and writes
into the output folder:

* ``episode.gif``: the environment's ``rgb_array`` frames (the world from above with the model
  overlaid and the left image), every ``frame_every``-th step, halved in size;
* ``model_steps.png``: the model of the latest observation at four moments of the episode, in the
  style of the paper's Figs. 6 and 11 (:func:`modeling.plotting.plot_model`), with the true
  outlines in green;
* ``summary.json``: the episode's figures (success, steps, collisions, looks, path length, the
  true shortest route, SPL, wall time) and the files written.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import pathlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["DemoResult", "run_demo"]


@dataclass(frozen=True, slots=True, kw_only=True)
class DemoResult:
    """What :func:`run_demo` wrote and measured.

    Attributes:
        gif: The animation.
        figure: The model figure.
        summary: The JSON summary file.
        figures: The summary's content.
    """

    gif: pathlib.Path
    figure: pathlib.Path
    summary: pathlib.Path
    figures: dict[str, Any]


def _frame(env: Any) -> NDArray[np.uint8]:
    """The env's ``rgb_array`` frame, or the left image alone where the env draws none."""
    frame = env.render()
    if frame is None:
        frame = env.unwrapped.render_stereo()[0]
    return np.ascontiguousarray(np.asarray(frame, dtype=np.uint8)[::2, ::2])


def run_demo(
    out_dir: str | pathlib.Path,
    *,
    scenario: str = "default",
    seed: int = 0,
    agent_name: str = "planner",
    max_steps: int = 500,
    frame_every: int = 2,
    log: Callable[[str], None] | None = print,
) -> DemoResult:
    """Run one episode and write the GIF, the model figure and the summary.

    Args:
        out_dir: Output folder (created).
        scenario: The env's ``scenario`` (a map name, a ``.json`` map or a family).
        seed: Reset seed (and the agent's).
        agent_name: Registry name of the agent.
        max_steps: Steps at most.
        frame_every: Keep one frame in this many steps for the GIF.
        log: Where the progress lines go (``None``: nowhere).

    Returns:
        The paths written and the figures.
    """
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import gymnasium as gym
    import imageio.v2 as imageio

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from agents import make_agent
    from agents.base import model_of, robot_pose
    from agents.baselines import true_shortest_route

    if frame_every < 1 or max_steps < 1:
        raise ValueError("frame_every and max_steps must be >= 1")
    say = log if log is not None else (lambda _line: None)
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    env = gym.make(
        "StereoNav-v0", scenario=scenario, render_mode="rgb_array", terminate_on_collision=False
    )
    agent = make_agent(agent_name, env)
    frames: list[ArrayLike] = []
    snapshots: list[tuple[int, Any, tuple[float, float, float, float]]] = []
    try:
        obs, info = env.reset(seed=seed)
        agent.reset(env, seed=seed)
        route = true_shortest_route(env)
        base: Any = env.unwrapped
        footprints = base.ground_truth_footprints()
        goal_radius = float(base.config.goal_radius_m)
        reference = math.nan if route is None else max(route.length_m - goal_radius, 1e-6)
        frames.append(_frame(env))
        pose = robot_pose(env)
        snapshots.append((0, model_of(env, info), pose))
        last = np.array(pose[:2])
        path = 0.0
        collisions = 0
        success = False
        steps = 0
        for steps in range(1, max_steps + 1):
            action = agent.act(obs, info)
            decision = getattr(agent, "decision", None)
            mode = decision.mode.value if decision is not None else "escape"
            obs, _, terminated, truncated, info = env.step(action)
            pose = robot_pose(env)
            path += float(np.hypot(pose[0] - last[0], pose[1] - last[1]))
            last = np.array(pose[:2])
            collided = bool(info.get("collision", False))
            collisions += int(collided)
            success = bool(info.get("is_success", False))
            model = model_of(env, info)
            n_regions = len(model.situations[0].critical_regions) if model.situations else 0
            say(
                f"step {steps:4d}  x {pose[0]:5.2f}  y {pose[1]:5.2f}  "
                f"heading {math.degrees(pose[2]):7.1f}  pan {math.degrees(pose[3]):6.1f}  "
                f"{mode:8s} situations {len(model.situations):2d}  regions {n_regions:2d}  "
                f"goal {info.get('distance_to_goal_m', float('nan')):5.2f} m"
                + ("  COLLISION" if collided else "")
            )
            if steps % frame_every == 0 or terminated or truncated:
                frames.append(_frame(env))
            if steps % 10 == 0:
                snapshots.append((steps, model, pose))
            if terminated or truncated:
                snapshots.append((steps, model, pose))
                break
        looks = int(agent.looks)
    finally:
        agent.close()
        env.close()
    gif = out / "episode.gif"
    imageio.mimsave(gif, frames, duration=0.1 * frame_every, loop=0)
    figure = _model_figure(snapshots, footprints, out / "model_steps.png")
    spl = float(reference / max(path, reference)) if success and math.isfinite(reference) else 0.0
    figures: dict[str, Any] = {
        "scenario": scenario,
        "seed": seed,
        "agent": agent_name,
        "success": success,
        "steps": steps,
        "collision_steps": collisions,
        "looks": looks,
        "path_length_m": round(path, 3),
        "shortest_route_m": None if route is None else round(route.length_m, 3),
        "spl": round(spl, 4),
        "frames": len(frames),
        "wall_time_s": round(time.perf_counter() - t0, 2),
        "files": {"gif": gif.name, "figure": figure.name},
    }
    summary = out / "summary.json"
    summary.write_text(json.dumps(figures, indent=2) + "\n")
    say(
        f"{'reached the goal' if success else 'did not reach the goal'} in {steps} steps, "
        f"{collisions} collision step(s), {looks} look(s), {path:.2f} m driven "
        f"(shortest {figures['shortest_route_m']} m), SPL {spl:.3f}"
    )
    return DemoResult(gif=gif, figure=figure, summary=summary, figures=figures)


def _richness(model: Any) -> int:
    """How much a model shows: situations, obstacles and (doubly) critical regions."""
    if not model.situations:
        return 0
    best = model.situations[0]
    return len(model.situations) + len(best.obstacles) + 2 * len(best.critical_regions)


def _pick_snapshots(snapshots: list[tuple[int, Any, Any]], count: int) -> list[int]:
    """Indices of ``count`` snapshots spread over the episode, each the richest of its stretch.

    The episode's snapshots are cut into ``count`` consecutive stretches of equal length; from each
    the one whose model shows the most (:func:`_richness`; the earliest on ties) is taken, so a
    stretch spent facing a plain wall does not give an empty panel when the robot saw more nearby.
    """
    bounds = np.linspace(0, len(snapshots), count + 1).round().astype(int)
    picks = []
    for lo, hi in itertools.pairwise(bounds):
        if hi > lo:
            picks.append(max(range(lo, hi), key=lambda k: (_richness(snapshots[k][1]), -k)))
    return picks


def _model_figure(
    snapshots: list[tuple[int, Any, tuple[float, float, float, float]]],
    footprints: list[NDArray[np.float64]],
    path: pathlib.Path,
) -> pathlib.Path:
    """Four panels: the most probable situation of the model at four moments."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from modeling.plotting import plot_model

    picks = _pick_snapshots(snapshots, 4)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5), squeeze=False)
    pts = np.concatenate([np.asarray(f).reshape(-1, 2) for f in footprints]) if footprints else None
    for ax, k in zip(axes.ravel(), picks, strict=False):
        step, model, pose = snapshots[k]
        if model.situations:
            plot_model(model, ax=ax, ground_truth=footprints)
        ax.plot([pose[0]], [pose[1]], "o", ms=8, mfc="none", mec="m")
        if pts is not None:
            ax.set_xlim(pts[:, 0].min() - 0.2, pts[:, 0].max() + 0.2)
            ax.set_ylim(pts[:, 1].min() - 0.2, pts[:, 1].max() + 0.2)
        ax.set_aspect("equal")
        n = len(model.situations)
        ax.set_title(f"step {step}: {n} situation(s), most probable shown", fontsize=9)
    for ax in axes.ravel()[len(picks) :]:
        ax.set_visible(False)
    fig.suptitle("The model of the latest observation (obstacles, critical regions with p)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
