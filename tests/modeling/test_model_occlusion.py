"""Occlusion (section 4.1): the ray sweep's nearest hits and shadow rings."""

from __future__ import annotations

import numpy as np
import shapely

from modeling.occlusion import RaysAndSegments, RaySweep, nearest_hits, shadow_rings


def test_nearest_hits_are_the_nearest_crossings_found_by_shapely() -> None:
    rng = np.random.default_rng(3)
    ang = np.linspace(-0.6, 0.6, 41)
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    a = rng.uniform([1.0, -3.0], [6.0, 3.0], (15, 2))
    b = a + rng.normal(scale=1.0, size=(15, 2))
    rays = RaysAndSegments(
        u=u, p=a, e=b - a, k0=np.zeros(15, np.int64), n_rays=np.full(15, 41, np.int64)
    )
    got = nearest_hits(rays)
    for k in range(41):
        ray = shapely.LineString([(0.0, 0.0), tuple(100.0 * u[k])])
        dists = [
            shapely.Point(0.0, 0.0).distance(ray.intersection(shapely.LineString([a[s], b[s]])))
            for s in range(15)
            if ray.intersects(shapely.LineString([a[s], b[s]]))
        ]
        if dists:
            assert abs(got[k] - min(dists)) < 1e-9
        else:
            assert got[k] == np.inf


def test_shadow_rings_are_one_ring_per_run_of_blocked_rays() -> None:
    u = np.stack([np.cos(np.arange(6.0)), np.sin(np.arange(6.0))], axis=1)
    hit = np.array([np.inf, 2.0, 3.0, np.inf, 9.0, 1.0])  # blocked runs: rays 1-2 and 5
    rings = shadow_rings(RaySweep(origin=np.zeros(2), u=u, hit=hit, max_range=5.0))
    # run 1-2: two hits, then the arc over rays 3..0; run 5: one hit, then the arc over 5..4
    assert rings.sizes.tolist() == [2 + 4, 1 + 2]
    np.testing.assert_allclose(rings.vertices[0], 2.0 * u[1])
    np.testing.assert_allclose(rings.vertices[2:6], 5.0 * u[[3, 2, 1, 0]])
    np.testing.assert_allclose(rings.vertices[6:], [1.0 * u[5], 5.0 * u[5], 5.0 * u[4]])
