"""What a level stereo head could see of the floor sides of the scene's parts.

:func:`modeling.stereo.faces.close_faces` closes a face where its bottom edge meets the floor; the
surrogate draws those floor lines where the head sees them. :func:`floor_hidden` says which floor
points a part hides (the sweep of :mod:`stereo_nav_env.perception.surrogate.visibility` at height
0), and :func:`visible_floor_lines` samples each floor side that faces the head and keeps the seen
runs as image lines. Both are compiled loops
(:mod:`stereo_nav_env.perception.surrogate._kernels.visibility`) with NumPy references a test holds
them equal to, bit for bit.

``ground_lines=True`` (:mod:`modeling.stereo.ground_lines`) reads every near-horizontal line of the
left image, not only those between two seen vertical edges: :func:`visible_ground_lines` gives the
left-image lines of every floor side that faces the head, sampled finely along the side, where
no part hides the floor and the left image shows it (its vertical edges may be outside the image:
a wall seen face-on).

Frames and units: world metres, floor plane x-y, z up; image pixels (u right, v down, (0, 0) the
centre of the top-left pixel); camera depth ``Z`` along the optical axis, ``X`` to the right.
"""

from __future__ import annotations

import numpy as np

from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import BoolArray, FloatArray, IntArray
from stereo_nav_env.perception.surrogate._kernels.visibility import (
    FloorSides,
    floor_hidden_loop,
    floor_lines_loop,
)
from stereo_nav_env.perception.surrogate.visibility import (
    PULL_BACK_M,
    SceneEdges,
    camera_array,
    camera_xz,
    head_array,
    in_both_images,
    parts_of,
    sight_blocked,
    sight_of,
)

__all__ = [
    "GROUND_STEP_M",
    "floor_hidden",
    "floor_hidden_reference",
    "visible_floor_lines",
    "visible_floor_lines_reference",
    "visible_ground_lines",
]


GROUND_STEP_M = 0.05
"""Spacing of :func:`visible_ground_lines`' samples along a floor side, metres: a seen run's ends
are where the image or an occluding part cuts the line, to half this."""


def floor_hidden_reference(edges: SceneEdges, head: HeadPose, points: FloatArray) -> BoolArray:
    """:func:`floor_hidden` in NumPy: the sight lines clipped to every part at once
    (:func:`sight_blocked`)."""
    Hh = head.height_m
    line, part, t0, t1 = sight_blocked(edges, head, points)
    # the floor point (t = 1) is hidden by a part whose height range the sight line (at height
    # Hh (1 - t)) meets between t0 and t1
    out = np.zeros(points.shape[0], dtype=bool)
    out[line[(Hh * (1.0 - t0) > edges.z_min[part]) & (Hh * (1.0 - t1) < edges.z_max[part])]] = True
    return out


def floor_hidden(edges: SceneEdges, head: HeadPose, points: FloatArray) -> BoolArray:
    """(n,) whether a part hides each floor point (n, 2) from the head; one compiled pass over
    the points and parts (:func:`floor_hidden_reference` is the same in NumPy, and a test
    holds them equal)."""
    return floor_hidden_loop(
        sight_of(head), parts_of(edges), np.ascontiguousarray(points, dtype=np.float64)
    )


def visible_floor_lines_reference(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    corners: IntArray,
    *,
    samples: int = 5,
    max_range_m: float,
) -> FloatArray:
    """The image lines of the parts' floor sides the head sees, (k, 2, 2) ``[[u, v], [u, v]]`` px,
    left end first.

    Only the sides whose two ends lie within 2 cm of edges among ``corners`` (indices into
    ``SceneEdges.corner_xy``: those seen, the only ones a face can join; a shelf's bottom board
    runs between the corners of its sides) are looked at. A side
    within ``max_range_m`` whose outer face turns to the head is sampled at
    ``samples`` points; a point is seen if it is in the image (both images' columns, the rows)
    and no part hides the floor there. Each run of seen points gives one line, from half a sample
    step before its first point to half a step after its last (clipped to the side).
    """
    if edges.line_ends.shape[0] == 0:
        return np.zeros((0, 2, 2))
    head_xy = np.array([head.x_m, head.y_m])
    mid = edges.line_ends.mean(axis=1)
    near = np.hypot(*(mid - head_xy).T) <= max_range_m
    facing = np.einsum("li,li->l", edges.line_normal, head_xy - mid) > 0.0
    seen_xy = edges.corner_xy[corners]  # (c, 2)
    gap = edges.line_ends[:, :, None, :] - seen_xy[None, None]  # (L, 2, c, 2)
    both = ((gap * gap).sum(axis=-1).min(axis=-1, initial=np.inf) <= 0.02**2).all(axis=1)
    lines = np.flatnonzero(near & facing & both)
    if lines.size == 0:
        return np.zeros((0, 2, 2))
    t = (np.arange(samples) + 0.5) / samples
    a, b = edges.line_ends[lines, 0], edges.line_ends[lines, 1]
    pts = a[:, None] + t[None, :, None] * (b - a)[:, None]  # (l, samples, 2)
    flat = pts.reshape(-1, 2)
    X, Z = camera_xz(flat, head)
    f, (cx, cy), Hh = rig.focal_px, rig.principal_point_px, head.height_m
    seen = in_both_images(X, Z, rig, 1.0)
    seen &= cy + f * Hh / np.where(Z > 0, Z, 1.0) <= rig.height_px - 1.0
    seen &= ~floor_hidden(edges, head, flat)
    seen = seen.reshape(lines.size, samples)
    # runs of seen samples: a start where the previous sample is unseen, a stop where the next is
    pad = np.zeros((lines.size, samples + 2), dtype=bool)
    pad[:, 1:-1] = seen
    line_k, first = np.nonzero(pad[:, 1:-1] & ~pad[:, :-2])
    _, last = np.nonzero(pad[:, 1:-1] & ~pad[:, 2:])  # row-major: the same runs, in order
    if line_k.size == 0:
        return np.zeros((0, 2, 2))
    half = 0.5 / samples
    ta, tb = t[first] - half, t[last] + half
    ab = (b - a)[line_k]
    ends = np.stack([a[line_k] + ta[:, None] * ab, a[line_k] + tb[:, None] * ab], axis=1)
    Xe, Ze = camera_xz(ends, head)
    Ze = np.maximum(Ze, 1e-6)
    img = np.stack([cx + f * Xe / Ze, cy + f * Hh / Ze], axis=-1)
    swap = img[:, 0, 0] > img[:, 1, 0]
    img[swap] = img[swap, ::-1]
    return img


def visible_floor_lines(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    corners: IntArray,
    *,
    samples: int = 5,
    max_range_m: float,
) -> FloatArray:
    """:func:`visible_floor_lines_reference` in one compiled pass over the parts' floor sides
    (a test holds them equal, bit for bit): about 0.02 ms a view instead of 0.18."""
    out: FloatArray = floor_lines_loop(
        head_array(head),
        camera_array(rig),
        FloorSides(edges.line_ends, edges.line_normal),
        np.ascontiguousarray(edges.corner_xy[corners]),
        int(samples),
        float(max_range_m),
        parts_of(edges),
        PULL_BACK_M,
    )
    return out


def visible_ground_lines(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    *,
    max_range_m: float,
    step_m: float = GROUND_STEP_M,
) -> FloatArray:
    """The left-image lines where the faces the head sees meet the floor, (k, 2, 2)
    ``[[u, v], [u, v]]`` px, left end first: what the segment extraction of the left image would
    find at the floor sides of the parts (the module docstring).

    Every floor side whose outer face turns to the head and that comes within ``max_range_m`` of
    it is sampled every ``step_m`` or less (at least twice); a sample is seen where it lies ahead
    of the head, in the left image's columns and above its last row, and no part hides the floor
    there (:func:`floor_hidden`). Each run of seen samples gives one line, from half a step
    before its first sample to half a step after its last (clipped to the side). The lines are
    whole, as the image shows them: :func:`modeling.stereo.ground_lines.line_ground_segments`
    drops those that end beyond its range.

    Args:
        edges: The scene's edges.
        head: Pose of the left optical centre (level).
        rig: The stereo rig.
        max_range_m: Sides farther than this from the head (their nearest point) are left out,
            metres: the ground lines do not reach them.
        step_m: Largest spacing of the samples along a side, metres (> 0).
    """
    if edges.line_ends.shape[0] == 0:
        return np.zeros((0, 2, 2))
    head_xy = np.array([head.x_m, head.y_m])
    a_all, b_all = edges.line_ends[:, 0], edges.line_ends[:, 1]
    ab_all = b_all - a_all
    length = np.hypot(ab_all[:, 0], ab_all[:, 1])
    t_near = np.clip(
        np.einsum("li,li->l", head_xy - a_all, ab_all) / np.maximum(length, 1e-12) ** 2, 0.0, 1.0
    )
    nearest = a_all + t_near[:, None] * ab_all
    near = np.hypot(*(nearest - head_xy).T) <= max_range_m
    mid = 0.5 * (a_all + b_all)
    facing = np.einsum("li,li->l", edges.line_normal, head_xy - mid) > 0.0
    lines = np.flatnonzero(near & facing & ~edges.line_detail)
    if lines.size == 0:
        return np.zeros((0, 2, 2))
    count = np.maximum(np.ceil(length[lines] / step_m).astype(np.int64), 2)
    line_of = np.repeat(np.arange(lines.size), count)
    first_of = np.cumsum(count) - count
    index = np.arange(line_of.size) - first_of[line_of]
    t = (index + 0.5) / count[line_of]
    a, ab = a_all[lines], ab_all[lines]
    pts = a[line_of] + t[:, None] * ab[line_of]
    X, Z = camera_xz(pts, head)
    f, (cx, cy), Hh = rig.focal_px, rig.principal_point_px, head.height_m
    Zs = np.where(Z > 1e-6, Z, 1.0)
    u = cx + f * X / Zs
    seen = (Z > 1e-6) & (u >= -0.5) & (u <= rig.width_px - 0.5)
    seen &= cy + f * Hh / Zs <= rig.height_px - 0.5
    seen[seen] = ~floor_hidden(edges, head, pts[seen])
    # runs of seen samples within each side: a start where the previous sample (of the same
    # side) is unseen, a stop where the next one is
    prev = np.concatenate([[False], seen[:-1]]) & (index > 0)
    nxt = np.concatenate([seen[1:], [False]]) & (index < count[line_of] - 1)
    starts = np.flatnonzero(seen & ~prev)
    stops = np.flatnonzero(seen & ~nxt)
    if starts.size == 0:
        return np.zeros((0, 2, 2))
    k = line_of[starts]
    half = 0.5 / count[k]
    ta = np.maximum(t[starts] - half, 0.0)
    tb = np.minimum(t[stops] + half, 1.0)
    ends = np.stack([a[k] + ta[:, None] * ab[k], a[k] + tb[:, None] * ab[k]], axis=1)
    Xe, Ze = camera_xz(ends, head)
    behind = Ze <= 1e-3  # an end stepped behind the head: its seen sample instead
    if behind.any():
        own = np.stack([pts[starts], pts[stops]], axis=1)
        ends[behind] = own[behind]
        Xe, Ze = camera_xz(ends, head)
    img = np.stack([cx + f * Xe / Ze, cy + f * Hh / Ze], axis=-1)
    swap = img[:, 0, 0] > img[:, 1, 0]
    img[swap] = img[swap, ::-1]
    # the image cuts a line at its first and last columns
    (u0, v0), (u1, v1) = img[:, 0].T, img[:, 1].T
    du = np.where(u1 - u0 > 1e-9, u1 - u0, 1.0)
    lo, hi = -0.5, rig.width_px - 0.5
    ua, ub = np.clip(u0, lo, hi), np.clip(u1, lo, hi)
    out: FloatArray = np.stack(
        [
            np.stack([ua, v0 + (ua - u0) / du * (v1 - v0)], axis=-1),
            np.stack([ub, v0 + (ub - u0) / du * (v1 - v0)], axis=-1),
        ],
        axis=1,
    )
    return out
