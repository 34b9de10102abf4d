"""Shortest collision-free routes among polygonal obstacles, and a path follower.

Routes are found on a visibility graph (shapely for the geometry, networkx for the search): the
obstacles are inflated by the robot's radius plus a clearance, the graph's nodes are the start, the
goal and the vertices of the inflated outlines, and two nodes are joined when the straight segment
between them stays in free space. The shortest path on that graph is the shortest route for a disc
robot up to the polygonal approximation of the inflation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

__all__ = ["PathFollower", "Route", "free_space", "shortest_route"]

FloatArray = NDArray[np.float64]


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


@dataclass(slots=True, kw_only=True)
class PathFollower:
    """Pure-pursuit follower turning a route into normalised (forward, turn) commands.

    Attributes:
        max_speed_mps: Speed that a forward command of 1 gives, m/s.
        max_turn_rate_rps: Turn rate that a turn command of 1 gives, rad/s.
        dt_s: Duration of one control step, seconds.
        lookahead_m: Pure-pursuit look-ahead distance, metres.
        goal_tolerance_m: Distance at which the route's end counts as reached, metres.
        shortcut_m: Pursue from the last part of the route that passes within this much of the
            robot (0: always from the nearest part). A re-planned route can start
            with a short step back (to the free cell nearest to a robot standing in a margin or
            in a doorway) and then pass the robot again; pursuing from the nearest part would
            turn the robot round on the spot for that step, and a fresh plan a few steps later
            can turn it back. No obstacle fits between two parts of a route this close.
    """

    max_speed_mps: float
    max_turn_rate_rps: float
    dt_s: float
    lookahead_m: float = 0.4
    goal_tolerance_m: float = 0.1
    shortcut_m: float = 0.0

    def command(self, pose: ArrayLike, waypoints: ArrayLike) -> tuple[float, float]:
        """Forward and turn commands in [-1, 1] moving ``pose`` (x, y, heading) along the route."""
        x, y, heading = np.asarray(pose, dtype=np.float64).reshape(3)
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        here = np.array([x, y])
        if len(pts) == 0 or np.linalg.norm(pts[-1] - here) < self.goal_tolerance_m:
            return 0.0, 0.0
        target = self._lookahead_point(here, pts)
        delta = target - here
        bearing = math.atan2(delta[1], delta[0]) - heading
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        turn = float(np.clip(bearing / (self.max_turn_rate_rps * self.dt_s), -1.0, 1.0))
        distance = float(np.linalg.norm(pts[-1] - here))
        # Slow down to turn on the spot when facing away; stop exactly at the goal.
        alignment = max(0.0, math.cos(bearing)) ** 2
        forward = min(1.0, distance / (self.max_speed_mps * self.dt_s)) * alignment
        if abs(bearing) > math.radians(60):
            forward = 0.0
        return float(forward), turn

    def point_ahead(self, here: ArrayLike, waypoints: ArrayLike, distance_m: float) -> FloatArray:
        """(2,) the point ``distance_m`` along the route ahead of the robot at ``here``."""
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        xy = np.asarray(here, dtype=np.float64).reshape(2)
        if len(pts) == 0:
            return xy
        return self._lookahead_point(xy, pts, distance_m)

    def _lookahead_point(
        self, here: FloatArray, pts: FloatArray, lookahead_m: float | None = None
    ) -> FloatArray:
        if len(pts) == 1:
            return pts[0]
        seg_a, seg_b = pts[:-1], pts[1:]
        d = seg_b - seg_a
        length2 = np.maximum((d * d).sum(axis=1), 1e-12)
        t = np.clip(((here - seg_a) * d).sum(axis=1) / length2, 0.0, 1.0)
        closest = seg_a + t[:, None] * d
        dist = np.linalg.norm(closest - here, axis=1)
        near = np.flatnonzero(dist <= self.shortcut_m)
        k = int(near[-1]) if near.size else int(np.argmin(dist))
        # Walk forward along the polyline by the look-ahead distance from the closest point.
        remaining = self.lookahead_m if lookahead_m is None else lookahead_m
        point = closest[k]
        for i in range(k, len(seg_b)):
            step = float(np.linalg.norm(seg_b[i] - point))
            if step >= remaining:
                return point + (seg_b[i] - point) * (remaining / max(step, 1e-12))
            remaining -= step
            point = seg_b[i]
        return pts[-1]
