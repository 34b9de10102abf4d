"""The ``rgb_array`` frame: the true world from above with the model overlaid, and the left image.

Layout (uint8 RGB, ``FRAME_HEIGHT x FRAME_WIDTH`` = 480 x 960): on the left a 640 x 480 map of the
scene (north up: world +y is up), on the right the left camera image (scaled to 320 wide) above a
legend. The map shows

* the true obstacle footprints (grey fill; walls darker), the true doubtful gaps (thin lines:
  dark green if the robot fits, dark red if not) and the goal (green disc of the goal radius);
* the field of view of the latest observation (pale yellow wedge) and its occluded area (dark
  hatching);
* the most probable situation's obstacles (blue skeleton lines), the other situations' obstacles
  (thin light blue);
* the most probable situation's critical regions filled by ``p_passable`` (red at 0, yellow at
  0.5, green at 1) with their narrowest relation as a line;
* the robot (disc outline of its true size, a line to its heading) and the head's gaze (orange).

Drawn with OpenCV only (anti-aliased, 4 bits of sub-pixel precision); the static scene is drawn
once per scene (:func:`draw_background`) and copied per frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.model.records import EnvironmentModel
from modeling.types import FloatArray, UInt8Image
from stereo_nav_env.sim.scenes import ObstacleKind, Scene
from stereo_nav_env.sim.scenes.types import DEFAULT_ROBOT_WIDTH_M

__all__ = [
    "FRAME_HEIGHT",
    "FRAME_WIDTH",
    "MapView",
    "draw_background",
    "draw_frame",
    "model_caption",
    "passability_color",
]

FRAME_HEIGHT = 480
FRAME_WIDTH = 960
MAP_WIDTH = 640
_MARGIN_PX = 12
_SHIFT = 4
_AA = cv2.LINE_AA
_SCALE = float(1 << _SHIFT)
_FLOOR = (245, 245, 240)
_WALL = (90, 90, 90)
_FURNITURE = (170, 160, 150)
_GOAL = (40, 170, 60)
_FOV = (255, 244, 170)
_OCCLUDED = (120, 120, 140)
_OBSTACLE = (30, 70, 200)
_OTHER_OBSTACLE = (150, 180, 235)
_ROBOT = (20, 20, 20)
_GAZE = (240, 130, 20)
_TEXT = (20, 20, 20)
_GAP_OK = (0, 120, 0)
_GAP_BLOCKED = (170, 0, 0)


@dataclass(frozen=True, slots=True, kw_only=True)
class MapView:
    """The world-to-map-pixel mapping of one scene: ``u = (x - x0) s + m``, ``v = (y1 - y) s + m``.

    Attributes:
        x0: World x at the map's left edge (minus the margin), metres.
        y1: World y at the map's top edge, metres.
        px_per_m: Scale, pixels per metre.
    """

    x0: float
    y1: float
    px_per_m: float

    @classmethod
    def of(cls, scene: Scene) -> MapView:
        """The largest scale at which ``scene``'s bounds fit the map area."""
        x0, y0, x1, y1 = scene.bounds
        s = min(
            (MAP_WIDTH - 2 * _MARGIN_PX) / (x1 - x0), (FRAME_HEIGHT - 2 * _MARGIN_PX) / (y1 - y0)
        )
        return cls(x0=x0, y1=y1, px_per_m=s)

    def pixels(self, points: FloatArray) -> FloatArray:
        """World points (..., 2) to map pixels (..., 2) (u right, v down)."""
        p = np.asarray(points, dtype=np.float64)
        u = (p[..., 0] - self.x0) * self.px_per_m + _MARGIN_PX
        v = (self.y1 - p[..., 1]) * self.px_per_m + _MARGIN_PX
        return np.stack([u, v], axis=-1)

    def fixed(self, points: FloatArray) -> NDArray[np.int32]:
        """World points to fixed-point pixels (int32, ``_SHIFT`` fractional bits) for OpenCV."""
        return np.rint(np.clip(self.pixels(points), -1e5, 1e5) * _SCALE).astype(np.int32)


def passability_color(p: float) -> tuple[int, int, int]:
    """RGB of a passability probability: red (0) through yellow (0.5) to green (1)."""
    p = min(max(float(p), 0.0), 1.0)
    return (round(230 * min(1.0, 2 * (1 - p))), round(200 * min(1.0, 2 * p)), 40)


def _blend(dst: UInt8Image, overlay: UInt8Image, mask: NDArray[np.bool_], alpha: float) -> None:
    """``dst[mask] = (1 - alpha) dst + alpha overlay`` (in place)."""
    if np.any(mask):
        dst[mask] = (dst[mask] * (1 - alpha) + overlay[mask] * alpha).astype(np.uint8)


def draw_background(
    scene: Scene, view: MapView, robot_width_m: float = DEFAULT_ROBOT_WIDTH_M
) -> UInt8Image:
    """The static part of the frame (H, W, 3) uint8 RGB: floor, true footprints, and the true
    doubtful gaps (within 30 % of ``robot_width_m``) as thin lines, dark green where the robot
    fits and dark red where it does not."""
    img = np.full((FRAME_HEIGHT, FRAME_WIDTH, 3), 255, dtype=np.uint8)
    x0, y0, x1, y1 = scene.bounds
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    cv2.fillPoly(img, [view.fixed(corners)], _FLOOR, cv2.LINE_AA, _SHIFT)
    for ob in scene.obstacles:
        color = _WALL if ob.kind is ObstacleKind.WALL else _FURNITURE
        pts = view.fixed(ob.footprint)
        cv2.fillPoly(img, [pts], color, cv2.LINE_AA, _SHIFT)
        cv2.polylines(img, [pts], True, _WALL, 1, cv2.LINE_AA, _SHIFT)
    for gap in scene.doubtful_gaps(robot_width_m):
        ends = view.fixed(np.array([gap.point_i, gap.point_j]))
        color = _GAP_OK if gap.passable(robot_width_m) else _GAP_BLOCKED
        cv2.line(img, tuple(ends[0]), tuple(ends[1]), color, 1, cv2.LINE_AA, _SHIFT)
    return img


def _disc(
    img: UInt8Image,
    view: MapView,
    xy: FloatArray,
    radius_m: float,
    color: tuple[int, int, int],
    width: int,
) -> None:
    c = view.fixed(np.asarray(xy, dtype=np.float64))
    r = round(radius_m * view.px_per_m * _SCALE)
    cv2.circle(img, (int(c[0]), int(c[1])), r, color, width, cv2.LINE_AA, _SHIFT)


def _ray(
    img: UInt8Image,
    view: MapView,
    xy: tuple[float, float],
    angle: float,
    length_m: float,
    color: tuple[int, int, int],
    width: int,
) -> None:
    a = np.asarray(xy, dtype=np.float64)
    b = a + length_m * np.array([math.cos(angle), math.sin(angle)])
    pa, pb = view.fixed(a), view.fixed(b)
    cv2.line(img, (int(pa[0]), int(pa[1])), (int(pb[0]), int(pb[1])), color, width, _AA, _SHIFT)


def draw_frame(
    background: UInt8Image,
    view: MapView,
    *,
    scene: Scene,
    model: EnvironmentModel | None,
    robot_pose: tuple[float, float, float],
    gaze_rad: float,
    robot_radius_m: float,
    goal_radius_m: float,
    left_image: UInt8Image | None,
    caption: str = "",
) -> UInt8Image:
    """One frame (``FRAME_HEIGHT``, ``FRAME_WIDTH``, 3) uint8 RGB (contents in the module doc).

    Args:
        background: :func:`draw_background` of ``scene`` (not modified).
        view: The scene's :class:`MapView`.
        scene: The true scene.
        model: The model of the latest observation (``None``: no overlay).
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
        gaze_rad: World direction of the head's optical axis, radians.
        robot_radius_m: Robot radius, metres.
        goal_radius_m: Goal radius, metres.
        left_image: The left image (H, W, 3) uint8, shown on the right (``None``: left blank).
        caption: Text lines (``\\n``-separated) printed under the image.
    """
    img = background.copy()
    map_area = img[:, :MAP_WIDTH]
    if model is not None:
        obs = model.observation
        vx, vy, heading = (float(v) for v in obs.viewpoint)
        half = 0.5 * float(obs.fov_rad)
        ang = heading + np.linspace(-half, half, 32)
        reach = obs.max_range_m
        wedge = np.vstack([[vx, vy], np.c_[vx + reach * np.cos(ang), vy + reach * np.sin(ang)]])
        layer = map_area.copy()
        cv2.fillPoly(layer, [view.fixed(wedge)], _FOV, cv2.LINE_8, _SHIFT)
        if model.occluded:
            occluded = [view.fixed(p) for p in model.occluded]
            cv2.fillPoly(layer, occluded, _OCCLUDED, cv2.LINE_8, _SHIFT)
        changed = np.any(layer != map_area, axis=2)
        _blend(map_area, layer, changed, 0.45)
        for k, situation in enumerate(model.situations):
            color, width = (_OBSTACLE, 2) if k == 0 else (_OTHER_OBSTACLE, 1)
            if k >= 8:
                break
            lines = [
                ob.lines if ob.lines.shape[0] else np.asarray(ob.points).reshape(-1, 2, 2)
                for ob in situation.obstacles
            ]
            if lines:
                pts = view.fixed(np.concatenate(lines))
                cv2.polylines(map_area, list(pts), False, color, width, cv2.LINE_AA, _SHIFT)
        if model.situations:
            layer = map_area.copy()
            for region in model.situations[0].critical_regions:
                color = passability_color(region.p_passable)
                cv2.fillPoly(layer, [view.fixed(region.polygon)], color, cv2.LINE_AA, _SHIFT)
                ends = view.fixed(region.narrowest)
                cv2.line(layer, tuple(ends[0]), tuple(ends[1]), color, 2, cv2.LINE_AA, _SHIFT)
            changed = np.any(layer != map_area, axis=2)
            _blend(map_area, layer, changed, 0.75)
    _disc(map_area, view, np.asarray(scene.goal), goal_radius_m, _GOAL, -1)
    x, y, heading = robot_pose
    _disc(map_area, view, np.array([x, y]), robot_radius_m, _ROBOT, 2)
    _ray(map_area, view, (x, y), heading, robot_radius_m, _ROBOT, 2)
    _ray(map_area, view, (x, y), gaze_rad, 2.5 * robot_radius_m, _GAZE, 2)

    panel = img[:, MAP_WIDTH:]
    panel_w = FRAME_WIDTH - MAP_WIDTH
    if left_image is not None:
        h, w = left_image.shape[:2]
        inset_h = round(h * panel_w / w)
        inset = cv2.resize(left_image, (panel_w, inset_h), interpolation=cv2.INTER_AREA)
        panel[:inset_h] = inset[:FRAME_HEIGHT]
        top = inset_h + 20
    else:
        top = 20
    for i, line in enumerate(caption.splitlines()):
        cv2.putText(
            panel, line, (8, top + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.45, _TEXT, 1, cv2.LINE_AA
        )
    return img


def model_caption(headline: str, model: EnvironmentModel | None) -> str:
    """The caption of a frame: ``headline``, then the model's situations and its most probable
    situation's obstacles and most doubtful critical regions (width, ``p_passable``)."""
    lines = [headline]
    if model is not None:
        best = model.situations[0] if model.situations else None
        lines.append(
            f"situations {len(model.situations)}  residual {model.residual_probability:.3f}"
        )
        if best is not None:
            lines.append(
                f"best: P={best.probability:.2f}  obstacles {len(best.obstacles)}  "
                f"regions {len(best.critical_regions)}"
            )
            doubtful = sorted(best.critical_regions, key=lambda r: abs(r.p_passable - 0.5))
            for region in doubtful[:6]:
                lines.append(
                    f"  width {region.width_mean_m:.2f}+-{region.width_std_m:.2f} m  "
                    f"p={region.p_passable:.2f}"
                )
    return "\n".join(lines)
