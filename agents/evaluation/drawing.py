"""Pictures for the demo: a top-down view of a scene and the stereo pair, written as PNG files.

matplotlib is imported lazily (only when a picture is drawn), with the non-interactive Agg backend.
"""

from __future__ import annotations

import math
import pathlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.sim.scenes import ObstacleKind, Scene
from stereo_nav_env.sim.scenes.types import DEFAULT_ROBOT_WIDTH_M

__all__ = ["render_demo", "write_stereo_pngs", "write_topdown_png"]

_KIND_COLOR = {
    ObstacleKind.WALL: "0.35",
    ObstacleKind.TABLE: "#a0522d",
    ObstacleKind.CHAIR: "#3a5ba0",
    ObstacleKind.BOOKSHELF: "#c8a064",
    ObstacleKind.BOX: "#b08040",
}


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def write_topdown_png(
    scene: Scene,
    path: str | pathlib.Path,
    *,
    robot_width_m: float = DEFAULT_ROBOT_WIDTH_M,
    robot_pose: tuple[float, float, float] | None = None,
    head_pose: HeadPose | None = None,
    rig: StereoRig | None = None,
    show_gaps: bool = True,
) -> pathlib.Path:
    """Draw the scene from above (footprints, start, goal, robot, camera field of view, gaps).

    Args:
        scene: The scene.
        path: Output PNG path (parent folders are created).
        robot_width_m: Robot diameter, metres (robot disc and doubtful gaps).
        robot_pose: ``(x, y, heading)`` of the robot; default: the scene's start.
        head_pose: Left optical centre; with ``rig``, its horizontal field of view is drawn.
        rig: The stereo rig (field of view and depth range).
        show_gaps: Mark the gaps within 30 % of the robot width.

    Returns:
        The path written.
    """
    plt = _pyplot()
    from matplotlib.patches import Circle, Polygon

    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    x0, y0, x1, y1 = scene.bounds
    fig, ax = plt.subplots(figsize=(8, 8 * (y1 - y0) / max(x1 - x0, 1e-9) + 0.5), dpi=100)
    try:
        for ob in scene.obstacles:
            ax.add_patch(
                Polygon(ob.footprint, closed=True, fc=_KIND_COLOR[ob.kind], ec="k", lw=0.6)
            )
        if show_gaps:
            for gap in scene.doubtful_gaps(robot_width_m):
                pts = np.stack([gap.point_i, gap.point_j])
                color = "tab:green" if gap.passable(robot_width_m) else "tab:red"
                ax.plot(pts[:, 0], pts[:, 1], color=color, lw=2)
                mid = pts.mean(axis=0)
                ax.annotate(f"{gap.width_m:.2f}", mid, fontsize=7, color=color)
        x, y, heading = scene.start if robot_pose is None else robot_pose
        ax.add_patch(Circle((x, y), robot_width_m / 2, fc="tab:blue", alpha=0.5, ec="tab:blue"))
        ax.plot([x, x + 0.4 * math.cos(heading)], [y, y + 0.4 * math.sin(heading)], "b-")
        ax.plot(*scene.goal, marker="*", color="gold", ms=16, mec="k")
        if head_pose is not None and rig is not None:
            half = rig.hfov_rad / 2
            r = rig.max_depth_m
            for side in (-half, half):
                a = head_pose.heading_rad + side
                ax.plot(
                    [head_pose.x_m, head_pose.x_m + r * math.cos(a)],
                    [head_pose.y_m, head_pose.y_m + r * math.sin(a)],
                    "c--",
                    lw=0.8,
                )
        ax.set_xlim(x0 - 0.2, x1 + 0.2)
        ax.set_ylim(y0 - 0.2, y1 + 0.2)
        ax.set_aspect("equal")
        ax.set_title(f"{scene.name}: start (blue), goal (star), doubtful gaps (green/red)")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        fig.savefig(path, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def write_stereo_pngs(
    left: NDArray[np.uint8], right: NDArray[np.uint8], out_dir: str | pathlib.Path
) -> tuple[pathlib.Path, pathlib.Path]:
    """Write ``left.png`` and ``right.png`` (uint8 (H, W, 3) each) into ``out_dir``."""
    plt = _pyplot()
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = (out / "left.png", out / "right.png")
    for img, p in zip((left, right), paths, strict=True):
        arr = np.asarray(img)
        if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] != 3:
            raise ValueError(f"images must be uint8 (H, W, 3), got {arr.dtype} {arr.shape}")
        plt.imsave(p, arr)
    return paths


def render_demo(
    scene: Scene,
    out_dir: str | pathlib.Path,
    *,
    rig: StereoRig | None = None,
    robot_width_m: float = DEFAULT_ROBOT_WIDTH_M,
    head_height_m: float = 0.8,
) -> dict[str, pathlib.Path]:
    """Top-down picture and stereo pair from the scene's start pose.

    Returns:
        ``{"topdown": ..., "left": ..., "right": ...}`` paths of the PNG files written.
    """
    from stereo_nav_env.rendering.renderer import StereoRenderer

    rig = StereoRig() if rig is None else rig
    x, y, heading = scene.start
    half = rig.baseline_m / 2
    head = HeadPose(
        x_m=x - half * math.sin(heading),
        y_m=y + half * math.cos(heading),
        heading_rad=heading,
        height_m=head_height_m,
    )
    renderer = StereoRenderer(rig, scene)
    try:
        left, right = renderer.render_stereo(head)
    finally:
        renderer.close()
    out = pathlib.Path(out_dir)
    top = write_topdown_png(
        scene, out / "topdown.png", robot_width_m=robot_width_m, head_pose=head, rig=rig
    )
    lp, rp = write_stereo_pngs(left, right, out)
    return {"topdown": top, "left": lp, "right": rp}
