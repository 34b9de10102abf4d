"""Triangulation of matched segments, their uncertainty, projection to the floor (sections 2, 3.2).

For every kept match, the two endpoints of the overlapping part ``(u, v, d)`` (left column, row,
disparity) are triangulated in the left camera frame::

    X = (u - cx) b / d,   Y = (v - cy) b / d,   Z = f b / d

and their covariance is propagated by linearisation, ``Sigma_P = J S J^T`` with ``J`` the Jacobian
of ``(X, Y, Z)`` with respect to ``(u, d, v)`` and ``S`` the covariance of ``(u, d, v)`` (``var u``,
``var d = var u_left + var u_right``, ``cov(u, d) = var u_left``, ``var v``): the depth standard
deviation grows as ``Z^2 / (f b) * sigma_d``. The points and covariances are then rotated into the
world frame through the ``HeadPose``.

Height band (section 2): the 3D segment is clipped to ``min_height_m <= z <= max_height_m``. Along
an image segment the disparity is affine in the row (it is a 3D line), so the row where the segment
crosses a height has a closed form; the clipped endpoint is re-evaluated there (mean exactly,
variances by linear interpolation between the two ends, which over-states them slightly). A segment
with nothing left inside the band is dropped. The floor segment is the ``(x, y)`` part, with the
full 2x2 covariance of each endpoint.

The head may be tilted down (``HeadPose.tilt_rad``, about the baseline: the pair stays rectified
and the camera-frame triangulation is unchanged): the floor point is ``p = A (X, Y, Z)`` with
``A`` the ``(x, y)`` rows of ``R_cam2world``, and its 2x2 covariance ``J_p S J_p^T``, ``J_p = A J``,
is computed in closed form (equal to the ``(x, y)`` block of the world-frame
``R J S J^T R^T``, which ``triangulate_points`` gives in full). Level, ``A`` has no ``Y`` column
and the row's variance moves only the height.

Ambiguity (section 3.3): a left segment whose matches all survive gives a ``FloorSegment`` (one
match) or an ``AmbiguousSegment`` (several). A match dropped by the height band is a possible match
that is no obstacle: its probability stays as the segment's "no obstacle here" mass
(``AmbiguousSegment.p_none``), so the survivors keep their probabilities and form an
``AmbiguousSegment`` even when only one survives; with none surviving, nothing is emitted.

The per-row work (usable rows, band clip, floor points and covariances, grouping) is one compiled
pass, :func:`modeling.stereo._kernels.tri.floor_rows`; :func:`floor_rows_reference` is the same step
in plain NumPy, the one to read (and to change first: a test holds the two equal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from modeling.observation import P_NONE_ATOL, AmbiguousSegment, FloorObservation, FloorSegment
from modeling.stereo._kernels.tri import FloorFrame, FloorRows, MatchRows, floor_rows
from modeling.stereo.matching import StereoMatches
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import FloatArray
from modeling.validation import instance, number, with_overrides

__all__ = [
    "TriangulationOptions",
    "floor_rows_reference",
    "triangulate_points",
    "triangulate_to_floor",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class TriangulationOptions:
    """Options of :func:`triangulate_to_floor`.

    Attributes:
        min_height_m: Lowest height above the floor that is kept, m (the floor itself is not an
            obstacle).
        max_height_m: Highest height kept, m (the robot's height); above ``min_height_m``.
        min_probability: Candidates below this probability are ignored, in [0, 1); so is a
            "no obstacle here" mass (``AmbiguousSegment.p_none``) below it.

    Raises:
        ValueError: a non-finite height, ``min_height_m >= max_height_m`` or ``min_probability``
            outside [0, 1) (naming the option).
    """

    min_height_m: float = 0.05
    max_height_m: float = 1.0
    min_probability: float = 1e-6

    def __post_init__(self) -> None:
        low = number(self.min_height_m, "min_height_m")
        high = number(self.max_height_m, "max_height_m")
        if low >= high:
            raise ValueError(f"min_height_m ({low}) must be below max_height_m ({high})")
        p = number(self.min_probability, "min_probability", low=0.0, high=1.0, strict=False)
        if p >= 1.0:
            raise ValueError(f"min_probability must be in [0, 1), got {self.min_probability!r}")
        object.__setattr__(self, "min_height_m", low)
        object.__setattr__(self, "max_height_m", high)
        object.__setattr__(self, "min_probability", p)


def triangulate_points(
    u: FloatArray,
    v: FloatArray,
    d: FloatArray,
    var_u: FloatArray,
    var_d: FloatArray,
    cov_ud: FloatArray,
    var_v: FloatArray,
    rig: StereoRig,
) -> tuple[FloatArray, FloatArray]:
    """Left-camera points and their linearised covariance from ``(u, v, d)`` and its covariance.

    Args:
        u, v, d: (n,) left column, row and disparity, px (``d > 0``).
        var_u, var_d, cov_ud, var_v: (n,) (co)variances of ``u``, ``d`` and ``v``, px^2; ``v`` is
            independent of ``u`` and ``d``.
        rig: The stereo rig.

    Returns:
        ``(P_cam (n, 3) m, cov_cam (n, 3, 3) m^2)`` in the left camera frame.
    """
    b = rig.baseline_m
    cx, cy = rig.principal_point_px
    inv_d = 1.0 / d
    xu = (u - cx) * b * inv_d
    yv = (v - cy) * b * inv_d
    Z = rig.fb * inv_d
    P = np.stack([xu, yv, Z], axis=-1)
    n = u.shape[0]
    # J rows: X, Y, Z; columns: u, d, v
    J = np.zeros((n, 3, 3))
    J[:, 0, 0] = b * inv_d
    J[:, 0, 1] = -xu * inv_d
    J[:, 1, 1] = -yv * inv_d
    J[:, 1, 2] = b * inv_d
    J[:, 2, 1] = -Z * inv_d
    S = np.zeros((n, 3, 3))
    S[:, 0, 0] = var_u
    S[:, 0, 1] = S[:, 1, 0] = cov_ud
    S[:, 1, 1] = var_d
    S[:, 2, 2] = var_v
    cov = J @ S @ np.swapaxes(J, 1, 2)
    return P, cov


def _segment(ends: FloatArray, cov: FloatArray, heights: FloatArray, source: int) -> FloorSegment:
    """A ``FloorSegment`` from read-only views of arrays already checked in bulk (finite, symmetric
    positive definite): skips the per-segment validation of the constructor, which would cost more
    than the whole triangulation."""
    seg = object.__new__(FloorSegment)
    object.__setattr__(seg, "endpoints", ends)
    object.__setattr__(seg, "cov", cov)
    object.__setattr__(seg, "height_m", heights)
    object.__setattr__(seg, "source", source)
    return seg


def _ambiguous(candidates: tuple[FloorSegment, ...], probs: list[float]) -> AmbiguousSegment:
    """An ``AmbiguousSegment`` whose probabilities were checked in bulk (positive, summing to 1,
    or to at most ``1 - min_probability`` with one candidate or more)."""
    amb = object.__new__(AmbiguousSegment)
    object.__setattr__(amb, "candidates", candidates)
    object.__setattr__(amb, "probabilities", tuple(probs))
    return amb


def _observation(
    segments: tuple[FloorSegment, ...],
    ambiguous: tuple[AmbiguousSegment, ...],
    rig: StereoRig,
    head_pose: HeadPose,
) -> FloorObservation:
    """A ``FloorObservation`` of segments built here, seen from a validated pose with a validated
    rig: the viewpoint is finite (``HeadPose`` checks it), the field of view of a rig whose
    principal point lies in the image is in (0, pi), its range is positive. Skips the constructor's
    checks, which cost as much as the rest of a small triangulation; values are converted exactly
    as the constructor does (``float``)."""
    viewpoint = np.array([head_pose.x_m, head_pose.y_m, head_pose.heading_rad])
    viewpoint.setflags(write=False)
    obs = object.__new__(FloorObservation)
    object.__setattr__(obs, "segments", segments)
    object.__setattr__(obs, "ambiguous", ambiguous)
    object.__setattr__(obs, "viewpoint", viewpoint)
    object.__setattr__(obs, "fov_rad", float(rig.hfov_rad))
    object.__setattr__(obs, "max_range_m", float(rig.max_depth_m))
    return obs


def floor_rows_reference(rows: MatchRows, frame: FloorFrame) -> FloorRows:
    """The usable matches clipped to the height band and triangulated to the floor (sections 2,
    3.2): the readable NumPy form of the compiled :func:`modeling.stereo._kernels.tri.floor_rows`,
    which gives the same rows bit for bit.

    1. Usable rows: probable enough (``min_probability``), in front of the camera (positive
       disparity at both ends), finite (a NaN or an infinity anywhere makes the row's sum
       non-finite).
    2. Height band (section 2): along the segment (``t`` in [0, 1] from the top end) the row and
       the disparity are affine, so the height
       ``h(t) = H - (cos(tilt) (v(t) - cy) b + sin(tilt) f b) / d(t)`` is monotonic and crosses
       a height at ``t = (k d0 - (cos(tilt) (v0 - cy) b + sin(tilt) f b)) /
       (cos(tilt) dv b - k dd)``, ``k = H - height``.
       The higher end leaves through ``max_height_m``, the lower one through ``min_height_m``; an
       end beyond its edge is moved to the crossing (``u, v, d`` and the variances interpolated
       there), the others stay at ``t = 0`` and ``1``. A row with nothing inside is dropped.
    3. Floor point and covariance (section 3.2): ``(u, d, v) -> (X, Y, Z) = ((u - cx) b / d,
       (v - cy) b / d, f b / d)``, the floor point ``p = (x0, y0) + A (X, Y, Z)`` with ``A``
       the ``(x, y)`` rows of the head's ``R_cam2world``, ``J_p = A J`` and
       ``S = [[var_u, var_u, 0], [var_u, var_d, 0], [0, 0, var_v]]`` (``cov(u, d) = var
       u_left`` since ``d = u_left - u_right``); level, ``A``'s ``Y`` column is 0 and ``v``
       moves only the height ``H - cos(tilt) Y - sin(tilt) Z``. A row with a degenerate
       covariance (not a normal distribution) is dropped.
    4. Grouping: by left segment, then decreasing probability (stable).

    Args:
        rows: The matches.
        frame: The band, the rig and the head.

    Returns:
        The kept rows.
    """
    d_all = rows.disparity
    row_sum = (
        d_all.sum(axis=1)
        + rows.ends.sum(axis=(1, 2))
        + rows.u_var.sum(axis=1)
        + rows.d_var.sum(axis=1)
    )
    idx = np.flatnonzero(
        (rows.probability >= frame.min_probability) & (d_all.min(axis=1) > 0) & np.isfinite(row_sum)
    )
    # 2. the height band: both band edges (columns: max_height_m, min_height_m) at once
    b, H, cy = frame.baseline_m, frame.height_m, frame.cy_px
    ct, st = frame.cos_tilt, frame.sin_tilt
    fbs = st * frame.fb
    lo, hi = frame.min_height_m, frame.max_height_m
    v_e = rows.ends[idx, :, 1]  # (k, 2) rows of the two ends
    d_e = d_all[idx]
    v0, d0 = v_e[:, 0], d_e[:, 0]
    dv = v_e[:, 1] - v0
    dd = d_e[:, 1] - d0
    k_band = np.array([H - hi, H - lo])
    with np.errstate(divide="ignore", invalid="ignore"):
        h = H - (ct * (v_e - cy) * b + fbs) / d_e  # (k, 2) heights of the two ends
        t_band = (k_band * d0[:, None] - (ct * (v0 - cy) * b + fbs)[:, None]) / (
            (ct * dv * b)[:, None] - k_band * dd[:, None]
        )
    h0, h1 = h[:, 0], h[:, 1]
    falling = h0 >= h1  # the usual case: the height drops as the row increases
    via_top = falling[:, None] == np.array([True, False])  # (k, 2)
    outside = np.where(via_top, h > hi, h < lo)
    T = np.where(outside, np.where(via_top, t_band[:, :1], t_band[:, 1:]), (0.0, 1.0))
    T = np.minimum(np.maximum(T, 0.0), 1.0)
    finite = np.isfinite(h) & np.isfinite(T)
    alive = (
        finite[:, 0]
        & finite[:, 1]
        & (np.maximum(h0, h1) >= lo)
        & (np.minimum(h0, h1) <= hi)
        & ((T[:, 1] > T[:, 0]) | (dv <= 0))
    )
    sel = np.flatnonzero(alive)
    idx, T = idx[sel], T[sel]
    ends = rows.ends[idx]
    block = np.stack(
        [
            ends[:, :, 0],
            ends[:, :, 1],
            d_all[idx],
            rows.u_var[idx],
            rows.d_var[idx],
            rows.v_var[idx],
        ]
    )  # (6, k, 2): u, v, d, var u, var d, var v at the two ends, moved to the clipped ends
    u, v, d, var_u, var_d, var_v = block[:, :, :1] + (block[:, :, 1:] - block[:, :, :1]) * T
    # 3. (u, d, v) -> camera (X, Y, Z); the floor point p = A (X, Y, Z) and J_p S J_p^T
    inv_d = 1.0 / d
    bd = b * inv_d
    X = (u - frame.cx_px) * bd
    Y = (v - cy) * bd
    Z = frame.fb * inv_d
    c, s = frame.cos_heading, frame.sin_heading
    A = np.array([[s, -st * c, ct * c], [-c, -st * s, ct * s]])  # rows: world x, y
    J = np.empty((*u.shape, 2, 3))  # J_p = A J, columns u, d, v
    for r in range(2):
        ax, ay, az = A[r]
        J[..., r, 0] = ax * bd
        J[..., r, 1] = -(ax * X + ay * Y + az * Z) * inv_d
        J[..., r, 2] = ay * bd
    xy = np.empty((*u.shape, 2))
    xy[..., 0] = frame.x_m + A[0, 0] * X + A[0, 1] * Y + A[0, 2] * Z
    xy[..., 1] = frame.y_m + A[1, 0] * X + A[1, 1] * Y + A[1, 2] * Z
    cov = np.empty((*u.shape, 2, 2))
    for r, q in ((0, 0), (1, 1), (0, 1)):  # S = [[vu, vu, 0], [vu, vd, 0], [0, 0, vv]]
        ju, jd, jv = J[..., r, 0], J[..., r, 1], J[..., r, 2]
        ku, kd, kv = J[..., q, 0], J[..., q, 1], J[..., q, 2]
        if r == q:
            cov[..., r, q] = (
                ju * ju * var_u + 2.0 * ju * jd * var_u + jd * jd * var_d + jv * jv * var_v
            )
        else:
            cov[..., 0, 1] = cov[..., 1, 0] = (
                ju * ku * var_u + (ju * kd + jd * ku) * var_u + jd * kd * var_d + jv * kv * var_v
            )
    heights = H - ct * Y - st * Z
    det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] ** 2
    ok = (cov[..., 0, 0] > 0) & (det > 0)
    good = np.flatnonzero(ok[:, 0] & ok[:, 1])
    # 4. grouped by left segment, the most probable candidate first
    left = rows.left_index[idx[good]]
    prob = rows.probability[idx[good]]
    order = np.lexsort((-prob, left))
    kept = good[order]
    return FloorRows(xy[kept], cov[kept], heights[kept], left[order], prob[order])


def triangulate_to_floor(
    matches: StereoMatches,
    rig: StereoRig,
    head_pose: HeadPose,
    options: TriangulationOptions | None = None,
    **overrides: Any,
) -> FloorObservation:
    """Floor segments with endpoint covariances from stereo matches (sections 2, 3.2, 3.3).

    Args:
        matches: Kept matches (``match_segments``); rows need not be sorted. Rows with a
            non-positive or non-finite disparity, or non-finite endpoints or variances, are
            ignored (nothing to triangulate).
        rig: The stereo rig that took the pair.
        head_pose: Pose of the left optical centre (level or tilted head) in the world.
        options: The height band and probability floor (defaults: ``TriangulationOptions()``).
        **overrides: Fields of :class:`TriangulationOptions` (``min_height_m``,
            ``max_height_m``, ``min_probability``) replacing those of ``options``.

    Returns:
        The observation: unambiguous ``FloorSegment``s (``source`` = left segment index) and
        ``AmbiguousSegment``s (candidates in decreasing probability; the mass of matches dropped
        by the height band is their ``p_none``), in increasing left segment index; viewpoint
        ``(x, y, heading)`` of the head, field of view ``rig.hfov_rad`` and range
        ``rig.max_depth_m``. Endpoint covariances are the ``(x, y)`` block of ``J S J^T`` in the
        world frame (equal to ``triangulate_points`` rotated to the world).

    Raises:
        ValueError: wrong argument types, an unknown option, or an option out of range (see
            :class:`TriangulationOptions`).
    """
    if not isinstance(matches, StereoMatches):
        raise ValueError(f"matches must be a StereoMatches, got {type(matches).__name__}")
    instance(rig, StereoRig, "rig")
    instance(head_pose, HeadPose, "head_pose")
    opts = with_overrides(options, TriangulationOptions, overrides)
    cx, cy = rig.principal_point_px
    frame = FloorFrame(
        min_probability=opts.min_probability,
        min_height_m=opts.min_height_m,
        max_height_m=opts.max_height_m,
        baseline_m=float(rig.baseline_m),
        cx_px=float(cx),
        cy_px=float(cy),
        fb=float(rig.fb),
        x_m=head_pose.x_m,
        y_m=head_pose.y_m,
        height_m=head_pose.height_m,
        cos_heading=math.cos(head_pose.heading_rad),
        sin_heading=math.sin(head_pose.heading_rad),
        cos_tilt=math.cos(head_pose.tilt_rad),
        sin_tilt=math.sin(head_pose.tilt_rad),
    )
    rows = MatchRows(
        probability=matches.probability,
        left_index=matches.left_index,
        ends=matches.left_endpoints,
        disparity=matches.disparity_px,
        u_var=matches.u_left_var,
        d_var=matches.disparity_var,
        v_var=matches.v_var,
    )
    segments, ambiguous = _grouped(floor_rows(rows, frame), opts.min_probability)
    return _observation(segments, ambiguous, rig, head_pose)


def _grouped(
    rows: FloorRows, min_probability: float
) -> tuple[tuple[FloorSegment, ...], tuple[AmbiguousSegment, ...]]:
    """The kept rows as segments (section 3.3). The probabilities of a left segment's matches sum
    to 1; the mass of those not kept (above or below the height band, behind the camera, below
    ``min_probability``) is the probability that the segment is no obstacle here
    (``AmbiguousSegment.p_none``), never spread over the kept ones. A left segment whose kept rows
    hold all its mass (up to ``min_probability``, the floor below which a possibility is ignored,
    the "none" one too) gives a ``FloorSegment`` if it has one row, an ``AmbiguousSegment`` with
    probabilities renormalised to 1 if several; otherwise an ``AmbiguousSegment`` of its kept rows
    with their own probabilities (one row allowed). A left segment with no row kept gives nothing.
    Each segment holds read-only views of one row."""
    for arr in (rows.xy, rows.cov, rows.heights):
        arr.setflags(write=False)
    xy_l, cov_l, h_l = list(rows.xy), list(rows.cov), list(rows.heights)
    gl_l = rows.left_index.tolist()
    gp_l = rows.probability.tolist()
    segments: list[FloorSegment] = []
    ambiguous: list[AmbiguousSegment] = []
    n = len(gl_l)
    a = 0
    while a < n:  # one left segment per run of equal indices
        src = gl_l[a]
        z = a + 1
        while z < n and gl_l[z] == src:
            z += 1
        p = gp_l[a:z]
        total = math.fsum(p)
        certain = 1.0 - total < max(min_probability, P_NONE_ATOL)
        if certain and z - a == 1:
            segments.append(_segment(xy_l[a], cov_l[a], h_l[a], src))
        else:
            cands = tuple(_segment(xy_l[r], cov_l[r], h_l[r], src) for r in range(a, z))
            ambiguous.append(_ambiguous(cands, [x / total for x in p] if certain else p))
        a = z
    return tuple(segments), tuple(ambiguous)
