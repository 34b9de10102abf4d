"""Occlusion (section 4.1): the ray sweep's nearest hits and shadow rings; what occludes."""

from __future__ import annotations

import numpy as np
import shapely

from modeling.model._kernels.sweep import RaysAndSegments, RaySweep
from modeling.model.build import build_model
from modeling.model.occlusion import (
    nearest_hits,
    occluded_area,
    occluded_polygons,
    polygons_of,
    shadow_rings,
)
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from modeling.stereo.faces import FACE_SOURCE


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


def test_occluded_polygons_are_the_rings_of_the_occluded_geometry() -> None:
    """The model's rings, made without shapely, equal those :func:`polygons_of` takes from the
    geometry (to the last bit; a hit just short of the range makes a ring of almost no area,
    which both leave out)."""
    rng = np.random.default_rng(7)
    obs = FloorObservation(segments=(), ambiguous=(), viewpoint=np.array([0.0, 0.0, 0.3]))
    rings = 0
    for k in range(60):
        n = int(rng.integers(0, 12))
        a = rng.uniform([0.5, -4.0], [7.0, 4.0], (n, 2))
        ends = np.stack([a, a + rng.normal(scale=0.8, size=(n, 2))], axis=1)
        if k == 0:  # a segment just inside the range, across the heading: a sliver of a ring
            r = float(obs.max_range_m) - 2e-9
            ends = np.array(
                [
                    [
                        [r * np.cos(0.3) - 1e-3, r * np.sin(0.3) - 1e-3],
                        [r * np.cos(0.3) + 1e-3, r * np.sin(0.3) + 1e-3],
                    ]
                ]
            )
        got, geometry = occluded_polygons(obs, ends), occluded_area(obs, ends)
        want = polygons_of(geometry)
        if k == 0:
            assert 0.0 < geometry.area < 1e-9 and got == ()
        assert [g.tobytes() for g in got] == [w.tobytes() for w in want]
        pairs = zip(got, want, strict=True)
        assert all(g.shape == w.shape and not g.flags.writeable for g, w in pairs)
        rings += len(got)
    assert rings >= 40


def _seg(a, b, sigma: float = 0.01, source: int = -1) -> FloorSegment:
    return FloorSegment(
        endpoints=np.array([a, b], dtype=float),
        cov=np.stack([np.eye(2) * sigma**2] * 2),
        source=source,
    )


def _point(x: float, y: float) -> FloorSegment:
    """A vertical edge: both ends at one floor point, 0.05 to 0.75 m high."""
    s = _seg((x, y), (x, y))
    return FloorSegment(endpoints=s.endpoints, cov=s.cov, height_m=np.array([0.75, 0.05]))


def _observe(segments, ambiguous=()) -> FloorObservation:
    return FloorObservation(
        segments=tuple(segments), ambiguous=tuple(ambiguous), viewpoint=np.array([0.0, 0.0, 0.0])
    )


def test_occlusion_is_behind_the_obstacles_of_the_most_probable_situation() -> None:
    # Issue 16d: occlusion was computed behind the base model's mean segments only. The
    # viewpoint is at the origin looking along +x; each case stands 3 m ahead.
    behind, beside = shapely.Point(4.5, 0.0), shapely.Point(4.5, 2.0)
    # a box seen by its four vertical edges only (floor points 0.4 m apart, joined impassably):
    # no segment has a length, but the obstacle hides the floor behind it
    corners = [_point(3.0, -0.2), _point(3.0, 0.2), _point(3.4, -0.2), _point(3.4, 0.2)]
    m = build_model(_observe(corners), 0.5)
    (s,) = m.situations
    assert len(s.obstacles) == 1
    assert m.occluded_geometry.contains(behind) and not m.occluded_geometry.contains(beside)
    # an obstacle that is only the chosen candidate of a remaining ambiguous segment (0.7):
    # the floor behind it is occluded (the 0.3 candidate extends the wall)
    cand = AmbiguousSegment(
        candidates=(_seg((3.0, -0.4), (3.0, 0.4)), _seg((5.9, 2.5), (5.9, 2.9))),
        probabilities=(0.7, 0.3),
    )
    wall = [_seg((6.0, -3.0), (6.0, 3.0))]
    m2 = build_model(_observe(wall, [cand]), 0.5)
    assert m2.units == ((0,),) and m2.situations[0].choice == {0: 0}
    assert m2.occluded_geometry.contains(behind)
    assert not m2.occluded_geometry.contains(shapely.Point(4.5, 1.5))  # visible up to the wall
    # an obstacle made only of a face-closed outline (two vertical edges and their face)
    face = [_point(3.0, -0.4), _point(3.0, 0.4), _seg((3.0, -0.4), (3.0, 0.4), source=FACE_SOURCE)]
    m3 = build_model(_observe(face), 0.5)
    assert m3.occluded_geometry.contains(behind) and not m3.occluded_geometry.contains(beside)


def test_a_corner_seen_from_inside_hides_only_what_is_behind_its_walls() -> None:
    # an L of walls open toward the viewpoint: the floor inside the corner is seen, though the
    # obstacle's convex hull covers it
    walls = [_seg((4.0, -2.0), (4.0, 2.0)), _seg((4.0, 2.0), (1.5, 2.0))]
    m = build_model(_observe(walls), 0.5)
    (s,) = m.situations
    (corner,) = s.obstacles
    inside = shapely.Point(3.5, 1.5)
    assert shapely.Polygon(corner.polygon).contains(inside)
    assert not m.occluded_geometry.contains(inside)
    assert m.occluded_geometry.contains(shapely.Point(5.0, 0.0))
