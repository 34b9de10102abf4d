"""The occlusion sweep's compiled loops equal their readable references (modeling.model.occlusion).

Inputs of every kind: segments crossing many rays, parallel to a ray, behind the viewpoint, with
spans wider than pi, outside the field of view, NaN endpoints; rays blocked in runs at both ends
of the sweep. Equality is exact (``assert_array_equal``): the loops do the references' arithmetic.
"""

from __future__ import annotations

import numpy as np
import pytest

from modeling.geometry import wrap_angle
from modeling.model._kernels.sweep import RaysAndSegments, RaySweep
from modeling.model.occlusion import (
    nearest_hits,
    nearest_hits_reference,
    ray_hits,
    ray_spans,
    ray_spans_reference,
    shadow_rings,
    shadow_rings_reference,
)
from modeling.observation import FloorObservation

N_RAYS = 61
HALF = 0.7


def _rays(n_rays: int = N_RAYS) -> np.ndarray:
    ang = 0.3 + np.linspace(-HALF, HALF, n_rays)
    return np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _segments(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(p, e)``: first endpoints around the origin (some behind it) and offsets, with a few
    degenerate ones: zero length, parallel to a ray, NaN."""
    p = rng.uniform(-3.0, 6.0, (n, 2))
    e = rng.normal(scale=2.0, size=(n, 2))
    e[0] = 0.0  # a point
    u = _rays()
    e[1] = 2.5 * u[7]  # along a ray
    p[1] = 1.5 * u[7]
    p[2, 0] = np.nan
    return p, e


def _spans(p: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(invalid="ignore"):
        a0 = wrap_angle(np.arctan2(p[:, 1], p[:, 0]) - 0.3)
        a1 = wrap_angle(np.arctan2(p[:, 1] + e[:, 1], p[:, 0] + e[:, 0]) - 0.3)
        return np.minimum(a0, a1), np.maximum(a0, a1)


@pytest.mark.parametrize("seed", range(6))
def test_ray_spans_kernel_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    lo, hi = _spans(*_segments(rng, 40))
    lo[3], hi[3] = -3.0, 3.0  # wider than pi: behind the viewpoint
    lo[4], hi[4] = np.nan, np.nan
    got = ray_spans(lo, hi, HALF, N_RAYS)
    want = ray_spans_reference(lo, hi, HALF, N_RAYS)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype == np.int64
        np.testing.assert_array_equal(g, w)
    assert got[1][3] == got[1][4] == 0
    assert 0 < int(got[1].sum()) < 40 * N_RAYS  # some rays, not all


@pytest.mark.parametrize("seed", range(6))
def test_nearest_hits_kernel_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p, e = _segments(rng, 10)
    k0, count = ray_spans_reference(*_spans(p, e), HALF, N_RAYS)
    rays = RaysAndSegments(u=_rays(), p=p, e=e, k0=k0, n_rays=count)
    got, want = nearest_hits(rays), nearest_hits_reference(rays)
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(got).any() and np.isinf(got).any()


@pytest.mark.parametrize("seed", range(6))
def test_shadow_rings_kernel_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    hit = rng.uniform(0.5, 8.0, N_RAYS)
    hit[rng.uniform(size=N_RAYS) < 0.3] = np.inf
    hit[0] = 1.0 if seed % 2 else np.inf  # a run at the first ray, or none
    hit[-1] = 2.0  # a run at the last ray
    sweep = RaySweep(origin=rng.normal(size=2), u=_rays(), hit=hit, max_range=5.0)
    got, want = shadow_rings(sweep), shadow_rings_reference(sweep)
    np.testing.assert_array_equal(got.sizes, want.sizes)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    assert got.sizes.dtype == np.int64 and got.sizes.shape[0] >= 2


def test_shadow_rings_kernel_of_no_blocked_ray_is_empty() -> None:
    sweep = RaySweep(origin=np.zeros(2), u=_rays(), hit=np.full(N_RAYS, np.inf), max_range=5.0)
    got, want = shadow_rings(sweep), shadow_rings_reference(sweep)
    assert got.sizes.shape == want.sizes.shape == (0,)
    assert got.vertices.shape == want.vertices.shape == (0, 2)


def test_ray_hits_equal_the_reference_loops() -> None:
    rng = np.random.default_rng(9)
    ends = rng.uniform(-2.0, 6.0, (30, 2, 2))
    obs = FloorObservation(segments=(), ambiguous=(), viewpoint=np.array([0.5, -0.2, 0.4]))
    sweep = ray_hits(obs, ends, 181)
    half = 0.5 * float(obs.fov_rad)
    p = ends[:, 0] - sweep.origin
    e = ends[:, 1] - ends[:, 0]
    a0 = wrap_angle(np.arctan2(p[:, 1], p[:, 0]) - 0.4)
    a1 = wrap_angle(np.arctan2(p[:, 1] + e[:, 1], p[:, 0] + e[:, 0]) - 0.4)
    k0, count = ray_spans_reference(np.minimum(a0, a1), np.maximum(a0, a1), half, 181)
    want = nearest_hits_reference(RaysAndSegments(u=sweep.u, p=p, e=e, k0=k0, n_rays=count))
    np.testing.assert_array_equal(sweep.hit, want)
    assert np.isfinite(sweep.hit).sum() > 10
