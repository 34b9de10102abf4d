"""Does modeling the uncertainty pay? The closed-loop ablation of issue 43.

The same agents on the same suite episodes (:mod:`agents.evaluation.suite`: the same seeds, so the
same scenes, starts and goals) under each perception of the ablation
(:data:`ABLATION_PERCEPTIONS`): ``stereo`` (the paper's model: uncertain endpoints, ambiguous
matches, situations), ``stereo_means`` (the same segments at face value), ``dense`` (OpenCV's
semi-global matching into an occupancy grid) and ``truth`` (the true visible outlines). Only
``perception=`` changes between the runs (:func:`run_ablation`).

:func:`ablation_summary` gives, per agent and perception, the suite's success rate, SPL, collision
rate and collision steps per episode, each with its 95 % bootstrap interval
(:func:`~agents.evaluation.suite.bootstrap_ci`), beside each perception's mean env step time
(:func:`perception_step_times`: ``env.step`` timed over one fixed scripted drive
(:func:`drive_action`) of one scene, each perception in turn, in the same process).
:func:`ablation_markdown` writes the table, :func:`plot_ablation` its plot (one panel per figure,
groups by perception, bars by agent, the intervals as error bars) and :func:`plot_views` what each
perception sees of one view (its floor segments with their 2-sigma ellipses and the most probable
situation's obstacles and critical regions, :func:`modeling.plotting.plot_models`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from agents.evaluation.suite import (
    ENV_ID,
    EpisodeResult,
    SuiteConfig,
    bootstrap_ci,
    evaluate,
    split_of,
    suite_rules,
    summarize,
)

__all__ = [
    "ABLATION_PERCEPTIONS",
    "METRICS",
    "ablation_markdown",
    "ablation_summary",
    "drive_action",
    "perception_step_times",
    "plot_ablation",
    "plot_views",
    "run_ablation",
]

ABLATION_PERCEPTIONS = ("stereo", "stereo_means", "dense", "truth")
"""The perceptions of the ablation, in the order of its table."""

METRICS = (
    ("success_rate", "success"),
    ("spl", "SPL"),
    ("collision_rate", "collision rate"),
    ("mean_collisions", "collision steps / episode"),
)
"""The summary's figures that the table and the plot show, ``(key, label)``; each has its 95 %
interval under ``key + "_ci"``."""


def _check_perceptions(perceptions: Sequence[str]) -> list[str]:
    from stereo_nav_env.perception.base import PerceptionName

    names = list(dict.fromkeys(perceptions))
    known = [p.value for p in PerceptionName]
    bad = [p for p in names if p not in known]
    if not names or bad:
        raise ValueError(
            f"perceptions must be a non-empty list of {known}, got {list(perceptions)}"
        )
    return names


def run_ablation(
    agent_names: Sequence[str],
    perceptions: Sequence[str],
    cfg: SuiteConfig,
    *,
    workers: int = 1,
    progress: bool = True,
) -> dict[str, dict[str, list[EpisodeResult]]]:
    """Every agent on every episode of the suite under each perception.

    Args:
        agent_names: Registry names (``"planner"``, ``"greedy"``, ...).
        perceptions: Perception names (:class:`~stereo_nav_env.perception.base.PerceptionName`
            values).
        cfg: The suite; its ``env_kwargs`` must not set ``perception`` (each run sets its own).
        workers: Parallel processes of each run (:func:`~agents.evaluation.suite.evaluate`).
        progress: Show a progress bar per perception.

    Returns:
        ``{perception: {agent: [EpisodeResult, ...]}}`` in suite order.

    Raises:
        ValueError: An unknown perception, or ``cfg.env_kwargs`` holding ``perception``.
    """
    names = _check_perceptions(perceptions)
    if "perception" in cfg.env_kwargs:
        raise ValueError("cfg.env_kwargs must not hold 'perception' (each run sets its own)")
    return {
        p: evaluate(agent_names, _with_perception(cfg, p), workers=workers, progress=progress)
        for p in names
    }


def _with_perception(cfg: SuiteConfig, perception: str) -> SuiteConfig:
    return dataclasses.replace(cfg, env_kwargs={**cfg.env_kwargs, "perception": perception})


def drive_action(i: int) -> np.ndarray:
    """The scripted drive of step ``i``: forward at 0.6, a slow weave, the head panning."""
    return np.array([0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)], dtype=np.float32)


def perception_step_times(
    perceptions: Sequence[str],
    *,
    scenario: str = "office",
    seed: int = 0,
    steps: int = 100,
    warmup: int = 5,
    rounds: int = 2,
    env_kwargs: Mapping[str, Any] | None = None,
) -> dict[str, float]:
    """The mean wall time of ``env.step`` under each perception, milliseconds.

    Each perception's env (``StereoNav-v1`` with ``env_kwargs``) is reset with ``seed`` in
    ``scenario``, stepped ``warmup`` times (compilation, the OpenGL context), reset again and
    driven by :func:`drive_action` for ``steps`` timed steps (an episode that ends is reset with
    the same seed, untimed): the same poses for every perception (the physics does not depend
    on it). The perceptions take turns over ``rounds`` rounds, so that a change of load on the
    machine falls on all of them; the figure is the mean over all timed steps.

    Raises:
        ValueError: An unknown perception or a count below 1 (``warmup``: below 0).
    """
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)

    names = _check_perceptions(perceptions)
    for name, value, low in (("steps", steps, 1), ("warmup", warmup, 0), ("rounds", rounds, 1)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    kwargs = {"diagnostics": False, **(env_kwargs or {}), "scenario": scenario}
    envs = {p: gym.make(ENV_ID, **{**kwargs, "perception": p}) for p in names}
    seconds: dict[str, list[float]] = {p: [] for p in names}
    try:
        for env in envs.values():
            env.reset(seed=seed)
            for i in range(warmup):
                env.step(drive_action(i))
        for _ in range(rounds):
            for p, env in envs.items():
                env.reset(seed=seed)
                for i in range(steps):
                    t0 = time.perf_counter()
                    _, _, terminated, truncated, _ = env.step(drive_action(i))
                    seconds[p].append(time.perf_counter() - t0)
                    if terminated or truncated:
                        env.reset(seed=seed)
    finally:
        for env in envs.values():
            env.close()
    return {p: 1e3 * float(np.mean(s)) for p, s in seconds.items()}


def ablation_summary(
    results: Mapping[str, Mapping[str, Sequence[EpisodeResult]]],
    step_ms: Mapping[str, float],
    cfg: SuiteConfig,
) -> dict[str, Any]:
    """The JSON of the ablation.

    Args:
        results: ``results[perception][agent]`` (:func:`run_ablation`): the same agents and
            episodes under each perception.
        step_ms: The mean env step time of each perception, milliseconds
            (:func:`perception_step_times`).
        cfg: The suite the results come from (the perception aside).

    Returns:
        ``{"suite": {...}, "step_ms": {perception: ms}, "results": {agent: {perception:
        figures}}}``: the suite's episodes, split, seed, families and rules; per agent and
        perception :func:`~agents.evaluation.suite.summarize`'s figures and the interval of the
        collision steps per episode (``mean_collisions_ci``).

    Raises:
        ValueError: The perceptions of ``results`` and ``step_ms`` differ, or their agents or
            episodes differ between perceptions.
    """
    perceptions = list(results)
    if sorted(perceptions) != sorted(step_ms):
        raise ValueError(
            f"step_ms must have one figure per perception {perceptions}, got {sorted(step_ms)}"
        )
    agents = list(results[perceptions[0]]) if perceptions else []
    out: dict[str, dict[str, Any]] = {agent: {} for agent in agents}
    for p in perceptions:
        if list(results[p]) != agents:
            raise ValueError(
                f"results[{p!r}] must hold the agents {agents}, got {list(results[p])}"
            )
        for agent in agents:
            episodes = list(results[p][agent])
            seeds = [e.seed for e in episodes]
            if seeds != [e.seed for e in results[perceptions[0]][agent]]:
                raise ValueError(f"results[{p!r}][{agent!r}] must hold the same episodes")
            figures = summarize({agent: episodes})[agent]
            figures["mean_collisions_ci"] = bootstrap_ci([e.collision_steps for e in episodes])
            out[agent][p] = figures
    return {
        "suite": {
            "env_id": ENV_ID,
            "episodes": cfg.episodes,
            "split": split_of(cfg.seed).value,
            "suite_seed": cfg.seed,
            "families": list(cfg.families),
            "max_steps": cfg.max_steps,
            "rules": suite_rules(cfg),
        },
        "step_ms": {p: float(step_ms[p]) for p in perceptions},
        "results": out,
    }


def _with_ci(figures: Mapping[str, Any], key: str, digits: int) -> str:
    lo, hi = figures[f"{key}_ci"]
    return f"{float(figures[key]):.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def ablation_markdown(summary: Mapping[str, Any]) -> str:
    """A Markdown table of :func:`ablation_summary`: one row per agent and perception, the four
    figures of :data:`METRICS` with their 95 % intervals and the perception's step time."""
    header = (
        "| agent | perception | episodes | success | SPL | collision rate | "
        "collision steps / episode | step (ms) |\n|---|---|---|---|---|---|---|---|\n"
    )
    rows = [
        f"| {agent} | {p} | {f['episodes']} | {_with_ci(f, 'success_rate', 2)} | "
        f"{_with_ci(f, 'spl', 3)} | {_with_ci(f, 'collision_rate', 2)} | "
        f"{_with_ci(f, 'mean_collisions', 2)} | {summary['step_ms'][p]:.1f} |"
        for agent, by_perception in summary["results"].items()
        for p, f in by_perception.items()
    ]
    return header + "\n".join(rows) + "\n"


def plot_ablation(summary: Mapping[str, Any], path: str | pathlib.Path) -> pathlib.Path:
    """The table of :func:`ablation_summary` as bars, written to ``path`` (PNG).

    One panel per figure of :data:`METRICS` and one of the step time; in each, a group per
    perception and a bar per agent, the 95 % interval as an error bar.
    """
    from matplotlib.figure import Figure

    results = summary["results"]
    agents = list(results)
    perceptions = list(summary["step_ms"])
    x = np.arange(len(perceptions))
    width = 0.8 / max(len(agents), 1)
    fig = Figure(figsize=(4.2 * (len(METRICS) + 1), 4.2))
    axes = fig.subplots(1, len(METRICS) + 1)
    for ax, (key, label) in zip(axes, METRICS, strict=False):
        for k, agent in enumerate(agents):
            values = np.array([float(results[agent][p][key]) for p in perceptions])
            ci = np.array([results[agent][p][f"{key}_ci"] for p in perceptions], dtype=float)
            err = np.stack([values - ci[:, 0], ci[:, 1] - values])
            offset = (k - (len(agents) - 1) / 2) * width
            ax.bar(x + offset, values, width, yerr=np.maximum(err, 0.0), capsize=3, label=agent)
        ax.set_title(label)
        ax.set_xticks(x, perceptions, rotation=20)
        if key != "mean_collisions":
            ax.set_ylim(0.0, 1.05)
        ax.grid(axis="y", alpha=0.3)
    step = axes[-1]
    step.bar(x, [float(summary["step_ms"][p]) for p in perceptions], 0.6, color="0.55")
    step.set_title("env step (ms)")
    step.set_xticks(x, perceptions, rotation=20)
    step.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper left")
    suite = summary["suite"]
    fig.suptitle(
        f"Ablation of the uncertainty model: {suite['episodes']} episodes per cell, "
        f"{suite['split']} split (suite seed {suite['suite_seed']}), 95 % intervals"
    )
    fig.tight_layout()
    out = pathlib.Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    return out


def plot_views(
    perceptions: Sequence[str],
    path: str | pathlib.Path,
    *,
    scenario: str = "default",
    seed: int = 0,
    steps: int = 0,
    env_kwargs: Mapping[str, Any] | None = None,
) -> pathlib.Path:
    """What each perception sees of one view, one panel each, written to ``path`` (PNG).

    Each perception's env (``StereoNav-v1``) is reset with ``seed`` in ``scenario`` and driven
    ``steps`` steps of :func:`drive_action` (the same pose for every perception); each panel
    draws its model of that view (:func:`modeling.plotting.plot_models`: the floor segments
    with their 2-sigma endpoint ellipses, the candidates of ambiguous segments, the most
    probable situation's obstacles and critical regions) over the true outlines, on common axes.
    """
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from modeling.plotting import plot_models

    names = _check_perceptions(perceptions)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
        raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
    kwargs = {"diagnostics": False, **(env_kwargs or {}), "scenario": scenario}
    models, poses = [], []
    outlines: list[np.ndarray] = []
    for p in names:
        env = gym.make(ENV_ID, **{**kwargs, "perception": p})
        try:
            env.reset(seed=seed)
            for i in range(steps):
                _, _, terminated, truncated, _ = env.step(drive_action(i))
                if terminated or truncated:
                    break
            base: Any = env.unwrapped
            models.append(base.model)
            poses.append(base.robot_pose)
            outlines = base.ground_truth_footprints()
        finally:
            env.close()
    if any(not np.allclose(pose, poses[0]) for pose in poses):
        raise RuntimeError(f"the perceptions' drives ended at different poses: {poses}")
    fig = plot_models(models, titles=names, ground_truth=outlines, number_obstacles=False)
    out = pathlib.Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    return out
