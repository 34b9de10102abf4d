"""The compiled edge-point loop equals its readable reference (section 3.2).

``modeling.stereo._kernels.edge.edge_sums`` against
``modeling.stereo.edge_points.edge_sums_reference``: exactly equal sums, polarities and row ranges
on seeded random images and lines (two images stacked, lines crossing the image sides, several
search options).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.stereo._kernels.edge import (
    EdgeSearch,
    EdgeSums,
    FitLimits,
    LinesToFit,
    edge_sums,
    segment_fits,
)
from modeling.stereo.edge_points import edge_sums_reference
from modeling.stereo.segments import SegmentOptions, least_squares_lines_reference

H, W = 48, 64


def _images(rng: np.random.Generator) -> np.ndarray:
    """Two stacked (H, W) images of random vertical-ish steps and noise."""
    out = []
    for _ in range(2):
        img = np.full((H, W), rng.uniform(40, 200))
        uu = np.arange(W)[None, :]
        vv = np.arange(H)[:, None]
        for _ in range(4):
            u0, s = rng.uniform(-5, W + 5), rng.uniform(-0.5, 0.5)
            img = np.where(uu >= u0 + s * (vv - H / 2), rng.uniform(20, 235), img)
        img = img + rng.normal(0, 4, img.shape)
        out.append(np.clip(np.rint(img), 0, 255).astype(np.uint8))
    return np.concatenate(out)


def _lines(rng: np.random.Generator, m: int) -> LinesToFit:
    y0 = rng.uniform(0, H / 2, m)
    r0 = np.maximum(np.ceil(y0).astype(np.int64) + 1, 1)
    r1 = np.minimum(r0 + rng.integers(2, 20, m), H - 2)
    return LinesToFit(
        image_of=rng.integers(0, 2, m),
        x0=rng.uniform(-3, W + 3, m),  # some lines run past the image sides
        y0=y0,
        inv_slope=rng.uniform(-0.8, 0.8, m),
        r0=r0,
        r1=r1,
    )


@pytest.mark.parametrize("seed", range(10))
def test_edge_sums_equal_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    search_px = int(rng.integers(1, 5))
    side_px = int(rng.integers(1, 5))
    near_px = float(rng.choice([0.5, 1.5, 2.25, 3.0]))
    search = EdgeSearch(
        height=H,
        search_px=search_px,
        side_px=side_px,
        near_px=near_px,
        half_block=search_px + max(side_px, math.ceil(near_px) + 1),
        min_gradient=float(rng.choice([0.0, 5.0, 7.3])),
    )
    stack, lines = _images(rng), _lines(rng, int(rng.integers(1, 12)))
    got, want = edge_sums(stack, lines, search), edge_sums_reference(stack, lines, search)
    for name in EdgeSums._fields:
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert np.any(got.sums[:, 0] > 0)  # edge points were found


def test_edge_sums_locate_a_step_edge() -> None:
    # a dark-to-bright step between columns 29 and 30 (the edge at u = 29.5), rows 5 to 20
    img = np.full((H, W), 50, dtype=np.uint8)
    img[:, 30:] = 150
    stack = np.concatenate([img, img])
    lines = LinesToFit(
        image_of=np.array([1]),
        x0=np.array([30.4]),
        y0=np.array([4.0]),
        inv_slope=np.array([0.0]),
        r0=np.array([5]),
        r1=np.array([20]),
    )
    search = EdgeSearch(
        height=H, search_px=3, side_px=3, near_px=1.5, half_block=6, min_gradient=5.0
    )
    for got in (edge_sums(stack, lines, search), edge_sums_reference(stack, lines, search)):
        n, _, sum_u = got.sums[0, :3]
        assert n == 16 and got.polarity[0] == 1
        assert got.first_row[0] == 5 and got.last_row[0] == 20
        np.testing.assert_allclose(sum_u / n + 30.4, 29.5, atol=1e-6)  # u relative to the line
        np.testing.assert_allclose(got.sums[0, 7:9] / n, [50.0, 150.0])  # far grey levels


@pytest.mark.parametrize("seed", range(10))
def test_segment_fits_equal_reference(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    search = EdgeSearch(
        height=H, search_px=3, side_px=3, near_px=1.5, half_block=6, min_gradient=5.0
    )
    stack, lines = _images(rng), _lines(rng, int(rng.integers(1, 12)))
    edges = edge_sums(stack, lines, search)
    opts = SegmentOptions(
        min_length_px=float(rng.choice([2.0, 5.0, 12.0])),
        min_angle_deg=float(rng.choice([20.0, 45.0, 70.0])),
    )
    limits = FitLimits(
        sigma_px=float(rng.choice([0.1, 0.3, 1.0])),
        min_length_px=float(opts.min_length_px),
        sin_min=opts.sin_min_angle,
    )
    got = segment_fits(edges, lines, limits)
    want = least_squares_lines_reference(edges, lines, limits)
    f = got.fit
    np.testing.assert_array_equal(got.ok, want["ok"])
    np.testing.assert_array_equal(f[:4].T.reshape(-1, 2, 2), want["endpoints"])
    rows = ["u_center", "v_center", "slope", "point_var", "n_points", "s_vv", "contrast"]
    rows += ["grey_left", "grey_right", "grey_left_near", "grey_right_near"]
    for k, name in enumerate(rows, start=4):
        np.testing.assert_array_equal(f[k], want[name].astype(np.float64), err_msg=name)
    assert f.shape == (15, lines.x0.size)
