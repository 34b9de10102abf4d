"""Compiled loop of :mod:`modeling.model.ambiguity`: Fig. 7's units of ambiguous segments moving
together (:func:`moving_together`; reference
:func:`modeling.model.ambiguity.units_moving_together_reference`, NumPy).

The same floating-point operations as the reference, in the same order (midpoints as the mean of
two endpoints, ``hypot`` distances, Ericson's closest points of
:func:`modeling.model._kernels.gap.closest_params`), so the candidate orders and the units equal the
reference's exactly; ``tests/modeling/model/test_compiled_model.py`` compares them. Compiled with
Numba on first use (:mod:`modeling.jit`); importing this module does not import Numba.
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
