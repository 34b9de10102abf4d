"""The compiled convex hulls (``modeling.model._kernels.hull.convex_rings``) equal GEOS's, vertex
for vertex, and the exact-orientation filter they rest on never gives a wrong sign."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from modeling.model._kernels.hull import HullSets, convex_rings, orientation
from modeling.model.obstacles import geos_hull_sets, hull_sets
from tests.modeling.model.test_compiled_model import _random_sets


def _assert_same_sets(got: HullSets, want: HullSets) -> None:
    for name in HullSets._fields:
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def _footprint_sets(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Sets like a model's: the corners of rotated boxes and a few scattered segment ends, with
    repeated points, at floor coordinates of a few metres."""
    sets = []
    for _ in range(n):
        centre = rng.uniform(-4.0, 4.0, 2)
        half = rng.uniform(0.05, 0.8, 2)
        theta = rng.uniform(-np.pi, np.pi)
        rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        corners = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * half
        pts = centre + corners @ rot.T
        extra = centre + rng.normal(scale=0.3, size=(int(rng.integers(0, 6)), 2))
        pts = np.concatenate([pts, extra, pts[: int(rng.integers(0, 3))]])
        sets.append(rng.permutation(pts))
    index = np.repeat(np.arange(n), [s.shape[0] for s in sets])
    return np.concatenate(sets), index


@pytest.mark.parametrize("seed", range(8))
def test_hull_sets_equal_geos_on_footprints_and_every_kind_of_set(seed: int) -> None:
    rng = np.random.default_rng(seed)
    decided = 0
    for make in (_footprint_sets, _random_sets):
        for _ in range(10):
            n = int(rng.integers(1, 14))
            points, index = make(rng, n)
            grow = rng.uniform(0.01, 0.2, n)
            counts = np.bincount(index, minlength=n)
            if make is _footprint_sets:
                decided += convex_rings(points, counts, counts <= 2).certain
            _assert_same_sets(
                hull_sets(points, index, n, grow), geos_hull_sets(points, index, n, grow)
            )
    assert decided >= 8  # the compiled chain, not only its fallback, was compared


def test_a_ring_runs_clockwise_from_its_lowest_vertex_without_collinear_points() -> None:
    # a square with a point on its bottom edge, a repeated corner and an inner point
    pts = np.array([[2.0, 0.0], [0.0, 2.0], [2.0, 2.0], [0.0, 0.0], [1.0, 0.0], [2.0, 2.0]])
    pts = np.concatenate([pts, [[1.0, 1.0]]])
    rings = convex_rings(pts, np.array([7]), np.array([False]))
    assert rings.certain
    assert rings.coords.tolist() == [[0, 0], [0, 2], [2, 2], [2, 0], [0, 0]]
    assert rings.n_coords.tolist() == [5] and rings.poly_set.tolist() == [0]
    want = geos_hull_sets(pts, np.zeros(7, np.int64), 1, 0.1)
    np.testing.assert_array_equal(rings.coords, want.coords)


def test_collinear_sets_are_flat_and_an_undecidable_turn_falls_back_to_geos() -> None:
    line = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [3.0, 0.0]])  # exactly 0: decided
    rings = convex_rings(line, np.array([4]), np.array([False]))
    assert rings.certain and rings.flat.tolist() == [True] and rings.poly_set.size == 0
    # 0.1 + 0.2 != 0.3: these three are almost collinear, closer than the filter can call
    tight = np.array([[0.1, 0.1], [0.3, 0.3], [0.2, 0.2], [0.0, 1.0]])
    assert not convex_rings(tight, np.array([4]), np.array([False])).certain
    index = np.zeros(4, np.int64)
    _assert_same_sets(hull_sets(tight, index, 1, 0.05), geos_hull_sets(tight, index, 1, 0.05))


def _exact_sign(p: np.ndarray) -> int:
    ax, ay, bx, by, cx, cy = (Fraction(float(v)) for v in p)
    det = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (det > 0) - (det < 0)


def test_orientation_is_the_exact_sign_wherever_it_decides() -> None:
    rng = np.random.default_rng(5)
    undecided = 0
    for _ in range(3000):
        a, b = rng.uniform(-5.0, 5.0, (2, 2))
        t = rng.uniform(-2.0, 2.0)
        c = a + t * (b - a) + rng.choice([0.0, 1e-17, 1e-15, 1e-9, 1.0]) * rng.normal(size=2)
        p = np.concatenate([a, b, c])
        got = orientation(*p.tolist())
        if got == 2:
            undecided += 1
            continue
        assert got == _exact_sign(p), p.tolist()
    assert 0 < undecided < 1500  # near-collinear triples are left to GEOS, the rest decided
