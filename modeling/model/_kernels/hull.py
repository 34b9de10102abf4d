"""Compiled loops of :mod:`modeling.model.obstacles`: the convex hulls as GEOS makes them
(:func:`convex_rings`; reference: GEOS, :func:`modeling.model.obstacles.geos_hull_sets`), the
outline polygons (:func:`finish_hulls`; reference
:func:`modeling.model.obstacles.finish_hulls_reference`) and the connected components
(:func:`union_find`; reference :func:`modeling.model.obstacles.components_reference`, scipy's
csgraph).

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not
import Numba.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call


class HullSets(NamedTuple):
    """Point sets and the convex hulls GEOS made of them.

    Attributes:
        points: (p, 2) float64, the points of all sets, set after set, metres.
        counts: (n,) int64, points per set.
        flat: (n,) bool, whether a set is flat already (at most two points, or no polygon from
            GEOS).
        grow: (n,) float64, half-thickness of each set's rectangle, metres.
        poly_set: (q,) int64, the sets whose GEOS hull is a polygon, increasing.
        coords: (c, 2) float64, their exterior rings, closed (first vertex repeated), one after
            another.
        n_coords: (q,) int64, vertices of each ring, closing one included.
    """

    points: np.ndarray
    counts: np.ndarray
    flat: np.ndarray
    grow: np.ndarray
    poly_set: np.ndarray
    coords: np.ndarray
    n_coords: np.ndarray


class Polygons(NamedTuple):
    """Polygons one after another.

    Attributes:
        vertices: (v, 2) float64, the polygons (counter-clockwise, not closed), metres.
        offsets: (n + 1,) int64, where each set's polygon starts in ``vertices``.
    """

    vertices: np.ndarray
    offsets: np.ndarray


_ORIENT_BOUND = 3.3306690738754716e-16
"""Shewchuk's ``ccwerrboundA``, ``(3 + 16 eps) eps``: where the rounded orientation determinant
exceeds this times the sum of its two products' magnitudes, its sign is the exact one."""


@compiled_helper
def orientation(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> int:
    """The exact sign of the turn a -> b -> c (1 counter-clockwise, -1 clockwise, 0 collinear)
    where the rounded determinant decides it (Shewchuk's filter); 2 where it cannot."""
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    bound = _ORIENT_BOUND * (abs(left) + abs(right))
    if det > bound:
        return 1
    if -det > bound:
        return -1
    if bound == 0.0:  # both products exactly 0 (a difference is exactly 0): collinear
        return 0
    return 2


class Rings(NamedTuple):
    """The convex hulls of point sets as GEOS gives them (the fields of :class:`HullSets`).

    Attributes:
        flat: (n,) bool, the sets given flat, and those whose hull has no area.
        poly_set: (q,) int64, the sets whose hull is a polygon, increasing.
        coords: (c, 2) float64, those hulls: clockwise from the lowest vertex (smallest y, then
            x), closed, one after another.
        n_coords: (q,) int64, vertices of each ring, closing one included.
        certain: False if an orientation was too close to call (the other fields are then
            meaningless).
    """

    flat: np.ndarray
    poly_set: np.ndarray
    coords: np.ndarray
    n_coords: np.ndarray
    certain: bool


@compiled_on_first_call
def convex_rings(points: np.ndarray, counts: np.ndarray, flat: np.ndarray) -> Rings:
    """The convex hull of each set not ``flat`` of ``points`` (sets one after another,
    ``counts`` points each), vertex for vertex as GEOS makes it.

    Andrew's monotone chain on the points sorted by (x, y), skipping repeated points and
    dropping collinear ones, with exact orientations (:func:`orientation`; the call gives up,
    ``certain`` False, at the first it cannot decide); a hull of fewer than 3 vertices makes its
    set flat.
    GEOS's ring of the same vertex set starts at the lowest vertex and runs clockwise.
    """
    n = counts.shape[0]
    flat = flat.copy()
    first = np.empty(n, np.int64)
    total = 0
    for s in range(n):
        first[s] = total
        total += counts[s]
    poly_set = np.empty(n, np.int64)
    n_coords = np.empty(n, np.int64)
    coords = np.empty((total + n, 2))
    hull = np.empty(2 * total + 1, np.int64)
    q = 0
    c = 0
    for s in range(n):
        if flat[s]:
            continue
        m = counts[s]
        order = np.arange(first[s], first[s] + m)
        for i in range(1, m):  # insertion sort by (x, y): the sets are small
            k = order[i]
            j = i - 1
            while j >= 0 and (
                points[order[j], 0] > points[k, 0]
                or (points[order[j], 0] == points[k, 0] and points[order[j], 1] > points[k, 1])
            ):
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = k
        h = 0
        for sweep in range(2):  # the lower chain, then the upper one
            floor = h + 1 if sweep else 2
            for i in range(m):
                k = order[i] if sweep == 0 else order[m - 2 - i] if i < m - 1 else -1
                if k < 0:
                    break
                if i > 0 or sweep:  # a repeated point (GEOS drops them) would make a == b
                    prev = order[i - 1] if sweep == 0 else order[m - 1 - i]
                    if points[prev, 0] == points[k, 0] and points[prev, 1] == points[k, 1]:
                        continue
                while h >= floor:
                    a, b = hull[h - 2], hull[h - 1]
                    turn = orientation(
                        points[a, 0],
                        points[a, 1],
                        points[b, 0],
                        points[b, 1],
                        points[k, 0],
                        points[k, 1],
                    )
                    if turn == 2:
                        return Rings(flat, poly_set[:0], coords[:0], n_coords[:0], False)
                    if turn > 0:
                        break
                    h -= 1
                hull[h] = k
                h += 1
        h -= 1  # the last vertex is the first again
        if h < 3:
            flat[s] = True
            continue
        low = 0
        for v in range(1, h):
            pv, pl = hull[v], hull[low]
            if points[pv, 1] < points[pl, 1] or (
                points[pv, 1] == points[pl, 1] and points[pv, 0] < points[pl, 0]
            ):
                low = v
        for v in range(h + 1):  # clockwise from the lowest, closed
            p = hull[(low - v) % h]
            coords[c + v, 0] = points[p, 0]
            coords[c + v, 1] = points[p, 1]
        poly_set[q] = s
        n_coords[q] = h + 1
        q += 1
        c += h + 1
    return Rings(flat, poly_set[:q], coords[:c], n_coords[:q], True)


@compiled_on_first_call
def finish_hulls(sets: HullSets) -> Polygons:
    """The polygon of each point set: its GEOS hull, or the rectangle around a flat set.

    A hull ring of (almost) no area (``|2 area| <= 1e-9 max(span, 1e-3)``, span the largest
    coordinate difference from its first vertex) makes its set flat. A flat set's polygon is the
    rectangle at distance ``grow`` around the segment between its extreme points: from the set's
    first point, the direction to its farthest point (the first of equals; x if all points
    coincide), then the smallest and largest projections on that direction.

    Args:
        sets: The point sets and their GEOS hulls.

    Returns:
        The polygon of each set.
    """
    points, counts, grow = sets.points, sets.counts, sets.grow
    poly_set, coords, n_coords = sets.poly_set, sets.coords, sets.n_coords
    flat = sets.flat.copy()  # with the thin hulls
    n = counts.shape[0]
    q = poly_set.shape[0]
    # the hull rings: twice the signed area (shoelace) and the span, so thin ones turn flat
    ring_start = np.empty(q, np.int64)
    ccw = np.empty(q, np.bool_)
    c0 = 0
    for k in range(q):
        m = n_coords[k]
        ring_start[k] = c0
        area2 = 0.0
        span = 0.0
        x0 = coords[c0, 0]
        y0 = coords[c0, 1]
        for r in range(c0, c0 + m):
            if r < c0 + m - 1:
                area2 += coords[r, 0] * coords[r + 1, 1] - coords[r + 1, 0] * coords[r, 1]
            span = max(span, abs(coords[r, 0] - x0), abs(coords[r, 1] - y0))
        if abs(area2) <= 1e-9 * max(span, 1e-3):
            flat[poly_set[k]] = True
        ccw[k] = area2 > 0
        c0 += m
    # sizes, then the vertices
    ring_of = np.full(n, -1, np.int64)
    for k in range(q):
        ring_of[poly_set[k]] = k
    offsets = np.empty(n + 1, np.int64)
    offsets[0] = 0
    for s in range(n):
        size = 4 if flat[s] else n_coords[ring_of[s]] - 1
        offsets[s + 1] = offsets[s] + size
    out = np.empty((offsets[n], 2))
    first = 0  # the set's first point
    for s in range(n):
        o = offsets[s]
        if not flat[s]:
            k = ring_of[s]
            c0 = ring_start[k]
            m = n_coords[k] - 1
            for v in range(m):
                # the ring without its closing vertex, reversed if clockwise
                r = c0 + v if ccw[k] else c0 + m - v
                out[o + v, 0] = coords[r, 0]
                out[o + v, 1] = coords[r, 1]
        else:
            px = points[first, 0]
            py = points[first, 1]
            far_d2 = -1.0
            far_x = 0.0
            far_y = 0.0
            for i in range(first, first + counts[s]):
                rx = points[i, 0] - px
                ry = points[i, 1] - py
                d2 = rx * rx + ry * ry
                if d2 > far_d2:
                    far_d2, far_x, far_y = d2, rx, ry
            length = math.sqrt(far_d2)
            if length > 1e-12:
                ax = far_x / length
                ay = far_y / length
            else:
                ax, ay = 1.0, 0.0
            t_lo = math.inf
            t_hi = -math.inf
            for i in range(first, first + counts[s]):
                t = (points[i, 0] - px) * ax + (points[i, 1] - py) * ay
                t_lo = min(t_lo, t)
                t_hi = max(t_hi, t)
            g = grow[s]
            ax_, ay_ = px + t_lo * ax, py + t_lo * ay  # the extreme points a and b
            bx_, by_ = px + t_hi * ax, py + t_hi * ay
            nx, ny = -ay * g, ax * g  # normal and tangent, grown
            tx, ty = ax * g, ay * g
            out[o, 0], out[o, 1] = ax_ - tx - nx, ay_ - ty - ny
            out[o + 1, 0], out[o + 1, 1] = bx_ + tx - nx, by_ + ty - ny
            out[o + 2, 0], out[o + 2, 1] = bx_ + tx + nx, by_ + ty + ny
            out[o + 3, 0], out[o + 3, 1] = ax_ - tx + nx, ay_ - ty + ny
        first += counts[s]
    return Polygons(out, offsets)


@compiled_helper
def join(parent: np.ndarray, a: int, b: int) -> None:
    """Join the trees of nodes ``a`` and ``b`` in the forest ``parent``: find both roots (with
    path halving on the way up), then hook the larger root onto the smaller, so every parent
    stays smaller than its child and a root is the smallest node of its tree."""
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    while parent[b] != b:
        parent[b] = parent[parent[b]]
        b = parent[b]
    if a < b:
        parent[b] = a
    elif b < a:
        parent[a] = b


@compiled_on_first_call
def union_find(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` nodes with edges ``(i[k], j[k])``.

    Union-find with path halving: each edge hooks the larger of its two roots onto the smaller
    (so every parent is smaller than its child, and a root is the smallest node of its tree), then
    one pass in node order points every node at its root. Reference:
    :func:`modeling.model.obstacles.components_reference` (scipy's csgraph).

    Returns:
        (n,) int64 label of each node: the smallest node of its component.
    """
    parent = np.arange(n)
    for k in range(i.shape[0]):
        join(parent, i[k], j[k])
    for v in range(n):  # its parent, smaller, points at the root already
        parent[v] = parent[parent[v]]
    return parent
