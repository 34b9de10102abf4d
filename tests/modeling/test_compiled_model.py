"""The model's compiled loop equals its readable reference (modeling.obstacles, section 4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from modeling._compiled.hull import finish_hulls
from modeling.obstacles import (
    _geos_hulls,
    components,
    components_reference,
    finish_hulls_reference,
)


def _random_sets(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` point sets of every kind: spread, collinear, coincident, one or two points."""
    sets = []
    for _ in range(n):
        kind = rng.integers(0, 5)
        m = int(rng.integers(1, 8))
        if kind == 0:  # spread: a proper hull
            pts = rng.normal(size=(m + 3, 2))
        elif kind == 1:  # collinear, in random order
            t = rng.uniform(-2.0, 2.0, m + 2)
            pts = rng.normal(size=2) + t[:, None] * rng.normal(size=2)
        elif kind == 2:  # coincident
            pts = np.repeat(rng.normal(size=(1, 2)), m, axis=0)
        elif kind == 3:  # almost collinear (a thin hull from GEOS)
            t = rng.uniform(-2.0, 2.0, m + 3)
            pts = np.stack([t, 1e-13 * rng.normal(size=t.shape[0])], axis=1)
        else:  # one or two points
            pts = rng.normal(size=(int(rng.integers(1, 3)), 2))
        sets.append(pts)
    index = np.repeat(np.arange(n), [s.shape[0] for s in sets])
    return np.concatenate(sets), index


@pytest.mark.parametrize("seed", range(6))
def test_finish_hulls_kernel_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 12
    points, index = _random_sets(rng, n)
    grow = rng.uniform(0.01, 0.2, n)
    sets = _geos_hulls(points, index, n, grow)
    flat_before = sets.flat.copy()
    got = finish_hulls(sets)
    want = finish_hulls_reference(sets)
    np.testing.assert_array_equal(got.offsets, want.offsets)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(sets.flat, flat_before)  # the inputs are not changed
    assert got.offsets[-1] == got.vertices.shape[0]


def test_finish_hulls_kernel_equals_reference_on_one_grow_for_all() -> None:
    rng = np.random.default_rng(11)
    points, index = _random_sets(rng, 8)
    sets = _geos_hulls(points, index, 8, 0.05)
    got, want = finish_hulls(sets), finish_hulls_reference(sets)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(got.offsets, want.offsets)


@pytest.mark.parametrize("seed", range(8))
def test_union_find_equals_the_csgraph_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for n in (1, 2, 7, 40, 300):
        m = int(rng.integers(0, 2 * n + 1))
        i, j = rng.integers(0, n, m), rng.integers(0, n, m)
        got, want = components(n, i, j), components_reference(n, i, j)
        assert got.dtype == want.dtype == np.int64
        np.testing.assert_array_equal(got, want)
