"""Edge points of the detected lines, row by row, and their least-squares sums (section 3.2).

The readable NumPy formulation of the compiled loop :func:`modeling.stereo._kernels.edge.edge_sums`,
which :func:`modeling.stereo.segments.extract_segments` runs (it saves about 0.5 ms per env step
over this version); ``tests/modeling/stereo/test_compiled_edge.py`` holds the two together.

In every image row ``v`` a detected line crosses, its edge point is the sub-pixel column ``u`` of
the peak of the horizontal intensity gradient (central difference, of the segment's own contrast
sign, float32) within ``search_px`` of the line, located by a parabola through the peak and its
two neighbours. A row's point counts if the peak is interior to the window and at least
``min_gradient``. The least-squares line of a segment is then fitted from the sums of its points
(``modeling.stereo.segments``): ``n, sum v, sum u, sum v^2, sum v u, sum u^2`` (``v`` from the first
searched row, ``u`` from the detected line), with the sums of the peak gradient and of the grey
levels at ``side_px`` (far) and ``near_px`` (near, linearly interpolated) on both sides.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from modeling.stereo._kernels.edge import N_SUMS, EdgeSearch, EdgeSums, LinesToFit

__all__ = ["edge_sums_reference"]


def edge_sums_reference(
    stack: NDArray[np.uint8], lines: LinesToFit, search: EdgeSearch
) -> EdgeSums:
    """Per-segment sums of the edge points of ``lines`` (section 3.2; see the module docstring).

    Args:
        stack: (n_images * height, W) uint8, the images one below the other.
        lines: The ``m`` detected lines to fit (each within one image's rows).
        search: The search window, the side samples and the pixel block half-width ``B``
            (pixels past an image's sides replicate its edge columns).

    Returns:
        (m, N_SUMS) float64 sums, (m,) int8 polarity, and the first and last row with an edge
        point (-1 where there is none).
    """
    m = lines.x0.shape[0]
    W = stack.shape[1]
    B, search_px, side_px = search.half_block, search.search_px, search.side_px
    nb, nwin = 2 * B + 1, 2 * search_px + 1
    # one entry per (segment, searched row), segment after segment
    counts = lines.r1 - lines.r0 + 1
    seg = np.repeat(np.arange(m), counts)
    starts = np.cumsum(counts) - counts
    rows = np.arange(seg.size) + np.repeat(lines.r0 - starts, counts)
    a = lines.x0 - lines.inv_slope * lines.y0
    u_line = a[seg] + lines.inv_slope[seg] * rows  # the detected line in each row
    c = np.minimum(np.maximum(np.rint(u_line), -B), W - 1 + B).astype(np.int64)
    # the (rows, 2 B + 1) block of pixels c - B .. c + B of each row, edge columns replicated
    image_rows = rows + lines.image_of[seg] * search.height
    cols = np.clip(c[:, None] - B + np.arange(nb), 0, W - 1)
    blk = stack[image_rows[:, None], cols].astype(np.float32)
    # polarity: the sign of the gradient summed over the segment's windows (the sum of central
    # differences over a window telescopes to the two pairs of pixels at its ends)
    lo = B - search_px - 1
    offsets = np.array([search_px + 1, search_px, -search_px, -search_px - 1])
    px = stack[image_rows[:, None], np.clip(c[:, None] + offsets, 0, W - 1)].astype(np.float32)
    total = np.zeros(m, np.float32)
    np.add.at(total, seg, px[:, 0] + px[:, 1] - px[:, 2] - px[:, 3])  # in row order, float32
    polarity = np.where(total >= 0, 1, -1).astype(np.int8)
    sign = polarity[seg].astype(np.float32)[:, None]
    # the gradient at offsets -search_px - 1 .. search_px + 1 from c, of the segment's sign
    half, two, tiny = np.float32(0.5), np.float32(2.0), np.float32(-1e-12)
    g = (blk[:, lo + 1 : lo + nwin + 3] - blk[:, lo - 1 : lo + nwin + 1]) * half * sign
    k = np.argmax(g[:, 1 : 1 + nwin], axis=1)  # the first maximum, offsets -search_px..search_px
    best = g[np.arange(seg.size), k + 1]
    col = c + k
    p = np.flatnonzero(
        (k > 0)
        & (k < nwin - 1)
        & (best.astype(np.float64) >= search.min_gradient)
        & (col > search_px)
        & (col < W - 1 + search_px)
    )  # the rows with an edge point
    k, best, gm, gp = k[p], best[p], g[p, k[p]], g[p, k[p] + 2]
    # the parabola's vertex (at an interior maximum |off| <= 0.5)
    off = half * (gm - gp) / np.minimum(gm - two * best + gp, tiny)
    rel_u = (k - search_px).astype(np.float64) + off.astype(np.float64)  # from column c
    u = rel_u + (c[p] - u_line[p])
    v = (rows[p] - lines.r0[seg[p]]).astype(np.float64)
    # the grey levels: far at an integer offset from the rounded edge column, near interpolated
    blk = blk[p]
    ru = B + np.rint(rel_u).astype(np.int64)
    idx = np.arange(p.size)
    greys = [blk[idx, ru - side_px].astype(np.float64), blk[idx, ru + side_px].astype(np.float64)]
    for x in (rel_u - search.near_px, rel_u + search.near_px):
        fx = np.floor(x)
        i = B + fx.astype(np.int64)
        w = x - fx
        greys.append(blk[idx, i].astype(np.float64) * (1.0 - w) + blk[idx, i + 1] * w)
    points = np.stack(
        [np.ones_like(v), v, u, v * v, v * u, u * u, best.astype(np.float64), *greys], axis=1
    )
    sums = np.zeros((m, N_SUMS))
    np.add.at(sums, seg[p], points)  # point after point, in row order, as the loop adds them
    # the first and last row with an edge point
    has = np.bincount(seg[p], minlength=m) > 0
    first_row = np.full(m, np.iinfo(np.int64).max)
    np.minimum.at(first_row, seg[p], rows[p])
    last_row = np.full(m, -1, np.int64)
    np.maximum.at(last_row, seg[p], rows[p])
    return EdgeSums(
        sums=sums, polarity=polarity, first_row=np.where(has, first_row, -1), last_row=last_row
    )
