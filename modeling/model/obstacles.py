"""Obstacles (paper section 4.1): connected components of impassable relations, and their outline
polygons.

An obstacle is a cluster of items (segments or chosen candidates) joined by impassable relations:
a connected component of the graph of those relations (:func:`components`). Its ``polygon`` is the
convex hull of its endpoints, the paper's plane figure, and its ``lines`` its skeleton (segments,
then the impassable links, closest point to closest point). A critical region's polygon is the
convex hull of its relations' closest points. Hulls of collinear points (or of one or two points)
are thin rectangles, so every polygon has an area (:func:`hulls`).

Frames: world, metres.
"""

from __future__ import annotations

import numpy as np
import shapely
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components

from modeling.model._kernels import hull as _hull_kernel
from modeling.model._kernels.hull import HullSets, Polygons
from modeling.model.records import Obstacle
from modeling.types import FloatArray

__all__ = [
    "components",
    "components_reference",
    "finish_hulls_reference",
    "geos_hull_sets",
    "hulls",
    "make_obstacles",
]

_POLYGON_TYPE_ID = 3  # shapely.get_type_id of a Polygon


def components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Connected components of the undirected graph on ``n`` nodes with edges ``(i[k], j[k])``.

    A compiled union-find (:func:`modeling.model._kernels.hull.union_find`): several calls per
    model, each 2-4 us against 0.1-0.15 ms for scipy's csgraph, whose input checks dominate at these
    sizes (0.3-0.7 ms per env step). Its reference, :func:`components_reference`, is csgraph; a
    test holds the two equal.

    Args:
        n: Number of nodes (>= 0).
        i: (m,) first node of each edge.
        j: (m,) second node of each edge.

    Returns:
        (n,) int64 label of each node: the smallest node of its component (so components are
        numbered in the order of their smallest node wherever the labels are sorted).
    """
    if len(i) == 0:  # no edges: every node is its own component
        return np.arange(n, dtype=np.int64)
    labels: np.ndarray = _hull_kernel.union_find(
        n, np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    )
    return labels


def components_reference(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """:func:`components` by scipy's csgraph (the readable reference of the compiled loop)."""
    if len(i) == 0:
        return np.arange(n, dtype=np.int64)
    # The edges as a sparse matrix in CSR form (rows sorted by i): half the cost of a COO one.
    order = np.argsort(i, kind="stable")
    row_starts = np.searchsorted(i[order], np.arange(n + 1)).astype(np.int32)
    graph = csr_array((np.ones(order.shape[0]), j[order].astype(np.int32), row_starts), (n, n))
    _, labels = connected_components(graph, directed=False)
    # csgraph numbers components arbitrarily: relabel each by its first (smallest) node.
    _, smallest = np.unique(labels, return_index=True)
    return smallest[labels].astype(np.int64)


def split_rows(arr: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
    """``arr`` cut into consecutive read-only views of ``counts`` rows each."""
    arr.setflags(write=False)
    b = [0, *np.cumsum(counts).tolist()]
    return [arr[b[k] : b[k + 1]] for k in range(len(b) - 1)]


def hulls(
    points: FloatArray, index: np.ndarray, n: int, grow_m: float | FloatArray
) -> list[FloatArray]:
    """Convex hulls (each (m, 2), counter-clockwise, not closed) of point sets (vectorised).

    A degenerate hull (all points on a line, or one point) becomes the rectangle around that
    segment at distance ``grow_m``, so every polygon has an area. The hulls of the sets of three
    or more points are those GEOS makes, vertex for vertex, from a compiled monotone chain
    (:func:`hull_sets`; GEOS itself, :func:`geos_hull_sets`, where an orientation is too close
    to call in floating point); the thin-hull test, the orientation and the rectangles are a
    second compiled pass (its reference: :func:`finish_hulls_reference`). Every set is computed
    on its own, so a set's hull does not depend on the other sets of the call: callers batch as
    many sets as they can into one call to share its fixed cost.

    Args:
        points: (p, 2) points, metres.
        index: (p,) sorted set index of each point, in [0, n).
        n: Number of sets (every set non-empty).
        grow_m: Half-thickness of degenerate hulls, metres: one for all sets, or (n,) per set.

    Returns:
        ``n`` read-only (m, 2) arrays.
    """
    if n == 0:
        return []
    polygons = _hull_kernel.finish_hulls(hull_sets(points, index, n, grow_m))
    vertices = polygons.vertices
    vertices.setflags(write=False)
    b = polygons.offsets.tolist()
    return [vertices[b[k] : b[k + 1]] for k in range(n)]


def hull_sets(
    points: FloatArray, index: np.ndarray, n: int, grow_m: float | FloatArray
) -> HullSets:
    """:func:`geos_hull_sets`, equal field for field (a test holds them so), the hulls made by
    the compiled :func:`modeling.model._kernels.hull.convex_rings` (GEOS's fixed cost per call, four
    shapely functions, is most of the time of a model's hulls); by GEOS where it gives up."""
    counts = np.bincount(index, minlength=n)
    pts = np.ascontiguousarray(points, dtype=np.float64)
    rings = _hull_kernel.convex_rings(pts, counts, counts <= 2)
    if not rings.certain:
        return geos_hull_sets(points, index, n, grow_m)
    return HullSets(
        points=pts,
        counts=counts,
        flat=rings.flat,
        grow=np.ascontiguousarray(np.broadcast_to(np.asarray(grow_m, dtype=np.float64), (n,))),
        poly_set=rings.poly_set,
        coords=rings.coords,
        n_coords=rings.n_coords,
    )


def geos_hull_sets(
    points: FloatArray, index: np.ndarray, n: int, grow_m: float | FloatArray
) -> HullSets:
    """The point sets of :func:`hulls` with the convex hulls GEOS makes of those of 3+ points:
    the reference of :func:`hull_sets`."""
    counts = np.bincount(index, minlength=n)
    flat = counts <= 2  # a hull of at most two points is flat: no need for GEOS
    big = (~flat).nonzero()[0]
    if big.shape[0]:
        sel = ~flat[index]
        rank = np.cumsum(~flat) - 1
        # Each set is a line string (much cheaper to build than a multipoint), same hull.
        hull = shapely.convex_hull(shapely.linestrings(points[sel], indices=rank[index[sel]]))
        is_poly = shapely.get_type_id(hull) == _POLYGON_TYPE_ID
        flat[big[~is_poly]] = True  # a line or a point: flat
        poly_set = big[is_poly]
        coords = shapely.get_coordinates(hull[is_poly])  # exterior rings (hulls have no holes)
        n_coords = shapely.get_num_coordinates(hull[is_poly])
    else:
        poly_set = np.zeros(0, dtype=np.int64)
        coords = np.zeros((0, 2))
        n_coords = np.zeros(0, dtype=np.int64)
    grow = np.broadcast_to(np.asarray(grow_m, dtype=np.float64), (n,))
    return HullSets(
        points=np.ascontiguousarray(points, dtype=np.float64),
        counts=counts,
        flat=flat,
        grow=np.ascontiguousarray(grow),
        poly_set=poly_set.astype(np.int64),
        coords=coords,
        n_coords=n_coords.astype(np.int64),
    )


def finish_hulls_reference(sets: HullSets) -> Polygons:
    """The polygon of each point set (section 4.1's plane figures), in NumPy: the readable
    reference of the compiled :func:`modeling.model._kernels.hull.finish_hulls` (equal results).

    A GEOS hull ring of (almost) no area (``|2 area| <= 1e-9 max(span, 1e-3)``, span the
    largest coordinate difference from its first vertex) makes its set flat; the other rings are
    kept without their closing vertex, reversed if clockwise. A flat set's polygon is the
    rectangle at distance ``grow`` around the segment between its extreme points: from the set's
    first point, the direction to its farthest point (the first of equals; x if all points
    coincide), then the smallest and largest projections on that direction.
    """
    n = sets.counts.shape[0]
    flat = sets.flat.copy()
    out: list[FloatArray] = [np.zeros((0, 2))] * n
    coords, n_coords = sets.coords, sets.n_coords
    starts = np.cumsum(n_coords) - n_coords
    for k, set_id in enumerate(sets.poly_set.tolist()):
        ring = coords[starts[k] : starts[k] + n_coords[k]]
        # twice the signed area (shoelace), summed in ring order
        area2 = sum((ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1]).tolist(), 0.0)
        span = float(np.abs(ring - ring[0]).max())
        if abs(area2) <= 1e-9 * max(span, 1e-3):
            flat[set_id] = True
        else:
            out[set_id] = ring[:-1] if area2 > 0 else ring[:0:-1]
    first = np.cumsum(sets.counts) - sets.counts
    for s in flat.nonzero()[0].tolist():
        pts = sets.points[first[s] : first[s] + sets.counts[s]]
        rel = pts - pts[0]
        d2 = rel[:, 0] * rel[:, 0] + rel[:, 1] * rel[:, 1]
        far = int(np.argmax(d2))  # the first of equals
        length = float(np.sqrt(d2[far]))
        axis = rel[far] / length if length > 1e-12 else np.array([1.0, 0.0])
        t = rel[:, 0] * axis[0] + rel[:, 1] * axis[1]
        a = pts[0] + t.min() * axis  # the extreme points
        b = pts[0] + t.max() * axis
        g = sets.grow[s]
        nrm = np.array([-axis[1], axis[0]]) * g
        tang = axis * g
        out[s] = np.stack([a - tang - nrm, b + tang - nrm, b + tang + nrm, a - tang + nrm])
    sizes = np.array([p.shape[0] for p in out], dtype=np.int64)
    offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    vertices = np.concatenate(out) if n else np.zeros((0, 2))
    return Polygons(vertices=vertices.reshape(-1, 2), offsets=offsets)


def make_obstacles(
    *,
    ends: FloatArray,
    links: FloatArray,
    item_segment: np.ndarray,
    item_candidate: np.ndarray,
    items: np.ndarray,
    counts: np.ndarray,
    link_rows: np.ndarray,
    link_counts: np.ndarray,
    link_order: np.ndarray,
    outline_buffer_m: float,
    region_rows: list[np.ndarray],
) -> tuple[list[Obstacle], list[FloatArray]]:
    """Obstacle records and region polygons, their hulls made in one batch.

    Args:
        ends: (N, 2, 2) endpoint means of every item, metres.
        links: (m, 2, 2) the closest points of every relation row, metres.
        item_segment: (N,) segment index of each item (-1: a candidate).
        item_candidate: (N, 2) ``(ambiguous index, candidate index)`` of each item (-1: segment).
        items: (k,) the obstacles' items, grouped by obstacle.
        counts: (t,) items per obstacle.
        link_rows: (q,) the obstacles' impassable relation rows (their links).
        link_counts: (t,) links per obstacle.
        link_order: (k + q,) the order that groups the obstacles' items, then links, by obstacle
            (a stable argsort of the obstacle of each of ``items``, then of ``link_rows``).
        outline_buffer_m: Half-width of the rectangle of a flat obstacle, metres.
        region_rows: The undecided relation rows of each region to outline.

    Returns:
        ``(obstacles, region_polygons)``: the ``t`` obstacles, and one polygon per region
        (rectangles 0.1 m wide when flat).
    """
    t = counts.shape[0]
    pts = ends[items].reshape(-1, 2)
    # One hull computation for the obstacles and the regions (points of the regions: the
    # closest points of their relations), each kind with its own degenerate half-width.
    r_pts = links[np.concatenate(region_rows)].reshape(-1, 2) if region_rows else pts[:0]
    r_cnt = np.array([2 * r.shape[0] for r in region_rows], dtype=np.int64)
    n_sets = t + len(region_rows)
    grow = np.concatenate((np.full(t, outline_buffer_m), np.full(len(region_rows), 0.05)))
    polygons = hulls(
        np.concatenate((pts, r_pts)),
        np.repeat(np.arange(n_sets), np.concatenate((2 * counts, r_cnt))),
        n_sets,
        grow,
    )
    # Skeleton: the obstacle's segments, then its impassable links (closest points).
    lines = np.concatenate([ends[items], links[link_rows]])[link_order]
    line_parts = split_rows(lines, counts + link_counts)
    pt_parts = split_rows(pts, 2 * counts)
    seg_of = item_segment[items].tolist()
    cand_of = item_candidate[items].tolist()
    start = 0
    obstacles = []
    for k, n_items in enumerate(counts.tolist()):
        stop = start + n_items
        obstacles.append(
            Obstacle(
                points=pt_parts[k],
                polygon=polygons[k],
                segments=tuple([s for s in seg_of[start:stop] if s >= 0]),
                candidates=tuple([(a, b) for a, b in cand_of[start:stop] if a >= 0]),
                lines=line_parts[k],
            )
        )
        start = stop
    return obstacles, polygons[t:]
