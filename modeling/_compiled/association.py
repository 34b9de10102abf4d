"""Compiled loop of the memory's association gate (:mod:`modeling.memory_association`).

:func:`gate_pairs` is :func:`modeling.memory_association.gated_pairs_reference` written as one
pass over the (new, remembered) pairs: the same midpoint prefilter, then the 4-dof squared
Mahalanobis distance of the endpoint difference in both orders, with the same arithmetic in the
same order (so the results are equal, not only close). A fuse gates five stacks against each
other; in NumPy each gate costs a dozen small array operations (about 0.1 ms), here a few
microseconds.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not import
Numba. ``tests/modeling/test_compiled_association.py`` compares it with the reference on seeded
random inputs.
"""

from __future__ import annotations

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
    of :class:`~modeling.memory_association.Association`); arrays as in the reference."""
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
