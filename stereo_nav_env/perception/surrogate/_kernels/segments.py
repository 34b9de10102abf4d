"""The compiled loops of the surrogate's image segments
(:mod:`stereo_nav_env.perception.surrogate.sensor`,
:mod:`stereo_nav_env.perception.surrogate.photometry`).

Each loop has a NumPy reference that a test holds it equal to, bit for bit:
:func:`first_surfaces_loop` (``first_surface_greys_reference``), :func:`runs_loop`
(``edge_pieces_reference``), :func:`piece_fits` (``piece_fits_reference``), and the two loops
:func:`segment_pieces_loop` and :func:`image_fits_loop` that make, between the random draws,
what ``surrogate_segments_reference`` makes with NumPy (``surrogate_segments`` is built of
them). They keep the reference's arithmetic, in its order; the last two take the small named
tuples below. Frames and units: world metres, floor plane x-y, z up; image pixels (u right, v
down); grey levels 0-255.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from modeling.jit import compiled_helper, compiled_on_first_call
from modeling.types import FloatArray, Int8Array, IntArray

__all__ = [
    "Detection",
    "FalseMatchDraws",
    "FalseMatchRates",
    "FoundEdges",
    "PieceSampling",
    "Pieces",
    "SeenEdges",
    "first_surfaces_loop",
    "image_fits_loop",
    "piece_fits",
    "runs_loop",
    "segment_pieces_loop",
]

Surfaces = tuple[
    float,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    float,
    float,
]
"""The scene's surfaces as the loops read them (``surface_arrays`` of the photometry): the far
depth, the parts' side starts, normals and greys, top and bottom greys, bottom and top heights,
the floor's box and grey, the background's grey."""


class SeenEdges(NamedTuple):
    """The seen edges (``VisibleEdges``) as :func:`segment_pieces_loop` reads them, ``n`` rows."""

    corner: IntArray  # (n,) index into ``SceneEdges.corner_xy``
    crease: NDArray[np.bool_]  # (n,) whether both sides meeting there face the head
    u: FloatArray  # (n,) column in the left image, px
    Z: FloatArray  # (n,) depth, metres
    v_top: FloatArray  # (n,) first row of the seen run, px
    v_bottom: FloatArray  # (n,) last row of the seen run, px


class Detection(NamedTuple):
    """What an edge's detection outcome is drawn from: its class (its obstacle's kind, outline or
    crease) and its depth bin pick a row of the measured rates (``SurrogateRates``)."""

    corner_kind: IntArray  # (C,) ``SceneEdges.corner_kind``
    inner_bins: FloatArray  # (k - 1,) the rates' inner depth-bin edges, metres
    table: FloatArray  # (classes, k, 3) both images, left only, right only


class PieceSampling(NamedTuple):
    """How the grey levels beside each edge are sampled and its pieces cut."""

    samples: FloatArray  # (7,) -side_px, side_px, -near_px, near_px (px), min_contrast (grey
    # levels), min_length_px, end_loss_px (px)
    n_rows: int  # rows sampled per edge


class Pieces(NamedTuple):
    """One image's pieces (the arrays of the photometry's ``EdgePieces``), ``m`` rows."""

    edge: IntArray  # (m,) the found edge each belongs to
    v_top: FloatArray  # (m,) first row, px
    v_bottom: FloatArray  # (m,) last row, px
    greys: FloatArray  # (4, m) far left, far right, near left, near right grey levels
    polarity: Int8Array  # (m,) +1 where brighter on the right of the edge, -1 otherwise


class FoundEdges(NamedTuple):
    """The edges found in at least one image (:func:`segment_pieces_loop`), ``n`` rows."""

    u: FloatArray  # (n,) column in the left image, px
    Z: FloatArray  # (n,) depth, metres
    outcome: IntArray  # (n,) 0 both images, 1 the left only, 2 the right only


class FalseMatchDraws(NamedTuple):
    """The draws that make a found edge's right segment a false match, ``n`` rows."""

    pick: FloatArray  # (n,) uniform, against the false-match rate at the edge's depth
    wrong_index: IntArray  # (n,) which measured error it takes
    sign_pick: FloatArray  # (n,) uniform, the error's sign (negative below 0.5)


class FalseMatchRates(NamedTuple):
    """The measured false matches (``SurrogateRates``), ``k`` depth bins."""

    inner_bins: FloatArray  # (k - 1,) inner depth-bin edges, metres
    rate: FloatArray  # (k,) false-match rate per depth bin
    error: FloatArray  # (e,) absolute disparity errors of the measured false matches, px


@compiled_helper
def fill_first_surfaces(
    out: FloatArray,
    origin: FloatArray,
    direction: FloatArray,
    y: FloatArray,
    hh: float,
    surfaces: Surfaces,
) -> None:
    """``out`` (rays, rows): per ray the floor, then every part (Cyrus-Beck in depth units, the
    entered side the first of the largest entering ``t``), the grey of the nearest surface."""
    z_far, side_start, side_normal, side_grey, top_grey, bottom_grey = surfaces[:6]
    z_min, z_max, floor_box, floor_grey, background_grey = surfaces[6:]
    n_rays, n_rows = y.shape
    n_parts, n_sides = side_start.shape[0], side_start.shape[1]
    best = np.empty(n_rows)
    for i in range(n_rays):
        ox, oy = origin[i, 0], origin[i, 1]
        dx, dy = direction[i, 0], direction[i, 1]
        for r in range(n_rows):
            best[r] = np.inf
            out[i, r] = background_grey
            if y[i, r] > 0:
                zf = hh / y[i, r]
                fx, fy = ox + zf * dx, oy + zf * dy
                if floor_box[0] <= fx <= floor_box[2] and floor_box[1] <= fy <= floor_box[3]:
                    best[r] = zf
                    out[i, r] = floor_grey
        for p in range(n_parts):
            t_enter, t_leave, side, outside = -np.inf, np.inf, -1, False
            for v in range(n_sides):
                nx, ny = side_normal[p, v, 0], side_normal[p, v, 1]
                num = nx * (side_start[p, v, 0] - ox) + ny * (side_start[p, v, 1] - oy)
                den = (nx * dx + ny * dy) * z_far
                if den == 0.0:
                    if num < 0.0:
                        outside = True
                    continue
                t = num / den
                if den < 0.0:
                    if t > t_enter:
                        t_enter, side = t, v
                elif t < t_leave:
                    t_leave = t
            t0, t1 = max(t_enter, 0.0), min(t_leave, 1.0)
            if outside or not t1 > t0:
                continue
            if t_enter < 0.0:
                side = -1
            z0, z1 = t0 * z_far, t1 * z_far
            lo, hi = z_min[p], z_max[p]
            for r in range(n_rows):
                yr = y[i, r]
                h0 = hh - yr * z0
                if side >= 0 and lo <= h0 <= hi:
                    z_hit, g = z0, side_grey[p, side]
                elif h0 > hi and yr > 0:
                    z_hit, g = (hh - hi) / yr, top_grey[p]
                elif h0 < lo and yr < 0:
                    z_hit, g = (hh - lo) / yr, bottom_grey[p]
                else:
                    continue
                if z_hit <= z1 and z_hit <= best[r]:
                    best[r] = z_hit
                    out[i, r] = g


@compiled_on_first_call
def first_surfaces_loop(
    origin: FloatArray,
    direction: FloatArray,
    y: FloatArray,
    hh: float,
    surfaces: Surfaces,
) -> FloatArray:
    """``first_surface_greys_reference`` as loops (:func:`fill_first_surfaces`)."""
    out = np.empty(y.shape)
    fill_first_surfaces(
        out,
        origin,
        direction,
        y,
        hh,
        surfaces,
    )
    return out


@compiled_helper
def runs_of(
    greys: FloatArray,
    v_top: FloatArray,
    v_bottom: FloatArray,
    min_contrast: float,
    min_length_px: float,
    end_loss_px: float,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, Int8Array]:
    """``edge_pieces_reference`` as loops: edge by edge, the runs of rows of one sign."""
    n, n_rows = greys.shape[1], greys.shape[2]
    cap = n * ((n_rows + 1) // 2) + 1  # at most every other row starts a run
    edge = np.empty(cap, np.int64)
    top = np.empty(cap)
    bottom = np.empty(cap)
    means = np.empty((4, cap))
    polarity = np.empty(cap, np.int8)
    m = 0
    for e in range(n):
        share = (v_bottom[e] - v_top[e]) / n_rows
        r = 0
        while r < n_rows:
            c = greys[3, e, r] - greys[2, e, r]
            if abs(c) < min_contrast:
                r += 1
                continue
            sign = 1.0 if c > 0 else -1.0
            first = r
            sums = np.zeros(4)
            while r < n_rows:
                c = greys[3, e, r] - greys[2, e, r]
                if abs(c) < min_contrast or (c > 0) != (sign > 0):
                    break
                for k in range(4):
                    sums[k] += greys[k, e, r]
                r += 1
            t = v_top[e] + first * share + end_loss_px
            b = v_top[e] + r * share - end_loss_px
            if b - t >= min_length_px:
                edge[m], top[m], bottom[m] = e, t, b
                for k in range(4):
                    means[k, m] = sums[k] / (r - first)
                polarity[m] = 1 if means[3, m] >= means[2, m] else -1
                m += 1
    return edge[:m], top[:m], bottom[:m], means[:, :m].copy(), polarity[:m]


@compiled_on_first_call
def runs_loop(
    greys: FloatArray,
    v_top: FloatArray,
    v_bottom: FloatArray,
    min_contrast: float,
    min_length_px: float,
    end_loss_px: float,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, Int8Array]:
    """:func:`runs_of`, called from Python."""
    return runs_of(greys, v_top, v_bottom, min_contrast, min_length_px, end_loss_px)


@compiled_helper
def fit_piece(
    top: float,
    bottom: float,
    centre: float,
    d0: float,
    d1: float,
    d2: float,
    point_var_px2: float,
    bias_var_px2: float,
) -> tuple[float, float, float, float, float, float, float]:
    """One piece's least-squares fit (``piece_fits_reference``'s arithmetic): ``(u_top,
    u_bottom, u_center, v_center, slope, n_rows, s_vv)``."""
    n_rows = np.floor(bottom - top) + 1.0
    s_vv = n_rows * (n_rows * n_rows - 1.0) / 12.0
    offset = d0 * np.sqrt(point_var_px2 / n_rows) + d2 * np.sqrt(bias_var_px2)
    slope = d1 * np.sqrt(point_var_px2 / s_vv)
    v_c = 0.5 * (top + bottom)
    u_c = centre + offset
    return u_c + slope * (top - v_c), u_c + slope * (bottom - v_c), u_c, v_c, slope, n_rows, s_vv


@compiled_on_first_call
def piece_fits(
    top: FloatArray,
    bottom: FloatArray,
    centre: FloatArray,
    draw: FloatArray,
    point_var_px2: float,
    bias_var_px2: float,
) -> tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray, FloatArray, FloatArray
]:
    """``piece_fits_reference`` in one compiled loop (:func:`fit_piece`)."""
    m = top.shape[0]
    ends = np.empty((m, 2, 2))
    u_c, v_c, slope, s_vv = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    n_points = np.empty(m, dtype=np.int64)
    for i in range(m):
        u0, u1, u_c[i], v_c[i], slope[i], n_rows, s_vv[i] = fit_piece(
            top[i],
            bottom[i],
            centre[i],
            draw[0, i],
            draw[1, i],
            draw[2, i],
            point_var_px2,
            bias_var_px2,
        )
        ends[i, 0, 0], ends[i, 0, 1], ends[i, 1, 0], ends[i, 1, 1] = u0, top[i], u1, bottom[i]
        n_points[i] = np.int64(n_rows)
    point_var, bias_var = np.full(m, point_var_px2), np.full(m, bias_var_px2)
    return ends, u_c, v_c, slope, point_var, n_points, s_vv, bias_var


@compiled_helper
def depth_bin(inner_bins: FloatArray, z: float) -> int:
    """The bin of depth ``z``: how many inner bin edges it reaches (``np.searchsorted(...,
    side="right")``)."""
    k = 0
    while k < inner_bins.shape[0] and inner_bins[k] <= z:
        k += 1
    return k


@compiled_on_first_call
def segment_pieces_loop(
    pick: FloatArray,
    seen: SeenEdges,
    detection: Detection,
    camera: FloatArray,
    head: FloatArray,
    sampling: PieceSampling,
    surfaces: Surfaces,
) -> tuple[IntArray, IntArray, IntArray, Pieces, Pieces]:
    """The detection outcome of each seen edge (``pick`` against its class's cumulative rates at
    its depth: 0 both images, 1 the left only, 2 the right only, 3 neither), then the pieces of
    the edges found, in the images that segment them (their grey levels as ``edge_greys``, cut
    as ``edge_pieces``).

    Args:
        pick: (n,) the uniform draws.
        seen: The ``n`` seen edges.
        detection: The scene's corner kinds and the rates' depth bins and table.
        camera: ``(f, cx, cy, f b, baseline)``. ``head``: ``(x, y, cos, sin, height)``.
        sampling: The samples' offsets and the pieces' limits, the rows sampled per edge.
        surfaces: The scene's parts and floor (:data:`Surfaces`).

    Returns:
        ``(found, outcome, left_corners, left, right)``: the edges found (indices into the seen
        ones) and their outcomes, the corners of those the left image segments, and each
        image's pieces (``edge`` indexes ``found``).
    """
    corner, crease, u, Z, v_top, v_bottom = seen
    corner_kind, inner_bins, table = detection
    samples, n_rows = sampling
    n_seen = pick.shape[0]
    outcome_all = np.empty(n_seen, np.int64)
    n = 0
    for e in range(n_seen):
        rates = table[2 * corner_kind[corner[e]] + np.int64(crease[e]), depth_bin(inner_bins, Z[e])]
        p0 = rates[0]
        p1 = p0 + rates[1]
        p2 = p1 + rates[2]
        outcome_all[e] = np.int64(pick[e] >= p0) + np.int64(pick[e] >= p1) + np.int64(pick[e] >= p2)
        if outcome_all[e] < 3:
            n += 1
    found = np.empty(n, np.int64)
    outcome = np.empty(n, np.int64)
    n_left = 0
    k = 0
    for e in range(n_seen):
        if outcome_all[e] < 3:
            found[k], outcome[k] = e, outcome_all[e]
            n_left += outcome_all[e] != 2
            k += 1
    left_corners = np.empty(n_left, np.int64)
    k = 0
    for i in range(n):
        if outcome[i] != 2:
            left_corners[k] = corner[found[i]]
            k += 1
    # the rays beside each edge: (image, sample, edge) flattened, then each row of its run
    f, cx, cy, fb, baseline = camera[0], camera[1], camera[2], camera[3], camera[4]
    hx, hy, c, s, hh = head[0], head[1], head[2], head[3], head[4]
    origin = np.empty((8 * n, 2))
    direction = np.empty((8 * n, 2))
    y = np.empty((8 * n, n_rows))
    eu, ez = np.empty(n), np.empty(n)
    top, bottom = np.empty(n), np.empty(n)
    for i in range(n):
        eu[i], ez[i] = u[found[i]], Z[found[i]]
        top[i], bottom[i] = v_top[found[i]], v_bottom[found[i]]
    for img in range(2):
        shift = 0.0 if img == 0 else fb
        b = 0.0 if img == 0 else baseline
        ox, oy = hx + b * s, hy + b * -c
        for q in range(4):
            for i in range(n):
                ray = (img * 4 + q) * n + i
                x = (eu[i] - shift / ez[i] + samples[q] - cx) / f
                origin[ray, 0], origin[ray, 1] = ox, oy
                direction[ray, 0], direction[ray, 1] = c + x * s, s + x * -c
                for r in range(n_rows):
                    row = top[i] + (r + 0.5) / n_rows * (bottom[i] - top[i])
                    y[ray, r] = (row - cy) / f
    grey = np.empty((8 * n, n_rows))
    fill_first_surfaces(
        grey,
        origin,
        direction,
        y,
        hh,
        surfaces,
    )
    grey4 = grey.reshape((2, 4, n, n_rows))
    left = _kept_runs(grey4[0], top, bottom, samples, outcome, 2)
    right = _kept_runs(grey4[1], top, bottom, samples, outcome, 1)
    return found, outcome, left_corners, left, right


@compiled_helper
def _kept_runs(
    greys: FloatArray,
    top: FloatArray,
    bottom: FloatArray,
    samples: FloatArray,
    outcome: IntArray,
    other: int,
) -> Pieces:
    """The runs of one image's edges (:func:`runs_of`) but those of edges whose outcome is
    ``other`` (segmented by the other image only); greys rows contiguous."""
    edge, t, b, means, polarity = runs_of(
        np.ascontiguousarray(greys), top, bottom, samples[4], samples[5], samples[6]
    )
    m = 0
    for j in range(edge.shape[0]):
        m += outcome[edge[j]] != other
    keep = np.empty(m, np.int64)
    m = 0
    for j in range(edge.shape[0]):
        if outcome[edge[j]] != other:
            keep[m] = j
            m += 1
    kept = np.empty((4, m))
    for k in range(4):
        for j in range(m):
            kept[k, j] = means[k, keep[j]]
    return Pieces(edge[keep], t[keep], b[keep], kept, polarity[keep])


@compiled_on_first_call
def image_fits_loop(
    pieces: Pieces,
    draw: FloatArray,
    found: FoundEdges,
    false_draws: FalseMatchDraws,
    false_rates: FalseMatchRates,
    scalars: FloatArray,
    right: bool,
) -> tuple[
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    FloatArray,
    IntArray,
    FloatArray,
    FloatArray,
    FloatArray,
]:
    """The fitted lines of one image's ``pieces`` (``m``) at the columns of their edges
    (``found``): in the left image ``u``; in the right one (``right``) ``u - f b / Z``, moved by
    a false match's error where ``outcome`` is 0 and ``false_draws.pick`` is below the
    false-match rate at ``Z`` (the error ``false_rates.error[wrong_index]``, negative where
    ``sign_pick < 0.5``).

    Args:
        pieces: The image's pieces (``edge`` indexes ``found``).
        draw: (3, m) standard normals: the offset's, the slope's and the bias's.
        found: The found edges.
        false_draws: Their false-match draws.
        false_rates: The measured false matches.
        scalars: ``(error_scale, f b, point_var, bias_var, 2 near_px)``, px and px^2.
        right: Whether the image is the right one.

    Returns:
        ``piece_fits``' arrays and the pieces' contrast.
    """
    edge, top, bottom, greys = pieces.edge, pieces.v_top, pieces.v_bottom, pieces.greys
    u, Z, outcome = found
    false_pick, wrong_index, sign_pick = false_draws
    inner_bins, false_rate, false_error = false_rates
    scale, fb, point_var_px2, bias_var_px2, two_near = (
        scalars[0],
        scalars[1],
        scalars[2],
        scalars[3],
        scalars[4],
    )
    m = edge.shape[0]
    ends = np.empty((m, 2, 2))
    u_c, v_c, slope, s_vv = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    n_points = np.empty(m, dtype=np.int64)
    contrast = np.empty(m)
    for i in range(m):
        e = edge[i]
        centre = u[e]
        if right:
            moved = 0.0
            if outcome[e] == 0 and false_pick[e] < false_rate[depth_bin(inner_bins, Z[e])]:
                moved = false_error[wrong_index[e]] * (-1.0 if sign_pick[e] < 0.5 else 1.0)
            centre = u[e] - fb / Z[e] + moved
        u0, u1, u_c[i], v_c[i], slope[i], n_rows, s_vv[i] = fit_piece(
            top[i],
            bottom[i],
            centre,
            draw[0, i] * scale,
            draw[1, i] * scale,
            draw[2, i] * scale,
            point_var_px2,
            bias_var_px2,
        )
        ends[i, 0, 0], ends[i, 0, 1], ends[i, 1, 0], ends[i, 1, 1] = u0, top[i], u1, bottom[i]
        n_points[i] = np.int64(n_rows)
        contrast[i] = abs(greys[3, i] - greys[2, i]) / two_near
    point_var, bias_var = np.full(m, point_var_px2), np.full(m, bias_var_px2)
    return ends, u_c, v_c, slope, point_var, n_points, s_vv, bias_var, contrast
