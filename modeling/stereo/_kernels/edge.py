"""The compiled loops of the segment fit (:mod:`modeling.stereo.segments`, section 3.2): edge points
and the least-squares lines.

:func:`edge_sums`: for every image row a detected line crosses, the edge point is found as the
parabolic peak of the horizontal central-difference gradient (of the segment's own contrast sign)
in a window around the line, and the least-squares sums of the segment's edge points are
accumulated. The arithmetic is that of the NumPy reference
:func:`modeling.stereo.edge_points.edge_sums_reference` (float32 gradients and peak offsets, float64
sums), written as one loop so that it costs a fraction of the many array passes.
:func:`segment_fits`: each segment's least-squares line from those sums, with the arithmetic of
:func:`modeling.stereo.segments.least_squares_lines_reference` (0.1-0.3 ms per env step saved). They
take and return the small named tuples below.

It is compiled with Numba on first use (:mod:`modeling.jit`); importing this module
does not import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_on_first_call


class LinesToFit(NamedTuple):
    """The detected lines to re-localise and fit, ``m`` rows (``modeling.stereo.segments``)."""

    image_of: np.ndarray  # (m,) image of each line (the images are stacked)
    x0: np.ndarray  # (m,) upper endpoint of each line, px
    y0: np.ndarray  # (m,)
    inv_slope: np.ndarray  # (m,) du/dv of each line
    r0: np.ndarray  # (m,) first row to search, within the image
    r1: np.ndarray  # (m,) last row to search (inclusive)


class EdgeSearch(NamedTuple):
    """How the edge point of a row is searched and sampled (:func:`edge_sums`)."""

    height: int  # rows per image
    search_px: int  # half-width of the peak search window, px
    side_px: int  # offset of the "far" grey samples, px
    near_px: float  # offset of the "near" grey samples (linear interpolation), px
    half_block: int  # half-width ``B`` of the pixel block around the line
    min_gradient: float  # smallest peak gradient of an edge point


class EdgeSums(NamedTuple):
    """Per-segment sums of the edge points (:func:`edge_sums`), ``m`` rows."""

    sums: np.ndarray  # (m, N_SUMS) float64, columns as ``N_SUMS`` says
    polarity: np.ndarray  # (m,) int8
    first_row: np.ndarray  # (m,) first row with an edge point (-1: none)
    last_row: np.ndarray  # (m,) last row with an edge point (-1: none)


class FitLimits(NamedTuple):
    """The fit's variance floor and the kept segments' limits (:func:`segment_fits`)."""

    sigma_px: float  # lower bound of the per-point sigma, px
    min_length_px: float  # shortest segment kept, px
    sin_min: float  # a kept segment rises by at least this of its length


class SegmentFits(NamedTuple):
    """The least-squares line of each segment (:func:`segment_fits`)."""

    fit: np.ndarray  # (N_FIT, m) float64, rows as ``N_FIT`` says
    ok: np.ndarray  # (m,) whether the segment is kept


# Columns of the per-segment sums: n, sum v, sum u, sum v^2, sum v u, sum u^2, then the sums of the


# Columns of the per-segment sums: n, sum v, sum u, sum v^2, sum v u, sum u^2, then the sums of the
# peak gradient, the far grey level left and right, the near grey level left and right.
N_SUMS = 11


@compiled_on_first_call
def edge_sums(stack: np.ndarray, lines: LinesToFit, search: EdgeSearch) -> EdgeSums:
    """Per-segment least-squares sums of the edge points (see the module docstring).

    Args:
        stack: (n_images * height, W) uint8, the images one below the other.
        lines: The lines to fit.
        search: The search window and the samples.

    Returns:
        (m, 11) float64 sums (columns as ``N_SUMS`` says; ``v`` relative to ``r0``, ``u`` to the
        detected line), (m,) int8 polarity, and the first and last row with an edge point (-1
        where there is none). Reference: :func:`modeling.stereo.edge_points.edge_sums_reference`.
    """
    image_of, x0, y0, inv_slope, r0, r1 = lines
    height, search_px, side_px, near_px, half_block, min_gradient = search
    m = x0.shape[0]
    width = stack.shape[1]
    B = half_block
    nb = 2 * B + 1
    nwin = 2 * search_px + 1
    lo = B - search_px - 1
    half = np.float32(0.5)
    two = np.float32(2.0)
    tiny = np.float32(-1e-12)
    sums = np.zeros((m, N_SUMS))
    polarity = np.ones(m, np.int8)
    first_row = np.full(m, -1, np.int64)
    last_row = np.full(m, -1, np.int64)
    blk = np.empty(nb, np.float32)
    g = np.empty(nwin + 2, np.float32)
    for s in range(m):
        base_row = image_of[s] * height
        a = x0[s] - inv_slope[s] * y0[s]
        # polarity: the sign of the gradient summed over the segment's windows
        total = np.float32(0.0)
        for r in range(r0[s], r1[s] + 1):
            c = min(max(np.rint(a + inv_slope[s] * r), -B), width - 1 + B)
            row = stack[base_row + r]
            c_hi1 = min(max(int(c) + search_px + 1, 0), width - 1)
            c_hi0 = min(max(int(c) + search_px, 0), width - 1)
            c_lo0 = min(max(int(c) - search_px, 0), width - 1)
            c_lo1 = min(max(int(c) - search_px - 1, 0), width - 1)
            total += (
                np.float32(row[c_hi1])
                + np.float32(row[c_hi0])
                - np.float32(row[c_lo0])
                - np.float32(row[c_lo1])
            )
        sign = np.float32(1.0) if total >= 0 else np.float32(-1.0)
        polarity[s] = 1 if total >= 0 else -1
        for r in range(r0[s], r1[s] + 1):
            u_line = a + inv_slope[s] * r
            c = int(min(max(np.rint(u_line), -B), width - 1 + B))
            row = stack[base_row + r]
            for o in range(nb):
                blk[o] = np.float32(row[min(max(c - B + o, 0), width - 1)])
            for j in range(nwin + 2):
                g[j] = (blk[lo + 1 + j] - blk[lo - 1 + j]) * half * sign
            k = 0
            best = g[1]
            for j in range(1, nwin):
                if g[1 + j] > best:
                    best = g[1 + j]
                    k = j
            col = c + k
            if not (
                k > 0
                and k < nwin - 1
                and best >= min_gradient
                and col > search_px
                and col < width - 1 + search_px
            ):
                continue
            gm = g[k]
            gp = g[k + 2]
            off = half * (gm - gp) / min(gm - two * best + gp, tiny)
            rel_u = float(k - search_px) + float(off)
            v = float(r - r0[s])
            u = rel_u + (c - u_line)
            sums[s, 0] += 1.0
            sums[s, 1] += v
            sums[s, 2] += u
            sums[s, 3] += v * v
            sums[s, 4] += v * u
            sums[s, 5] += u * u
            sums[s, 6] += float(best)
            ru = int(np.rint(rel_u))
            sums[s, 7] += float(blk[B + ru - side_px])
            sums[s, 8] += float(blk[B + ru + side_px])
            for side in range(2):
                x = rel_u - near_px if side == 0 else rel_u + near_px
                fx = np.floor(x)
                i = B + int(fx)
                w = x - fx
                sums[s, 9 + side] += float(blk[i]) * (1.0 - w) + float(blk[i + 1]) * w
            if first_row[s] < 0:
                first_row[s] = r
            last_row[s] = r
    return EdgeSums(sums=sums, polarity=polarity, first_row=first_row, last_row=last_row)


# Rows of the per-segment fit: the two ends (u0, v0, u1, v1), the fitted line (u_center, v_center,
# slope), the per-point variance, n, S_vv, then the mean peak gradient and grey levels (far left,
# far right, near left, near right).
N_FIT = 15


@compiled_on_first_call
def segment_fits(edges: EdgeSums, lines: LinesToFit, limits: FitLimits) -> SegmentFits:
    """The least-squares line of each segment from its sums (see :func:`edge_sums`).

    Returns:
        (15, m) float64 rows as ``N_FIT`` says, and (m,) whether the segment is kept (at least 3
        edge points spread over rows, long and steep enough). Reference:
        :func:`modeling.stereo.segments.least_squares_lines_reference`.
    """
    sums, first_row, last_row = edges.sums, edges.first_row, edges.last_row
    x0, y0, inv_slope, r0 = lines.x0, lines.y0, lines.inv_slope, lines.r0
    sigma_px, min_length_px, sin_min = limits
    m = sums.shape[0]
    fit = np.zeros((N_FIT, m))
    ok = np.zeros(m, np.bool_)
    var_min = sigma_px**2
    for s in range(m):
        n = sums[s, 0]
        safe_n = max(n, 1.0)
        mv = sums[s, 1] / safe_n
        mu = sums[s, 2] / safe_n
        svv = sums[s, 3] - n * mv * mv
        suv = sums[s, 4] - n * mv * mu
        suu = sums[s, 5] - n * mu * mu
        good = n >= 3 and svv > 1e-9
        b = suv / (svv if good else 1.0)  # slope relative to the detected line
        rss = max(suu - b * suv, 0.0)
        slope = inv_slope[s] + b
        vc = r0[s] + mv  # mean row of the edge points
        uc = x0[s] + inv_slope[s] * (vc - y0[s]) + mu  # the fitted column there
        v0 = float(first_row[s])
        v1 = float(last_row[s])
        u0 = uc + slope * (v0 - vc)
        u1 = uc + slope * (v1 - vc)
        seg_len = np.hypot(u1 - u0, v1 - v0)
        ok[s] = good and v1 > v0 and seg_len >= min_length_px and (v1 - v0) >= sin_min * seg_len
        fit[0, s] = u0
        fit[1, s] = v0
        fit[2, s] = u1
        fit[3, s] = v1
        fit[4, s] = uc
        fit[5, s] = vc
        fit[6, s] = slope
        fit[7, s] = max(rss / max(n - 2.0, 1.0), var_min)
        fit[8, s] = n
        fit[9, s] = svv
        for c in range(5):
            fit[10 + c, s] = sums[s, 6 + c] / safe_n
    return SegmentFits(fit=fit, ok=ok)
