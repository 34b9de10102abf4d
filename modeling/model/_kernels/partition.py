"""Compiled loop of :mod:`modeling.model.situations`: the obstacles of every situation and the
relation groups between them (:func:`partition_arrays`; reference
:func:`modeling.model.situations.partition_arrays_reference`, NumPy).

Integer bookkeeping and stable sorts only (no arithmetic on the floats, which are only compared),
so the results equal the reference's exactly; ``tests/modeling/test_situations.py`` compares
them. Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not
import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call
from modeling.model._kernels.hull import join


class PartitionArrays(NamedTuple):
    """The obstacles of S situations over the same N items and m relations, and their groups.

    A situation's obstacles are the connected components of the impassable relations among its
    active items, numbered in the order of their smallest item. "Groups" are the relation rows
    between two obstacles of a situation (both items active, different obstacles) of one kind,
    grouped by (situation, lower obstacle, higher obstacle), each group sorted by a value of its
    rows (ascending, ties in row order).

    Attributes:
        items: (k,) int64, the active items by (situation, obstacle, item).
        counts: (t,) int64, items per obstacle, situation after situation.
        first_obst: (S + 1,) int64, where each situation's obstacles start in ``counts``.
        item_bounds: (S + 1,) int64, where each situation's items start in ``items``.
        imp_rows: (q,) int64, the impassable rows inside obstacles, by (situation, row).
        link_obst: (q,) int64, the obstacle of each of those rows in its situation.
        imp_bounds: (S + 1,) int64, where each situation's rows start in ``imp_rows``.
        oi: (S, m) int64, the obstacle of each relation's first item in each situation (-1:
            inactive).
        oj: (S, m) int64, that of its second item.
        und: The undecided rows' groups, ordered by ``p_passable`` (:data:`Groups`).
        und_bounds: (S + 1,) int64, where each situation's undecided groups start.
        pas: The short passable rows' groups, ordered by ``distance_m``.
    """

    items: np.ndarray
    counts: np.ndarray
    first_obst: np.ndarray
    item_bounds: np.ndarray
    imp_rows: np.ndarray
    link_obst: np.ndarray
    imp_bounds: np.ndarray
    oi: np.ndarray
    oj: np.ndarray
    und: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    und_bounds: np.ndarray
    pas: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


Groups = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""``(rows, starts, s, lo, hi)``: the sorted rows, the start of each group in them, and each
group's situation and obstacle pair ``lo < hi``."""


@compiled_helper
def _groups(
    mask: np.ndarray, oi: np.ndarray, oj: np.ndarray, within: np.ndarray, span: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The groups of the rows of ``mask`` (S, m) (:class:`PartitionArrays`), sorted by ``within``
    (m,) in each group; ``span`` exceeds every obstacle number."""
    n_sit, m = mask.shape
    n = 0
    for s in range(n_sit):
        for r in range(m):
            if mask[s, r]:
                n += 1
    sit = np.empty(n, dtype=np.int64)
    rows = np.empty(n, dtype=np.int64)
    key = np.empty(n, dtype=np.int64)
    value = np.empty(n, dtype=np.float64)
    k = 0
    for s in range(n_sit):  # situation-major, then by row
        for r in range(m):
            if mask[s, r]:
                lo, hi = min(oi[s, r], oj[s, r]), max(oi[s, r], oj[s, r])
                sit[k] = s
                rows[k] = r
                key[k] = (s * span + lo) * span + hi
                value[k] = within[r]
                k += 1
    # by key, then by value, then in row order: two stable sorts, the minor key first
    by_value = np.argsort(value, kind="mergesort")
    order = by_value[np.argsort(key[by_value], kind="mergesort")]
    rows, key, sit = rows[order], key[order], sit[order]
    n_groups = 0
    for k in range(n):
        if k == 0 or key[k] != key[k - 1]:
            n_groups += 1
    starts = np.empty(n_groups, dtype=np.int64)
    g = 0
    for k in range(n):
        if k == 0 or key[k] != key[k - 1]:
            starts[g] = k
            g += 1
    g_sit = sit[starts]
    g_key = key[starts]
    return rows, starts, g_sit, (g_key // span) % span, g_key % span


@compiled_on_first_call
def partition_arrays(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    is_und: np.ndarray,
    is_short_pas: np.ndarray,
    p_passable: np.ndarray,
    distance_m: np.ndarray,
) -> PartitionArrays:
    """The obstacles and relation groups of situations whose active items are ``act`` (S, N)
    bool, over relations ``(ri, rj)`` (m,) int64 of kinds ``is_imp``, ``is_und`` and
    ``is_short_pas`` (m,) bool: :class:`PartitionArrays` (undecided groups by ``p_passable``,
    short passable ones by ``distance_m``).

    Each situation's components by union-find over its impassable rows (:func:`join`, each
    root the smallest item of its tree, as :func:`modeling.model.obstacles.components` labels them).
    """
    n_sit, n = act.shape
    m = ri.shape[0]
    both = np.zeros((n_sit, m), dtype=np.bool_)
    n_imp = 0
    for s in range(n_sit):
        for r in range(m):
            if act[s, ri[r]] and act[s, rj[r]]:
                both[s, r] = True
                if is_imp[r]:
                    n_imp += 1
    imp_rows = np.empty(n_imp, dtype=np.int64)
    imp_sit = np.empty(n_imp, dtype=np.int64)
    imp_bounds = np.zeros(n_sit + 1, dtype=np.int64)
    obst = np.full((n_sit, n), -1, dtype=np.int64)
    n_obst = np.zeros(n_sit, dtype=np.int64)
    parent = np.empty(n, dtype=np.int64)
    q = 0
    for s in range(n_sit):
        for x in range(n):
            parent[x] = x
        for r in range(m):
            if both[s, r] and is_imp[r]:
                imp_rows[q] = r
                imp_sit[q] = s
                q += 1
                join(parent, ri[r], rj[r])
        imp_bounds[s + 1] = q
        for x in range(n):  # in item order: a parent (smaller) points at its root already
            parent[x] = parent[parent[x]]
            if act[s, x]:
                if parent[x] == x:  # a root: the next obstacle
                    obst[s, x] = n_obst[s]
                    n_obst[s] += 1
                else:
                    obst[s, x] = obst[s, parent[x]]
    first_obst = np.zeros(n_sit + 1, dtype=np.int64)
    for s in range(n_sit):
        first_obst[s + 1] = first_obst[s] + n_obst[s]
    counts = np.zeros(first_obst[n_sit], dtype=np.int64)
    item_bounds = np.zeros(n_sit + 1, dtype=np.int64)
    for s in range(n_sit):
        item_bounds[s + 1] = item_bounds[s]
        for x in range(n):
            if act[s, x]:
                counts[first_obst[s] + obst[s, x]] += 1
                item_bounds[s + 1] += 1
    # the items grouped by (situation, obstacle), ascending within an obstacle
    fill = np.empty(first_obst[n_sit], dtype=np.int64)
    at = 0
    for c in range(fill.shape[0]):
        fill[c] = at
        at += counts[c]
    items = np.empty(at, dtype=np.int64)
    for s in range(n_sit):
        for x in range(n):
            if act[s, x]:
                c = first_obst[s] + obst[s, x]
                items[fill[c]] = x
                fill[c] += 1
    oi = np.empty((n_sit, m), dtype=np.int64)
    oj = np.empty((n_sit, m), dtype=np.int64)
    span = 1
    for s in range(n_sit):
        span = max(span, n_obst[s] + 1)
        for r in range(m):
            oi[s, r] = obst[s, ri[r]]
            oj[s, r] = obst[s, rj[r]]
    link_obst = np.empty(n_imp, dtype=np.int64)
    for k in range(n_imp):
        link_obst[k] = oi[imp_sit[k], imp_rows[k]]
    und_mask = np.zeros((n_sit, m), dtype=np.bool_)
    pas_mask = np.zeros((n_sit, m), dtype=np.bool_)
    for s in range(n_sit):
        for r in range(m):
            if both[s, r] and oi[s, r] != oj[s, r]:
                und_mask[s, r] = is_und[r]
                pas_mask[s, r] = is_short_pas[r]
    und = _groups(und_mask, oi, oj, p_passable, span)
    und_bounds = np.zeros(n_sit + 1, dtype=np.int64)
    for g in range(und[2].shape[0]):
        und_bounds[und[2][g] + 1] += 1
    for s in range(n_sit):
        und_bounds[s + 1] += und_bounds[s]
    pas = _groups(pas_mask, oi, oj, distance_m, span)
    return PartitionArrays(
        items,
        counts,
        first_obst,
        item_bounds,
        imp_rows,
        link_obst,
        imp_bounds,
        oi,
        oj,
        und,
        und_bounds,
        pas,
    )
