"""Results over training seeds: one summary per family and a learning-curve band.

A trained agent's figure is the mean over its training seeds, each seed's policy evaluated on
the same suite episodes. :func:`seed_summary` gives, per family, the mean success rate, SPL and
collision rate over the seeds, each seed's own figures, and 95 % bootstrap intervals of the
pooled episodes (``scipy.stats.bootstrap`` through
:func:`agents.evaluation.suite.bootstrap_ci`; with equal episodes per seed the pooled mean is the
mean of the seeds' means). :func:`plot_seed_curves` draws each seed's rolling training success rate
and the band from the lowest to the highest seed.
"""

from __future__ import annotations

import csv
import itertools
import pathlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from agents.evaluation.suite import EpisodeResult, bootstrap_ci

__all__ = ["plot_seed_curves", "seed_summary", "seed_table"]


def seed_summary(per_seed: Mapping[str, Sequence[EpisodeResult]]) -> dict[str, Any]:
    """The figures of one agent on one family over its training seeds.

    Args:
        per_seed: ``{seed label: that seed's episodes}`` (the same suite episodes each).

    Returns:
        ``seeds``, ``episodes`` (per seed), ``success_rate``, ``spl``, ``collision_rate`` (means
        over the seeds), their ``*_ci`` (pooled episodes) and ``per_seed`` (each seed's three).

    Raises:
        ValueError: No seeds, or seeds with different numbers of episodes.
    """
    if not per_seed:
        raise ValueError("per_seed must hold at least one seed")
    counts = {len(eps) for eps in per_seed.values()}
    if len(counts) != 1 or 0 in counts:
        raise ValueError(f"per_seed must hold the same, non-zero episode count each, got {counts}")
    out: dict[str, Any] = {"seeds": len(per_seed), "episodes": counts.pop(), "per_seed": {}}
    for label, eps in per_seed.items():
        out["per_seed"][label] = {k: float(np.mean(_values(eps, k))) for k in _KEYS}
    pooled = [e for eps in per_seed.values() for e in eps]
    for key in _KEYS:
        out[key] = float(np.mean([s[key] for s in out["per_seed"].values()]))
        out[f"{key}_ci"] = bootstrap_ci(_values(pooled, key))
    return out


_KEYS = {
    "success_rate": "success",
    "spl": "spl",
    "collision_rate": "collided",
    "collision_steps": "collision_steps",
}


def _values(episodes: Sequence[EpisodeResult], key: str) -> list[float]:
    """The per-episode values behind the figure ``key`` of :data:`_KEYS`."""
    return [float(getattr(e, _KEYS[key])) for e in episodes]


def seed_table(rows: Mapping[str, Mapping[str, Any]]) -> str:
    """A Markdown table: one row per ``{label: seed_summary}``, the seeds' successes listed."""
    lines = [
        "| agent / family | seeds x episodes | success [95 % CI] | per seed | SPL | collision rate "
        "| collision steps / episode |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, s in rows.items():
        lo, hi = s["success_rate_ci"]
        seeds = ", ".join(f"{v['success_rate']:.2f}" for v in s["per_seed"].values())
        lines.append(
            f"| {label} | {s['seeds']} x {s['episodes']} | {s['success_rate']:.2f} "
            f"[{lo:.2f}, {hi:.2f}] | {seeds} | {s['spl']:.3f} | {s['collision_rate']:.2f} "
            f"| {s.get('collision_steps', float('nan')):.2f} |"
        )
    return "\n".join(lines) + "\n"


def _rolling_success(curve_csv: pathlib.Path, window: int) -> tuple[np.ndarray, np.ndarray]:
    """(timesteps, rolling success rate over ``window`` episodes) of one run's ``curve.csv``."""
    with curve_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    t = np.array([float(r["timesteps"]) for r in rows])
    s = np.array([float(r["success"]) for r in rows])
    if t.size == 0:
        return t, s
    cum = np.concatenate([[0.0], np.cumsum(s)])
    idx = np.arange(1, s.size + 1)
    start = np.maximum(idx - window, 0)
    return t, (cum[idx] - cum[start]) / (idx - start)


def _phase_starts(curve_csv: pathlib.Path) -> list[tuple[float, str]]:
    """Where each phase of an imitation run's ``curve.csv`` begins (0, then the last episode
    before it ends, env steps) and its label (``beta``, the teacher's share of the steps, or
    PPO for the recipe's fine-tuning); empty for a run without phases (PPO alone)."""
    with curve_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    if not rows or "phase" not in rows[0]:
        return []

    def label(row: dict[str, str]) -> str:
        if row["phase"] == "ppo fine-tuning":  # agents.learning.finetune.PHASE
            return " PPO"
        return f" teacher {float(row['beta']):.0%}"

    starts = [(0.0, label(rows[0]))]
    for before, row in itertools.pairwise(rows):
        if row["phase"] != before["phase"]:
            starts.append((float(before["timesteps"]), label(row)))
    return starts


def plot_seed_curves(
    curve_csvs: Mapping[str, pathlib.Path],
    out_png: pathlib.Path,
    *,
    window: int = 50,
    title: str = "PPO training success",
) -> pathlib.Path:
    """Each seed's rolling training success rate, their mean and the min-max band.

    Args:
        curve_csvs: ``{seed label: curve.csv of that run}``
            (:func:`agents.learning.training.train_ppo`).
        out_png: Where to write the figure.
        window: Episodes of the rolling mean.
        title: The figure's title.

    Returns:
        ``out_png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = {k: _rolling_success(pathlib.Path(p), window) for k, p in curve_csvs.items()}
    curves = {k: c for k, c in curves.items() if c[0].size}
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    phases: list[tuple[float, str]] = []
    if curves:
        end = min(float(t[-1]) for t, _ in curves.values())
        grid = np.linspace(0.0, end, 200)
        stack = np.stack([np.interp(grid, t, s, left=s[0]) for t, s in curves.values()])
        ax.fill_between(grid, stack.min(axis=0), stack.max(axis=0), alpha=0.25, label="seeds")
        ax.plot(grid, stack.mean(axis=0), color="tab:blue", label="mean of seeds")
        for label, (t, s) in curves.items():
            name = label if label.startswith("seed") else f"seed {label}"
            ax.plot(t, s, lw=0.6, alpha=0.7, label=name)
        phases = _phase_starts(pathlib.Path(next(iter(curve_csvs.values()))))
        for k, (at, text) in enumerate(phases):  # labels on three staggered rows
            ax.axvline(at, color="grey", lw=0.6, ls=":")
            y = 0.02 + 0.07 * (k % 3)
            ax.text(at, y, text, fontsize=7, color="dimgrey", ha="left", va="bottom")
    ax.set_xlabel("env steps")
    ax.set_ylabel(f"success, last {window} episodes")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    # the phases' labels run along the bottom
    ax.legend(fontsize=7, loc="center right" if phases else "lower right")
    ax.set_title(title)
    fig.tight_layout()
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return out_png
