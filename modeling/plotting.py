"""Figures of an environment model in the style of the paper's Figs. 6 and 11.

:func:`plot_model` draws a model's situations; :func:`plot_models` draws several models (the model
of one view beside the model fused over many, section 6) side by side on common axes.

matplotlib is imported lazily, inside the functions, so that ``import modeling`` (and this
module) never pulls it in; a new figure is a plain :class:`matplotlib.figure.Figure` (no pyplot, no
global backend change), to be saved with ``fig.savefig(...)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from modeling.model.records import EnvironmentModel

__all__ = ["plot_model", "plot_models"]


def _ellipse_xy(mean: np.ndarray, cov: np.ndarray, k: float = 2.0, n: int = 24) -> np.ndarray:
    vals, vecs = np.linalg.eigh(cov)
    t = np.linspace(0, 2 * math.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1) * (k * np.sqrt(np.maximum(vals, 0)))
    out: np.ndarray = mean + circle @ vecs.T
    return out


def plot_model(
    model: EnvironmentModel,
    *,
    ax: Any = None,
    max_panels: int = 4,
    ground_truth: Sequence[np.ndarray] | None = None,
    show_ellipses: bool = True,
) -> Any:
    """Draw the model: one panel per situation (most probable first), or one situation on ``ax``.

    Each panel shows the occluded area (grey), the obstacles (filled convex polygon, numbered, and
    their skeleton in black), the critical regions (orange, labelled with ``p_passable``, the
    narrowest relation dashed), the candidates of the ambiguous segments (purple: thin and dotted,
    the chosen one thick), 2-sigma endpoint ellipses, the viewpoint (red triangle), and optionally
    the ground-truth outlines (green); its title gives the situation's probability and choices
    ``{ambiguous index: candidate index}`` ("none": no candidate is an obstacle).

    Args:
        model: The environment model.
        ax: A matplotlib Axes: draw the most probable situation there. Default: a new figure.
        max_panels: At most this many situations (panels) in a new figure.
        ground_truth: Optional (k, 2) outlines, world frame, metres.
        show_ellipses: Draw endpoint uncertainty ellipses.

    Returns:
        The matplotlib Figure (new: a :class:`matplotlib.figure.Figure`, not managed by pyplot).

    Raises:
        ValueError: ``max_panels`` below 1.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon as MplPolygon

    if isinstance(max_panels, bool) or not isinstance(max_panels, int) or max_panels < 1:
        raise ValueError(f"max_panels must be an integer >= 1, got {max_panels!r}")
    sits = list(model.situations[: (1 if ax is not None else max_panels)])
    if ax is None:
        n = len(sits)
        cols = min(n, 2)
        rows = math.ceil(n / cols)
        fig = Figure(figsize=(6 * cols, 5 * rows))
        axes_list = [fig.add_subplot(rows, cols, k + 1) for k in range(n)]
        fig.suptitle(
            f"{len(model.situations)} situation(s), residual {model.residual_probability:.3g}",
            fontsize=10,
        )
    else:
        fig = ax.figure
        axes_list = [ax]
    obs = model.observation
    ellipses = (
        [_ellipse_xy(sg.endpoints[k], sg.cov[k]) for sg in obs.segments for k in range(2)]
        if show_ellipses
        else []
    )
    for a, sit in zip(axes_list, sits, strict=False):
        for ring in model.occluded:
            a.add_patch(MplPolygon(ring, closed=True, fc="0.85", ec="none", zorder=0))
        if ground_truth is not None:
            for outline in ground_truth:
                o = np.asarray(outline)
                a.add_patch(MplPolygon(o, closed=True, fill=False, ec="green", lw=1, zorder=1))
        if ellipses:
            a.add_collection(LineCollection(ellipses, colors="0.4", linewidths=0.5, zorder=2))
        for oi, ob in enumerate(sit.obstacles):
            a.add_patch(
                MplPolygon(ob.polygon, closed=True, fc="tab:blue", alpha=0.15, ec="tab:blue")
            )
            c = ob.points.mean(axis=0)
            a.text(c[0], c[1], str(oi), fontsize=7, color="tab:blue", zorder=5)
        skeleton = [ln for ob in sit.obstacles for ln in ob.lines]
        if skeleton:
            a.add_collection(LineCollection(skeleton, colors="k", linewidths=2, zorder=3))
        for reg in sit.critical_regions:
            a.add_patch(
                MplPolygon(reg.polygon, closed=True, fc="orange", alpha=0.4, ec="darkorange")
            )
            nw = np.asarray(reg.narrowest)
            a.plot(nw[:, 0], nw[:, 1], ls="--", color="darkorange", lw=1.5, zorder=4)
            m = nw.mean(axis=0)
            a.text(m[0], m[1], f"{reg.p_passable:.2f}", fontsize=8, color="darkred", zorder=6)
        # Ambiguous segments: every candidate thin and dotted, the chosen one thick.
        others: list[np.ndarray] = []
        chosen: list[np.ndarray] = []
        for ai, amb in enumerate(obs.ambiguous):
            pick = sit.choice.get(ai, model.merged_ambiguous.get(ai))
            for ci, cand in enumerate(amb.candidates):
                (chosen if ci == pick else others).append(cand.endpoints)
        if others:
            a.add_collection(
                LineCollection(others, colors="purple", linewidths=0.8, linestyles=":", zorder=3)
            )
        if chosen:
            a.add_collection(LineCollection(chosen, colors="purple", linewidths=2.5, zorder=4))
        vp = obs.viewpoint
        a.plot([vp[0]], [vp[1]], marker="^", color="red", zorder=7)
        a.set_aspect("equal")
        a.autoscale_view()
        picks = " ".join(f"{k}:{v if v >= 0 else 'none'}" for k, v in sit.choice.items())
        a.set_title(f"p = {sit.probability:.3g}" + (f"  [{picks}]" if picks else ""), fontsize=9)
    return fig


def plot_models(
    models: Sequence[EnvironmentModel],
    *,
    titles: Sequence[str] | None = None,
    ground_truth: Sequence[np.ndarray] | None = None,
    seen: Sequence[Any] | None = None,
    limits: tuple[float, float, float, float] | None = None,
    show_ellipses: bool = True,
) -> Any:
    """Draw the most probable situation of each model in its own panel, side by side.

    Each panel is :func:`plot_model` of one model on its axes (the same legend), under the
    floor seen so far (light blue, where given), all panels on the same axes limits.

    Args:
        models: The models (at least one), world frame.
        titles: One title per model, put before the situation's probability (default: none).
        ground_truth: Optional (k, 2) outlines, world frame, metres, drawn in every panel.
        seen: Optional, one per model: a shapely geometry of the floor seen (or ``None``).
        limits: ``(x_min, x_max, y_min, y_max)`` metres; default: the union of the panels'.
        show_ellipses: Draw endpoint uncertainty ellipses (2 sigma).

    Returns:
        A new :class:`matplotlib.figure.Figure` (not managed by pyplot).

    Raises:
        ValueError: No model, or ``titles`` / ``seen`` of another length than ``models``.
    """
    import shapely
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon as MplPolygon

    models = list(models)
    if not models:
        raise ValueError("models must hold at least one EnvironmentModel")
    for name, values in (("titles", titles), ("seen", seen)):
        if values is not None and len(values) != len(models):
            raise ValueError(f"{name} must have one entry per model ({len(models)})")
    fig = Figure(figsize=(6 * len(models), 5.5))
    axes = [fig.add_subplot(1, len(models), k + 1) for k in range(len(models))]
    for k, (ax, model) in enumerate(zip(axes, models, strict=True)):
        area = None if seen is None else seen[k]
        if area is not None and not area.is_empty:
            for part in shapely.get_parts(area):
                if isinstance(part, shapely.Polygon):
                    ring = np.asarray(part.exterior.coords)
                    ax.add_patch(MplPolygon(ring, closed=True, fc="#dcebf7", ec="none", zorder=-1))
                    for hole in part.interiors:
                        ax.add_patch(
                            MplPolygon(
                                np.asarray(hole.coords), closed=True, fc="w", ec="none", zorder=-0.5
                            )
                        )
        if model.situations:
            plot_model(model, ax=ax, ground_truth=ground_truth, show_ellipses=show_ellipses)
        if titles is not None:
            ax.set_title(f"{titles[k]}\n{ax.get_title()}", fontsize=9)
        ax.set_aspect("equal")
    if limits is None:
        ax_limits = [(*ax.get_xlim(), *ax.get_ylim()) for ax in axes]
        limits = (
            min(v[0] for v in ax_limits),
            max(v[1] for v in ax_limits),
            min(v[2] for v in ax_limits),
            max(v[3] for v in ax_limits),
        )
    for ax in axes:
        ax.set_xlim(limits[0], limits[1])
        ax.set_ylim(limits[2], limits[3])
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.tight_layout()
    return fig
