"""Compiled loops of the memory's association and fusion (:mod:`modeling.memory.association`).

:func:`gate_pairs` is :func:`modeling.memory.association.gated_pairs_reference` written as one
pass over the (new, remembered) pairs: the same midpoint prefilter, then the 4-dof squared
Mahalanobis distance of the endpoint difference in both orders. :func:`fuse_pairs` is the
arithmetic of :func:`modeling.memory.association.fused_segments_reference` (the endpoints
aligned, the weighted product of Gaussians of
:func:`modeling.memory.association.gaussian_product`, its variances floored as
:func:`modeling.memory.association.floored_covariances` floors them, the larger heights) as one
pass over the pairs. Both keep the reference's arithmetic in the same order, so the results are
equal, not only close. A fuse gates five stacks against each other and fuses two or three; in
NumPy each costs a dozen small array operations (about 0.1 ms), here a few microseconds.
:func:`fuse_pairs` takes the small named tuples below.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not import
Numba. ``tests/modeling/memory/test_compiled_association.py`` compares them with the references on
seeded random inputs.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call


@compiled_helper
def _mahalanobis2(dx: float, dy: float, a: float, b: float, c: float) -> float:
    """``d^T S^-1 d`` for ``d = (dx, dy)``, ``S = [[a, b], [b, c]]`` (the reference's form)."""
    return (c * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / (a * c - b * b)


@compiled_helper
def _endpoint_d2(
    ne: np.ndarray, nc: np.ndarray, me: np.ndarray, mc: np.ndarray, i: int, j: int, flip: int
) -> float:
    """The 4-dof distance of new segment ``i`` against remembered ``j``, the new endpoints in
    order (``flip`` 0) or reversed (1): the sum over the two endpoints."""
    total = 0.0
    for e in range(2):
        k = e ^ flip
        dx = ne[i, k, 0] - me[j, e, 0]
        dy = ne[i, k, 1] - me[j, e, 1]
        a = nc[i, k, 0, 0] + mc[j, e, 0, 0]
        b = nc[i, k, 0, 1] + mc[j, e, 0, 1]
        c = nc[i, k, 1, 1] + mc[j, e, 1, 1]
        total += _mahalanobis2(dx, dy, a, b, c)
    return total


@compiled_on_first_call
def gate_pairs(
    new_ends: np.ndarray,
    new_cov: np.ndarray,
    mem_ends: np.ndarray,
    mem_cov: np.ndarray,
    gate_chi2: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(rows, cols, d2, swapped)`` of the gated pairs, ordered by row then column (the fields
    of :class:`~modeling.memory.association.Association`); arrays as in the reference."""
    n, m = new_ends.shape[0], mem_ends.shape[0]
    t_new = np.empty(n)
    for i in range(n):
        t_new[i] = max(
            new_cov[i, 0, 0, 0] + new_cov[i, 0, 1, 1], new_cov[i, 1, 0, 0] + new_cov[i, 1, 1, 1]
        )
    t_mem = np.empty(m)
    for j in range(m):
        t_mem[j] = max(
            mem_cov[j, 0, 0, 0] + mem_cov[j, 0, 1, 1], mem_cov[j, 1, 0, 0] + mem_cov[j, 1, 1, 1]
        )
    rows = np.empty(n * m, dtype=np.int64)
    cols = np.empty(n * m, dtype=np.int64)
    d2 = np.empty(n * m)
    swapped = np.empty(n * m, dtype=np.bool_)
    k = 0
    for i in range(n):
        mx = (new_ends[i, 0, 0] + new_ends[i, 1, 0]) / 2.0
        my = (new_ends[i, 0, 1] + new_ends[i, 1, 1]) / 2.0
        for j in range(m):
            dx = mx - (mem_ends[j, 0, 0] + mem_ends[j, 1, 0]) / 2.0
            dy = my - (mem_ends[j, 0, 1] + mem_ends[j, 1, 1]) / 2.0
            if dx * dx + dy * dy > gate_chi2 * (t_new[i] + t_mem[j]):
                continue
            straight = _endpoint_d2(new_ends, new_cov, mem_ends, mem_cov, i, j, 0)
            reverse = _endpoint_d2(new_ends, new_cov, mem_ends, mem_cov, i, j, 1)
            flip = reverse < straight
            best = reverse if flip else straight
            if best <= gate_chi2:
                rows[k] = i
                cols[k] = j
                d2[k] = best
                swapped[k] = flip
                k += 1
    return rows[:k].copy(), cols[:k].copy(), d2[:k].copy(), swapped[:k].copy()


@compiled_helper
def _inverse2(a: float, b: float, d: float) -> tuple[float, float, float]:
    """``(i00, i01, i11)`` of the inverse of ``[[a, b], [b, d]]`` (the reference's closed form)."""
    det = a * d - b * b
    return d / det, -b / det, a / det


@compiled_helper
def _floored2(a: float, b: float, d: float, min_var: float) -> tuple[float, float, float]:
    """``(c00, c01, c11)`` of ``[[a, b], [b, d]]`` with its variances raised to at least
    ``min_var`` (> 0) in every direction: the arithmetic of
    :func:`modeling.memory.association.floored_covariances`, in its order."""
    m = 0.5 * (a + d)
    r = math.hypot(0.5 * (a - d), b)
    if not m - r < min_var:
        return a, b, d
    hi = m + r
    if hi >= min_var and r > 0.0:  # thin: the minor axis raised
        k = (min_var - (m - r)) / (2.0 * r)
        return a + k * (hi - a), b + k * (0.0 - b), d + k * (hi - d)
    return min_var, 0.0, min_var


class GaussianSegments(NamedTuple):
    """Uncertain segments as :func:`fuse_pairs` reads them, ``n`` rows (the arrays of a
    :class:`~modeling.memory.association.SegmentStack` but its source)."""

    ends: np.ndarray  # (n, 2, 2) endpoint means, world frame, metres
    cov: np.ndarray  # (n, 2, 2, 2) endpoint covariances, m^2
    heights: np.ndarray  # (n, 2) endpoint heights, metres


class FusedPairs(NamedTuple):
    """The ``k`` pairs to fuse (:func:`fuse_pairs`)."""

    rows: np.ndarray  # (k,) int64, index of the new segment
    cols: np.ndarray  # (k,) int64, index of the remembered segment
    swapped: np.ndarray  # (k,) bool, the new segment's endpoints in reverse
    weight: np.ndarray  # (k,) factor on the new segment's information


@compiled_on_first_call
def fuse_pairs(
    mem: GaussianSegments, new: GaussianSegments, pairs: FusedPairs, min_var: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mean, cov, top)`` (k, 2, 2), (k, 2, 2, 2), (k, 2) of the remembered segments
    ``pairs.cols`` of ``mem`` fused with the new ones ``pairs.rows`` of ``new`` (endpoints in
    reverse where ``pairs.swapped``), the new one's information times ``pairs.weight`` (k,),
    the covariances' variances raised to at least ``min_var`` (m^2; none when 0) in every
    direction (the means are the product's)."""
    mem_ends, mem_cov, mem_heights = mem
    new_ends, new_cov, new_heights = new
    rows, cols, swapped, weight = pairs
    k = rows.shape[0]
    mean = np.empty((k, 2, 2))
    cov = np.empty((k, 2, 2, 2))
    top = np.empty((k, 2))
    for p in range(k):
        r, c, w = rows[p], cols[p], weight[p]
        for e in range(2):
            f = 1 - e if swapped[p] else e
            a00, a01, a11 = _inverse2(mem_cov[c, e, 0, 0], mem_cov[c, e, 0, 1], mem_cov[c, e, 1, 1])
            b00, b01, b11 = _inverse2(new_cov[r, f, 0, 0], new_cov[r, f, 0, 1], new_cov[r, f, 1, 1])
            b00, b01, b11 = b00 * w, b01 * w, b11 * w
            p00, p01, p11 = _inverse2(a00 + b00, a01 + b01, a11 + b11)
            ax, ay = mem_ends[c, e, 0], mem_ends[c, e, 1]
            bx, by = new_ends[r, f, 0], new_ends[r, f, 1]
            ix = (a00 * ax + a01 * ay) + (b00 * bx + b01 * by)
            iy = (a01 * ax + a11 * ay) + (b01 * bx + b11 * by)
            mean[p, e, 0] = p00 * ix + p01 * iy
            mean[p, e, 1] = p01 * ix + p11 * iy
            if min_var > 0.0:
                p00, p01, p11 = _floored2(p00, p01, p11, min_var)
            cov[p, e, 0, 0] = p00
            cov[p, e, 0, 1] = p01
            cov[p, e, 1, 0] = p01
            cov[p, e, 1, 1] = p11
            top[p, e] = max(mem_heights[c, e], new_heights[r, f])
    return mean, cov, top
