"""The compiled face test (``modeling.stereo._kernels.face.face_joins``) equals its NumPy reference
(``modeling.stereo.faces.face_joins_reference``) on seeded random edges and lines."""

from __future__ import annotations

import numpy as np
import pytest

from modeling.stereo._kernels.face import FaceEdges, FaceTest, face_joins
from modeling.stereo.faces import face_joins_reference


def _edges(rng: np.random.Generator, c: int, k: int, end: int = 1) -> FaceEdges:
    """``c`` near-vertical edges whose ``end`` (1: bottom, 0: top) lies near one image row, and
    ``k`` lines: half along that row (they join some pairs), half anywhere (they join none)."""
    u = np.sort(rng.uniform(10.0, 310.0, c))
    length = rng.uniform(30.0, 120.0, c)
    if end == 1:
        bottom = rng.uniform(195.0, 205.0, c)
        top = bottom - length
    else:
        top = rng.uniform(195.0, 205.0, c) - 150.0
        bottom = top + length
    slope = rng.uniform(-0.2, 0.2, c)
    ends_img = np.stack(
        [np.stack([u + slope * (top - bottom), top], -1), np.stack([u, bottom], -1)], axis=1
    )
    floor_pts = rng.uniform(-3.0, 3.0, (c, 2, 2))
    start = rng.uniform(0.0, 300.0, k)
    length = rng.uniform(5.0, 150.0, k)
    row = rng.uniform(197.0, 207.0, (k, 2)) - (0.0 if end == 1 else 156.0)
    lines = np.stack(
        [np.stack([start, row[:, 0]], -1), np.stack([start + length, row[:, 1]], -1)], axis=1
    )
    lines[k // 2 :] = rng.uniform(0.0, 240.0, (k - k // 2, 2, 2))
    return FaceEdges(
        floor_pts=floor_pts,
        ends_img=ends_img,
        slope=slope,
        top_h=rng.uniform(0.3, 0.5, c),
        lines=lines,
    )


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("end", [1, 0])
def test_kernel_equals_reference(seed: int, end: int) -> None:
    rng = np.random.default_rng(seed)
    edges = _edges(rng, 12, 16, end)
    eligible = np.flatnonzero(rng.uniform(size=12) < 0.8)
    test = FaceTest(
        end=end,
        step=3.0 if end == 1 else -3.0,
        top_match_m=0.1,
        max_length_m=4.0,
        tol_px=3.0,
        min_cover=rng.uniform(0.2, 0.8),
    )
    got, want = face_joins(edges, eligible, test), face_joins_reference(edges, eligible, test)
    n_pairs = eligible.size * (eligible.size - 1) // 2
    assert 0 < want.first.size < n_pairs  # some pairs joined, others not
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype == np.int64
        np.testing.assert_array_equal(g, w)
    # the left one in the image first
    assert np.all(edges.ends_img[want.first, end, 0] <= edges.ends_img[want.second, end, 0])


def test_kernel_equals_reference_with_fewer_than_two_edges() -> None:
    edges = _edges(np.random.default_rng(3), 4, 4)
    test = FaceTest(end=1, step=3.0, top_match_m=0.1, max_length_m=4.0, tol_px=3.0, min_cover=0.5)
    for eligible in (np.zeros(0, np.int64), np.array([2])):
        got, want = face_joins(edges, eligible, test), face_joins_reference(edges, eligible, test)
        assert got.first.size == want.first.size == 0
        assert got.second.size == want.second.size == 0
