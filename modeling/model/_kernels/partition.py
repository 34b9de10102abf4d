"""Compiled loop of :mod:`modeling.model.partitions`: the obstacles of every situation, each
distinct one once, and the relation groups between them (:func:`situation_partitions`; reference
:func:`modeling.model.partitions.situation_partitions_reference`, NumPy).

Integer bookkeeping and stable sorts only (no arithmetic on the floats, which are only compared),
so the results equal the reference's exactly; ``tests/modeling/model/test_compiled_model.py``
compares them. Compiled with Numba on first use (:mod:`modeling.jit`); importing this module
does not import Numba.
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


class SituationPartitions(NamedTuple):
    """The obstacles of S situations over the same N items and m relations, each distinct
    obstacle (item set) once, and their relation groups (:class:`PartitionArrays`' groups).

    Attributes:
        obstacle: (t,) int64, the distinct obstacle of each situation's obstacles, situation
            after situation, in the order of their smallest item.
        first_obst: (S + 1,) int64, where each situation's obstacles start in ``obstacle``.
        items: (k,) int64, the distinct obstacles' items, obstacle after obstacle (in the order
            of their first occurrence), ascending within one.
        counts: (u,) int64, items per distinct obstacle.
        links: (q,) int64, the impassable rows inside each distinct obstacle, ascending.
        link_counts: (u,) int64, links per distinct obstacle.
        und: The undecided rows' groups, least passable first (:data:`FlipGroups`).
        und_bounds: (S + 1,) int64, where each situation's undecided groups start.
        pas: The short passable rows' groups, narrowest first.
    """

    obstacle: np.ndarray
    first_obst: np.ndarray
    items: np.ndarray
    counts: np.ndarray
    links: np.ndarray
    link_counts: np.ndarray
    und: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    und_bounds: np.ndarray
    pas: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


FlipGroups = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""``(rows, starts, s, lo, hi, flip)``: :data:`Groups`, and whether the first row of each group
has its first item on the higher obstacle ``hi``."""


@compiled_helper
def _situation_groups(
    order: np.ndarray,
    act: np.ndarray,
    obst: np.ndarray,
    n_obst: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The groups (:data:`FlipGroups`) of the rows ``order`` (m',) (sorted by the value that
    orders a group, ties by row) between two obstacles ``obst`` (S, N) of each situation."""
    n_sit = act.shape[0]
    size = n_sit * order.shape[0]
    rows = np.empty(size, dtype=np.int64)
    sit = np.empty(size, dtype=np.int64)
    key = np.empty(size, dtype=np.int64)
    k = 0
    for s in range(n_sit):
        k0 = k
        span = n_obst[s] + 1
        for q in range(order.shape[0]):
            r = order[q]
            a, b = ri[r], rj[r]
            if act[s, a] and act[s, b] and obst[s, a] != obst[s, b]:
                oa, ob = obst[s, a], obst[s, b]
                rows[k] = r
                sit[k] = s
                key[k] = min(oa, ob) * span + max(oa, ob)
                k += 1
        if k - k0 > 1:  # by obstacle pair; a stable sort keeps each group in ``order``
            srt = np.argsort(key[k0:k], kind="mergesort") + k0
            rows[k0:k] = rows[srt]
            key[k0:k] = key[srt]
    n = k
    rows = rows[:n].copy()
    n_groups = 0
    for k in range(n):
        if k == 0 or sit[k] != sit[k - 1] or key[k] != key[k - 1]:
            n_groups += 1
    starts = np.empty(n_groups, dtype=np.int64)
    g_sit = np.empty(n_groups, dtype=np.int64)
    lo = np.empty(n_groups, dtype=np.int64)
    hi = np.empty(n_groups, dtype=np.int64)
    flip = np.empty(n_groups, dtype=np.bool_)
    g = 0
    for k in range(n):
        if k == 0 or sit[k] != sit[k - 1] or key[k] != key[k - 1]:
            s = sit[k]
            oa, ob = obst[s, ri[rows[k]]], obst[s, rj[rows[k]]]
            starts[g] = k
            g_sit[g] = s
            lo[g] = min(oa, ob)
            hi[g] = max(oa, ob)
            flip[g] = oa > ob
            g += 1
    return rows, starts, g_sit, lo, hi, flip


@compiled_helper
def _rows_between_obstacles(
    order: np.ndarray,
    act: np.ndarray,
    base: np.ndarray,
    base_root: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
) -> np.ndarray:
    """The rows of ``order`` (in its order) that may lie between two obstacles of some
    situation: both items active in some situation of ``act`` (S, N), and not two items of one
    component of the base (``base``: active in every situation; ``base_root``: the root of
    each item's base component), which are in one obstacle in every situation."""
    n_sit, n = act.shape
    somewhere = np.zeros(n, dtype=np.bool_)
    for s in range(n_sit):
        for x in range(n):
            somewhere[x] = somewhere[x] or act[s, x]
    out = np.empty(order.shape[0], dtype=np.int64)
    c = 0
    for q in range(order.shape[0]):
        r = order[q]
        a, b = ri[r], rj[r]
        if not (somewhere[a] and somewhere[b]):
            continue
        if base[a] and base[b] and base_root[a] == base_root[b]:
            continue
        out[c] = r
        c += 1
    return out[:c]


@compiled_on_first_call
def situation_partitions(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    und_order: np.ndarray,
    pas_order: np.ndarray,
) -> SituationPartitions:
    """The obstacles of situations whose active items are ``act`` (S, N) bool, over relations
    ``(ri, rj)`` (m,) int64 of which ``is_imp`` (m,) bool are impassable, each distinct obstacle
    once, and the groups of the undecided rows ``und_order`` and of the short passable rows
    ``pas_order`` (each sorted by the value that orders its groups, ties by row):
    :class:`SituationPartitions`.

    What the situations share is done once: the items active in every situation (the base
    model's) are joined by their impassable rows first (:func:`join`; each root the smallest
    item of its tree, as :func:`modeling.model.obstacles.components` labels them); each
    situation then joins only the rows of its other active items. An obstacle is found again in
    a later situation by its smallest item and its item list, and its links are listed once.
    The groups are looked for only among the rows that may lie between two obstacles
    (:func:`_rows_between_obstacles`): a row within one component of the base is within one
    obstacle in every situation.
    """
    n_sit, n = act.shape
    m = ri.shape[0]
    base = np.ones(n, dtype=np.bool_)
    for s in range(n_sit):
        for x in range(n):
            base[x] = base[x] and act[s, x]
    base_parent = np.arange(n)
    n_var = 0
    for r in range(m):
        if is_imp[r]:
            if base[ri[r]] and base[rj[r]]:
                join(base_parent, ri[r], rj[r])
            else:
                n_var += 1
    for x in range(n):  # in item order: a parent (smaller) points at its root already
        base_parent[x] = base_parent[base_parent[x]]
    var_rows = np.empty(n_var, dtype=np.int64)
    imp_list = np.empty(m, dtype=np.int64)
    q = 0
    n_imp = 0
    for r in range(m):
        if is_imp[r]:
            imp_list[n_imp] = r
            n_imp += 1
            if not (base[ri[r]] and base[rj[r]]):
                var_rows[q] = r
                q += 1
    # Each situation's components, numbered in the order of their smallest item.
    obst = np.full((n_sit, n), -1, dtype=np.int64)
    n_obst = np.zeros(n_sit, dtype=np.int64)
    parent = np.empty(n, dtype=np.int64)
    for s in range(n_sit):
        parent[:] = base_parent
        for k in range(n_var):
            r = var_rows[k]
            if act[s, ri[r]] and act[s, rj[r]]:
                join(parent, ri[r], rj[r])
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
    t = first_obst[n_sit]
    # Every obstacle's items (ascending), obstacle after obstacle.
    size = np.zeros(t, dtype=np.int64)
    root = np.empty(t, dtype=np.int64)
    for s in range(n_sit):
        for x in range(n):
            if act[s, x]:
                c = first_obst[s] + obst[s, x]
                if size[c] == 0:
                    root[c] = x
                size[c] += 1
    start = np.zeros(t + 1, dtype=np.int64)
    for c in range(t):
        start[c + 1] = start[c] + size[c]
    fill = start[:t].copy()
    all_items = np.empty(start[t], dtype=np.int64)
    for s in range(n_sit):
        for x in range(n):
            if act[s, x]:
                c = first_obst[s] + obst[s, x]
                all_items[fill[c]] = x
                fill[c] += 1
    # The distinct obstacles, in the order of first occurrence: each is compared with the
    # earlier distinct ones of the same smallest item (a chain per item).
    obstacle = np.empty(t, dtype=np.int64)
    rep = np.empty(t, dtype=np.int64)  # the obstacle (of all t) that each distinct one is
    chain = np.full(n, -1, dtype=np.int64)  # the latest distinct obstacle of each smallest item
    prev = np.empty(t, dtype=np.int64)  # the one before it in its chain
    u = 0
    for c in range(t):
        found = -1
        d = chain[root[c]]
        while d >= 0 and found < 0:
            e = rep[d]
            if size[e] == size[c]:
                same = True
                for k in range(size[c]):
                    if all_items[start[e] + k] != all_items[start[c] + k]:
                        same = False
                        break
                if same:
                    found = d
            d = prev[d]
        if found < 0:
            rep[u] = c
            prev[u] = chain[root[c]]
            chain[root[c]] = u
            found = u
            u += 1
        obstacle[c] = found
    counts = np.empty(u, dtype=np.int64)
    n_items = 0
    for d in range(u):
        counts[d] = size[rep[d]]
        n_items += counts[d]
    items = np.empty(n_items, dtype=np.int64)
    k = 0
    for d in range(u):
        e = rep[d]
        items[k : k + size[e]] = all_items[start[e] : start[e] + size[e]]
        k += size[e]
    # The links of each distinct obstacle: the impassable rows with both items in it (both are
    # active wherever it occurs), from the rows of each item (by the row's first item).
    row_start = np.zeros(n + 1, dtype=np.int64)
    for k in range(n_imp):
        row_start[ri[imp_list[k]] + 1] += 1
    for x in range(n):
        row_start[x + 1] += row_start[x]
    rows_of = np.empty(n_imp, dtype=np.int64)
    at = row_start[:n].copy()
    for k in range(n_imp):  # ascending within each item
        r = imp_list[k]
        rows_of[at[ri[r]]] = r
        at[ri[r]] += 1
    member = np.full(n, -1, dtype=np.int64)
    link_counts = np.zeros(u, dtype=np.int64)
    buffer = np.empty(n_imp, dtype=np.int64)
    parts = []
    for d in range(u):
        e = rep[d]
        for k in range(start[e], start[e] + size[e]):
            member[all_items[k]] = d
        q = 0
        for k in range(start[e], start[e] + size[e]):
            x = all_items[k]
            for h in range(row_start[x], row_start[x + 1]):
                r = rows_of[h]
                if member[rj[r]] == d:
                    buffer[q] = r
                    q += 1
        link_counts[d] = q
        parts.append(np.sort(buffer[:q]))
    links = np.empty(link_counts.sum(), dtype=np.int64)
    k = 0
    for d in range(u):
        links[k : k + link_counts[d]] = parts[d]
        k += link_counts[d]
    # The groups, of the rows that may lie between two obstacles (most undecided and short
    # passable rows lie within one obstacle of the base, in every situation).
    und_rows = _rows_between_obstacles(und_order, act, base, base_parent, ri, rj)
    und = _situation_groups(und_rows, act, obst, n_obst, ri, rj)
    und_bounds = np.zeros(n_sit + 1, dtype=np.int64)
    for g in range(und[2].shape[0]):
        und_bounds[und[2][g] + 1] += 1
    for s in range(n_sit):
        und_bounds[s + 1] += und_bounds[s]
    pas_rows = _rows_between_obstacles(pas_order, act, base, base_parent, ri, rj)
    pas = _situation_groups(pas_rows, act, obst, n_obst, ri, rj)
    return SituationPartitions(
        obstacle, first_obst, items, counts, links, link_counts, und, und_bounds, pas
    )
