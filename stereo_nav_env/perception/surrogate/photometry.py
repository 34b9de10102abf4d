"""The grey levels beside each seen edge, and the pieces the segment extraction would cut it
into: the surrogate's photometry.

The matcher (:func:`modeling.stereo.matching.match_segments`) pairs a left and a right segment only
if the grey levels on their two sides agree ("near", ``near_px`` from the edge, and "far",
``side_px``; :mod:`modeling.stereo.segments` averages them along the segment). So which edges can be
taken for one another is decided by what lies beside them: a leg's outline against the floor
does not match an identical leg's outline against a wall, two wall corners between the same wall
faces do match. And the extraction images an edge only where it has contrast, as one segment
per run of one polarity: an outline in front of the floor below and a brighter wall above flips
its polarity where the background changes, and is found as two segments (or one, where the
other part has too little contrast).

:func:`edge_greys` gives the grey levels the renderer draws beside ``n`` edges: for each camera
(left, right: ``baseline_m`` apart along the camera's x axis), the rays through the columns
``u - side_px``, ``u + side_px``, ``u - near_px``, ``u + near_px`` of the edge's image column
``u``, at :data:`ROWS` rows evenly along its seen run, meet a first surface, whose grey level
(:mod:`stereo_nav_env.rendering.shading`: the baked shade of a part's side, top or bottom face, the
floor, or the background) is the sample's. :func:`edge_pieces` cuts each edge's rows into the runs
of one polarity whose near contrast reaches ``min_contrast`` and averages the samples over each.

A ray (pixel ``(u, v)`` of a level camera at height ``Hh``) is parameterised by the depth ``Z``
along the optical axis: its floor point is ``o + Z (forward + x right)``, ``x = (u - cx) / f``,
its height ``Hh - y Z``, ``y = (v - cy) / f``. Its floor line is clipped to every part footprint
(:func:`~stereo_nav_env.perception.surrogate.visibility.clip_to_parts`, depths ``Z0 < Z1`` inside);
inside a part of heights ``[z_min, z_max]`` it meets the entered side face at ``Z0`` if its height
there is within them, else the top (descending through ``z_max``) or the bottom (rising through
``z_min``) before ``Z1``. The floor is met at ``Z = Hh / y`` (``y > 0``) inside the rendered floor.
The nearest of these is the surface seen.

Frames and units: world metres, floor plane x-y, z up; image pixels (u right, v down, (0, 0) the
centre of the top-left pixel); grey levels 0-255.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import SegmentOptions
from modeling.types import FloatArray, IntArray
from stereo_nav_env.perception.surrogate._kernels.segments import (
    Surfaces,
    first_surfaces_loop,
    runs_loop,
)
from stereo_nav_env.perception.surrogate.visibility import SceneEdges, clip_to_parts

__all__ = [
    "ROWS",
    "EdgePieces",
    "edge_greys",
    "edge_pieces",
    "edge_pieces_reference",
    "far_depth",
    "first_surface_greys",
    "first_surface_greys_reference",
    "image_pieces",
    "sample_rows",
    "surface_arrays",
]


ROWS = 12
"""Rows sampled along each edge's seen run (evenly, each the middle of an equal share)."""


def sample_rows(v_top: FloatArray, v_bottom: FloatArray) -> FloatArray:
    """(n, ROWS) the sampled rows of runs ``[v_top, v_bottom]`` (n,) px: the middles of
    :data:`ROWS` equal shares of each."""
    frac = (np.arange(ROWS) + 0.5) / ROWS
    out: FloatArray = v_top[:, None] + frac * (v_bottom - v_top)[:, None]
    return out


def edge_greys(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    u: FloatArray,
    Z: FloatArray,
    rows: FloatArray,
    *,
    near_px: float,
    side_px: float,
) -> FloatArray:
    """The grey levels beside ``n`` edges in both images, row by row (the module docstring).

    Args:
        edges: The scene's parts (their footprints, heights and face greys).
        head: Pose of the left optical centre (level).
        rig: The stereo rig.
        u: (n,) the edges' columns in the left image, px (in the right image: ``u - f b / Z``).
        Z: (n,) their depths, metres.
        rows: (n, R) the image rows sampled along each edge, px (:func:`sample_rows`).
        near_px: Distance from the edge of the "near" samples, px.
        side_px: Distance from the edge of the "far" samples, px.

    Returns:
        (2, 4, n, R) grey levels: image (0 left, 1 right), then far left, far right, near left,
        near right of the edge (as ``ImageSegments.grey_left``, ``grey_right``,
        ``grey_left_near``, ``grey_right_near``), edge, row.
    """
    n, n_rows = rows.shape
    if n == 0:
        return np.zeros((2, 4, 0, n_rows))
    f, (cx, cy), Hh = rig.focal_px, rig.principal_point_px, head.height_m
    c, s = math.cos(head.heading_rad), math.sin(head.heading_rad)
    forward, right = np.array([c, s]), np.array([s, -c])
    head_xy = np.array([head.x_m, head.y_m])
    offsets = np.array([-side_px, side_px, -near_px, near_px])
    # the rays' columns: (image, sample, edge), flattened in that order
    col = u[None, None, :] - np.array([0.0, rig.fb])[:, None, None] / Z + offsets[None, :, None]
    x = ((col - cx) / f).reshape(-1)
    origin = np.repeat(head_xy + np.array([0.0, rig.baseline_m])[:, None] * right, 4 * n, axis=0)
    direction = forward + x[:, None] * right  # floor displacement per metre of depth
    y = np.tile((rows - cy) / f, (8, 1))  # (rays, R): the height lost per metre of depth
    grey = first_surface_greys(edges, origin, direction, y, Hh)
    out: FloatArray = grey.reshape(2, 4, n, n_rows)
    return out


def far_depth(edges: SceneEdges) -> float:
    """A depth past every surface of the scene (the rendered floor's diagonal and a metre)."""
    box = edges.floor_box
    return math.hypot(box[2] - box[0], box[3] - box[1]) + 1.0


def first_surface_greys(
    edges: SceneEdges, origin: FloatArray, direction: FloatArray, y: FloatArray, height_m: float
) -> FloatArray:
    """The grey level of the first surface each ray meets (the module docstring), by one
    compiled pass over the rays and parts (:func:`first_surface_greys_reference` is the same in
    NumPy, the one to read).

    Args:
        edges: The scene's parts (footprints, heights, face greys) and floor.
        origin: (m, 2) each ray's camera centre on the floor plane, world metres.
        direction: (m, 2) its floor displacement per metre of depth.
        y: (m, R) at each of ``R`` rows, the height it loses per metre of depth
            (``(v - cy) / f``).
        height_m: Height of the cameras, metres.

    Returns:
        (m, R) grey levels.
    """
    return first_surfaces_loop(
        np.ascontiguousarray(origin, dtype=np.float64),
        np.ascontiguousarray(direction, dtype=np.float64),
        np.ascontiguousarray(y, dtype=np.float64),
        float(height_m),
        surface_arrays(edges),
    )


def surface_arrays(edges: SceneEdges) -> Surfaces:
    """The scene's surfaces as the compiled first-surface loops read them
    (:data:`~stereo_nav_env.perception.surrogate._kernels.segments.Surfaces`)."""
    return (
        far_depth(edges),
        edges.side_start,
        edges.side_normal,
        edges.side_grey,
        edges.top_grey,
        edges.bottom_grey,
        edges.z_min,
        edges.z_max,
        edges.floor_box,
        float(edges.floor_grey),
        float(edges.background_grey),
    )


def first_surface_greys_reference(
    edges: SceneEdges, origin: FloatArray, direction: FloatArray, y: FloatArray, height_m: float
) -> FloatArray:
    """:func:`first_surface_greys` in NumPy: the floor lines of the rays clipped to the parts
    (:func:`~stereo_nav_env.perception.surrogate.visibility.clip_to_parts`), each crossing's hit
    (side face, top or bottom) at every row, the nearest of them and the floor per ray and row."""
    Hh = height_m
    n_rows = y.shape[1]
    box = edges.floor_box
    z_far = far_depth(edges)
    # the floor, where the ray descends onto its rendered extent; else the background
    with np.errstate(divide="ignore"):
        z_floor = np.where(y > 0, Hh / np.where(y > 0, y, 1.0), np.inf)
    floor_xy = (
        origin[:, None, :]
        + np.where(np.isfinite(z_floor), z_floor, 0.0)[..., None] * (direction[:, None, :])
    )
    on_floor = (
        np.isfinite(z_floor)
        & (floor_xy[..., 0] >= box[0])
        & (floor_xy[..., 0] <= box[2])
        & (floor_xy[..., 1] >= box[1])
        & (floor_xy[..., 1] <= box[3])
    )
    best = np.where(on_floor, z_floor, np.inf)
    grey = np.where(on_floor, edges.floor_grey, edges.background_grey)
    line, part, t0, t1, side = clip_to_parts(edges, origin, origin + z_far * direction)
    if line.size:
        Z0, Z1 = (t0 * z_far)[:, None], (t1 * z_far)[:, None]
        yk = y[line]  # (k, R)
        lo, hi = edges.z_min[part][:, None], edges.z_max[part][:, None]
        h0 = Hh - yk * Z0
        face = (side >= 0)[:, None] & (h0 >= lo) & (h0 <= hi)
        safe = np.where(yk != 0, yk, 1.0)
        z_top = np.where((h0 > hi) & (yk > 0), (Hh - hi) / safe, np.inf)
        z_bottom = np.where((h0 < lo) & (yk < 0), (Hh - lo) / safe, np.inf)
        z_top = np.where(z_top <= Z1, z_top, np.inf)
        z_bottom = np.where(z_bottom <= Z1, z_bottom, np.inf)
        z_hit = np.where(face, Z0, np.minimum(z_top, z_bottom))
        g_hit = np.where(
            face,
            edges.side_grey[part, np.maximum(side, 0)][:, None],
            np.where(
                z_top <= z_bottom, edges.top_grey[part][:, None], edges.bottom_grey[part][:, None]
            ),
        )
        # per (ray, row) the nearest surface: the crossings' depths, minimised per cell
        cell = line[:, None] * n_rows + np.arange(n_rows)
        flat_best = best.reshape(-1)
        np.minimum.at(flat_best, cell, z_hit)
        won = np.isfinite(z_hit) & (z_hit == flat_best[cell])
        grey.reshape(-1)[cell[won]] = g_hit[won]
    out: FloatArray = grey
    return out


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class EdgePieces:
    """The pieces (``m``) of edges one image's extraction would find, one row each.

    Attributes:
        edge: (m,) the edge each piece belongs to (index into the rows given).
        v_top, v_bottom: (m,) its rows, px.
        greys: (4, m) far left, far right, near left, near right grey levels (means over its
            sampled rows).
        polarity: (m,) +1 where brighter on the right of the edge, -1 otherwise.
    """

    edge: IntArray
    v_top: FloatArray
    v_bottom: FloatArray
    greys: FloatArray
    polarity: NDArray[np.int8]

    def __len__(self) -> int:
        return int(self.edge.shape[0])


def edge_pieces(
    greys: FloatArray,
    v_top: FloatArray,
    v_bottom: FloatArray,
    *,
    min_contrast: float,
    min_length_px: float,
    end_loss_px: float = 0.0,
) -> EdgePieces:
    """The pieces of ``n`` edges in one image: the runs of sampled rows of one polarity whose
    near contrast ``|near right - near left|`` is at least ``min_contrast``, each covering its
    rows' shares of the edge's run ``[v_top, v_bottom]`` less ``end_loss_px`` at both ends, at
    least ``min_length_px`` long; one compiled pass (:func:`edge_pieces_reference` is the same
    in NumPy, the one to read).

    Args:
        greys: (4, n, R) the image's samples (:func:`edge_greys` of one image).
        v_top, v_bottom: (n,) the edges' seen runs, px.
        min_contrast: Smallest near contrast of an imaged row, grey levels.
        min_length_px: Shortest piece kept, px.
        end_loss_px: Rows lost at each end of a piece, px (the extraction's line support
            stops short of where the edge ends).
    """
    edge, top, bottom, means, polarity = runs_loop(
        np.ascontiguousarray(greys, dtype=np.float64),
        np.ascontiguousarray(v_top, dtype=np.float64),
        np.ascontiguousarray(v_bottom, dtype=np.float64),
        float(min_contrast),
        float(min_length_px),
        float(end_loss_px),
    )
    return EdgePieces(edge=edge, v_top=top, v_bottom=bottom, greys=means, polarity=polarity)


def edge_pieces_reference(
    greys: FloatArray,
    v_top: FloatArray,
    v_bottom: FloatArray,
    *,
    min_contrast: float,
    min_length_px: float,
    end_loss_px: float = 0.0,
) -> EdgePieces:
    """:func:`edge_pieces` in NumPy: each row's sign of contrast (0 below ``min_contrast``),
    runs numbered where the sign changes, their rows' means."""
    n, n_rows = greys.shape[1], greys.shape[2]
    contrast = greys[3] - greys[2]  # (n, R)
    sign = np.where(np.abs(contrast) >= min_contrast, np.sign(contrast), 0.0)
    # a run starts where the sign is set and differs from the previous row's
    prev = np.concatenate([np.zeros((n, 1)), sign[:, :-1]], axis=1)
    start = (sign != 0) & (sign != prev)
    run_id = np.cumsum(start.reshape(-1)).reshape(n, n_rows) - 1  # runs numbered row-major
    member = sign != 0
    ids = run_id[member]
    n_runs = int(start.sum())
    edge_of = np.repeat(np.arange(n), n_rows).reshape(n, n_rows)[member]
    row_of = np.tile(np.arange(n_rows), (n, 1))[member]
    count = np.bincount(ids, minlength=n_runs).astype(np.float64)
    first = np.full(n_runs, n_rows, dtype=np.int64)
    last = np.zeros(n_runs, dtype=np.int64)
    np.minimum.at(first, ids, row_of)
    np.maximum.at(last, ids, row_of)
    edge = np.zeros(n_runs, dtype=np.int64)
    edge[ids] = edge_of
    sums = np.stack([np.bincount(ids, weights=g[member], minlength=n_runs) for g in greys])
    means: FloatArray = sums / np.maximum(count, 1.0)
    share = (v_bottom - v_top)[edge] / n_rows
    top = v_top[edge] + first * share + end_loss_px
    bottom = v_top[edge] + (last + 1) * share - end_loss_px
    keep = np.flatnonzero(bottom - top >= min_length_px)
    polarity = np.where(means[3] >= means[2], 1, -1).astype(np.int8)  # the run's sign
    return EdgePieces(
        edge=edge[keep],
        v_top=top[keep],
        v_bottom=bottom[keep],
        greys=means[:, keep],
        polarity=polarity[keep],
    )


def image_pieces(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    u: FloatArray,
    Z: FloatArray,
    v_top: FloatArray,
    v_bottom: FloatArray,
    options: SegmentOptions,
    *,
    end_loss_px: float = 0.0,
) -> tuple[EdgePieces, EdgePieces]:
    """The pieces of ``n`` edges (columns ``u``, depths ``Z``, seen runs ``[v_top, v_bottom]``)
    in the left and in the right image: :func:`edge_greys` then :func:`edge_pieces` with the
    extraction's sample distances and thresholds (``options``: a row is imaged where the near
    contrast is at least twice ``min_gradient``, the central difference of a sharp step being
    half of it; pieces at least ``min_length_px`` long) and ``end_loss_px``."""
    grey = edge_greys(
        edges,
        head,
        rig,
        u,
        Z,
        sample_rows(v_top, v_bottom),
        near_px=options.near_px,
        side_px=float(options.side_px),
    )
    left, right = (
        edge_pieces(
            grey[k],
            v_top,
            v_bottom,
            min_contrast=2.0 * options.min_gradient,
            min_length_px=options.min_length_px,
            end_loss_px=end_loss_px,
        )
        for k in range(2)
    )
    return left, right
