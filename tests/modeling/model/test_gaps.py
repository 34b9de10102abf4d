"""Exact gap passability (modeling.model.gaps) against Monte Carlo and the scalar reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.model._kernels.gap import GH_FEW_SLOPE, GH_MAX_SLOPE
from modeling.model.gaps import (
    Relation,
    classify_gap,
    classify_gaps,
    eigen_frame,
    gap_passable_probability,
    gap_passable_probability_batch,
    gap_width_moments,
    gh_slope,
)

_N_MC = 1_000_000
_Z0, _Z1 = np.random.default_rng(12345).standard_normal((2, _N_MC))
_BUF = np.empty((2, _N_MC))


def _mc(mu: np.ndarray, S: np.ndarray, w: float) -> float:
    """P(||d|| > w) for d ~ N(mu, S) from 1e6 common standard-normal samples (d = mu + L z)."""
    (l00, _), (l10, l11) = np.linalg.cholesky(S)
    d0, d1 = _BUF  # in place: no fresh 8 MB arrays per case
    np.multiply(_Z0, l00, out=d0)
    d0 += mu[0]
    np.multiply(_Z0, l10, out=d1)
    d1 += mu[1]
    d1 += l11 * _Z1
    d0 *= d0
    d1 *= d1
    d0 += d1
    return float(np.count_nonzero(d0 > w * w)) / _N_MC


def _rot(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _random_cases(
    n: int, seed: int
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]]:
    """Stereo-like anisotropic endpoints: depth sd up to 0.3 m, lateral 2-20 mm, sideways gaps."""
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(n):
        w = rng.uniform(0.3, 0.8)
        view = rng.uniform(0, 2 * math.pi)  # viewing direction of both points (depth axis)
        covs = []
        for _k in range(2):
            sd_depth = rng.uniform(0.01, 0.3)
            sd_lat = rng.uniform(0.002, 0.02)
            R = _rot(view + rng.normal(0, 0.2))
            covs.append(R @ np.diag([sd_depth**2, sd_lat**2]) @ R.T)
        # Gap direction: sideways (perpendicular to the view) half of the time.
        gdir = view + (math.pi / 2 if rng.random() < 0.5 else rng.uniform(0, math.pi))
        length = w + rng.normal(0, 0.15)
        a = rng.uniform(-3, 3, 2)
        b = a + abs(length) * np.array([math.cos(gdir), math.sin(gdir)])
        cases.append((a, covs[0], b, covs[1], w))
    return cases


def test_paper_sideways_example_is_not_linearised() -> None:
    # Gap 0.55 m sideways, robot 0.6 m, depth sigma 0.3 m on each endpoint (depth along y).
    ca = cb = np.diag([0.005**2, 0.3**2])
    p = gap_passable_probability([0.0, 0.0], ca, [0.55, 0.0], cb, 0.6)
    mc = _mc(np.array([0.55, 0.0]), ca + cb, 0.6)
    assert abs(p - mc) < 0.002
    assert 0.5 < p < 0.7
    assert _linearised(np.zeros(2), ca, np.array([0.55, 0.0]), cb, 0.6) < 0.05  # badly wrong


def test_agrees_with_monte_carlo_on_random_anisotropic_cases() -> None:
    cases = _random_cases(110, seed=7)
    ps = np.array([gap_passable_probability(a, ca, b, cb, w) for a, ca, b, cb, w in cases])
    mc = np.array([_mc(b - a, ca + cb, w) for a, ca, b, cb, w in cases])
    assert np.max(np.abs(ps - mc)) < 0.002
    # The cases are not trivial: many are genuinely uncertain, with depth sigma up to 0.3 m
    # and sideways gaps, where linearising along the gap fails badly.
    assert np.sum((ps > 0.05) & (ps < 0.95)) >= 30
    depth_sd = np.array([np.sqrt(np.linalg.eigvalsh(ca)[1]) for _, ca, _, _, _ in cases])
    assert depth_sd.max() > 0.25 and depth_sd.min() < 0.05
    lin = np.array([_linearised(a, ca, b, cb, w) for a, ca, b, cb, w in cases])
    assert np.max(np.abs(lin - mc)) > 0.2
    # The batch function (the model's) agrees with the same Monte Carlo estimates.
    batch = gap_passable_probability_batch(
        [c[0] for c in cases],
        [c[1] for c in cases],
        [c[2] for c in cases],
        [c[3] for c in cases],
        [c[4] for c in cases],
    )
    assert np.max(np.abs(batch - mc)) < 0.002


def _linearised(a: np.ndarray, ca: np.ndarray, b: np.ndarray, cb: np.ndarray, w: float) -> float:
    """The wrong method: the distance as a normal with the variance along the connecting line."""
    d = b - a
    n = np.linalg.norm(d)
    e = d / n
    sd = math.sqrt(e @ (ca + cb) @ e)
    return 0.5 * math.erfc((w - n) / (sd * math.sqrt(2)))


def test_batch_rules_agree_with_adaptive_quadrature_on_stereo_like_pairs() -> None:
    # Both rules of the batch function (Gauss-Hermite for smooth pairs, Gauss-Legendre panels
    # for the others) against the adaptive scalar function.
    cases = _random_cases(600, seed=11)
    mu = np.array([b - a for a, _, b, _, _ in cases])
    S = np.array([ca + cb for _, ca, _, cb, _ in cases])
    w = np.array([c[4] for c in cases])
    slope = np.array([gh_slope(eigen_frame(mu[k], S[k], w[k]), w[k]) for k in range(600)])
    smooth = slope <= GH_MAX_SLOPE
    batch = gap_passable_probability_batch(np.zeros_like(mu), S / 2, mu, S / 2, w)
    scalar = np.array(
        [gap_passable_probability([0, 0], S[k] / 2, mu[k], S[k] / 2, w[k]) for k in range(600)]
    )
    uncertain = (scalar > 1e-3) & (scalar < 1 - 1e-3)
    assert np.sum(smooth & uncertain) > 100 and np.sum(~smooth & uncertain) > 50
    assert np.max(np.abs(batch - scalar)[smooth]) < 1e-6
    # The flattest smooth pairs take the 8-node rule: as exact as the adaptive reference.
    few = slope <= GH_FEW_SLOPE
    assert np.sum(few & uncertain) > 50
    assert np.max(np.abs(batch - scalar)[few]) < 1e-9
    assert np.max(np.abs(batch - scalar)) < 1e-4


def test_batch_matches_scalar_within_1e4_including_extremes() -> None:
    rng = np.random.default_rng(3)
    m = 400
    ang = rng.uniform(0, math.pi, m)
    s1 = 10 ** rng.uniform(-4, -0.3, m)
    s2 = 10 ** rng.uniform(-4, -0.3, m)
    S = np.stack(
        [_rot(t) @ np.diag([x * x, y * y]) @ _rot(t).T for t, x, y in zip(ang, s1, s2, strict=True)]
    )
    w = rng.uniform(0.05, 1.0, m)
    direction = rng.normal(size=(m, 2))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    mu = direction * (w + rng.normal(0, 1, m) * np.maximum(s1, s2))[:, None]
    zeros = np.zeros((m, 2))
    batch = gap_passable_probability_batch(zeros, S / 2, mu, S / 2, w)
    scalar = np.array(
        [gap_passable_probability(zeros[k], S[k] / 2, mu[k], S[k] / 2, w[k]) for k in range(m)]
    )
    assert np.max(np.abs(batch - scalar)) < 1e-4


def test_near_singular_covariances() -> None:
    tiny = np.diag([1e-14, 1e-14])
    # Essentially exact points: 0.7 apart > 0.6, 0.5 apart < 0.6.
    assert gap_passable_probability([0, 0], tiny, [0.7, 0], tiny, 0.6) == pytest.approx(1.0)
    assert gap_passable_probability([0, 0], tiny, [0.5, 0], tiny, 0.6) == pytest.approx(0.0)
    # A needle-thin covariance along y: P(|d| > w) with d = (0.5, y), y ~ N(0, 0.3^2 * 2).
    thin = np.diag([1e-12, 0.09])
    p = gap_passable_probability([0, 0], thin, [0.5, 0], thin, 0.6)
    y = math.sqrt(0.6**2 - 0.5**2) / math.sqrt(0.18)
    expected = 2 * (1 - 0.5 * (1 + math.erf(y / math.sqrt(2))))
    assert p == pytest.approx(expected, abs=1e-6)
    batch = gap_passable_probability_batch([[0, 0]], [thin], [[0.5, 0]], [thin], 0.6)
    assert batch[0] == pytest.approx(expected, abs=1e-4)


def test_zero_width_and_symmetry() -> None:
    c = np.diag([0.01, 0.02])
    assert gap_passable_probability([0, 0], c, [0.1, 0], c, 0.0) == 1.0
    p1 = gap_passable_probability([0, 0], c, [0.4, 0.1], c * 2, 0.5)
    p2 = gap_passable_probability([0.4, 0.1], c * 2, [0, 0], c, 0.5)
    assert p1 == pytest.approx(p2, abs=1e-12)


def test_classify_gap_thresholds() -> None:
    assert classify_gap(0.99, 0.05) is Relation.PASSABLE
    assert classify_gap(0.01, 0.05) is Relation.IMPASSABLE
    assert classify_gap(0.5, 0.05) is Relation.UNDECIDED
    assert classify_gap(0.95, 0.05) is Relation.UNDECIDED  # passable needs p > 1 - eps
    assert list(classify_gaps([0.99, 0.01, 0.5], 0.05)) == [0, 1, 2]
    with pytest.raises(ValueError, match="eps"):
        classify_gap(0.5, 0.7)
    with pytest.raises(ValueError, match="p_passable"):
        classify_gap(1.5, 0.05)


def test_width_moments_match_monte_carlo() -> None:
    mu = np.array([[0.55, 0.0], [0.5, 0.2]])
    S = np.array([np.diag([1e-4, 0.18]), np.diag([0.01, 0.005])])
    mean, std = gap_width_moments(mu, S)
    for k in range(2):
        (l00, _), (l10, l11) = np.linalg.cholesky(S[k])
        r = np.hypot(l00 * _Z0 + mu[k, 0], l10 * _Z0 + l11 * _Z1 + mu[k, 1])
        assert mean[k] == pytest.approx(r.mean(), abs=2e-3)
        assert std[k] == pytest.approx(r.std(), abs=2e-3)


def test_touching_points_integrate_without_warnings() -> None:
    import warnings

    # Coincident means (touching segments): the breakpoints of the quadrature coincide.
    rng = np.random.default_rng(5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(50):
            R = _rot(rng.uniform(0, math.pi))
            S = R @ np.diag(rng.uniform(0.05, 0.15, 2) ** 2) @ R.T
            p = gap_passable_probability([0, 0], S / 2, [4e-16, -4e-16], S / 2, 0.5)
            assert p == pytest.approx(
                gap_passable_probability_batch([[0, 0]], [S / 2], [[0, 0]], [S / 2], 0.5)[0],
                abs=1e-4,
            )
