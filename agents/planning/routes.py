"""Shortest collision-free routes among polygonal obstacles (the oracle's map).

Routes are found on a visibility graph (shapely for the geometry, networkx for the search): the
obstacles are inflated by the robot's radius plus a clearance, the graph's nodes are the start, the
goal and the vertices of the inflated outlines, and two nodes are joined when the straight segment
between them stays in free space. The shortest path on that graph is the shortest route for a disc
robot up to the polygonal approximation of the inflation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np
import shapely
from numpy.typing import ArrayLike
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from modeling.types import FloatArray

__all__ = ["Route", "free_space", "shortest_route"]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Route:
    """A polyline from start to goal.

    Attributes:
        waypoints: (n, 2) world points, metres, start first and goal last.
        length_m: Total length, metres.
    """

    waypoints: FloatArray
    length_m: float


def _polygon(points: ArrayLike) -> Polygon:
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"obstacle outline must have shape (k, 2), got {arr.shape}")
    if arr.shape[0] >= 3:
        poly = Polygon(arr)
        return poly if poly.is_valid else poly.buffer(0)
    if arr.shape[0] == 2:
        return LineString(arr).buffer(1e-3)
    return Point(arr[0]).buffer(1e-3)


def free_space(
    obstacles: Sequence[ArrayLike], clearance_m: float, *, resolution: int = 2
) -> shapely.Geometry:
    """The union of the obstacles inflated by ``clearance_m`` (what a disc's centre must avoid)."""
    if clearance_m < 0:
        raise ValueError(f"clearance_m must be non-negative, got {clearance_m}")
    polys = [_polygon(o) for o in obstacles]
    if not polys:
        return Polygon()
    return unary_union([p.buffer(clearance_m, quad_segs=resolution) for p in polys])


def shortest_route(
    obstacles: Sequence[ArrayLike],
    start: ArrayLike,
    goal: ArrayLike,
    *,
    clearance_m: float,
    bounds: tuple[float, float, float, float] | None = None,
) -> Route | None:
    """The shortest route of a disc of radius ``clearance_m`` among polygonal obstacles.

    Args:
        obstacles: Outlines, each (k, 2) world metres.
        start: (2,) start point.
        goal: (2,) goal point.
        clearance_m: Robot radius plus safety margin, metres.
        bounds: Optional ``(xmin, ymin, xmax, ymax)``: waypoints must stay inside.

    Returns:
        The route, or ``None`` when the goal cannot be reached. A start inside an inflated
        obstacle (the robot already touching one) is allowed to leave it by the shortest way.
    """
    s = np.asarray(start, dtype=np.float64).reshape(2)
    g = np.asarray(goal, dtype=np.float64).reshape(2)
    blocked = free_space(obstacles, clearance_m)
    # Vertices slightly outside the inflated outline, so lines along them do not graze it.
    outline = free_space(obstacles, clearance_m * 1.02 + 1e-3)
    vertices: list[tuple[float, float]] = []
    for geom in getattr(outline, "geoms", [outline]):
        if isinstance(geom, Polygon) and not geom.is_empty:
            vertices.extend(geom.exterior.coords[:-1])
            for ring in geom.interiors:
                vertices.extend(ring.coords[:-1])
    nodes = np.array([s, g, *vertices], dtype=np.float64).reshape(-1, 2)
    if bounds is not None:
        xmin, ymin, xmax, ymax = bounds
        keep = (
            (nodes[:, 0] >= xmin)
            & (nodes[:, 0] <= xmax)
            & (nodes[:, 1] >= ymin)
            & (nodes[:, 1] <= ymax)
        )
        keep[:2] = True
        nodes = nodes[keep]
    if not blocked.is_empty:
        inside = shapely.contains_xy(blocked, nodes[:, 0], nodes[:, 1])
        inside[:2] = False
        nodes = nodes[~inside]
    start_inside = (not blocked.is_empty) and blocked.contains(Point(s))
    goal_inside = (not blocked.is_empty) and blocked.contains(Point(g))
    if goal_inside:
        return None

    n = len(nodes)
    i_idx, j_idx = np.triu_indices(n, k=1)
    lines = shapely.linestrings(np.stack([nodes[i_idx], nodes[j_idx]], axis=1).reshape(-1, 2, 2))
    if blocked.is_empty:
        ok = np.ones(len(lines), dtype=bool)
    else:
        shapely.prepare(blocked)
        ok = ~shapely.intersects(blocked, lines)
        if start_inside:
            # The robot already touches an inflated obstacle: let it leave by any straight line
            # that clears everything beyond a small disc around it.
            from_start = i_idx == 0
            escape = shapely.difference(blocked, Point(s).buffer(2.0 * clearance_m))
            ok[from_start] = ~shapely.intersects(escape, lines[from_start])
    lengths = np.linalg.norm(nodes[i_idx] - nodes[j_idx], axis=1)
    graph = nx.Graph()
    graph.add_nodes_from(range(n))
    graph.add_weighted_edges_from(
        zip(i_idx[ok].tolist(), j_idx[ok].tolist(), lengths[ok].tolist(), strict=True)
    )
    try:
        path = nx.astar_path(
            graph,
            0,
            1,
            heuristic=lambda a, b: float(np.linalg.norm(nodes[a] - nodes[b])),
            weight="weight",
        )
    except nx.NetworkXNoPath:
        return None
    waypoints = nodes[path]
    return Route(
        waypoints=waypoints,
        length_m=float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum()),
    )
