"""Cost grids, gate edges and cost-to-go fields for the scripted planners (scipy csgraph).

The robot's centre moves on an 8-connected grid (:class:`~agents.planning.gridmap.GridSpec`). A
cell is *blocked* when it is closer than ``hard_m`` to an occupied cell, and costs more the closer
it is than ``soft_m`` (keep a margin where there is room). Every gate (critical region) is a thick
line of blocked cells across its gap, so the only way through is its *gate edge*: a directed edge
from an entry cell on one side, through the middle of the narrowest relation, to an exit cell on the
other side. A gate edge's weight is chosen by the caller (length only, length plus expected detour,
or absent when the gate is taken as closed).

``cost_to_go`` runs Dijkstra from the target on the reversed graph, so its distances are costs *to*
the target and its predecessors point the way there. A planner asks one grid for several graphs
that differ only by their gate edges (open, closed, expected, each without one gate):
:meth:`CostGrid.to_target` and :meth:`CostGrid.from_source` build the grid's own edges into a
sparse matrix once per direction and add each call's few gate edges to it, the same matrix as
:meth:`CostGrid.matrix` (and its transpose) made whole each time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from agents.planning.gridmap import Gate, GridSpec, _line_points
from modeling.types import BoolArray, FloatArray, IntArray

__all__ = ["CostGrid", "GateEdge", "cost_from", "cost_to_go", "path_from", "path_length_m"]


_OFFSETS = ((0, 1), (1, 0), (0, -1), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class GateEdge:
    """Where a gate can be crossed.

    Attributes:
        gate: Index of the gate in the caller's list.
        a: Flat cell index of the entry on one side.
        b: Flat cell index of the exit on the other side.
        a_xy: (2,) world centre of ``a``.
        b_xy: (2,) world centre of ``b``.
        mid_xy: (2,) middle of the narrowest relation (the route passes it).
        length_m: ``|a - mid| + |mid - b|``, metres.
    """

    gate: int
    a: int
    b: int
    a_xy: FloatArray
    b_xy: FloatArray
    mid_xy: FloatArray
    length_m: float


class CostGrid:
    """An 8-connected grid graph with blocked cells, cell costs and gate barriers.

    Args:
        spec: The grid.
        occupied: (ny, nx) obstacle cells.
        gates: Gates whose gap is barred (each gets a barrier line and, if both sides are free,
            a :class:`GateEdge` pair).
        hard_m: Cells closer than this to an obstacle are blocked, metres.
        soft_m: Cells closer than this cost more, metres.
        soft_weight: Extra cost factor at ``hard_m`` (linear down to 0 at ``soft_m``).
        free_xy: (n, 2) points whose cells (and neighbours within ``hard_m``) are never blocked
            (the goal).
        walls: (ny, nx) cells that no gate edge may jump over (bump marks: a gate edge crosses
            the blocked cells beside its gap, but a contact on its way is certain), or ``None``.
    """

    def __init__(
        self,
        spec: GridSpec,
        occupied: BoolArray,
        gates: Sequence[Gate] = (),
        *,
        hard_m: float = 0.2,
        soft_m: float = 0.5,
        soft_weight: float = 3.0,
        free_xy: NDArray[np.floating] | None = None,
        walls: BoolArray | None = None,
    ) -> None:
        if occupied.shape != spec.shape:
            raise ValueError(f"occupied must have shape {spec.shape}, got {occupied.shape}")
        if not 0 <= hard_m < soft_m:
            raise ValueError(f"need 0 <= hard_m < soft_m, got {hard_m!r}, {soft_m!r}")
        self.spec = spec
        res = spec.resolution_m
        if occupied.any():
            dist = distance_transform_edt(~occupied) * res
        else:
            dist = np.full(spec.shape, np.inf)
        self.clearance_m = dist
        blocked = dist < hard_m
        if free_xy is not None:
            for p in np.asarray(free_xy, dtype=np.float64).reshape(-1, 2):
                X, Y = spec.centers()
                blocked &= np.hypot(X - p[0], Y - p[1]) > hard_m
        excess = np.clip((soft_m - dist) / (soft_m - hard_m), 0.0, 1.0)
        self.cost = 1.0 + soft_weight * excess
        self.obstacle_blocked = blocked.copy()
        # Gate barriers: the narrowest relation, extended a little at both ends, a cell thick.
        self.gates = list(gates)
        barrier = np.zeros(spec.shape, dtype=bool)
        for g in self.gates:
            d = g.direction
            line = np.array([[g.ends[0] - 0.15 * d, g.ends[1] + 0.15 * d]])
            pts = _line_points(line, 0.25 * res)
            n = g.normal
            pts = np.concatenate([pts + s * 0.5 * res * n for s in (-1.0, 0.0, 1.0)])
            pts = pts[spec.inside(pts)]
            if pts.shape[0]:
                rc = spec.cell_of(pts)
                barrier[rc[:, 0], rc[:, 1]] = True
        self.barrier = barrier
        self.blocked = blocked | barrier
        self.gate_edges: list[GateEdge] = []
        for k, g in enumerate(self.gates):
            edge = self._gate_edge(k, g, hard_m)
            if edge is not None and (walls is None or not self._crosses(edge, walls)):
                self.gate_edges.append(edge)
        self._base = self._base_edges()
        self._base_matrices: dict[bool, csr_matrix] = {}  # reverse: the grid's edges

    # ------------------------------------------------------------------ construction
    def _free_along(self, start: FloatArray, direction: FloatArray, max_m: float) -> int | None:
        """First unblocked cell from ``start`` stepping along ``direction`` up to ``max_m``."""
        spec = self.spec
        for t in np.arange(0.0, max_m + 1e-9, 0.5 * spec.resolution_m):
            p = start + t * direction
            if not spec.inside(p[None])[0]:
                return None
            idx = int(spec.index_of(p[None])[0])
            if not self.blocked.reshape(-1)[idx]:
                return idx
        return None

    def _gate_edge(self, k: int, g: Gate, hard_m: float) -> GateEdge | None:
        mid = g.midpoint
        n = g.normal
        proj = (np.asarray(g.polygon).reshape(-1, 2) - mid) @ n if len(g.polygon) else np.zeros(1)
        offs = (
            max(hard_m + 0.1, float(proj.max()) + 0.1),
            max(hard_m + 0.1, float(-proj.min()) + 0.1),
        )
        a = self._free_along(mid + offs[0] * n, n, 0.5)
        b = self._free_along(mid - offs[1] * n, -n, 0.5)
        if a is None or b is None or a == b:
            return None
        a_xy, b_xy = self.spec.xy_of(np.array([a, b]))
        length = float(np.hypot(*(a_xy - mid)) + np.hypot(*(b_xy - mid)))
        return GateEdge(gate=k, a=a, b=b, a_xy=a_xy, b_xy=b_xy, mid_xy=mid, length_m=length)

    def _crosses(self, edge: GateEdge, walls: BoolArray) -> bool:
        """Whether ``edge``'s way (entry, middle of the gap, exit) passes a cell of ``walls``."""
        line = np.array([[edge.a_xy, edge.mid_xy], [edge.mid_xy, edge.b_xy]])
        pts = _line_points(line, 0.5 * self.spec.resolution_m)
        pts = pts[self.spec.inside(pts)]
        if not pts.shape[0]:
            return False
        rc = self.spec.cell_of(pts)
        return bool(walls[rc[:, 0], rc[:, 1]].any())

    def _base_edges(self) -> tuple[IntArray, IntArray, FloatArray]:
        ny, nx = self.spec.shape
        free = ~self.blocked
        idx = np.arange(ny * nx).reshape(ny, nx)
        src_l, dst_l, w_l = [], [], []
        res = self.spec.resolution_m
        for dr, dc in _OFFSETS:
            r0, r1 = max(0, -dr), ny - max(0, dr)
            c0, c1 = max(0, -dc), nx - max(0, dc)
            a = (slice(r0, r1), slice(c0, c1))
            b = (slice(r0 + dr, r1 + dr), slice(c0 + dc, c1 + dc))
            ok = free[a] & free[b]
            step = res * (math.sqrt(2.0) if dr and dc else 1.0)
            src_l.append(idx[a][ok])
            dst_l.append(idx[b][ok])
            w_l.append(step * 0.5 * (self.cost[a][ok] + self.cost[b][ok]))
        return np.concatenate(src_l), np.concatenate(dst_l), np.concatenate(w_l)

    # ------------------------------------------------------------------ graphs
    def matrix(self, gate_weights: dict[tuple[int, int], float]) -> csr_matrix:
        """The directed graph with the given gate edges ``{(a, b): weight}`` added."""
        return self._graph(gate_weights, reverse=False).copy()

    def to_target(
        self, gate_weights: dict[tuple[int, int], float], target: int
    ) -> tuple[FloatArray, IntArray]:
        """:func:`cost_to_go` of ``target`` on :meth:`matrix` ``(gate_weights)``."""
        return _dijkstra(self._graph(gate_weights, reverse=True), target)

    def from_source(
        self, gate_weights: dict[tuple[int, int], float], source: int
    ) -> tuple[FloatArray, IntArray]:
        """:func:`cost_from` of ``source`` on :meth:`matrix` ``(gate_weights)``."""
        return _dijkstra(self._graph(gate_weights, reverse=False), source)

    def _graph(self, gate_weights: dict[tuple[int, int], float], *, reverse: bool) -> csr_matrix:
        """The graph with ``gate_weights``' edges (``reverse``: every edge turned around): the
        grid's own edges (made once per direction and shared: not to be changed) plus the gates'.
        A pair has at most one grid edge and one gate edge, so the sum is, bit for bit, the
        matrix of all the edges made at once."""
        n = self.spec.size
        base = self._base_matrices.get(reverse)
        if base is None:
            src, dst, w = self._base
            base = _edge_matrix(*((dst, src) if reverse else (src, dst)), w, n)
            self._base_matrices[reverse] = base
        if not gate_weights:
            return base
        keys = list(gate_weights)
        a = np.array([k[0] for k in keys], dtype=np.int64)
        b = np.array([k[1] for k in keys], dtype=np.int64)
        w = np.array([gate_weights[k] for k in keys], dtype=np.float64)
        out: csr_matrix = base + _edge_matrix(*((b, a) if reverse else (a, b)), w, n)
        return out

    def edge_weight(self, u: int, v: int, gate_weights: dict[tuple[int, int], float]) -> float:
        """Weight of the move ``u -> v`` (a grid neighbour or a gate edge); ``inf`` if none."""
        if (u, v) in gate_weights:
            return gate_weights[(u, v)]
        flat = self.blocked.reshape(-1)
        if flat[u] or flat[v]:
            return math.inf
        ru, cu = divmod(u, self.spec.nx)
        rv, cv = divmod(v, self.spec.nx)
        if max(abs(ru - rv), abs(cu - cv)) != 1:
            return math.inf
        step = self.spec.resolution_m * (math.sqrt(2.0) if ru != rv and cu != cv else 1.0)
        c = self.cost.reshape(-1)
        return float(step * 0.5 * (c[u] + c[v]))

    def nearest_free(self, xy: NDArray[np.floating], max_m: float = 1.0) -> int | None:
        """The unblocked cell nearest to ``xy`` within ``max_m`` (``None`` if none)."""
        spec = self.spec
        p = np.asarray(xy, dtype=np.float64).reshape(2)
        idx = int(spec.index_of(p[None])[0])
        if not self.blocked.reshape(-1)[idx]:
            return idx
        r = max(1, math.ceil(max_m / spec.resolution_m))
        row, col = divmod(idx, spec.nx)
        r0, r1 = max(0, row - r), min(spec.ny, row + r + 1)
        c0, c1 = max(0, col - r), min(spec.nx, col + r + 1)
        sub = ~self.blocked[r0:r1, c0:c1]
        if not sub.any():
            return None
        rr, cc = np.nonzero(sub)
        cand = (rr + r0) * spec.nx + (cc + c0)
        d = np.hypot(*(spec.xy_of(cand) - p).T)
        k = int(np.argmin(d))
        return int(cand[k]) if d[k] <= max_m else None


def _edge_matrix(src: IntArray, dst: IntArray, w: FloatArray, n: int) -> csr_matrix:
    """The (n, n) sparse matrix of the edges ``src -> dst`` of weights ``w``, with a tiny
    positive floor (csgraph treats explicit zeros as missing edges)."""
    return csr_matrix((np.maximum(w, 1e-9), (src, dst)), shape=(n, n))


def cost_to_go(matrix: csr_matrix, target: int) -> tuple[FloatArray, IntArray]:
    """Costs to ``target`` (N,) from every node, and each node's next node towards it (-9999: none).

    Dijkstra on the reversed graph (``matrix.T``).
    """
    return _dijkstra(matrix.T.tocsr(), target)


def cost_from(matrix: csr_matrix, source: int) -> tuple[FloatArray, IntArray]:
    """Costs from ``source`` to every node (N,), and each node's previous node on the way there
    (-9999: none)."""
    return _dijkstra(matrix, source)


def _dijkstra(matrix: csr_matrix, index: int) -> tuple[FloatArray, IntArray]:
    # scipy-stubs 1.17 types ``indices`` as arrays only (scipy takes an int and then returns
    # 1-D arrays): the ignore is for those stubs.
    dist, pred = dijkstra(matrix, directed=True, indices=index, return_predecessors=True)  # type: ignore[call-overload]
    return dist, pred


def path_from(pred: IntArray, start: int, max_len: int = 100_000) -> list[int]:
    """Nodes from ``start`` to the target of :func:`cost_to_go` (empty if unreachable)."""
    path = [start]
    node = start
    while True:
        nxt = int(pred[node])
        if nxt < 0:
            break
        path.append(nxt)
        node = nxt
        if len(path) > max_len:
            return []
    return path


def path_length_m(points: FloatArray) -> float:
    """Length of the polyline (n, 2), metres."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return float(np.hypot(*np.diff(p, axis=0).T).sum()) if p.shape[0] > 1 else 0.0
