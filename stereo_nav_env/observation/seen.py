"""The floor seen so far in an episode, on a world-frame grid (the policy raster's channel 4).

:class:`SeenFloor` marks, view after view, the floor each view sees (its field of view beyond
the blind band and within range, less the occluded area: :func:`~stereo_nav_env.observation.raster.
view_wedge` and ``model.occluded``), and cuts the egocentric "never seen" channel out of it with
one ``cv2.warpAffine``. Floor outside the scene's bounds is never seen. Frames: world, metres;
grid row ``i``, column ``j`` is the cell ``[xmin + j c, xmin + (j + 1) c) x [ymin + i c, ...)``.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.model.records import EnvironmentModel
from modeling.types import FloatArray
from stereo_nav_env.config import ObservationConfig
from stereo_nav_env.observation.raster import visible_mask

__all__ = ["SeenFloor"]


_ZERO = np.zeros(1, dtype=np.uint8)
"""The scalar 0 as OpenCV's ``compare`` takes it (a one-element array, broadcast)."""

_MAX_CELLS = 4096
"""Largest grid side: a scene of 200 m at 5 cm cells (larger scenes get coarser cells)."""


class SeenFloor:
    """Which floor cells some view of the episode has seen.

    Args:
        bounds: ``(xmin, ymin, xmax, ymax)`` of the scene, metres.
        cell_m: Grid cell side, metres (coarsened so no side exceeds 4,096 cells).

    Raises:
        ValueError: Bounds not increasing or a non-positive cell.
    """

    def __init__(self, bounds: tuple[float, float, float, float], cell_m: float) -> None:
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"bounds must satisfy xmin < xmax and ymin < ymax, got {bounds}")
        if not (math.isfinite(cell_m) and cell_m > 0.0):
            raise ValueError(f"cell_m must be a positive number, got {cell_m!r}")
        cell = max(float(cell_m), max(xmax - xmin, ymax - ymin) / _MAX_CELLS)
        self.origin = (xmin, ymin)
        self.cell_m = cell
        shape = (math.ceil((ymax - ymin) / cell), math.ceil((xmax - xmin) / cell))
        self.grid: NDArray[np.uint8] = np.zeros(shape, dtype=np.uint8)
        """255 where seen, 0 where never seen; (rows along y, columns along x)."""
        self._grid_map = (np.eye(2) / cell, -np.asarray(self.origin) / cell - 0.5)
        """The affine map ``p @ A.T + b`` from world metres to grid (column, row) pixels."""

    def mark(self, model: EnvironmentModel, near_m: float) -> None:
        """Mark the floor the view of ``model`` sees (beyond ``near_m`` of its viewpoint)."""
        A, b = self._grid_map
        visible = visible_mask(model, A, b, self.grid.shape, near_m)
        np.bitwise_or(self.grid, visible, out=self.grid)

    def never_seen(
        self, robot_pose: tuple[float, float, float], cfg: ObservationConfig
    ) -> NDArray[np.uint8]:
        """The egocentric (S, S) uint8 channel: 255 where never seen, 0 where seen.

        Args:
            robot_pose: ``(x_m, y_m, heading_rad)`` of the robot's centre, world frame.
            cfg: Raster size and extent
                (:func:`~stereo_nav_env.observation.raster.world_to_raster`).
        """
        size = cfg.raster_size_px
        seen = cv2.warpAffine(
            self.grid,
            self.raster_to_grid(robot_pose, cfg),
            (size, size),
            flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0,
        )
        # raster.UNKNOWN_VALUE (255) where the grid is 0, else 0
        return np.asarray(cv2.compare(seen, _ZERO, cv2.CMP_EQ), dtype=np.uint8)

    def raster_to_grid(
        self, robot_pose: tuple[float, float, float], cfg: ObservationConfig
    ) -> FloatArray:
        """The (2, 3) affine map from the egocentric raster's pixels to this grid's: the
        inverse of :func:`~stereo_nav_env.observation.raster.world_to_raster`'s map, then the
        grid's.

        That map is ``k Q`` with ``Q = [[s, -c], [-c, -s]]`` (its own inverse: ``Q Q = I``) and
        ``k = 1 / raster_cell``, and its offset ``centre (1, 1) - k Q (x, y)``; so, with ``r =
        raster_cell / grid_cell``, a raster pixel ``u`` is the grid pixel ``r Q u + (x, y) /
        grid_cell - r centre Q (1, 1) + g`` (``g``: the grid map's offset).
        """
        x, y, heading = robot_pose
        c, s = math.cos(heading), math.sin(heading)
        r = cfg.raster_cell_m / self.cell_m
        centre = cfg.raster_size_px / 2.0 - 0.5
        (ox, oy), cell = self.origin, self.cell_m
        return np.array(
            [
                [r * s, -r * c, (x - ox) / cell - 0.5 - r * centre * (s - c)],
                [-r * c, -r * s, (y - oy) / cell - 0.5 + r * centre * (c + s)],
            ]
        )
