"""Figures of an environment model in the style of the paper's Figs. 6, 10 and 11.

:func:`plot_model` draws a model's situations (one panel each, or a chosen one on given axes);
:func:`plot_models` draws several models (the model of one view beside the model fused over many,
section 6) side by side on common axes; :func:`legend_handles` gives the legend of what they draw.
:func:`model_extent` frames what a model says something about. Nothing here changes a model.

Labels are few and placed so that they do not overlap (:func:`place_labels`): the most doubtful
critical regions get ``w = mean ± std m`` and ``P(pass) = p`` in a boxed label offset from the
region with a leader line, then the possible positions of the units of ambiguous segments get
``a1``, ``a2``, ``b1``, ... (Fig. 10), then (optionally) the obstacles their numbers; a label that
finds no free place is left out.

matplotlib is imported lazily, inside the functions, so that ``import modeling`` (and this
module) never pulls it in; a new figure is a plain :class:`matplotlib.figure.Figure` (no pyplot, no
global backend change), to be saved with ``fig.savefig(...)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from modeling.model.records import CriticalRegion, EnvironmentModel, Situation

__all__ = [
    "format_probability",
    "label_situation",
    "legend_handles",
    "model_extent",
    "place_labels",
    "plot_model",
    "plot_models",
    "region_label",
    "situation_choices",
    "situation_title",
    "unit_name",
]

OBSTACLE_COLOR = "tab:blue"
REGION_FILL = "orange"
REGION_EDGE = "darkorange"
CANDIDATE_COLOR = "purple"
TRUTH_COLOR = "green"
OCCLUDED_COLOR = "0.82"
FOV_COLOR = "#fff6c4"
VIEWPOINT_COLOR = "red"
LABEL_FONTSIZE = 9.0
"""Font size of the labels, points."""

_LEGEND_IN = 1.4
"""Height under the panels of a new figure for its legend, inches."""

_OFFSETS_PT = tuple(
    (r * math.cos(a), r * math.sin(a))
    for r in (26.0, 44.0, 64.0)
    for a in np.radians([45, -45, 135, -135, 0, 180, 90, -90])
)
"""Where a label may go, relative to its anchor, points (nearest first)."""


def _ellipse_xy(mean: np.ndarray, cov: np.ndarray, k: float = 2.0, n: int = 24) -> np.ndarray:
    vals, vecs = np.linalg.eigh(cov)
    t = np.linspace(0, 2 * math.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1) * (k * np.sqrt(np.maximum(vals, 0)))
    out: np.ndarray = mean + circle @ vecs.T
    return out


def format_probability(p: float) -> str:
    """``p`` with two decimals (``0.62``), or two significant digits below 0.1 (``0.015``)."""
    return f"{p:.2f}" if p >= 0.1 or p == 0.0 else f"{p:.2g}"


def region_label(region: CriticalRegion) -> str:
    """The label of a critical region: its width (mean ± std, metres) and ``p_passable``."""
    return (
        f"w = {region.width_mean_m:.2f} ± {region.width_std_m:.2f} m\n"
        f"P(pass) = {region.p_passable:.2f}"
    )


def legend_handles(
    *, ground_truth: bool = True, ellipses: bool = True, fov: bool = True
) -> list[tuple[Any, str]]:
    """Proxy artists and texts explaining what :func:`plot_model` draws.

    Use as ``handles, labels = zip(*legend_handles())`` and ``fig.legend(handles, labels)``.

    Args:
        ground_truth: Include the true outlines.
        ellipses: Include the endpoint ellipses.
        fov: Include the field of view.

    Returns:
        ``(artist, text)`` pairs in drawing order (artists not in any figure).
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    items: list[tuple[Any, str]] = []
    if fov:
        items.append((Patch(fc=FOV_COLOR, ec="none"), "field of view"))
    items.append((Patch(fc=OCCLUDED_COLOR, ec="none"), "occluded area"))
    hull = Patch(fc=OBSTACLE_COLOR, alpha=0.2, ec=OBSTACLE_COLOR)
    items.append(((hull, Line2D([], [], color="k", lw=2)), "obstacle (hull, segments)"))
    items.append(
        (Patch(fc=REGION_FILL, alpha=0.45, ec=REGION_EDGE), "critical region (w, P(pass))")
    )
    items.append((Line2D([], [], color=REGION_EDGE, ls="--", lw=1.5), "its narrowest gap"))
    items.append(
        (
            Line2D([], [], color=CANDIDATE_COLOR, lw=1, ls=":", marker="o", mfc="none", ms=8),
            "ambiguous segment: possible position (a1, a2, ...)",
        )
    )
    items.append(
        (
            Line2D([], [], color=CANDIDATE_COLOR, lw=2.5, marker="o", ms=8),
            "ambiguous segment: position in this situation",
        )
    )
    if ellipses:
        items.append((Line2D([], [], color="0.45", lw=0.6), "endpoint 2σ ellipse"))
    if ground_truth:
        items.append((Line2D([], [], color=TRUTH_COLOR, lw=1.2), "true outline"))
    items.append(
        (
            Line2D([], [], ls="none", marker="o", color=VIEWPOINT_COLOR, ms=5),
            "viewpoint (left camera)",
        )
    )
    return items


def _renderer(fig: Any) -> Any:
    """A renderer of ``fig`` to measure text (an Agg canvas is attached where it has none)."""
    canvas = fig.canvas
    if not hasattr(canvas, "get_renderer"):
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        canvas = FigureCanvasAgg(fig)
    return canvas.get_renderer()


def place_labels(
    ax: Any,
    labels: Sequence[tuple[np.ndarray, str, dict[str, Any]]],
    *,
    max_labels: int | None = None,
    avoid: np.ndarray | None = None,
) -> list[Any]:
    """Annotate points of ``ax`` with texts that neither overlap nor leave the axes.

    Each label is tried at the offsets of ``_OFFSETS_PT`` (nearest first) with a leader line to
    its anchor and is kept at the first place where its box stays inside the axes, clear of the
    texts already on the axes, of the labels kept before it, of the other anchors and of the
    points ``avoid``; a label with no such place is left out. Call it once the axes' limits and
    position are final (texts are offset in points).

    Args:
        ax: The matplotlib Axes.
        labels: ``(anchor (2,) data coordinates, text, extra Annotation keywords)``, most important
            first.
        max_labels: Keep at most this many (default: all that fit).
        avoid: (n, 2) more points no label may cover, data coordinates (markers).

    Returns:
        The kept :class:`matplotlib.text.Annotation` objects.
    """
    from matplotlib.text import Text

    if not labels:
        return []
    renderer = _renderer(ax.figure)
    ax.apply_aspect()
    frame = ax.get_window_extent(renderer)
    anchors = ax.transData.transform(np.array([np.asarray(a, float) for a, _, _ in labels]))
    others = (
        np.zeros((0, 2)) if avoid is None else ax.transData.transform(np.reshape(avoid, (-1, 2)))
    )
    pad = 3.0 * ax.figure.dpi / 72.0
    kept: list[Any] = []
    boxes: list[Any] = []  # the texts already on the axes, then the labels kept
    for text in ax.texts:
        if hasattr(text, "update_positions"):
            text.update_positions(renderer)
        boxes.append(Text.get_window_extent(text, renderer).padded(pad))
    for k, (anchor, text, extra) in enumerate(labels):
        if max_labels is not None and len(kept) >= max_labels:
            break
        if not frame.contains(*anchors[k]):
            continue
        for dx, dy in _OFFSETS_PT:
            ha = "center" if abs(dx) < 1 else ("left" if dx > 0 else "right")
            va = "center" if abs(dy) < 1 else ("bottom" if dy > 0 else "top")
            style = {
                "fontsize": LABEL_FONTSIZE,
                "bbox": {"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.6", "alpha": 0.9},
                "arrowprops": {"arrowstyle": "-", "color": "0.3", "lw": 0.8, "shrinkB": 2},
                "zorder": 10,
                **extra,
            }
            ann = ax.annotate(
                text,
                xy=tuple(anchor),
                xytext=(dx, dy),
                textcoords="offset points",
                ha=ha,
                va=va,
                **style,
            )
            ann.update_positions(renderer)  # places the text (offset points) for measuring
            box = Text.get_window_extent(ann, renderer).padded(pad)
            inside = (
                box.x0 >= frame.x0
                and box.x1 <= frame.x1
                and box.y0 >= frame.y0
                and box.y1 <= frame.y1
            )
            clear = (
                not any(box.overlaps(b) for b in boxes)
                and not any(box.contains(*p) for j, p in enumerate(anchors) if j != k)
                and not any(box.contains(*p) for p in others)
            )
            if inside and clear:
                kept.append(ann)
                boxes.append(box)
                break
            ann.remove()
    return kept


def _draw_situation(
    a: Any,
    model: EnvironmentModel,
    sit: Situation,
    *,
    ground_truth: Sequence[np.ndarray] | None,
    ellipses: list[np.ndarray],
    show_fov: bool,
) -> None:
    """Everything of situation ``sit`` of ``model`` on axes ``a`` but the labels."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Polygon as MplPolygon
    from matplotlib.patches import Wedge

    obs = model.observation
    vp = obs.viewpoint
    if show_fov:
        half = math.degrees(obs.fov_rad) / 2
        heading = math.degrees(float(vp[2]))
        a.add_patch(
            Wedge(
                (float(vp[0]), float(vp[1])),
                float(obs.max_range_m),
                heading - half,
                heading + half,
                fc=FOV_COLOR,
                ec="none",
                zorder=-2,
            )
        )
    for ring in model.occluded:
        a.add_patch(MplPolygon(ring, closed=True, fc=OCCLUDED_COLOR, ec="none", zorder=-1))
    if ground_truth is not None:
        for outline in ground_truth:
            o = np.asarray(outline)
            a.add_patch(MplPolygon(o, closed=True, fill=False, ec=TRUTH_COLOR, lw=1.2, zorder=1))
    if ellipses:
        a.add_collection(LineCollection(ellipses, colors="0.45", linewidths=0.6, zorder=2))
    for ob in sit.obstacles:
        a.add_patch(
            MplPolygon(
                ob.polygon, closed=True, fc=OBSTACLE_COLOR, alpha=0.2, ec=OBSTACLE_COLOR, zorder=2
            )
        )
    skeleton = [ln for ob in sit.obstacles for ln in ob.lines]
    if skeleton:
        a.add_collection(LineCollection(skeleton, colors="k", linewidths=2, zorder=3))
    for reg in sit.critical_regions:
        a.add_patch(
            MplPolygon(
                reg.polygon, closed=True, fc=REGION_FILL, alpha=0.45, ec=REGION_EDGE, zorder=4
            )
        )
        nw = np.asarray(reg.narrowest)
        a.plot(nw[:, 0], nw[:, 1], ls="--", color=REGION_EDGE, lw=1.5, zorder=5)
    # Ambiguous segments: every candidate thin and dotted, the chosen one thick; the possible
    # positions of the segments whose choice makes the situations (the units) circled, the
    # position of this situation filled (the paper's Fig. 10).
    others: list[np.ndarray] = []
    chosen: list[np.ndarray] = []
    for ai, amb in enumerate(obs.ambiguous):
        pick = sit.choice.get(ai, model.merged_ambiguous.get(ai))
        for ci, cand in enumerate(amb.candidates):
            (chosen if ci == pick else others).append(cand.endpoints)
    if others:
        a.add_collection(
            LineCollection(others, colors=CANDIDATE_COLOR, linewidths=1, linestyles=":", zorder=3)
        )
    if chosen:
        a.add_collection(LineCollection(chosen, colors=CANDIDATE_COLOR, linewidths=2.5, zorder=6))
    for ai in sit.choice:
        for ci, cand in enumerate(obs.ambiguous[ai].candidates):
            m = cand.endpoints.mean(axis=0)
            filled = ci == sit.choice[ai]
            a.plot(
                [m[0]],
                [m[1]],
                ls="none",
                marker="o",
                ms=9,
                mew=1.5,
                mec=CANDIDATE_COLOR,
                mfc=CANDIDATE_COLOR if filled else "none",
                alpha=1.0 if filled else 0.7,
                zorder=6,
            )
    a.plot([vp[0]], [vp[1]], ls="none", marker="o", ms=5, color=VIEWPOINT_COLOR, zorder=7)


def unit_name(k: int) -> str:
    """The name of the ``k``-th unit of ambiguous segments: ``a``, ``b``, ... ``z``, ``u27``, ..."""
    return chr(ord("a") + k) if k < 26 else f"u{k + 1}"


def _unit_positions(model: EnvironmentModel) -> list[list[np.ndarray]]:
    """Per unit of ``model.units``, per candidate index: the mean midpoint (2,) of its members'
    candidates (metres): where the unit may be."""
    obs = model.observation
    out: list[list[np.ndarray]] = []
    for unit in model.units:
        n = min(len(obs.ambiguous[ai].candidates) for ai in unit)
        out.append(
            [
                np.mean([obs.ambiguous[ai].candidates[ci].endpoints.mean(axis=0) for ai in unit], 0)
                for ci in range(n)
            ]
        )
    return out


def situation_choices(model: EnvironmentModel, index: int) -> str:
    """What makes situation ``index`` in the paper's words: ``"a2, b1 true; c absent"``: per unit of
    ambiguous segments (:func:`unit_name`), the candidate taken (from 1), or absent when the
    choice is "none" (empty without units)."""
    sit = model.situations[index]
    true: list[str] = []
    absent: list[str] = []
    for k, unit in enumerate(model.units):
        ci = sit.choice.get(unit[0])
        if ci is None:
            continue
        (true.append(f"{unit_name(k)}{ci + 1}") if ci >= 0 else absent.append(unit_name(k)))
    parts = ([", ".join(true) + " true"] if true else []) + (
        [", ".join(absent) + " absent"] if absent else []
    )
    return "; ".join(parts)


def situation_title(model: EnvironmentModel, index: int) -> str:
    """``"situation k of n: p = 0.62"`` (k from 1, most probable first), then on a second line
    :func:`situation_choices` where the model has units."""
    sit = model.situations[index]
    n = len(model.situations)
    title = f"situation {index + 1} of {n}: p = {format_probability(sit.probability)}"
    choices = situation_choices(model, index)
    return f"{title}\n{choices}" if choices else title


def label_situation(
    a: Any,
    model: EnvironmentModel,
    index: int,
    *,
    max_labels: int = 3,
    max_units: int = 4,
    number_obstacles: bool = True,
) -> list[Any]:
    """Label situation ``index`` of ``model`` drawn on ``a``: its most doubtful critical regions
    (:func:`region_label`, ``p_passable`` nearest 1/2 first), the possible positions of the first
    units of ambiguous segments (``a1``, ``a2``, ``b1``, ...; the paper's Fig. 10), then its
    obstacles' numbers; no label overlaps another (:func:`place_labels`). Call once ``a``'s limits
    and position are final.

    Args:
        a: The axes it is drawn on.
        model: The model.
        index: Index of the situation.
        max_labels: At most this many region labels.
        max_units: Label the positions of at most this many units.
        number_obstacles: Also number the obstacles (small, where there is room).

    Returns:
        The kept annotations.
    """
    sit = model.situations[index]
    obs = model.observation
    markers = [  # the circles at the units' possible positions
        cand.endpoints.mean(axis=0) for ai in sit.choice for cand in obs.ambiguous[ai].candidates
    ]
    avoid = np.reshape(markers, (-1, 2))
    regions = sorted(sit.critical_regions, key=lambda r: abs(r.p_passable - 0.5))
    labels: list[tuple[np.ndarray, str, dict[str, Any]]] = [
        (np.asarray(r.narrowest).mean(axis=0), region_label(r), {"color": "darkred"})
        for r in regions
    ]
    kept = place_labels(a, labels, max_labels=max_labels, avoid=avoid)
    positions: list[tuple[np.ndarray, str, dict[str, Any]]] = []
    for k, (unit, where) in enumerate(zip(model.units, _unit_positions(model), strict=True)):
        if k >= max_units:
            break
        pick = sit.choice.get(unit[0])
        for ci, xy in enumerate(where):
            style = {
                "color": CANDIDATE_COLOR,
                "fontweight": "bold" if ci == pick else "normal",
                "bbox": {"boxstyle": "round,pad=0.2", "fc": "white", "ec": CANDIDATE_COLOR},
            }
            positions.append((xy, f"{unit_name(k)}{ci + 1}", style))
    kept += place_labels(a, positions, avoid=avoid)
    if number_obstacles:
        numbers = [
            (
                ob.points.mean(axis=0),
                str(oi),
                {
                    "fontsize": LABEL_FONTSIZE - 1,
                    "color": OBSTACLE_COLOR,
                    "bbox": {"boxstyle": "circle,pad=0.15", "fc": "white", "ec": OBSTACLE_COLOR},
                },
            )
            for oi, ob in enumerate(sit.obstacles)
        ]
        kept += place_labels(a, numbers)
    return kept


def plot_model(
    model: EnvironmentModel,
    *,
    ax: Any = None,
    max_panels: int = 4,
    ground_truth: Sequence[np.ndarray] | None = None,
    show_ellipses: bool = True,
    situation: int = 0,
    limits: tuple[float, float, float, float] | None = None,
    max_labels: int = 3,
    number_obstacles: bool = True,
    show_fov: bool = True,
    labels: bool = True,
) -> Any:
    """Draw the model: one panel per situation (most probable first), or one situation on ``ax``.

    Each panel shows the field of view (pale yellow), the occluded area (grey), the obstacles
    (filled convex polygon, their segments and links in black, optionally numbered), the critical
    regions (orange, the narrowest gap dashed; the most doubtful labelled with their width, mean
    ± std, and ``p_passable``), the candidates of the ambiguous segments (purple: thin and
    dotted, the chosen one thick; those of the units that make the situations circled at every
    possible position, filled at this situation's, and labelled ``a1``, ``a2``, ``b1``, ...),
    2-sigma endpoint ellipses, the viewpoint (red dot), and optionally the ground-truth outlines
    (green); its title is :func:`situation_title` (``"situation 1 of 2: p = 0.62"`` and the
    choices, ``"a2 true"``). :func:`legend_handles` explains the drawing; a new
    figure has that legend under its panels.

    Args:
        model: The environment model.
        ax: A matplotlib Axes: draw situation ``situation`` there. Default: a new figure.
        max_panels: At most this many situations (panels) in a new figure.
        ground_truth: Optional (k, 2) outlines, world frame, metres.
        show_ellipses: Draw endpoint uncertainty ellipses.
        situation: Index of the situation drawn on ``ax`` (0: the most probable).
        limits: ``(x_min, x_max, y_min, y_max)`` metres of every panel (default: autoscaled).
        max_labels: At most this many critical regions labelled per panel.
        number_obstacles: Number the obstacles (where there is room).
        show_fov: Draw the field of view.
        labels: Label the panels (set ``False`` to call :func:`label_situation` later, after the
            figure's layout is final).

    Returns:
        The matplotlib Figure (new: a :class:`matplotlib.figure.Figure`, not managed by pyplot).

    Raises:
        ValueError: ``max_panels`` below 1 or ``situation`` not an index of the situations.
    """
    from matplotlib.figure import Figure

    if isinstance(max_panels, bool) or not isinstance(max_panels, int) or max_panels < 1:
        raise ValueError(f"max_panels must be an integer >= 1, got {max_panels!r}")
    if not 0 <= situation < max(len(model.situations), 1):
        raise ValueError(
            f"situation must be an index of the {len(model.situations)} situations, "
            f"got {situation!r}"
        )
    if ax is not None:
        fig = ax.figure
        axes_list = [ax]
        indices = [situation] if model.situations else []
    else:
        indices = list(range(min(len(model.situations), max_panels)))
        n = max(len(indices), 1)
        cols = min(n, 2)
        rows = math.ceil(n / cols)
        fig = Figure(figsize=(6 * cols, 5 * rows + _LEGEND_IN))
        axes_list = [fig.add_subplot(rows, cols, k + 1) for k in range(len(indices))]
        fig.suptitle(
            f"{len(model.situations)} situation(s), residual {model.residual_probability:.3g}",
            fontsize=12,
        )
        items = legend_handles(ground_truth=ground_truth is not None, ellipses=show_ellipses)
        fig.legend(
            [h for h, _ in items],
            [t for _, t in items],
            loc="lower center",
            ncol=3 if cols > 1 else 2,
            fontsize=9,
            frameon=False,
        )
    obs = model.observation
    ellipses = (
        [_ellipse_xy(sg.endpoints[k], sg.cov[k]) for sg in obs.segments for k in range(2)]
        if show_ellipses
        else []
    )
    for a, k in zip(axes_list, indices, strict=False):
        sit = model.situations[k]
        _draw_situation(
            a,
            model,
            sit,
            ground_truth=ground_truth,
            ellipses=ellipses,
            show_fov=show_fov,
        )
        a.set_aspect("equal")
        lim = model_extent(model, [k]) if limits is None else limits
        a.set_xlim(lim[0], lim[1])
        a.set_ylim(lim[2], lim[3])
        a.set_title(situation_title(model, k), fontsize=11)
    if ax is None and axes_list:
        fig.tight_layout(rect=(0, _LEGEND_IN / fig.get_figheight(), 1, 1))
    if labels:
        for a, k in zip(axes_list, indices, strict=False):
            label_situation(
                a,
                model,
                k,
                max_labels=max_labels,
                number_obstacles=number_obstacles,
            )
    return fig


def plot_models(
    models: Sequence[EnvironmentModel],
    *,
    titles: Sequence[str] | None = None,
    ground_truth: Sequence[np.ndarray] | None = None,
    seen: Sequence[Any] | None = None,
    limits: tuple[float, float, float, float] | None = None,
    show_ellipses: bool = True,
    number_obstacles: bool = True,
) -> Any:
    """Draw the most probable situation of each model in its own panel, side by side.

    Each panel is :func:`plot_model` of one model on its axes (the same drawing), under the
    floor seen so far (light blue, where given), all panels on the same axes limits, with the
    legend (:func:`legend_handles`) under them.

    Args:
        models: The models (at least one), world frame.
        titles: One title per model, put before the situation's probability (default: none).
        ground_truth: Optional (k, 2) outlines, world frame, metres, drawn in every panel.
        seen: Optional, one per model: a shapely geometry of the floor seen (or ``None``).
        limits: ``(x_min, x_max, y_min, y_max)`` metres; default: the union of the panels'
            :func:`model_extent`.
        show_ellipses: Draw endpoint uncertainty ellipses (2 sigma).
        number_obstacles: Number the obstacles (where there is room).

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
    if limits is None:
        extents = np.array([model_extent(m) for m in models])
        limits = (
            float(extents[:, 0].min()),
            float(extents[:, 1].max()),
            float(extents[:, 2].min()),
            float(extents[:, 3].max()),
        )
    fig = Figure(figsize=(6 * len(models), 5.5 + _LEGEND_IN))
    axes = [fig.add_subplot(1, len(models), k + 1) for k in range(len(models))]
    for k, (ax, model) in enumerate(zip(axes, models, strict=True)):
        area = None if seen is None else seen[k]
        if area is not None and not area.is_empty:
            for part in shapely.get_parts(area):
                if isinstance(part, shapely.Polygon):
                    ring = np.asarray(part.exterior.coords)
                    ax.add_patch(
                        MplPolygon(ring, closed=True, fc="#dcebf7", ec="none", zorder=-1.5)
                    )
                    for hole in part.interiors:
                        ax.add_patch(
                            MplPolygon(
                                np.asarray(hole.coords), closed=True, fc="w", ec="none", zorder=-1.4
                            )
                        )
        if model.situations:
            plot_model(
                model,
                ax=ax,
                ground_truth=ground_truth,
                show_ellipses=show_ellipses,
                limits=limits,
                labels=False,
                show_fov=False,
            )
        if titles is not None:
            ax.set_title(f"{titles[k]}\n{ax.get_title()}", fontsize=11)
        ax.set_aspect("equal")
        ax.set_xlim(limits[0], limits[1])
        ax.set_ylim(limits[2], limits[3])
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    items = legend_handles(ground_truth=ground_truth is not None, ellipses=show_ellipses, fov=False)
    if seen is not None:
        from matplotlib.patches import Patch

        items.insert(0, (Patch(fc="#dcebf7", ec="none"), "floor seen so far"))
    fig.legend(
        [h for h, _ in items],
        [t for _, t in items],
        loc="lower center",
        ncol=max(2, int(fig.get_figwidth() / 3.4)),
        fontsize=10,
        frameon=False,
    )
    fig.tight_layout(rect=(0, _LEGEND_IN / fig.get_figheight(), 1, 1))
    for ax, model in zip(axes, models, strict=True):
        if model.situations:
            label_situation(ax, model, 0, number_obstacles=number_obstacles)
    return fig


def model_extent(
    model: EnvironmentModel,
    situations: Sequence[int] | None = None,
    *,
    margin_m: float = 0.5,
    min_span_m: float = 2.0,
    near_m: float | None = None,
) -> tuple[float, float, float, float]:
    """The part of the floor a model says something about: ``(x_min, x_max, y_min, y_max)``, metres.

    The bounding box of the viewpoint and, in the given situations (default: all), the
    obstacles' outlines, the critical regions and the candidates of the ambiguous segments whose
    choice makes the situations,
    grown by ``margin_m`` and to at least ``min_span_m`` along each axis (about its centre). The
    field of view and the occluded area, which reach to the range limit, are left out, and with
    ``near_m`` so are the obstacles farther than that from the viewpoint (a far wall).

    Args:
        model: The model.
        situations: Indices of the situations that count (default: all).
        margin_m: Margin, metres.
        min_span_m: Smallest width and height, metres.
        near_m: Count only the obstacles with a point within this distance of the viewpoint,
            metres (default: all).

    Returns:
        The limits, metres.
    """
    obs = model.observation
    pts = [np.asarray(obs.viewpoint[:2], dtype=np.float64).reshape(1, 2)]
    indices = range(len(model.situations)) if situations is None else situations
    for k in indices:
        sit = model.situations[k]
        pts += [
            np.asarray(ob.polygon).reshape(-1, 2)
            for ob in sit.obstacles
            if near_m is None or np.min(np.hypot(*(np.asarray(ob.polygon) - pts[0]).T)) <= near_m
        ]
        pts += [np.asarray(r.polygon).reshape(-1, 2) for r in sit.critical_regions]
        for ai in sit.choice:  # every possible position of the units
            pts += [cand.endpoints for cand in obs.ambiguous[ai].candidates]
    xy = np.concatenate(pts)
    lo, hi = xy.min(axis=0) - margin_m, xy.max(axis=0) + margin_m
    centre, half = (lo + hi) / 2, np.maximum((hi - lo) / 2, min_span_m / 2)
    return (
        float(centre[0] - half[0]),
        float(centre[0] + half[0]),
        float(centre[1] - half[1]),
        float(centre[1] + half[1]),
    )
