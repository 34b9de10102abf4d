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

The head is level, so the floor coordinates depend on ``(X, Z)`` only: the 2x2 floor covariance is
computed in closed form from the ``(u, d)`` block of ``S`` (equal to the ``(x, y)`` block of the
world-frame ``R J S J^T R^T``, which ``triangulate_points`` gives in full).

Ambiguity (section 3.3): a left segment with one surviving match gives a ``FloorSegment``; one with
several gives an ``AmbiguousSegment`` whose probabilities are renormalised over the survivors.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from modeling._compiled.tri import floor_rows
from modeling.validation import FloatArray
from modeling.matching import StereoMatches
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from modeling.rig import HeadPose, StereoRig

__all__ = ["triangulate_points", "triangulate_to_floor"]


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
    assert rig.cx_px is not None and rig.cy_px is not None
    inv_d = 1.0 / d
    xu = (u - rig.cx_px) * b * inv_d
    yv = (v - rig.cy_px) * b * inv_d
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


def _slot_setter(cls: type, name: str) -> Callable[[object, object], None]:
    """The ``__set__`` of slot ``name`` of the slotted dataclass ``cls``: it writes the slot as
    ``object.__setattr__`` does, without looking the name up on every call (about half the cost;
    a triangulation builds a few dozen segments of four slots each)."""
    setter: Callable[[object, object], None] = vars(cls)[name].__set__
    return setter


_set_endpoints = _slot_setter(FloorSegment, "endpoints")
_set_cov = _slot_setter(FloorSegment, "cov")
_set_height_m = _slot_setter(FloorSegment, "height_m")
_set_source = _slot_setter(FloorSegment, "source")


def _segment(ends: FloatArray, cov: FloatArray, heights: FloatArray, source: int) -> FloorSegment:
    """A ``FloorSegment`` from read-only views of arrays already checked in bulk (finite, symmetric
    positive definite): skips the per-segment validation of the constructor, which would cost more
    than the whole triangulation."""
    seg = object.__new__(FloorSegment)
    _set_endpoints(seg, ends)
    _set_cov(seg, cov)
    _set_height_m(seg, heights)
    _set_source(seg, source)
    return seg


def _ambiguous(candidates: tuple[FloorSegment, ...], probs: list[float]) -> AmbiguousSegment:
    """An ``AmbiguousSegment`` whose probabilities were checked in bulk (positive, sum to 1)."""
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


def triangulate_to_floor(
    matches: StereoMatches,
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    min_height_m: float = 0.05,
    max_height_m: float = 1.0,
    min_probability: float = 1e-6,
) -> FloorObservation:
    """Floor segments with endpoint covariances from stereo matches.

    Args:
        matches: Kept matches (``match_segments``); rows need not be sorted.
        rig: The stereo rig that took the pair.
        head_pose: Pose of the left optical centre (level head) in the world.
        min_height_m: Lowest height above the floor that is kept, m (the floor itself is not an
            obstacle).
        max_height_m: Highest height kept, m (the robot's height).
        min_probability: Candidates below this probability are ignored, in [0, 1). Rows with a
            non-positive or non-finite disparity, or non-finite endpoints or variances, are
            ignored too (nothing to triangulate).

    Returns:
        The observation: unambiguous ``FloorSegment``s (``source`` = left segment index) and
        ``AmbiguousSegment``s (candidates in decreasing probability), in increasing left segment
        index; viewpoint ``(x, y, heading)`` of the head, field of view ``rig.hfov_rad`` and range
        ``rig.max_depth_m``. Endpoint covariances are the ``(x, y)`` block of ``J S J^T`` in the
        world frame (equal to ``triangulate_points`` rotated to the world).

    Raises:
        ValueError: wrong argument types, non-finite heights, ``min_height_m >= max_height_m`` or
            ``min_probability`` outside [0, 1).
    """
    if not isinstance(matches, StereoMatches):
        raise ValueError(f"matches must be a StereoMatches, got {type(matches).__name__}")
    if not isinstance(rig, StereoRig):
        raise ValueError(f"rig must be a StereoRig, got {type(rig).__name__}")
    if not isinstance(head_pose, HeadPose):
        raise ValueError(f"head_pose must be a HeadPose, got {type(head_pose).__name__}")
    if not (math.isfinite(min_height_m) and math.isfinite(max_height_m)):
        raise ValueError("min_height_m and max_height_m must be finite")
    if min_height_m >= max_height_m:
        raise ValueError(
            f"min_height_m ({min_height_m}) must be below max_height_m ({max_height_m})"
        )
    if not (0.0 <= min_probability < 1.0):
        raise ValueError(f"min_probability must be in [0, 1), got {min_probability!r}")
    # usable rows: probable enough, in front of the camera (positive disparity), finite (a NaN or
    # an infinity anywhere in a row makes the row's sum non-finite).
    # Clipped to the height band: along the segment (t in [0, 1] from the top end) the row and the
    # disparity are affine, so the height h(t) = H - (v(t) - cy) b / d(t) is monotonic and crosses a
    # given height at t = (k d0 - (v0 - cy) b) / (dv b - k dd), k = H - height; the higher end
    # (the top one of a falling segment) leaves through max_height_m, the lower one through
    # min_height_m; an end beyond its edge is moved to the crossing, the others stay at t = 0 and 1.
    # Then (u, d) -> camera (X, Z) = ((u - cx) b / d, f b / d) with J = [[b/d, -X/d], [0, -Z/d]]
    # on (u, d) and S = [[var_u, var_u], [var_u, var_d]] (cov(u, d) = var u_left since
    # d = u_left - u_right); v only moves Y, the height, which the floor does not see. Camera
    # (X, Z) -> world (x, y) of a level head: x = x0 + s X + c Z, y = y0 - c X + s Z. A degenerate
    # covariance (zero variances) is not a normal distribution: such rows are dropped. All in one
    # compiled pass (``_tri_kernel.floor_rows``), rows grouped by left segment, the most probable
    # candidate first.
    assert rig.cx_px is not None and rig.cy_px is not None
    xy, cov, heights, left_idx, gp = floor_rows(
        matches.probability,
        matches.left_index,
        matches.left_endpoints,
        matches.disparity_px,
        matches.u_left_var,
        matches.disparity_var,
        float(min_probability),
        float(min_height_m),
        float(max_height_m),
        (float(rig.baseline_m), float(rig.cx_px), float(rig.cy_px), float(rig.fb)),
        (
            float(head_pose.x_m),
            float(head_pose.y_m),
            float(head_pose.height_m),
            math.cos(head_pose.heading_rad),
            math.sin(head_pose.heading_rad),
        ),
    )
    # the rows in output order, read-only; each segment holds views of one row of these
    for arr in (xy, cov, heights):
        arr.setflags(write=False)
    xy_l, cov_l, h_l = list(xy), list(cov), list(heights)
    gl_l = left_idx.tolist()
    segments: list[FloorSegment] = []
    ambiguous: list[AmbiguousSegment] = []
    n = len(gl_l)
    a = 0
    while a < n:  # one left segment per run of equal indices
        src = gl_l[a]
        z = a + 1
        while z < n and gl_l[z] == src:
            z += 1
        if z - a == 1:
            segments.append(_segment(xy_l[a], cov_l[a], h_l[a], src))
        else:
            p = gp[a:z]
            cands = tuple(_segment(xy_l[r], cov_l[r], h_l[r], src) for r in range(a, z))
            ambiguous.append(_ambiguous(cands, (p / p.sum()).tolist()))
        a = z
    return _observation(tuple(segments), tuple(ambiguous), rig, head_pose)
