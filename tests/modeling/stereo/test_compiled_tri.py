"""The compiled floor loop (``modeling.stereo._kernels.tri.floor_rows``) equals its NumPy reference
(``modeling.stereo.triangulation.floor_rows_reference``) bit for bit on seeded random matches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.stereo._kernels.tri import FloorFrame, MatchRows, floor_rows
from modeling.stereo.triangulation import floor_rows_reference


def _rows(rng: np.random.Generator, m: int) -> MatchRows:
    """Random matches: most usable, some crossing the band, some not usable at all."""
    u = rng.uniform(0.0, 319.0, (m, 2))
    v = np.sort(rng.uniform(0.0, 239.0, (m, 2)), axis=1)
    v[: m // 8] = v[: m // 8, ::-1]  # a few listed bottom first (dv < 0)
    disparity = rng.uniform(2.0, 40.0, (m, 2))
    u_var = rng.uniform(0.005, 0.1, (m, 2))
    d_var = rng.uniform(0.01, 0.3, (m, 2))
    v_var = rng.uniform(0.5, 2.0, (m, 2))
    probability = rng.choice([0.0, 0.25, 0.5, 1.0], m)  # ties: the sort must be stable
    bad = rng.integers(0, m, 6)
    disparity[bad[0], 0] = -1.0
    disparity[bad[1], 1] = 0.0
    u[bad[2], 0] = np.nan
    d_var[bad[3], 1] = np.inf
    u_var[bad[4]] = 0.0
    d_var[bad[4]] = 0.0  # a degenerate covariance
    v[bad[5]] = 119.5  # horizontal through the principal point: a zero band denominator
    return MatchRows(
        probability=probability,
        left_index=rng.integers(0, m // 3, m).astype(np.int64),
        ends=np.stack([u, v], axis=-1),
        disparity=disparity,
        u_var=u_var,
        d_var=d_var,
        v_var=v_var,
    )


def _frame(rng: np.random.Generator, tilt: float = 0.0) -> FloorFrame:
    heading = rng.uniform(-math.pi, math.pi)
    low = rng.uniform(-0.2, 0.3)
    return FloorFrame(
        min_probability=0.1,
        min_height_m=low,
        max_height_m=low + rng.uniform(0.2, 1.2),
        baseline_m=0.12,
        cx_px=159.5,
        cy_px=119.5,
        fb=0.12 * rng.uniform(200.0, 300.0),
        x_m=rng.uniform(-5.0, 5.0),
        y_m=rng.uniform(-5.0, 5.0),
        height_m=rng.uniform(0.5, 1.2),
        cos_heading=math.cos(heading),
        sin_heading=math.sin(heading),
        cos_tilt=math.cos(tilt),
        sin_tilt=math.sin(tilt),
    )


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("tilt", [0.0, 0.3, -0.2])
def test_kernel_equals_reference(seed: int, tilt: float) -> None:
    rng = np.random.default_rng(seed)
    rows, frame = _rows(rng, 48), _frame(rng, tilt)
    got, want = floor_rows(rows, frame), floor_rows_reference(rows, frame)
    assert 0 < want.xy.shape[0] < 48  # some rows kept, some dropped
    assert got._fields == want._fields
    for name, g, w in zip(want._fields, got, want, strict=True):
        assert g.dtype == w.dtype, name
        np.testing.assert_array_equal(g, w, err_msg=name)


def test_kernel_equals_reference_on_no_rows() -> None:
    rows = _rows(np.random.default_rng(0), 8)
    empty = rows._replace(**{name: getattr(rows, name)[:0] for name in rows._fields})
    frame = _frame(np.random.default_rng(1))
    got, want = floor_rows(empty, frame), floor_rows_reference(empty, frame)
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape and g.dtype == w.dtype
