"""Geodesic distance to the goal through the true free space (for the progress reward).

The scene's floor is rasterised on a grid of ``cell_m`` cells (OpenCV ``fillPoly`` of the true
footprints, the bounds' outside blocked), a cell is free when its centre is more than the robot's
radius from every blocked cell (OpenCV's exact Euclidean distance transform, minus half a cell for
the blocked cell's extent), and the shortest path length from the goal to every free cell is found
by Dijkstra's algorithm (``scipy.sparse.csgraph``) on 16-connected moves (the 8 neighbours and the
8 knight moves, each allowed when the cells it crosses are free), whose lengths are within 3 % of
the Euclidean length in every direction. Cells that cannot reach the goal (inside obstacles, or in
another component) get the distance of the nearest reachable cell plus the straight distance to it
(``scipy.ndimage``), so the field is finite everywhere and continuous across contacts. Queries
interpolate bilinearly between cell centres.

World frame, metres. Computed once per scene (a few tens of milliseconds for a 9 x 6 m room).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from modeling.types import FloatArray
from stereo_nav_env.sim.scenes import Scene

__all__ = ["GeodesicField"]


# (row, col) moves of the 16-connected grid (one direction of each undirected pair), and the
# cells a move crosses besides its two ends (which must be free too).
_MOVES: tuple[tuple[tuple[int, int], tuple[tuple[int, int], ...]], ...] = (
    ((0, 1), ()),
    ((1, 0), ()),
    ((1, 1), ()),
    ((1, -1), ()),
    ((1, 2), ((0, 1), (1, 1))),
    ((2, 1), ((1, 0), (1, 1))),
    ((1, -2), ((0, -1), (1, -1))),
    ((2, -1), ((1, 0), (1, -1))),
)
_SHIFT = 8  # fixed-point bits of the coordinates given to cv2.fillPoly


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class GeodesicField:
    """Shortest-path distance to the goal for a disc robot, sampled on a grid.

    Attributes:
        origin: (2,) world ``(x, y)`` of the centre of cell (row 0, col 0), metres.
        cell_m: Cell side, metres.
        distance: (rows, cols) float64 distance from each cell centre to the goal, metres (finite
            everywhere; see the module docstring for cells that cannot reach the goal).
        free: (rows, cols) bool, cells whose centre the robot's centre may occupy.
        reachable: (rows, cols) bool, free cells connected to the goal.
    """

    origin: FloatArray
    cell_m: float
    distance: FloatArray
    free: NDArray[np.bool_]
    reachable: NDArray[np.bool_]

    @classmethod
    def build(cls, scene: Scene, robot_radius_m: float, cell_m: float = 0.05) -> GeodesicField:
        """The field of ``scene``'s goal for a robot of ``robot_radius_m``.

        Args:
            scene: The true scene (footprints, bounds, goal).
            robot_radius_m: Radius of the robot disc, metres (> 0).
            cell_m: Grid cell side, metres (> 0).

        Raises:
            ValueError: A non-positive radius or cell size.
        """
        if not (math.isfinite(robot_radius_m) and robot_radius_m > 0):
            raise ValueError(f"robot_radius_m must be a positive number, got {robot_radius_m!r}")
        if not (math.isfinite(cell_m) and cell_m > 0):
            raise ValueError(f"cell_m must be a positive number, got {cell_m!r}")
        x0, y0, x1, y1 = scene.bounds
        cols = max(1, math.ceil((x1 - x0) / cell_m))
        rows = max(1, math.ceil((y1 - y0) / cell_m))
        origin = np.array([x0 + 0.5 * cell_m, y0 + 0.5 * cell_m])
        # Open floor = 255, obstacles = 0; one blocked cell of padding stands for the bounds.
        open_floor = np.zeros((rows + 2, cols + 2), dtype=np.uint8)
        open_floor[1:-1, 1:-1] = 255
        scale = float(1 << _SHIFT)
        polys = [
            np.rint(((np.asarray(ob.footprint) - origin) / cell_m + 1.0) * scale).astype(np.int32)
            for ob in scene.obstacles
        ]
        if polys:
            cv2.fillPoly(open_floor, polys, 0, lineType=cv2.LINE_8, shift=_SHIFT)
        clearance = cv2.distanceTransform(open_floor, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        clearance_m = clearance[1:-1, 1:-1].astype(np.float64) * cell_m - 0.5 * cell_m
        free = clearance_m > robot_radius_m

        goal_rc = _cell_of(np.asarray(scene.goal, dtype=np.float64), origin, cell_m, rows, cols)
        if not free[goal_rc] and np.any(free):
            # the goal hugs an obstacle: start from the nearest free cell
            _, (ri, ci) = ndimage.distance_transform_edt(~free, return_indices=True)
            goal_rc = (int(ri[goal_rc]), int(ci[goal_rc]))
        dist = np.full((rows, cols), np.inf)
        if free[goal_rc]:
            dist = _dijkstra(free, goal_rc, cell_m)
        reachable = np.isfinite(dist)
        if not np.any(reachable):
            # no free space at all: fall back to the straight-line distance
            rr, cc = np.mgrid[0:rows, 0:cols]
            gx, gy = scene.goal
            dist = np.hypot(origin[0] + cc * cell_m - gx, origin[1] + rr * cell_m - gy)
        elif not np.all(reachable):
            step, (ri, ci) = ndimage.distance_transform_edt(~reachable, return_indices=True)
            dist = dist[ri, ci] + step * cell_m
        for arr in (origin, dist, free, reachable):
            arr.setflags(write=False)
        return cls(
            origin=origin, cell_m=float(cell_m), distance=dist, free=free, reachable=reachable
        )

    def __call__(self, xy: Sequence[float] | FloatArray) -> float:
        """Geodesic distance from world point ``xy`` (2,) to the goal, metres (bilinear)."""
        # in Python floats: the arithmetic of the array expression, without its allocations
        # (the reward asks twice a step)
        x, y = float(xy[0]), float(xy[1])
        rows, cols = self.distance.shape
        c = min(max((x - float(self.origin[0])) / self.cell_m, 0.0), cols - 1.0)
        r = min(max((y - float(self.origin[1])) / self.cell_m, 0.0), rows - 1.0)
        c0, r0 = min(int(c), max(cols - 2, 0)), min(int(r), max(rows - 2, 0))
        fc, fr = c - c0, r - r0
        c1, r1 = min(c0 + 1, cols - 1), min(r0 + 1, rows - 1)
        d = self.distance
        top = (1 - fc) * d[r0, c0] + fc * d[r0, c1]
        bottom = (1 - fc) * d[r1, c0] + fc * d[r1, c1]
        return float((1 - fr) * top + fr * bottom)


def _cell_of(
    xy: FloatArray, origin: FloatArray, cell_m: float, rows: int, cols: int
) -> tuple[int, int]:
    c = int(np.clip(np.rint((xy[0] - origin[0]) / cell_m), 0, cols - 1))
    r = int(np.clip(np.rint((xy[1] - origin[1]) / cell_m), 0, rows - 1))
    return r, c


def _dijkstra(free: NDArray[np.bool_], source: tuple[int, int], cell_m: float) -> FloatArray:
    """(rows, cols) shortest 16-connected path lengths from ``source`` through ``free`` cells."""
    rows, cols = free.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    pad = 2
    fp = np.zeros((rows + 2 * pad, cols + 2 * pad), dtype=bool)
    fp[pad:-pad, pad:-pad] = free

    def shifted(dr: int, dc: int) -> NDArray[np.bool_]:
        return fp[pad + dr : pad + dr + rows, pad + dc : pad + dc + cols]

    src: list[np.ndarray] = []
    dst: list[np.ndarray] = []
    weight: list[np.ndarray] = []
    for (dr, dc), crossed in _MOVES:
        ok = free & shifted(dr, dc)
        for cr, cc in crossed:
            ok &= shifted(cr, cc)
        r, c = np.nonzero(ok)
        src.append(index[r, c])
        dst.append(index[r + dr, c + dc])
        weight.append(np.full(r.shape[0], math.hypot(dr, dc) * cell_m))
    graph = coo_matrix(
        (np.concatenate(weight), (np.concatenate(src), np.concatenate(dst))),
        shape=(rows * cols, rows * cols),
    ).tocsr()
    # scipy-stubs' overloads of dijkstra do not accept a csr_matrix, which it takes
    out = dijkstra(graph, directed=False, indices=int(index[source]))  # type: ignore[call-overload]
    return np.asarray(out, dtype=np.float64).reshape(rows, cols)
