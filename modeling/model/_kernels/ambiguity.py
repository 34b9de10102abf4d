"""Compiled loops of :mod:`modeling.model.ambiguity`: Fig. 7's units of ambiguous segments
moving together (:func:`moving_together`; reference
:func:`modeling.model.ambiguity.units_moving_together_reference`, NumPy) and Fig. 8's effects
of every choice of the units on the base model (:func:`choice_effects`; reference
:func:`modeling.model.ambiguity._signature` on the base state of
:func:`modeling.model.ambiguity._base_state`, Python).

The same floating-point operations as the reference, in the same order (midpoints as the mean of
two endpoints, ``hypot`` distances, Ericson's closest points of
:func:`modeling.model._kernels.gap.closest_params`), so the candidate orders and the units equal the
reference's exactly; the effects are integer bookkeeping (component labels, relation kinds).
``tests/modeling/model/test_compiled_model.py`` compares both with their references. Compiled
with Numba on first use (:mod:`modeling.jit`); importing this module does not import Numba.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call
from modeling.model._kernels.gap import Segment, closest_params
from modeling.model._kernels.hull import join


class LiveCandidates(NamedTuple):
    """The candidates of the L live ambiguous segments (``ambiguous.units_moving_together``).

    Attributes:
        ends: (N, 2, 2) endpoint means of every item, world frame, metres.
        items: (c,) int64, the item of each candidate, segment after segment (candidate order).
        offsets: (L + 1,) int64, where each segment's candidates start in ``items``.
        has_none: (L,) bool, whether the segment's candidates leave mass to "none".
    """

    ends: np.ndarray
    items: np.ndarray
    offsets: np.ndarray
    has_none: np.ndarray


class MovingTogether(NamedTuple):
    """Fig. 7's result for the live segments.

    Attributes:
        order: (c,) int64, segment after segment: the candidate index of each rank (rank: order
            of the candidates' midpoint distance from the viewpoint, ties in candidate order).
        labels: (L,) int64, the unit of each live segment: the position (in the live list) of
            its unit's first member.
    """

    order: np.ndarray
    labels: np.ndarray


@compiled_helper
def _mid(ends: np.ndarray, item: int) -> tuple[float, float]:
    """Midpoint of item ``item``'s mean segment (the mean of its two endpoints)."""
    return (ends[item, 0, 0] + ends[item, 1, 0]) / 2.0, (ends[item, 0, 1] + ends[item, 1, 1]) / 2.0


@compiled_helper
def _segment(ends: np.ndarray, item: int) -> Segment:
    """Item ``item``'s mean segment."""
    return Segment(ends[item, 0, 0], ends[item, 0, 1], ends[item, 1, 0], ends[item, 1, 1])


@compiled_helper
def _together(live: LiveCandidates, order: np.ndarray, x: int, y: int, width: float) -> bool:
    """Whether live segments ``x`` and ``y`` (same candidate count) move together: each rank's
    displacement from rank 0 agrees within ``0.1 + 0.2 |displacement of x|``, and the candidates
    of each rank lie within ``width`` of each other."""
    ends, items, off = live.ends, live.items, live.offsets
    m = off[x + 1] - off[x]
    x0x, x0y = _mid(ends, items[off[x] + order[off[x]]])
    y0x, y0y = _mid(ends, items[off[y] + order[off[y]]])
    for k in range(m):
        xkx, xky = _mid(ends, items[off[x] + order[off[x] + k]])
        ykx, yky = _mid(ends, items[off[y] + order[off[y] + k]])
        dxx, dxy = xkx - x0x, xky - x0y
        dyx, dyy = ykx - y0x, yky - y0y
        if not math.hypot(dxx - dyx, dxy - dyy) <= 0.1 + 0.2 * math.hypot(dxx, dxy):
            return False
    for k in range(m):
        a = _segment(ends, items[off[x] + order[off[x] + k]])
        b = _segment(ends, items[off[y] + order[off[y] + k]])
        s, t = closest_params(a, b)
        pax = a.px + s * (a.qx - a.px)
        pay = a.py + s * (a.qy - a.py)
        pbx = b.px + t * (b.qx - b.px)
        pby = b.py + t * (b.qy - b.py)
        if not math.hypot(pax - pbx, pay - pby) <= width:
            return False
    return True


@compiled_on_first_call
def moving_together(live: LiveCandidates, vx: float, vy: float, width: float) -> MovingTogether:
    """Fig. 7: rank each live segment's candidates by distance from the viewpoint ``(vx, vy)``,
    then join every pair of segments with the same candidate count and "none" choice whose
    candidates move together (:func:`_together`)."""
    ends, items, off = live.ends, live.items, live.offsets
    n_live = off.shape[0] - 1
    order = np.empty(items.shape[0], dtype=np.int64)
    dist = np.empty(items.shape[0])
    for x in range(n_live):
        for c in range(off[x], off[x + 1]):
            mx, my = _mid(ends, items[c])
            dist[c] = math.hypot(mx - vx, my - vy)
            # insertion sort, stable: candidate c - off[x] goes after the equal ones before it
            r = c
            while r > off[x] and dist[off[x] + order[r - 1]] > dist[c]:
                order[r] = order[r - 1]
                r -= 1
            order[r] = c - off[x]
    parent = np.arange(n_live)
    for x in range(n_live):
        for y in range(x + 1, n_live):
            same_choices = off[x + 1] - off[x] == off[y + 1] - off[y]
            if same_choices and live.has_none[x] == live.has_none[y]:
                if _together(live, order, x, y, width):
                    join(parent, x, y)
    for v in range(n_live):  # its parent, smaller, points at the root already
        parent[v] = parent[parent[v]]
    return MovingTogether(order, parent)


class ChoiceEffects(NamedTuple):
    """What :func:`choice_effects` reads: the relations, the items of the base model and the
    choices.

    Attributes:
        ri: (m,) int64, the first item of each relation.
        rj: (m,) int64, its second item.
        kind: (m,) int8, its :class:`~modeling.model.gaps.Relation` code.
        is_cand: (N,) bool, whether each item is a candidate of an ambiguous segment.
        active: (N,) bool, whether each item is in the base model.
        items: (c,) int64, the items of every choice, choice after choice.
        starts: (k + 1,) int64, where each choice's items start in ``items``.
    """

    ri: np.ndarray
    rj: np.ndarray
    kind: np.ndarray
    is_cand: np.ndarray
    active: np.ndarray
    items: np.ndarray
    starts: np.ndarray


EFFECT_NEW, EFFECT_MERGE, EFFECT_UNDECIDED, EFFECT_NEAR = 0, 1, 2, 3
"""The codes of :class:`modeling.model.ambiguity.Effect` in :func:`choice_effects`' output."""


@compiled_helper
def _is_undecided_pair(codes: np.ndarray, n: int, a: int, b: int) -> bool:
    """Whether the component pair ``(min, max)`` of ``a``, ``b`` is in the sorted ``codes``."""
    code = min(a, b) * n + max(a, b)
    k = int(np.searchsorted(codes, code))
    return k < codes.shape[0] and bool(codes[k] == code)


@compiled_helper
def _unique_sorted(values: np.ndarray, count: int) -> np.ndarray:
    """The distinct values of ``values[:count]``, ascending."""
    if count == 0:
        return values[:0].copy()
    v = np.sort(values[:count])
    keep = 1
    for k in range(1, count):
        if v[k] != v[keep - 1]:
            v[keep] = v[k]
            keep += 1
    return v[:keep].copy()


@compiled_on_first_call
def choice_effects(
    effects: ChoiceEffects, imp_code: int, und_code: int
) -> tuple[np.ndarray, np.ndarray]:
    """Each choice's changes of space passability against the base model (Fig. 8; the
    reference is :func:`modeling.model.ambiguity._signature`, with the base model's state of
    :func:`modeling.model.ambiguity._base_state` and the candidates' relations of
    :func:`modeling.model.ambiguity.candidate_adjacency`), as sorted distinct codes
    ``(effect * S + a) * S + b`` (``S = N + 1``; effects :data:`EFFECT_NEW` ...; for new
    obstacles ``a = b`` = their count): ``(codes, code_starts)``, the codes of choice ``k`` in
    ``codes[code_starts[k]:code_starts[k + 1]]``. ``imp_code``, ``und_code``: the codes of
    impassable and undecided relations."""
    ri, rj, kind, is_cand, active = (
        effects.ri, effects.rj, effects.kind, effects.is_cand, effects.active
    )  # fmt: skip
    items, starts = effects.items, effects.starts
    n = active.shape[0]
    m = ri.shape[0]
    # The base model: components of the impassable relations among active items (each labelled
    # by its smallest item), and the undecided pairs of components.
    labels = np.arange(n)
    for r in range(m):
        if kind[r] == imp_code and active[ri[r]] and active[rj[r]]:
            join(labels, ri[r], rj[r])
    for v in range(n):  # its parent, smaller, points at the root already
        labels[v] = labels[labels[v]]
    pairs = np.empty(m, dtype=np.int64)
    n_p = 0
    for r in range(m):
        if kind[r] == und_code and active[ri[r]] and active[rj[r]]:
            a, b = labels[ri[r]], labels[rj[r]]
            if a != b:
                pairs[n_p] = min(a, b) * n + max(a, b)
                n_p += 1
    und = _unique_sorted(pairs, n_p)
    # The candidates' non-passable relations, by item (CSR).
    adj_start = np.zeros(n + 1, dtype=np.int64)
    for r in range(m):
        if kind[r] == imp_code or kind[r] == und_code:
            if is_cand[ri[r]]:
                adj_start[ri[r] + 1] += 1
            if is_cand[rj[r]]:
                adj_start[rj[r] + 1] += 1
    for v in range(n):
        adj_start[v + 1] += adj_start[v]
    fill = adj_start[:n].copy()
    adj_other = np.empty(adj_start[n], dtype=np.int64)
    adj_imp = np.empty(adj_start[n], dtype=np.bool_)
    for r in range(m):
        if kind[r] == imp_code or kind[r] == und_code:
            if is_cand[ri[r]]:
                adj_other[fill[ri[r]]] = rj[r]
                adj_imp[fill[ri[r]]] = kind[r] == imp_code
                fill[ri[r]] += 1
            if is_cand[rj[r]]:
                adj_other[fill[rj[r]]] = ri[r]
                adj_imp[fill[rj[r]]] = kind[r] == imp_code
                fill[rj[r]] += 1
    size = n + 1
    n_choices = starts.shape[0] - 1
    code_starts = np.zeros(n_choices + 1, dtype=np.int64)
    out = np.empty(0, dtype=np.int64)
    for ch in range(n_choices):
        c0, c1 = starts[ch], starts[ch + 1]
        c = c1 - c0
        degree = 0
        for k in range(c0, c1):
            degree += adj_start[items[k] + 1] - adj_start[items[k]]
        joined = np.empty(degree, dtype=np.int64)
        undecided = np.empty(degree, dtype=np.int64)
        link_a = np.empty(degree, dtype=np.int64)
        link_b = np.empty(degree, dtype=np.int64)
        anchored = np.zeros(c, dtype=np.bool_)
        n_j = n_u = n_l = 0
        for k in range(c):
            it = items[c0 + k]
            for h in range(adj_start[it], adj_start[it + 1]):
                other = adj_other[h]
                if active[other]:
                    if adj_imp[h]:
                        joined[n_j] = labels[other]
                        n_j += 1
                        anchored[k] = True
                    else:
                        undecided[n_u] = labels[other]
                        n_u += 1
                elif adj_imp[h]:
                    for q in range(c):
                        if items[c0 + q] == other:
                            link_a[n_l] = k
                            link_b[n_l] = q
                            n_l += 1
                            break
        js = _unique_sorted(joined, n_j)
        us_all = _unique_sorted(undecided, n_u)
        keep_u = np.ones(us_all.shape[0], dtype=np.bool_)
        for x in range(us_all.shape[0]):  # undecided minus joined
            for y in range(js.shape[0]):
                if us_all[x] == js[y]:
                    keep_u[x] = False
        us = us_all[keep_u]
        # New obstacles: components of the links among the choice's items none of whose items
        # is anchored (impassable to an active item).
        parent = np.arange(c)
        for e in range(n_l):
            join(parent, link_a[e], link_b[e])
        for v in range(c):
            parent[v] = parent[parent[v]]
        rooted_anchor = np.zeros(c, dtype=np.bool_)
        for v in range(c):
            if anchored[v]:
                rooted_anchor[parent[v]] = True
        new = 0
        for v in range(c):
            if parent[v] == v and not rooted_anchor[v]:
                new += 1
        codes = np.empty(1 + js.shape[0] ** 2 + (js.shape[0] + 1) * us.shape[0] ** 2 + 1, np.int64)
        n_c = 0
        if new:
            codes[n_c] = (EFFECT_NEW * size + new) * size + new
            n_c += 1
        for x in range(js.shape[0]):
            for y in range(x + 1, js.shape[0]):
                codes[n_c] = (EFFECT_MERGE * size + js[x]) * size + js[y]
                n_c += 1
        if js.shape[0]:
            for y in range(us.shape[0]):
                for x in range(js.shape[0]):
                    a, b = min(js[x], us[y]), max(js[x], us[y])
                    if not _is_undecided_pair(und, n, a, b):
                        codes[n_c] = (EFFECT_UNDECIDED * size + a) * size + b
                        n_c += 1
        elif us.shape[0]:
            if us.shape[0] == 1:
                codes[n_c] = (EFFECT_NEAR * size + us[0]) * size + us[0]
                n_c += 1
            for x in range(us.shape[0]):
                for y in range(x + 1, us.shape[0]):
                    if not _is_undecided_pair(und, n, us[x], us[y]):
                        codes[n_c] = (EFFECT_UNDECIDED * size + us[x]) * size + us[y]
                        n_c += 1
        mine = _unique_sorted(codes, n_c)
        out = np.concatenate((out, mine))
        code_starts[ch + 1] = out.shape[0]
    return out, code_starts
