"""The never-seen channel: ``SeenFloor``'s closed-form raster-to-grid map and the channel it cuts
out of the grid, against the world points the simulator knows."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_nav_env.config import ObservationConfig
from stereo_nav_env.observation.raster import UNKNOWN_VALUE, world_to_raster
from stereo_nav_env.observation.seen import SeenFloor


@pytest.mark.parametrize("seed", range(4))
def test_raster_to_grid_is_the_inverse_raster_map_then_the_grid_map(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(25):
        xmin, ymin = rng.uniform(-10.0, 0.0, 2)
        floor = SeenFloor((xmin, ymin, xmin + 12.0, ymin + 7.0), float(rng.uniform(0.02, 0.2)))
        cfg = ObservationConfig(
            raster_size_px=int(rng.integers(36, 129)),
            raster_half_extent_m=float(rng.uniform(1.0, 8.0)),
        )
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)), float(rng.uniform(-7, 7)))
        A, b = world_to_raster(pose, cfg)
        # a raster pixel u is the world point inv(A) (u - b), then the grid pixel of that point
        u = rng.uniform(-10.0, 140.0, (50, 2))
        world = (u - b) @ np.linalg.inv(A).T
        want = world / floor.cell_m - np.asarray(floor.origin) / floor.cell_m - 0.5
        M = floor.raster_to_grid(pose, cfg)
        np.testing.assert_allclose(u @ M[:, :2].T + M[:, 2], want, rtol=0.0, atol=1e-9)


def test_never_seen_is_unknown_outside_the_marked_square_and_zero_inside() -> None:
    floor = SeenFloor((0.0, 0.0, 10.0, 10.0), 0.05)
    floor.grid[40:80, 100:140] = 255  # seen: x in [5, 7), y in [2, 4)
    cfg = ObservationConfig(raster_size_px=64, raster_half_extent_m=4.0)
    pose = (5.5, 3.5, 0.7)
    out = floor.never_seen(pose, cfg)
    assert out.shape == (64, 64) and out.dtype == np.uint8
    assert set(np.unique(out).tolist()) == {0, UNKNOWN_VALUE}
    A, b = world_to_raster(pose, cfg)
    cols, rows = np.meshgrid(np.arange(64.0), np.arange(64.0))
    pix = np.stack([cols.ravel(), rows.ravel()], axis=1)
    world = (pix - b) @ np.linalg.inv(A).T
    inside = (world[:, 0] > 5.0) & (world[:, 0] < 7.0) & (world[:, 1] > 2.0) & (world[:, 1] < 4.0)
    margin = 0.1  # pixel centres within a cell of the square's edge may round either way
    clear = (
        (np.abs(world[:, 0] - 5.0) > margin)
        & (np.abs(world[:, 0] - 7.0) > margin)
        & (np.abs(world[:, 1] - 2.0) > margin)
        & (np.abs(world[:, 1] - 4.0) > margin)
    )
    got = out.ravel()
    assert inside[clear].any() and (~inside[clear]).any()
    assert (got[clear & inside] == 0).all()
    assert (got[clear & ~inside] == UNKNOWN_VALUE).all()
