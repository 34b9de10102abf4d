"""The model's compiled loops equal their readable references (modeling.obstacles and
modeling.partitions, sections 4.1 and 4.2)."""

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
from modeling.partitions import partition_arrays, partition_arrays_reference


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


def _situation_inputs(rng: np.random.Generator, n_sit: int, n: int, m: int) -> tuple:
    """Random partition inputs: ``m`` relations among ``n`` items of every kind, in ``n_sit``
    situations with random active items; ``p_passable`` and distances with ties."""
    i = rng.integers(0, max(n - 1, 1), m)
    j = np.minimum(i + rng.integers(1, max(n, 2), m), max(n - 1, 0))
    kind = rng.integers(0, 3, m)  # impassable, undecided, short passable
    act = rng.random((n_sit, n)) < rng.uniform(0.3, 1.0)
    p = np.round(rng.random(m), 1)  # ties within groups: row order decides
    d = np.round(rng.uniform(0.0, 2.0, m), 1)
    return act, i, j, kind == 0, kind == 1, kind == 2, p, d


@pytest.mark.parametrize("seed", range(10))
def test_partition_kernel_equals_its_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    cases = [(1, 0, 0), (1, 1, 0), (2, 3, 0)]  # degenerate: no items, no relations
    cases += [
        (int(rng.integers(1, 6)), int(rng.integers(2, 40)), int(rng.integers(0, 120)))
        for _ in range(12)
    ]
    multi = 0
    for n_sit, n, m in cases:
        args = _situation_inputs(rng, n_sit, n, m)
        got, want = partition_arrays(*args), partition_arrays_reference(*args)
        for name, g, w in zip(got._fields, got, want, strict=True):
            for a, b in zip(g, w, strict=True) if isinstance(g, tuple) else [(g, w)]:
                assert np.asarray(a).dtype == np.asarray(b).dtype == np.int64, name
                np.testing.assert_array_equal(a, b, err_msg=name)
        multi += int((np.diff(got.first_obst) > 1).any() and got.und[0].size > 1)
    assert multi >= 3  # several obstacles and undecided groups to sort, not only empty cases
