"""Obstacles (section 4.1): components of impassable relations and outline polygons."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
import shapely

from modeling.model.obstacles import components, hulls


def test_components_label_each_node_with_the_smallest_node_of_its_component() -> None:
    rng = np.random.default_rng(2)
    for n, m in [(0, 0), (1, 0), (6, 0), (30, 20), (200, 150), (50, 400)]:
        i, j = rng.integers(0, max(n, 1), m), rng.integers(0, max(n, 1), m)
        graph = nx.Graph()
        graph.add_nodes_from(range(n))
        graph.add_edges_from(zip(i.tolist(), j.tolist(), strict=True))
        want = np.empty(n, dtype=np.int64)
        for comp in nx.connected_components(graph):
            want[list(comp)] = min(comp)
        got = components(n, i, j)
        assert got.dtype == np.int64
        assert np.array_equal(got, want)
    # a long chain, given in either direction, is one component
    chain = np.arange(4999)
    assert not components(5000, chain, chain + 1).any()
    assert not components(5000, chain[::-1] + 1, chain[::-1]).any()


def test_outline_polygons_are_the_convex_hulls_or_the_rectangles_of_flat_sets() -> None:
    rng = np.random.default_rng(4)
    spread = rng.normal(size=(7, 2))  # a proper hull
    on_line = np.array([[0.0, 0.0], [2.0, 1.0], [1.0, 0.5], [-1.0, -0.5]])  # collinear
    one_point = np.array([[3.0, 3.0], [3.0, 3.0]])  # coincident
    pair = np.array([[0.0, 1.0], [0.0, 2.0]])  # two points
    sets = [spread, on_line, one_point, pair]
    points = np.concatenate(sets)
    index = np.repeat(np.arange(4), [len(s) for s in sets])
    out = hulls(points, index, 4, np.array([0.1, 0.1, 0.2, 0.05]))
    assert len(out) == 4 and all(not p.flags.writeable for p in out)
    # the hull: GEOS's own, counter-clockwise, not closed
    want = shapely.convex_hull(shapely.MultiPoint(spread))
    got = shapely.Polygon(out[0])
    assert got.is_valid and got.exterior.is_ccw
    assert out[0].shape[0] == len(want.exterior.coords) - 1
    assert got.symmetric_difference(want).area < 1e-12
    # a collinear set: the rectangle 2 grow wide around its extreme points (-1, -0.5)..(2, 1)
    ext = np.hypot(3.0, 1.5)
    assert shapely.Polygon(out[1]).area == pytest.approx((ext + 0.2) * 0.2)
    assert shapely.Polygon(out[1]).exterior.is_ccw
    assert shapely.Polygon(out[1]).contains(shapely.LineString(on_line[[3, 1]]))
    # coincident points: a square of side 2 grow, along x
    np.testing.assert_allclose(out[2], [[2.8, 2.8], [3.2, 2.8], [3.2, 3.2], [2.8, 3.2]])
    # two points: the rectangle of the segment, 0.1 wide
    np.testing.assert_allclose(out[3], [[0.05, 0.95], [0.05, 2.05], [-0.05, 2.05], [-0.05, 0.95]])
    assert hulls(points[:0], index[:0], 0, 0.1) == []
