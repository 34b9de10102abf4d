"""Each compiled loop of modeling.model._kernels.gap equals its readable reference (seeded inputs).

The loops are reached through their public functions where one exists (``closest_points``,
``passable_from_difference``, ``gap_width_moments``, ``segment_relations``); the others
(``grown_boxes``, ``near_pairs``, ``relation_rows``, ``relation_rows_taking`` and the scalar
helpers) only exist in the
compiled module, the module under test here. Inputs stay small: with ``NUMBA_DISABLE_JIT=1``
every loop runs as plain Python.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from modeling.model._kernels import gap as kernel
from modeling.model._kernels.gap import GH_FEW_SLOPE, GH_MAX_SLOPE
from modeling.model.gaps import (
    QUADRATURE_RULES,
    eigen_frame,
    gap_passable_probability,
    gap_width_moments,
    gap_width_moments_reference,
    gh_slope,
    integration_breakpoints,
    passable_from_difference,
)
from modeling.model.relations import (
    closest_points,
    closest_points_reference,
    grown_boxes_reference,
    near_pairs_reference,
    prune_sigmas,
    relation_rows_reference,
    relation_rows_taking_reference,
)

W = 0.5


def _rot(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _covariances(
    rng: np.random.Generator, m: int, lo: float = 0.003, hi: float = 0.2
) -> np.ndarray:
    """(m, 2, 2) random anisotropic covariances, standard deviations in [lo, hi] metres."""
    sd = rng.uniform(lo, hi, (m, 2))
    return np.stack(
        [
            _rot(a) @ np.diag(s**2) @ _rot(a).T
            for a, s in zip(rng.uniform(0, math.pi, m), sd, strict=True)
        ]
    )


def _segments(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2, 2) endpoints on a 1/8 m grid (boxes that merely touch occur), a few point segments
    and collinear ones, and (n, 2, 2, 2) endpoint covariances."""
    ends = np.round(rng.uniform(0.0, 4.0, (n, 2, 2)) * 8.0) / 8.0
    ends[::7, 1] = ends[::7, 0]  # point segments
    ends[3::9, :, 1] = ends[3::9, 0, 1, None]  # horizontal: parallel pairs
    cov = _covariances(rng, 2 * n, 0.005, 0.08).reshape(n, 2, 2, 2)
    return ends, cov


def _hits(box: np.ndarray) -> np.ndarray:
    tree_boxes = shapely.box(box[:, 0], box[:, 1], box[:, 2], box[:, 3])
    hits: np.ndarray = shapely.STRtree(tree_boxes).query(tree_boxes).astype(np.int64)
    return hits


def test_closest_points_loop_equals_the_numpy_reference() -> None:
    rng = np.random.default_rng(1)
    ends, _ = _segments(rng, 60)
    a, b = rng.integers(0, 60, (2, 400))
    args = (ends[a, 0], ends[a, 1], ends[b, 0], ends[b, 1])
    s, t = closest_points(*args)
    s_ref, t_ref = closest_points_reference(*args)
    assert np.array_equal(s, s_ref) and np.array_equal(t, t_ref)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    assert np.count_nonzero((s > 0) & (s < 1) & (t > 0) & (t < 1)) > 10  # interior points too


def test_grown_boxes_and_near_pairs_loops_equal_the_numpy_references() -> None:
    rng = np.random.default_rng(2)
    ends, cov = _segments(rng, 40)
    k = prune_sigmas(0.05)
    sigma, box = kernel.grown_boxes(kernel.Segments(ends, cov), 0.5 * W, k)
    sigma_ref, box_ref = grown_boxes_reference(ends, cov, 0.5 * W, k)
    assert np.array_equal(sigma, sigma_ref) and np.array_equal(box, box_ref)
    hits = _hits(box)
    got = kernel.near_pairs(ends, sigma, hits, W, k)
    ref = near_pairs_reference(ends, sigma, hits, W, k)
    for name in ("i", "j", "s", "t"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert 0 < len(got.i) < hits.shape[1] // 2  # the filter keeps some hits and drops others


def _near_pairs(
    rng: np.random.Generator, n: int
) -> tuple[np.ndarray, np.ndarray, kernel.PairParams]:
    """``n`` random segments, their covariances and their near pairs (the compiled loops)."""
    ends, cov = _segments(rng, n)
    k = prune_sigmas(0.05)
    sigma, box = kernel.grown_boxes(kernel.Segments(ends, cov), 0.5 * W, k)
    return ends, cov, kernel.near_pairs(ends, sigma, _hits(box), W, k)


def test_relation_rows_loop_equals_the_reference() -> None:
    ends, cov, pairs = _near_pairs(np.random.default_rng(3), 12)
    got = kernel.relation_rows(kernel.Segments(ends, cov), pairs, W, QUADRATURE_RULES)
    ref = relation_rows_reference(ends, cov, pairs, W)
    for a, b in zip(got[:5], ref[:5], strict=True):  # points, covariances, distance: same ops
        assert np.array_equal(a, b)
    np.testing.assert_allclose(got.p_passable, ref[5], rtol=0, atol=1e-4)
    assert np.count_nonzero((ref[5] > 0.01) & (ref[5] < 0.99)) >= 2
    zero = kernel.relation_rows(kernel.Segments(ends, cov), pairs, 0.0, QUADRATURE_RULES)
    assert np.all(zero.p_passable == 1.0)


def test_relation_rows_taking_loop_equals_the_reference() -> None:
    """Rows taken from earlier rows are copied bit for bit; the others are relation_rows'."""
    rng = np.random.default_rng(4)
    ends, cov, pairs = _near_pairs(rng, 12)
    m = pairs.i.shape[0]
    earlier = tuple(rng.normal(size=a.shape) for a in relation_rows_reference(ends, cov, pairs, W))
    take = np.where(rng.random(m) < 0.5, rng.integers(0, m, m), -1)
    rows = kernel.RelationRows(*earlier)
    got = kernel.relation_rows_taking(
        kernel.Segments(ends, cov), pairs, W, QUADRATURE_RULES, take, rows
    )
    ref = relation_rows_taking_reference(ends, cov, pairs, W, take, earlier)
    for a, b in zip(got[:5], ref[:5], strict=True):
        assert np.array_equal(a, b)
    np.testing.assert_allclose(got.p_passable, ref[5], rtol=0, atol=1e-4)
    taken = take >= 0
    assert np.array_equal(got.p_passable[taken], earlier[5][take[taken]])
    plain = kernel.relation_rows(kernel.Segments(ends, cov), pairs, W, QUADRATURE_RULES)
    for a, b in zip(got, plain, strict=True):  # the computed rows: relation_rows' bit for bit
        assert np.array_equal(a[~taken], b[~taken])
    assert 0 < np.count_nonzero(taken) < m


def _gaps(rng: np.random.Generator, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gap vectors near the robot width: mean (m, 2), covariance (m, 2, 2), width (m,)."""
    S = _covariances(rng, m)
    w = rng.uniform(0.3, 0.8, m)
    direction = _rot(1.0) @ rng.normal(size=(2, m))
    direction /= np.linalg.norm(direction, axis=0)
    mu = (direction * (w + rng.normal(0, 0.15, m))).T
    return mu, S, w


def test_passability_loop_agrees_with_the_adaptive_reference() -> None:
    rng = np.random.default_rng(4)
    mu, S, w = _gaps(rng, 150)
    got = passable_from_difference(mu, S, w)
    half = S / 2  # half + half == S exactly
    ref = np.array(
        [gap_passable_probability([0, 0], half[k], mu[k], half[k], w[k]) for k in range(150)]
    )
    slope = np.array([gh_slope(eigen_frame(mu[k], S[k], w[k]), w[k]) for k in range(150)])
    uncertain = (ref > 1e-3) & (ref < 1 - 1e-3)
    # All three rules are exercised, each within its error bound of the exact value (the gaps
    # answered by a tail bound are near 0 or 1, within 4.1e-5).
    for rule, bound in (
        (slope <= GH_FEW_SLOPE, 1e-9),
        (slope <= GH_MAX_SLOPE, 1e-6),
        (slope > GH_MAX_SLOPE, 1e-4),
    ):
        assert np.count_nonzero(rule & uncertain) >= 5
        assert np.max(np.abs(got - ref)[rule & uncertain]) < bound
    assert np.max(np.abs(got - ref)) < 1e-4  # screened gaps (p near 0 or 1) included
    assert np.count_nonzero(ref < 1e-3) >= 5 and np.count_nonzero(ref > 1 - 1e-3) >= 5


def test_width_moments_loop_equals_the_numpy_reference() -> None:
    rng = np.random.default_rng(5)
    mu, S, _ = _gaps(rng, 60)
    thin = S[:20] * 0 + np.diag([1e-6, 0.04])  # minor sd below a tenth of the major one
    S = np.concatenate([thin, S[20:]])
    for order in (12, 5):
        mean, std = gap_width_moments(mu, S, order=order)
        mean_ref, std_ref = gap_width_moments_reference(mu, S, order=order)
        np.testing.assert_allclose(mean, mean_ref, rtol=1e-12)
        np.testing.assert_allclose(std, std_ref, rtol=1e-9)


def test_scalar_helpers_equal_their_references() -> None:
    rng = np.random.default_rng(6)
    mu, S, w = _gaps(rng, 200)
    mu[:20] *= 6.0  # empty integration windows
    bps = np.empty(7)
    n_empty = 0
    for k in range(200):
        gap = kernel.Gap(mu[k, 0], mu[k, 1], S[k, 0, 0], S[k, 0, 1], S[k, 1, 0], S[k, 1, 1], w[k])
        m_u, s_u, m_v, s_v = kernel.eigen_frame(gap)
        ref = eigen_frame(mu[k], S[k], w[k])
        # The integral depends on |m_v| and is symmetric in m_u: the axes' signs are free.
        np.testing.assert_allclose(
            [abs(m_u), abs(m_v)], [abs(ref.m_u), abs(ref.m_v)], rtol=1e-9, atol=1e-12
        )
        np.testing.assert_allclose([s_u, s_v], [ref.s_u, ref.s_v], rtol=1e-9)
        frame = type(ref)(m_u, s_u, m_v, s_v)  # the kernel's frame, for the helpers after it
        assert kernel.gh_slope(m_u, s_u, s_v, w[k]) == gh_slope(frame, w[k])
        expected = integration_breakpoints(frame, w[k])
        if not kernel.breakpoints(m_u, s_u, m_v, w[k], bps):
            assert expected is None
            n_empty += 1
        else:
            assert expected is not None
            np.testing.assert_allclose(bps, expected, rtol=1e-14, atol=1e-15)
    assert 0 < n_empty < 100
