"""The graph of possible paths of one situation (paper sections 4.2 and 5).

:func:`path_graph` (or :func:`situation_graph`, from a model) builds a roadmap (networkx) for a
disc robot of diameter ``robot_width_m`` (radius ``r``) in one
:class:`~modeling.model.build.Situation`:

* Nodes (each with ``xy`` (2,) metres, world frame, and ``kind``):

  - ``"start"`` and ``"goal"``;
  - for every critical region ``k``: ``("region", k, 0)`` and ``("region", k, 1)``, on either
    side of its narrowest relation, along the normal through its midpoint, at least ``r +
    margin`` away and just outside the region's polygon;
  - for every passage ``k`` (the narrowest clearly passable gap of a nearby obstacle pair):
    ``("passage", k, 0)`` and ``("passage", k, 1)`` likewise;
  - corners: ``("corner", i, v)``, points around the ends of obstacle ``i``'s segments at
    distance ``(r + margin) / cos(pi / 8)`` (ahead, +-45 and +-90 degrees from the segment's
    outward direction), so the chords between neighbouring ones keep ``r + margin`` from the end;
    those within ``r + margin / 2`` of any obstacle, inside a gate's barrier, or within 1 cm of
    another are dropped. Concave obstacles (an L of walls) are followed.

* Edges (each with ``length_m``, ``p_passable``, ``kind``, ``region``, ``passage``, ``narrowest``):

  - a *gate edge* joins the two nodes of a critical region (``kind="critical"``, ``region=k``,
    ``p_passable`` the region's, ``narrowest`` its (2, 2) points) or of a passage
    (``kind="passage"``, ``passage=k``, ``p_passable`` > 1 - eps);
  - a *free edge* (``kind="free"``, ``p_passable=1``, ``region=None``) joins two nodes whose
    straight connection keeps the robot disc off every obstacle (it stays at least ``r`` from
    every obstacle skeleton) and crosses no critical-region polygon and no passage line, so a
    route between two obstacles must take their gate edge. Candidates are the start-goal pair, the
    Delaunay edges of the nodes and each node's ``neighbours`` nearest nodes, at most
    ``connect_radius_m`` long (those of start and goal: any length). An obstacle within ``r`` of
    an end of the edge (the two obstacles of a gate, or a wall the start touches) is checked with
    its bare skeleton instead; a barrier that contains the start or the goal is ignored.

A route from ``"start"`` to ``"goal"`` is a path; within the situation it succeeds with the product
of its edges' ``p_passable`` (critical regions taken as independent), and the regions it must pass
are the ``region`` attributes along it: :func:`routes` lists the shortest few, one per sequence of
critical regions, and :func:`model_routes` does so for every situation of a model. Occluded areas
count as free space, as in the paper. Searching the graph yourself works too, e.g.
``nx.shortest_path(graph, "start", "goal", weight="length_m")``.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import networkx as nx
import numpy as np
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import Delaunay, QhullError, cKDTree

from modeling.model.records import EnvironmentModel, Situation, safe_linestrings
from modeling.types import FloatArray
from modeling.validation import finite_array, positive

__all__ = ["Route", "model_routes", "path_graph", "routes", "situation_graph"]

_GATE_FANOUT = 24  # routes(): each gate is joined to this many nearest gates (and the goal)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Route:
    """One path from start to goal through a situation's path graph.

    Attributes:
        nodes: The graph nodes along it, ``"start"`` first, ``"goal"`` last.
        length_m: Its length, metres.
        p_passable: Product of its edges' ``p_passable`` (the critical regions' passabilities).
        regions: Indices of the critical regions it crosses, in order.
        waypoints: (n, 2) node positions, world frame, metres.
        passages: Indices of the passages (clearly passable gaps) it crosses, in order.
    """

    nodes: tuple[Any, ...]
    length_m: float
    p_passable: float
    regions: tuple[int, ...]
    waypoints: FloatArray
    passages: tuple[int, ...] = ()


def situation_graph(
    model: EnvironmentModel,
    situation: Situation | int,
    start_xy: Sequence[float],
    goal_xy: Sequence[float],
    robot_width_m: float | None = None,
    **kw: Any,
) -> nx.Graph:
    """The graph of possible paths of one situation of ``model``; see :func:`path_graph`.

    Args:
        model: The environment model.
        situation: One of ``model.situations``, or its index there.
        start_xy: (2,) start position, world frame, metres.
        goal_xy: (2,) goal position, metres.
        robot_width_m: Robot width (diameter), metres; default the model's.
        **kw: ``margin_m``, ``connect_radius_m``, ``neighbours`` of :func:`path_graph`.

    Returns:
        The ``nx.Graph`` described in the module docstring.

    Raises:
        ValueError: ``situation`` is neither a situation of ``model`` nor a valid index, or bad
            arguments (naming them).
    """
    chosen: Situation
    if isinstance(situation, Situation):
        if not any(situation is s for s in model.situations):
            raise ValueError("situation must be one of model.situations or an index into it")
        chosen = situation
    elif isinstance(situation, int | np.integer) and not isinstance(situation, bool):
        if not 0 <= int(situation) < len(model.situations):
            raise ValueError(
                f"situation index {situation} out of range for {len(model.situations)} situations"
            )
        chosen = model.situations[int(situation)]
    else:
        raise ValueError("situation must be one of model.situations or an index into it")
    width = model.robot_width_m if robot_width_m is None else robot_width_m
    return path_graph(chosen, start_xy, goal_xy, robot_width_m=width, **kw)


def model_routes(
    model: EnvironmentModel,
    start_xy: Sequence[float],
    goal_xy: Sequence[float],
    *,
    max_routes: int = 3,
    **kw: Any,
) -> list[list[Route]]:
    """The shortest routes of every situation (see :func:`routes`), in ``model.situations`` order.

    Args:
        model: The environment model.
        start_xy: (2,) start position, world frame, metres.
        goal_xy: (2,) goal position, metres.
        max_routes: Routes per situation, at most.
        **kw: Options of :func:`path_graph` (``robot_width_m`` defaults to the model's).

    Returns:
        One list of routes per situation (empty where the goal cannot be reached).
    """
    kw.setdefault("robot_width_m", model.robot_width_m)
    return [
        routes(path_graph(s, start_xy, goal_xy, **kw), max_routes=max_routes)
        for s in model.situations
    ]


def path_graph(
    situation: Situation,
    start_xy: Sequence[float],
    goal_xy: Sequence[float],
    *,
    robot_width_m: float | None = None,
    margin_m: float = 0.05,
    connect_radius_m: float = 6.0,
    neighbours: int = 12,
) -> nx.Graph:
    """The roadmap of possible paths of ``situation`` from ``start_xy`` to ``goal_xy``.

    Args:
        situation: A situation of an :class:`~modeling.model.build.EnvironmentModel`.
        start_xy: (2,) start position, world frame, metres.
        goal_xy: (2,) goal position, metres.
        robot_width_m: Robot width (diameter), metres, for the clearance of free edges and
            nodes; default the situation's. The critical regions and their ``p_passable`` are
            those of the model, built for ``situation.robot_width_m``: for another robot, build
            another model.
        margin_m: Extra clearance of gate and corner nodes, metres (>= 0).
        connect_radius_m: Free edges between other nodes than start and goal are at most this
            long, metres (> 0).
        neighbours: Each node is tried against this many nearest nodes (besides its Delaunay
            neighbours), >= 1.

    Returns:
        An undirected ``nx.Graph`` as described in the module docstring.

    Raises:
        ValueError: Bad arguments, naming them.
    """
    start = finite_array(start_xy, "start_xy", (2,))
    goal = finite_array(goal_xy, "goal_xy", (2,))
    width = positive(
        situation.robot_width_m if robot_width_m is None else robot_width_m, "robot_width_m"
    )
    margin = positive(margin_m, "margin_m", allow_zero=True)
    connect = positive(connect_radius_m, "connect_radius_m")
    if isinstance(neighbours, bool) or not isinstance(neighbours, int | np.integer):
        raise ValueError(f"neighbours must be an integer >= 1, got {neighbours!r}")
    if neighbours < 1:
        raise ValueError(f"neighbours must be an integer >= 1, got {neighbours!r}")
    r = 0.5 * width
    obstacles = situation.obstacles
    n_obs = len(obstacles)

    # Obstacle skeletons: their segments and the impassable links between them (one
    # multilinestring each). "Grown by r" is tested as "within distance r" (no buffering).
    if n_obs:
        lines = [o.lines if o.lines.shape[0] else o.points.reshape(-1, 2, 2) for o in obstacles]
        counts = [x.shape[0] for x in lines]
        skeletons = shapely.multilinestrings(
            safe_linestrings(np.concatenate(lines)), indices=np.repeat(np.arange(n_obs), counts)
        )
        tree = shapely.STRtree(skeletons)
    else:
        skeletons = np.zeros(0, dtype=object)

    names: list[Any] = ["start", "goal"]
    xy: list[FloatArray] = [start, goal]
    kinds = ["start", "goal"]
    excused: list[tuple[int, int]] = []  # (node, obstacle) pairs checked with the bare skeleton
    G = nx.Graph()

    # Gates. A critical region is a barrier polygon with a node just outside it on either side of
    # its narrowest relation; a passage's barrier is its narrowest line.
    barriers: list[Any] = []
    gate_edges: list[tuple[Any, Any, dict[str, Any]]] = []
    specs: list[tuple[str, int, FloatArray, float, tuple[int, int], FloatArray | None]] = []
    for k, reg in enumerate(situation.critical_regions):
        poly = np.asarray(reg.polygon)
        specs.append(("region", k, np.asarray(reg.narrowest), reg.p_passable, reg.obstacles, poly))
        if poly.shape[0] >= 3:
            barriers.append(shapely.Polygon(poly))
        else:
            barriers.append(safe_linestrings(reg.narrowest)[0])
    for k, pas in enumerate(situation.passages):
        specs.append(("passage", k, np.asarray(pas.narrowest), pas.p_passable, pas.obstacles, None))
        barriers.append(safe_linestrings(np.asarray(pas.narrowest))[0])
    for kind, k, narrow, p, (oi, oj), outline in specs:
        a, b = narrow[0], narrow[1]
        d = b - a
        length = float(np.hypot(*d))
        nrm = np.array([-d[1], d[0]]) / length if length > 1e-12 else np.array([1.0, 0.0])
        mid = 0.5 * (a + b)
        plus = minus = r + margin
        if outline is not None and outline.shape[0]:
            proj = (outline - mid) @ nrm
            plus = max(plus, float(proj.max()) + margin)
            minus = max(minus, float(-proj.min()) + margin)
        for side, pos in enumerate((mid + plus * nrm, mid - minus * nrm)):
            excused.extend([(len(names), oi), (len(names), oj)])
            names.append((kind, k, side))
            xy.append(pos)
            kinds.append(kind)
        gate_edges.append(
            (
                (kind, k, 0),
                (kind, k, 1),
                {
                    "length_m": plus + minus,
                    "p_passable": float(p),
                    "kind": "critical" if kind == "region" else "passage",
                    "region": k if kind == "region" else None,
                    "passage": k if kind == "passage" else None,
                    "narrowest": narrow,
                },
            )
        )

    # Corners: around each end of each obstacle segment, five points at distance
    # (r + margin) / cos(pi / 8) (straight ahead, +-45 and +-90 degrees from the segment's
    # outward direction; eight around a point), so that the chords between them keep r + margin
    # from the end; dropped when within r + margin / 2 of an obstacle, inside a gate's barrier,
    # or within 1 cm of another corner.
    if n_obs:
        seg_ends = np.concatenate([o.points.reshape(-1, 2, 2) for o in obstacles])
        seg_obst = np.repeat(np.arange(n_obs), [o.points.shape[0] // 2 for o in obstacles])
        coords, corner_obst = _corner_points(seg_ends, seg_obst, (r + margin) / np.cos(np.pi / 8))
        pts = shapely.points(coords)
        keep = np.ones(coords.shape[0], dtype=bool)
        hit_pt, _ = tree.query(pts, predicate="dwithin", distance=r + 0.5 * margin)
        keep[hit_pt] = False
        if barriers:
            hit_pt, _ = shapely.STRtree(barriers).query(pts, predicate="intersects")
            keep[hit_pt] = False
        cell = np.round(coords / 0.01).astype(np.int64)
        cell -= cell.min(axis=0)
        _, first = np.unique(cell[:, 0] * (cell[:, 1].max() + 1) + cell[:, 1], return_index=True)
        unique = np.zeros(coords.shape[0], dtype=bool)
        unique[first] = True
        keep &= unique
        vertex = np.arange(coords.shape[0]) - np.searchsorted(corner_obst, corner_obst)
        for pt, ob, v in zip(
            coords[keep], corner_obst[keep].tolist(), vertex[keep].tolist(), strict=True
        ):
            names.append(("corner", ob, v))
            xy.append(pt)
            kinds.append("corner")

    # Start and goal excuse the obstacles they touch (so a robot against a wall can leave it).
    if n_obs:
        hit_node, hit_obs = tree.query(
            shapely.points(np.array(xy[:2])), predicate="dwithin", distance=r
        )
        excused.extend(zip(hit_node.tolist(), hit_obs.tolist(), strict=True))

    for name, pos, kind in zip(names, xy, kinds, strict=True):
        G.add_node(name, xy=pos, kind=kind)
    for u, v, attrs in gate_edges:
        G.add_edge(u, v, **attrs)

    # Free edges.
    P = np.asarray(xy, dtype=np.float64)
    pairs = _candidate_pairs(P, connect, int(neighbours))
    # Not between the two nodes of one gate (that is the gate edge).
    gate_of = np.full(P.shape[0], -1, dtype=np.int64)
    gate_of[2 : 2 + 2 * len(specs)] = np.repeat(np.arange(len(specs)), 2)
    pairs = pairs[(gate_of[pairs[:, 0]] < 0) | (gate_of[pairs[:, 0]] != gate_of[pairs[:, 1]])]
    if pairs.shape[0] == 0:
        return G
    segs = np.stack([P[pairs[:, 0]], P[pairs[:, 1]]], axis=1)
    lines_ = safe_linestrings(segs)
    blocked = np.zeros(pairs.shape[0], dtype=bool)
    if n_obs:
        hit_line, hit_obs = tree.query(lines_, predicate="dwithin", distance=r)
        exc = np.asarray(excused, dtype=np.int64).reshape(-1, 2)
        exc_code = exc[:, 0] * n_obs + exc[:, 1]
        ok = np.isin(pairs[hit_line, 0] * n_obs + hit_obs, exc_code) | np.isin(
            pairs[hit_line, 1] * n_obs + hit_obs, exc_code
        )
        blocked[hit_line[~ok]] = True
        bare_line, _ = tree.query(lines_, predicate="intersects")
        blocked[bare_line] = True
    if barriers:
        bar = np.array(barriers, dtype=object)
        hit_line, hit_bar = shapely.STRtree(bar).query(lines_, predicate="intersects")
        # A barrier that contains the start or the goal (only those can be inside one) does not
        # block their edges.
        excuse = np.zeros(hit_line.shape[0], dtype=bool)
        for end in (0, 1):
            node = pairs[hit_line, end]
            at = node < 2
            excuse[at] |= shapely.intersects(bar[hit_bar[at]], shapely.points(P[node[at]]))
        blocked[hit_line[~excuse]] = True
    free = ~blocked
    lengths = np.hypot(*(segs[:, 1] - segs[:, 0]).T)
    G.add_edges_from(
        (
            names[i],
            names[j],
            {
                "length_m": float(length),
                "p_passable": 1.0,
                "kind": "free",
                "region": None,
                "passage": None,
                "narrowest": None,
            },
        )
        for (i, j), length in zip(pairs[free].tolist(), lengths[free].tolist(), strict=True)
    )
    return G


def routes(
    graph: nx.Graph, *, max_routes: int = 5, distinct: bool = True, max_examined: int = 50
) -> list[Route]:
    """The shortest routes from ``"start"`` to ``"goal"`` (by ``length_m``), shortest first.

    With ``distinct`` (the default) each route crosses a different sequence of critical regions
    (with the direction of crossing), each at most once: routes that differ only in the free
    space and passages they cross carry the same risk (up to the passages' ``p > 1 - eps``), so a
    planner needs only the shortest of them. They are the k shortest paths of a small graph whose
    edges are the regions' gates and the shortest connections through free space and passages
    (Dijkstra) from the start to every gate and the goal, and from each gate to the goal and its
    ``_GATE_FANOUT`` nearest gates: exact for routes through at most one region; in crowded
    graphs a route through several distant regions may be missed.

    Args:
        graph: A graph from :func:`path_graph`.
        max_routes: How many routes at most (>= 1).
        distinct: One route per gate sequence (else: the plain k shortest simple paths, which
            may differ only by a corner).
        max_examined: Stop after this many candidate paths (>= 1), bounding the time.

    Returns:
        The routes (empty when the goal cannot be reached).

    Raises:
        ValueError: Bad ``max_routes`` or ``max_examined``.
    """
    for name, value in (("max_routes", max_routes), ("max_examined", max_examined)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if "start" not in graph or "goal" not in graph:
        return []
    paths = _gate_paths(graph) if distinct else _simple_paths(graph)
    out: list[Route] = []
    for path in itertools.islice(paths, max_examined):
        route = _route(graph, path)
        if distinct and len(set(route.regions)) < len(route.regions):
            continue  # a region crossed twice
        out.append(route)
        if len(out) >= max_routes:
            break
    return out


def _simple_paths(graph: nx.Graph) -> Iterator[list[Any]]:
    """The simple paths from start to goal, shortest first (empty when there is none)."""
    try:
        yield from nx.shortest_simple_paths(graph, "start", "goal", weight="length_m")
    except nx.NetworkXNoPath:
        return


def _gate_paths(graph: nx.Graph) -> Iterator[list[Any]]:
    """Node paths from start to goal, one per directed sequence of critical regions, shortest
    first."""
    names = list(graph.nodes)
    index = {n: k for k, n in enumerate(names)}
    n = len(names)
    fi, fj, fw, gates = [], [], [], []
    for u, v, e in graph.edges(data=True):
        if e["kind"] != "critical":  # free space and (clearly passable) passages
            fi.append(index[u])
            fj.append(index[v])
            fw.append(e["length_m"] + 1e-12)  # explicit zeros would be missing edges
        else:
            gates.append((index[u], index[v], e["length_m"]))
    free = csr_matrix((fw, (fi, fj)), shape=(n, n))
    start, goal = index["start"], index["goal"]
    ends = sorted({g for u, v, _ in gates for g in (u, v)})
    gate_of = {}
    for k, (u, v, _) in enumerate(gates):
        gate_of[u] = gate_of[v] = k
    sources = [start, *ends]
    dist, pred = dijkstra(free, directed=False, indices=sources, return_predecessors=True)
    H = nx.DiGraph()
    targets = np.array([goal, *ends])
    for row, src in enumerate(sources):
        d = dist[row, targets]
        ok = np.isfinite(d)
        if src != start:
            ok &= np.array([t == goal or gate_of[t] != gate_of[src] for t in targets.tolist()])
        cand = np.flatnonzero(ok)
        if src != start:  # the goal, then the nearest gates (from the start: every gate)
            cand = cand[np.argsort(d[cand], kind="stable")][: _GATE_FANOUT + 1]
            cand = np.union1d(cand, [0]) if ok[0] else cand
        for t in cand.tolist():
            tgt = int(targets[t])
            H.add_edge(
                "S" if src == start else ("out", src),
                "T" if tgt == goal else ("in", tgt),
                weight=float(d[t]),
                row=row,
            )
    for u, v, length in gates:
        H.add_edge(("in", u), ("out", v), weight=length, row=-1)
        H.add_edge(("in", v), ("out", u), weight=length, row=-1)
    if "S" not in H or "T" not in H:
        return
    try:
        for hpath in nx.shortest_simple_paths(H, "S", "T", weight="weight"):
            nodes: list[int] = [start]
            for x, y in itertools.pairwise(hpath):
                row = H.edges[x, y]["row"]
                tgt = goal if y == "T" else y[1]
                if row < 0:  # a gate
                    nodes.append(tgt)
                    continue
                back = [tgt]
                while back[-1] != sources[row]:
                    back.append(int(pred[row, back[-1]]))
                nodes.extend(back[-2::-1])
            yield [names[k] for k in nodes]
    except nx.NetworkXNoPath:
        return


def _route(graph: nx.Graph, path: list[Any]) -> Route:
    """The :class:`Route` along a node path of ``graph``."""
    length = 0.0
    p = 1.0
    regions: list[int] = []
    passages: list[int] = []
    for u, v in itertools.pairwise(path):
        e = graph.edges[u, v]
        length += e["length_m"]
        p *= e["p_passable"]
        if e["region"] is not None:
            regions.append(int(e["region"]))
        elif e["passage"] is not None:
            passages.append(int(e["passage"]))
    return Route(
        nodes=tuple(path),
        length_m=length,
        p_passable=p,
        regions=tuple(regions),
        waypoints=np.array([graph.nodes[x]["xy"] for x in path]).reshape(-1, 2),
        passages=tuple(passages),
    )


def _candidate_pairs(P: FloatArray, radius: float, k: int) -> np.ndarray:
    """Unordered node pairs (m, 2), ``i < j``, to try as free edges (see the module docstring)."""
    n = P.shape[0]
    chunks = [np.array([[0, 1]], dtype=np.int64)]  # start - goal
    if n >= 3:
        _, nn = cKDTree(P).query(P, k=min(k + 1, n))
        nn = np.atleast_2d(nn)
        chunks.append(np.stack([np.repeat(np.arange(n), nn.shape[1]), nn.ravel()], axis=1))
    if n >= 4:
        try:
            tri = Delaunay(P).simplices
            chunks.append(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]))
        except QhullError:  # all nodes on a line
            pass
    allp = np.sort(np.concatenate(chunks), axis=1)
    allp = allp[allp[:, 0] != allp[:, 1]]
    d = P[allp[:, 1]] - P[allp[:, 0]]
    near = np.einsum("ij,ij->i", d, d) <= radius * radius
    allp = allp[near | (allp[:, 0] < 2)]  # start and goal edges may be longer
    code = np.unique(allp[:, 0] * n + allp[:, 1])
    return np.stack([code // n, code % n], axis=1)


def _corner_points(
    ends: FloatArray, owner: np.ndarray, reach: float
) -> tuple[FloatArray, np.ndarray]:
    """Candidate corner points around segment ends (see :func:`path_graph`).

    Args:
        ends: (q, 2, 2) segments, metres.
        owner: (q,) sorted obstacle index of each segment.
        reach: Distance of the points from the segment's end, metres.

    Returns:
        ``(points (p, 2), obstacle (p,))``, grouped by obstacle.
    """
    d = ends[:, 1] - ends[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    t = np.where((length > 1e-9)[:, None], d / np.maximum(length, 1e-9)[:, None], [1.0, 0.0])
    base = np.arctan2(t[:, 1], t[:, 0])  # direction from end 0 to end 1
    fan = np.radians([-90.0, -45.0, 0.0, 45.0, 90.0])
    # Outward from end 1 along +t, from end 0 along -t; a point gets eight directions.
    ang1 = base[:, None] + fan[None, :]
    ang0 = base[:, None] + np.pi + fan[None, :]
    ang = np.concatenate([ang0, ang1], axis=1)  # (q, 10)
    origin = np.repeat(ends, 5, axis=1)  # (q, 10, 2): end 0 five times, then end 1
    pts = origin + reach * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    return pts.reshape(-1, 2), np.repeat(owner, 10)
