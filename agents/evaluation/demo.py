"""The main job (``make demo``): one episode of the planner, as a GIF, a model figure and a summary.

:func:`run_demo` drives the ``planner`` agent through one episode of ``StereoNav-v1`` (collisions
do not end it, so a bump and the recovery are visible; the env keeps no fused memory, which the
demo does not draw), printing one line per step, and writes into the output folder:

* ``episode.gif``: the environment's ``rgb_array`` frames at full resolution (480 x 960: the world
  from above with the model overlaid, the left image and the status text), every
  ``frame_every``-th step, each frame quantised to its own 256 colours without dithering so that
  the text stays sharp;
* ``model_steps.png``: the paper's idea in one picture (:func:`model_figure`, in the style of its
  Figs. 10 and 11): for up to two views of the episode chosen by :func:`pick_views` (views whose
  stereo matches were ambiguous, so that the model holds several situations), the most probable
  situations side by side, each titled with its probability and its choices (``a1, b2 true``),
  over the true outlines: the possible positions of the ambiguous segments circled (``a1``,
  ``a2``, ...; this situation's filled), the critical regions labelled with their width (mean ±
  std) and ``p_passable``, the robot and its head, and one legend;
* ``summary.json``: the episode's figures (success, steps, collisions, looks, path length, the
  true shortest route, SPL, wall time, the steps the figure shows) and the files written.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.model.records import EnvironmentModel, Situation

__all__ = ["DemoResult", "View", "model_figure", "pick_views", "run_demo"]

ENV_ID = "StereoNav-v1"
"""The environment the demo drives (v1 rules: collisions do not end an episode)."""


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


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class View:
    """One observation of the episode: its model and where the robot was.

    Attributes:
        step: The step that made it (0: the reset).
        model: The model of the view (``info["model"]``).
        pose: ``(x_m, y_m, heading_rad, pan_rad)`` of the robot then, world frame.
    """

    step: int
    model: EnvironmentModel
    pose: tuple[float, float, float, float]


def _frame(env: Any) -> NDArray[np.uint8]:
    """The env's ``rgb_array`` frame (H, W, 3), or the left image alone where the env draws none."""
    frame = env.render()
    if frame is None:
        frame = env.unwrapped.render_stereo()[0]
    return np.ascontiguousarray(np.asarray(frame, dtype=np.uint8))


def _gif_frame(frame: NDArray[np.uint8]) -> Any:
    """``frame`` (H, W, 3) as a PIL image of its own 256 colours, undithered (crisp text)."""
    from PIL import Image

    return Image.fromarray(frame).quantize(
        colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
    )


# ------------------------------------------------------------------------------ choosing views
def _regions(situation: Situation) -> tuple[float, ...]:
    """What a situation says about passability: its regions' ``p_passable`` (0.1 steps)."""
    return tuple(sorted(round(r.p_passable, 1) for r in situation.critical_regions))


def _interest(model: EnvironmentModel, shown: int) -> float:
    """How much the alternatives of a view show: the probability of the situations drawn beside
    the most probable one, counted twice where their critical regions differ from its own (an
    ambiguous match that changes what is passable: the paper's point)."""
    sits = model.situations
    if len(sits) < 2:
        return 0.0
    first = _regions(sits[0])
    return sum(s.probability * (2.0 if _regions(s) != first else 1.0) for s in sits[1:shown])


def _richness(model: EnvironmentModel) -> int:
    """How much a one-situation view shows: obstacles and (doubly) critical regions."""
    if not model.situations:
        return 0
    best = model.situations[0]
    return len(best.obstacles) + 2 * len(best.critical_regions)


def pick_views(
    models: Sequence[EnvironmentModel],
    count: int = 2,
    *,
    shown: int = 3,
    min_separation: int = 10,
) -> list[int]:
    """Indices of the views (models) worth drawing, in episode order.

    The candidates are the views with more than one situation; only when the episode has none,
    the views whose most probable situation has critical regions; only when it has none of
    those either, every view. Views with several situations are ranked by :func:`_interest` (the
    probability of the alternatives drawn, doubled where they change the critical regions), the
    others by their obstacles and regions; the earliest wins ties. The best ones are taken, at
    least ``min_separation`` views apart where the candidates allow (so that two panels are not
    the same view twice), then the next best to make up ``count``.

    Args:
        models: The models of the episode's views, in order.
        count: How many views at most (>= 1).
        shown: How many situations of a view are drawn (>= 1).
        min_separation: Preferred smallest distance between two picks, in views (>= 0).

    Returns:
        ``min(count, len(models))`` indices into ``models``, ascending.

    Raises:
        ValueError: ``count`` or ``shown`` below 1, or ``min_separation`` negative.
    """
    if count < 1 or shown < 1 or min_separation < 0:
        raise ValueError(
            f"count and shown must be >= 1 and min_separation >= 0, got {count}, {shown}, "
            f"{min_separation}"
        )
    several = [k for k, m in enumerate(models) if len(m.situations) > 1]
    if several:
        pool = several
        scores = {k: float(_interest(models[k], shown)) for k in pool}
    else:
        with_regions = [
            k for k, m in enumerate(models) if m.situations and m.situations[0].critical_regions
        ]
        pool = with_regions or list(range(len(models)))
        scores = {k: float(_richness(models[k])) for k in pool}
    ranked = sorted(pool, key=lambda k: (-scores[k], k))
    picks: list[int] = []
    for k in ranked:
        if len(picks) < count and all(abs(k - j) >= min_separation for j in picks):
            picks.append(k)
    for k in ranked:
        if len(picks) < count and k not in picks:
            picks.append(k)
    return sorted(picks)


# ------------------------------------------------------------------------------ the figure
def _panel_limits(
    view: View,
    shown: Sequence[int],
    robot_radius_m: float,
    aspect: float,
    bounds: tuple[float, float, float, float] | None,
    near_m: float = 4.0,
) -> tuple[float, float, float, float]:
    """``(x_min, x_max, y_min, y_max)`` metres framing the situations ``shown`` of ``view`` and the
    robot (obstacles farther than ``near_m`` from the viewpoint left out: a far wall), widened to
    the panel's ``aspect`` (width / height), kept inside ``bounds`` (the floor) where they fit."""
    from modeling.plotting import model_extent

    x0, x1, y0, y1 = model_extent(
        view.model, list(shown), margin_m=0.4, min_span_m=2.5, near_m=near_m
    )
    x, y = view.pose[0], view.pose[1]
    r = robot_radius_m + 0.3
    x0, x1, y0, y1 = min(x0, x - r), max(x1, x + r), min(y0, y - r), max(y1, y + r)
    w, h = x1 - x0, y1 - y0
    if w / h < aspect:
        x0, x1 = (x0 + x1) / 2 - h * aspect / 2, (x0 + x1) / 2 + h * aspect / 2
    else:
        y0, y1 = (y0 + y1) / 2 - w / aspect / 2, (y0 + y1) / 2 + w / aspect / 2
    if bounds is not None:  # slide (not shrink) the frame back onto the floor
        for lo, hi, blo, bhi in ((0, 1, bounds[0], bounds[1]), (2, 3, bounds[2], bounds[3])):
            lim = [x0, x1, y0, y1]
            span = lim[hi] - lim[lo]
            if span <= bhi - blo:
                shift = max(blo - lim[lo], 0.0) + min(bhi - lim[hi], 0.0)
                lim[lo], lim[hi] = lim[lo] + shift, lim[hi] + shift
            x0, x1, y0, y1 = lim
    return x0, x1, y0, y1


def _robot_handles() -> list[tuple[Any, str]]:
    """Legend entries of :func:`_draw_robot`."""
    from matplotlib.lines import Line2D

    return [
        (
            Line2D([], [], ls="-", color="k", marker="o", mfc="none", ms=11, lw=1.2),
            "robot (true size) and heading",
        ),
        (Line2D([], [], color="tab:orange", lw=2.5), "head (gaze)"),
    ]


def _draw_robot(ax: Any, pose: tuple[float, float, float, float], radius_m: float) -> None:
    """The robot's disc, its heading and the head's gaze on ``ax``."""
    from matplotlib.patches import Circle

    x, y, heading, pan = pose
    ax.add_patch(Circle((x, y), radius_m, fill=False, ec="k", lw=1.5, zorder=8))
    ax.plot(
        [x, x + radius_m * math.cos(heading)],
        [y, y + radius_m * math.sin(heading)],
        color="k",
        lw=1.5,
        zorder=8,
    )
    gaze = heading + pan
    reach = 2.2 * radius_m
    ax.annotate(
        "",
        xy=(x + reach * math.cos(gaze), y + reach * math.sin(gaze)),
        xytext=(x, y),
        arrowprops={"arrowstyle": "-|>", "color": "tab:orange", "lw": 2.5, "shrinkA": 0},
        zorder=9,
    )


def model_figure(
    views: Sequence[View],
    footprints: Sequence[NDArray[np.float64]],
    *,
    robot_radius_m: float,
    count: int = 2,
    shown: int = 3,
) -> Any:
    """The paper's idea in one figure: the possible situations of chosen views, side by side.

    One row per view of :func:`pick_views` (in episode order), headed by its step and number of
    situations; in the row, its ``shown`` most probable situations
    (:func:`modeling.plotting.plot_model`), each titled ``"situation k of n: p = ..."``, on the
    same limits, over the true outlines, with the robot and its head; the legend under the rows.
    Where no view has several situations (one panel per view), the views are put in one row.

    Args:
        views: The episode's views, in order (at least one).
        footprints: True outlines, each (k, 2), world frame, metres.
        robot_radius_m: Robot radius, metres.
        count: How many views at most.
        shown: How many situations of a view at most.

    Returns:
        A new :class:`matplotlib.figure.Figure` with an Agg canvas (not managed by pyplot).

    Raises:
        ValueError: No view.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from modeling.plotting import label_situation, legend_handles, plot_model, unit_name

    if not views:
        raise ValueError("views must hold at least one View")
    picks = pick_views([v.model for v in views], count, shown=shown)
    several = any(len(views[k].model.situations) > 1 for k in picks)
    per_row = [list(range(min(shown, len(views[k].model.situations)))) for k in picks]
    if several:
        rows = [[(k, s) for s in sits] for k, sits in zip(picks, per_row, strict=True)]
    else:  # one panel per view, all in one row
        rows = [[(k, 0) for k in picks if views[k].model.situations]]
    # At least 3 slots a row, for the titles and the legend (a short row leaves slots empty).
    cols = max(3, *(len(r) for r in rows))
    panel_w, panel_h, legend_h, title_h = 4.8, 4.5, 1.25, 0.55
    width = panel_w * cols
    fig = Figure(figsize=(width, title_h + panel_h * len(rows) + legend_h))
    FigureCanvasAgg(fig)
    pts = np.concatenate([np.asarray(f).reshape(-1, 2) for f in footprints]) if footprints else None
    bounds = (
        None
        if pts is None
        else (
            float(pts[:, 0].min()) - 0.1,
            float(pts[:, 0].max()) + 0.1,
            float(pts[:, 1].min()) - 0.1,
            float(pts[:, 1].max()) + 0.1,
        )
    )
    subs: Any = fig.subfigures(  # (len(rows) + 2,) SubFigures: title, rows, legend
        len(rows) + 2, 1, height_ratios=[title_h, *([panel_h] * len(rows)), legend_h]
    )
    subs[0].suptitle(
        "Each row one view: its possible situations side by side, with their probabilities"
        if several
        else "No view had ambiguous matches (one situation each): views with the most to show",
        fontsize=14,
        y=0.6,
    )
    drawn: list[tuple[Any, EnvironmentModel, int]] = []
    for sub, row in zip(subs[1:-1], rows, strict=True):
        axes = sub.subplots(1, cols, squeeze=False)[0]
        sub.subplots_adjust(left=0.06, right=0.99, bottom=0.12, top=0.80, wspace=0.12)
        box = axes[0].get_position()
        aspect = (box.width * width) / (box.height * panel_h)
        if several:
            view = views[row[0][0]]
            n = len(view.model.situations)
            rest = 1.0 - sum(s.probability for s in view.model.situations[: len(row)])
            units = len(view.model.units)
            n_amb = len(view.model.observation.ambiguous)
            names = ", ".join(unit_name(u) for u in range(units))
            sub.suptitle(
                f"step {view.step}: {n} possible situations"
                + (
                    f" ({len(row)} most probable shown, the rest p = {rest:.2f})"
                    if n > len(row)
                    else ""
                )
                + f" from {n_amb} ambiguous segment{'s' if n_amb > 1 else ''}"
                + (f" moving as {units} unit{'s' if units > 1 else ''} ({names})" if units else ""),
                fontsize=12,
                x=0.06,
                y=0.99,
                ha="left",
            )
        for col, ax in enumerate(axes):
            if col >= len(row):
                ax.set_visible(False)
                continue
            k, s = row[col]
            view = views[k]
            lim = _panel_limits(view, per_row[picks.index(k)], robot_radius_m, aspect, bounds)
            plot_model(
                view.model,
                ax=ax,
                situation=s,
                ground_truth=footprints,
                limits=lim,
                labels=False,
            )
            _draw_robot(ax, view.pose, robot_radius_m)
            if not several:
                ax.set_title(f"step {view.step}: {ax.get_title()}", fontsize=11)
            ax.tick_params(labelsize=8)
            ax.set_xlabel("x (m)", fontsize=9)
            if col == 0:
                ax.set_ylabel("y (m)", fontsize=9)
            drawn.append((ax, view.model, s))
    items = legend_handles() + _robot_handles()
    subs[-1].legend(
        [h for h, _ in items],
        [t for _, t in items],
        loc="center",
        ncol=min(len(items), int(width / 3.4)),
        fontsize=10,
        frameon=False,
    )
    for ax, model, s in drawn:
        label_situation(ax, model, s, max_labels=3, number_obstacles=False)
    return fig


# ------------------------------------------------------------------------------ the episode
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
    # memory=False: the demo draws nothing of the fused model and the planner does not read it
    # (its fused_range_m is 0), so it is not built.
    env = gym.make(ENV_ID, scenario=scenario, render_mode="rgb_array", memory=False)
    agent = make_agent(agent_name, env)
    frames: list[Any] = []
    views: list[View] = []
    try:
        obs, info = env.reset(seed=seed)
        agent.reset(env, seed=seed)
        route = true_shortest_route(env)
        base: Any = env.unwrapped
        footprints = base.ground_truth_footprints()
        goal_radius = float(base.config.goal_radius_m)
        robot_radius = float(base.config.world.robot_radius_m)
        reference = math.nan if route is None else max(route.length_m - goal_radius, 1e-6)
        frames.append(_gif_frame(_frame(env)))
        pose = robot_pose(env)
        views.append(View(step=0, model=model_of(env, info), pose=pose))
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
            views.append(View(step=steps, model=model, pose=pose))
            n_regions = len(model.situations[0].critical_regions) if model.situations else 0
            say(
                f"step {steps:4d}  x {pose[0]:5.2f}  y {pose[1]:5.2f}  "
                f"heading {math.degrees(pose[2]):7.1f}  pan {math.degrees(pose[3]):6.1f}  "
                f"{mode:8s} situations {len(model.situations):2d}  regions {n_regions:2d}  "
                f"goal {info.get('distance_to_goal_m', float('nan')):5.2f} m"
                + ("  COLLISION" if collided else "")
            )
            if steps % frame_every == 0 or terminated or truncated:
                frames.append(_gif_frame(_frame(env)))
            if terminated or truncated:
                break
        looks = int(agent.looks)
    finally:
        agent.close()
        env.close()
    gif = out / "episode.gif"
    frames[0].save(gif, save_all=True, append_images=frames[1:], duration=100 * frame_every, loop=0)
    fig = model_figure(views, footprints, robot_radius_m=robot_radius)
    figure = out / "model_steps.png"
    fig.savefig(figure, dpi=100)
    shown = pick_views([v.model for v in views])
    spl = float(reference / max(path, reference)) if success and math.isfinite(reference) else 0.0
    figures: dict[str, Any] = {
        "scenario": scenario,
        "seed": seed,
        "agent": agent_name,
        "env_id": ENV_ID,
        "success": success,
        "steps": steps,
        "collision_steps": collisions,
        "looks": looks,
        "path_length_m": round(path, 3),
        "shortest_route_m": None if route is None else round(route.length_m, 3),
        "spl": round(spl, 4),
        "frames": len(frames),
        "views_with_several_situations": sum(len(v.model.situations) > 1 for v in views),
        "figure_steps": [views[k].step for k in shown],
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
