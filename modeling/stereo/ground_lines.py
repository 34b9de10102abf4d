"""Floor lines from the image's lowest near-horizontal lines: where plain faces meet the floor.

Segment stereo cannot measure a line along the epipolar rows: the bottom edge of a wall seen
face-on, or of a box's side whose vertical edges are out of the image, is never matched, and
the floor in front of such a face looks free (``docs/evaluation.md``: most of the planner's
contacts are with those faces). :func:`close_faces` closes a face only when both its vertical
edges are measured. This stage reads the near-horizontal lines that segment extraction keeps
aside (``ImageSegments.horizontal``) with the ground-plane constraint instead: a line where a
surface meets the floor lies at height 0, so each of its image points has one floor point,
where its ray meets the floor (:func:`floor_points`), with a covariance from the line's pixel
error (:func:`floor_point_jacobians`: the depth error grows as ``Z^2 / (f h)``).

Not every near-horizontal line is on the floor: the top edges of boxes and tables, and the
boards of a shelf, lie above it, and their floor points fall behind the object, in the floor
it hides. Such a line has, in the same image columns, the line where its object meets the
floor below it (nearer). So a line is kept only when no other near-horizontal line lies lower
in the image over more than ``max_covered`` of its columns (:func:`lowest_lines`): the nearest
floor contact in each column. On the evaluation scenes (stereo, 240 views) 99 % of the lines so
kept lay within 0.15 m of a true outline, against 74 % of all the lines below the horizon.

This is an addition to the paper's pipeline (a monocular cue: the paper uses matched segments
only), off by default (``ground_lines=True`` in the env and in
:func:`modeling.stereo.pipeline.stereo_to_floor` turns it on).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.observation import FloorObservation, FloorSegment
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments
from modeling.types import FloatArray
from modeling.validation import instance, positive, with_overrides

__all__ = [
    "GROUND_SOURCE",
    "GroundLineOptions",
    "add_ground_lines",
    "add_line_ground_segments",
    "floor_point_jacobians",
    "floor_points",
    "ground_segments",
    "line_ground_segments",
    "lowest_lines",
]


#: ``FloorSegment.source`` of a ground line's segment (an unmatched image line, no left index).
GROUND_SOURCE = -3


@dataclass(frozen=True, slots=True, kw_only=True)
class GroundLineOptions:
    """Options of :func:`ground_segments`.

    Attributes:
        ground_range_m: Both floor points within this distance of the camera, metres (> 0): the
            depth error grows as the square of the depth.
        end_sigma_px: Standard deviation of a line's end in each image direction, px (> 0).
        below_px: Another line lies below a line where it is this many rows lower, px (>= 0).
        max_covered: A line is dropped when other lines lie below it over more than this
            fraction of its columns, in [0, 1).
        min_ground_length_m: Shortest floor segment kept, metres (> 0).

    Raises:
        ValueError: an option out of range (naming it).
    """

    ground_range_m: float = 5.0
    end_sigma_px: float = 1.0
    below_px: float = 2.0
    max_covered: float = 0.5
    min_ground_length_m: float = 0.05

    def __post_init__(self) -> None:
        for name in ("ground_range_m", "end_sigma_px", "min_ground_length_m"):
            object.__setattr__(self, name, positive(getattr(self, name), name))
        object.__setattr__(self, "below_px", positive(self.below_px, "below_px", allow_zero=True))
        if not (0.0 <= self.max_covered < 1.0):
            raise ValueError(f"max_covered must be in [0, 1), got {self.max_covered!r}")
        object.__setattr__(self, "max_covered", float(self.max_covered))


def _rays(uv: FloatArray, rig: StereoRig, head_pose: HeadPose) -> FloatArray:
    """(n, 3) world directions of the left camera's rays through the pixels ``uv`` (n, 2)."""
    cx, cy = rig.principal_point_px
    f = rig.focal_px
    d = np.stack([(uv[:, 0] - cx) / f, (uv[:, 1] - cy) / f, np.ones(uv.shape[0])], axis=1)
    return d @ head_pose.R_cam2world.T


def floor_points(
    uv: FloatArray, rig: StereoRig, head_pose: HeadPose
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Where the left camera's rays through the pixels ``uv`` (n, 2) meet the floor.

    Returns:
        ``(points, hits)``: (n, 2) world floor points, metres, and (n,) whether the ray meets the
        floor ahead (it points down); the points of the others are NaN.
    """
    d = _rays(np.asarray(uv, dtype=np.float64).reshape(-1, 2), rig, head_pose)
    hits = d[:, 2] < -1e-9
    t = np.full(d.shape[0], np.nan)
    t[hits] = -head_pose.height_m / d[hits, 2]
    return np.array([head_pose.x_m, head_pose.y_m]) + t[:, None] * d[:, :2], hits


def floor_point_jacobians(uv: FloatArray, rig: StereoRig, head_pose: HeadPose) -> FloatArray:
    """(n, 2, 2) derivatives of :func:`floor_points` by ``(u, v)``, metres per pixel.

    With the ray ``d`` and ``t = -h / d_z``, the floor point is ``C + t d``, so its derivative by
    a pixel coordinate ``x`` is ``t (d'_xy - d_xy d'_z / d_z)`` with ``d' = R[:, x] / f``.
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    d = _rays(uv, rig, head_pose)
    t = -head_pose.height_m / d[:, 2]
    columns = head_pose.R_cam2world[:, :2] / rig.focal_px  # (3, 2): d' by u and by v
    return t[:, None, None] * (
        columns[None, :2, :] - d[:, :2, None] * (columns[None, 2:3, :] / d[:, 2, None, None])
    )


def lowest_lines(horizontal: FloatArray, options: GroundLineOptions | None = None) -> FloatArray:
    """The lines of ``horizontal`` (k, 2, 2) with no other line below them over more than
    ``max_covered`` of their columns (the module docstring), in their order.

    Another line is below a line over the columns the two share where, at the middle of those
    columns, it is more than ``below_px`` rows lower in the image (larger ``v``).
    """
    opts = options if options is not None else GroundLineOptions()
    hor = np.asarray(horizontal, dtype=np.float64).reshape(-1, 2, 2)
    if hor.shape[0] < 2:
        return hor
    u = hor[:, :, 0]
    lo, hi = u.min(axis=1), u.max(axis=1)
    a = np.maximum(lo[:, None], lo[None, :])  # shared columns of line i (rows) and j (columns)
    b = np.minimum(hi[:, None], hi[None, :])
    mid = 0.5 * (a + b)
    du = u[:, 1] - u[:, 0]
    safe = np.where(np.abs(du) > 1e-9, du, 1.0)
    slope = np.where(np.abs(du) > 1e-9, (hor[:, 1, 1] - hor[:, 0, 1]) / safe, 0.0)
    v_at = hor[:, 0, 1][:, None] + slope[:, None] * (mid - u[:, 0][:, None])  # line i at mid
    below = (b > a) & (v_at.T > v_at + opts.below_px)  # line j lower than line i there
    np.fill_diagonal(below, False)
    covered = np.where(below, b - a, 0.0).sum(axis=1)
    kept: FloatArray = hor[covered <= opts.max_covered * np.maximum(hi - lo, 1.0)]
    return kept


def ground_segments(
    left: ImageSegments,
    rig: StereoRig,
    head_pose: HeadPose,
    options: GroundLineOptions | None = None,
    **overrides: Any,
) -> list[FloorSegment]:
    """The floor segments of the lowest near-horizontal lines of ``left`` (the module docstring;
    :func:`line_ground_segments` of ``left.horizontal``).

    Raises:
        ValueError: ``left``, ``rig`` or ``head_pose`` of the wrong type, an unknown option or
            one out of range.
    """
    if not isinstance(left, ImageSegments):
        raise ValueError(f"left must be ImageSegments, got {type(left).__name__}")
    return line_ground_segments(left.horizontal, rig, head_pose, options, **overrides)


def line_ground_segments(
    lines: FloatArray,
    rig: StereoRig,
    head_pose: HeadPose,
    options: GroundLineOptions | None = None,
    **overrides: Any,
) -> list[FloorSegment]:
    """The floor segments of the lowest of the near-horizontal image lines ``lines``.

    Of ``lines`` (k, 2, 2) ``[[u0, v0], [u1, v1]]`` px in the left image (an image's
    ``ImageSegments.horizontal``, or the surrogate's imitation of them), the lowest ones
    (:func:`lowest_lines`) whose two ends meet the floor within ``ground_range_m`` each give the
    segment between those floor points, each end with the covariance
    ``J diag(end_sigma_px^2) J^T`` of its pixel error (:func:`floor_point_jacobians`), heights 0
    and ``source`` :data:`GROUND_SOURCE`.

    Raises:
        ValueError: ``lines`` not of shape (k, 2, 2), ``rig`` or ``head_pose`` of the wrong
            type, an unknown option or one out of range.
    """
    instance(rig, StereoRig, "rig")
    instance(head_pose, HeadPose, "head_pose")
    opts = with_overrides(options, GroundLineOptions, overrides)
    hor = np.asarray(lines, dtype=np.float64)
    if hor.ndim != 3 or hor.shape[1:] != (2, 2):
        raise ValueError(f"lines must have shape (k, 2, 2), got {hor.shape}")
    lines = lowest_lines(hor, opts)
    if lines.shape[0] == 0:
        return []
    ends = lines.reshape(-1, 2)
    points, hits = floor_points(ends, rig, head_pose)
    points, hits = points.reshape(-1, 2, 2), hits.reshape(-1, 2)
    rel = points - np.array([head_pose.x_m, head_pose.y_m])
    with np.errstate(invalid="ignore"):
        near = (np.hypot(rel[..., 0], rel[..., 1]) <= opts.ground_range_m).all(axis=1)
        length = np.hypot(*(points[:, 1] - points[:, 0]).T)
        keep = np.flatnonzero(hits.all(axis=1) & near & (length >= opts.min_ground_length_m))
    if keep.size == 0:
        return []
    J = floor_point_jacobians(lines[keep].reshape(-1, 2), rig, head_pose)
    cov = (opts.end_sigma_px**2) * (J @ J.transpose(0, 2, 1))
    cov = cov.reshape(-1, 2, 2, 2) + 1e-8 * np.eye(2)  # a line's ends are never exact
    return [
        FloorSegment(endpoints=points[k], cov=cov[n], height_m=np.zeros(2), source=GROUND_SOURCE)
        for n, k in enumerate(keep.tolist())
    ]


def add_ground_lines(
    left: ImageSegments,
    floor: FloorObservation,
    rig: StereoRig,
    head_pose: HeadPose,
    options: GroundLineOptions | None = None,
    **overrides: Any,
) -> FloorObservation:
    """``floor`` with the segments of :func:`ground_segments` added (itself when there are
    none)."""
    return _with_segments(floor, ground_segments(left, rig, head_pose, options, **overrides))


def add_line_ground_segments(
    lines: FloatArray,
    floor: FloorObservation,
    rig: StereoRig,
    head_pose: HeadPose,
    options: GroundLineOptions | None = None,
    **overrides: Any,
) -> FloorObservation:
    """``floor`` with the segments of :func:`line_ground_segments` of ``lines`` added (itself
    when there are none)."""
    return _with_segments(floor, line_ground_segments(lines, rig, head_pose, options, **overrides))


def _with_segments(floor: FloorObservation, added: list[FloorSegment]) -> FloorObservation:
    """``floor`` with ``added`` after its segments (itself when ``added`` is empty)."""
    if not added:
        return floor
    return FloorObservation(
        segments=(*floor.segments, *added),
        ambiguous=floor.ambiguous,
        viewpoint=floor.viewpoint,
        fov_rad=floor.fov_rad,
        max_range_m=floor.max_range_m,
    )
