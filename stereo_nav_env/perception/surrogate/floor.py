"""What a level stereo head could see of the floor sides of the scene's parts.

:func:`modeling.stereo.faces.close_faces` closes a face where its bottom edge meets the floor; the
surrogate draws those floor lines where the head sees them. :func:`floor_hidden` says which floor
points a part hides (the sweep of :mod:`stereo_nav_env.perception.surrogate.visibility` at height
0), and :func:`visible_floor_lines` samples each floor side that faces the head and keeps the seen
runs as image lines. Both are compiled loops
(:mod:`stereo_nav_env.perception.surrogate._kernels.visibility`) with NumPy references a test holds
them equal to, bit for bit.

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
    "floor_hidden",
    "floor_hidden_reference",
    "visible_floor_lines",
    "visible_floor_lines_reference",
]


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
