"""Bad input is a ValueError naming it; degenerate-but-legal input gives a valid empty result."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modeling.gaps import gap_passable_probability, gap_passable_probability_batch
from modeling.model import build_model
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

C = np.eye(2) * 1e-4


def good_seg() -> FloorSegment:
    return FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, C]))


def test_nan_coordinates() -> None:
    with pytest.raises(ValueError, match="endpoints"):
        FloorSegment(endpoints=np.array([[0.0, np.nan], [1.0, 0.0]]), cov=np.stack([C, C]))
    with pytest.raises(ValueError, match="mean_a"):
        gap_passable_probability([np.nan, 0], C, [1, 0], C, 0.5)
    with pytest.raises(ValueError, match="mean_b"):
        gap_passable_probability_batch([[0, 0]], [C], [[np.inf, 0]], [C], 0.5)


def test_nan_covariance_and_width() -> None:
    with pytest.raises(ValueError, match="cov_a"):
        gap_passable_probability([0, 0], [[np.nan, 0], [0, 1e-4]], [1, 0], C, 0.5)
    with pytest.raises(ValueError, match="cov"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, C * np.nan]))
    with pytest.raises(ValueError, match="robot_width_m"):
        build_model(FloorObservation(), float("nan"))
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability([0, 0], C, [1, 0], C, float("inf"))


def test_non_symmetric_covariance() -> None:
    bad = np.array([[1e-4, 5e-5], [0.0, 1e-4]])
    with pytest.raises(ValueError, match=r"cov.*symmetric"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([bad, C]))
    with pytest.raises(ValueError, match="cov_a must be symmetric"):
        gap_passable_probability([0, 0], bad, [1, 0], C, 0.5)


def test_non_positive_definite_covariance() -> None:
    bad = np.array([[1e-4, 2e-4], [2e-4, 1e-4]])
    with pytest.raises(ValueError, match=r"cov.*positive definite"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, bad]))
    with pytest.raises(ValueError, match="cov_b must be positive definite"):
        gap_passable_probability([0, 0], C, [1, 0], bad, 0.5)
    with pytest.raises(ValueError, match="cov_b"):
        gap_passable_probability([0, 0], C, [1, 0], -C, 0.5)


def test_probabilities_not_summing_to_one() -> None:
    with pytest.raises(ValueError, match="probabilities must sum to 1"):
        AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(0.5, 0.4))


def test_negative_width() -> None:
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability([0, 0], C, [1, 0], C, -0.1)
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability_batch([[0, 0]], [C], [[1, 0]], [C], -0.1)
    with pytest.raises(ValueError, match="robot_width_m"):
        build_model(FloorObservation(), -0.5)


def test_bad_model_arguments() -> None:
    obs = FloorObservation(segments=(good_seg(),))
    with pytest.raises(ValueError, match="eps"):
        build_model(obs, 0.5, eps=0.6)
    with pytest.raises(ValueError, match="max_situations"):
        build_model(obs, 0.5, max_situations=0)
    with pytest.raises(ValueError, match="min_isolated_length_m"):
        build_model(obs, 0.5, min_isolated_length_m=-1.0)
    with pytest.raises(ValueError, match="observation"):
        build_model([good_seg()], 0.5)  # type: ignore[arg-type]


def test_empty_observation_gives_one_certain_empty_situation() -> None:
    m = build_model(FloorObservation(), 0.5)
    (s,) = m.situations
    assert s.probability == 1.0
    assert s.obstacles == () and s.critical_regions == ()
    assert m.residual_probability == 0.0
    assert m.occluded == ()
    assert len(m.relations) == 0
    g = s.path_graph([0, 0], [3, 0])
    assert g.has_edge("start", "goal")


def test_single_segment_is_one_obstacle() -> None:
    m = build_model(FloorObservation(segments=(good_seg(),)), 0.5)
    (s,) = m.situations
    assert len(s.obstacles) == 1
    assert s.obstacles[0].polygon.shape[1] == 2 and s.obstacles[0].polygon.shape[0] >= 3


def test_fast_record_constructors_make_the_same_frozen_objects() -> None:
    import dataclasses

    from modeling.model import CriticalRegion, Passage, _make_region, _record_maker

    a, b = np.zeros((4, 2)), np.ones((2, 2))
    fast = _make_region((0, 1), a, 0.6, 0.05, 0.4, b, (3, 7), np.zeros((2, 2, 2)))
    slow = CriticalRegion(
        obstacles=(0, 1),
        polygon=a,
        width_mean_m=0.6,
        width_std_m=0.05,
        p_passable=0.4,
        narrowest=b,
        relations=(3, 7),
        relation_lines=fast.relation_lines,
    )
    for f in dataclasses.fields(CriticalRegion):
        assert getattr(fast, f.name) is getattr(slow, f.name) or getattr(fast, f.name) == getattr(
            slow, f.name
        )
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.p_passable = 1.0  # type: ignore[misc]
    # The field list must be the class's own (order is the caller's, checked by name).
    with pytest.raises(TypeError, match="Passage"):
        _record_maker(Passage, ("obstacles", "narrowest", "width_mean_m", "p_passable"))


def test_outline_polygons_are_the_convex_hulls_or_the_rectangles_of_flat_sets() -> None:
    import shapely

    from modeling.model import _hulls

    rng = np.random.default_rng(4)
    spread = rng.normal(size=(7, 2))  # a proper hull
    on_line = np.array([[0.0, 0.0], [2.0, 1.0], [1.0, 0.5], [-1.0, -0.5]])  # collinear
    one_point = np.array([[3.0, 3.0], [3.0, 3.0]])  # coincident
    pair = np.array([[0.0, 1.0], [0.0, 2.0]])  # two points
    sets = [spread, on_line, one_point, pair]
    points = np.concatenate(sets)
    index = np.repeat(np.arange(4), [len(s) for s in sets])
    grow = np.array([0.1, 0.1, 0.2, 0.05])
    out = _hulls(points, index, 4, grow)
    assert len(out) == 4 and all(not p.flags.writeable for p in out)
    # the hull: GEOS's own, counter-clockwise, not closed
    want = shapely.convex_hull(shapely.MultiPoint(spread))
    got = shapely.Polygon(out[0])
    assert got.is_valid and shapely.Polygon(out[0]).exterior.is_ccw
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
    assert _hulls(points[:0], index[:0], 0, 0.1) == []


def test_components_label_each_node_with_the_smallest_node_of_its_component() -> None:
    import networkx as nx

    from modeling.model import _components

    rng = np.random.default_rng(2)
    for n, m in [(0, 0), (1, 0), (6, 0), (30, 20), (200, 150), (50, 400)]:
        i, j = rng.integers(0, max(n, 1), m), rng.integers(0, max(n, 1), m)
        graph = nx.Graph()
        graph.add_nodes_from(range(n))
        graph.add_edges_from(zip(i.tolist(), j.tolist(), strict=True))
        want = np.empty(n, dtype=np.int64)
        for comp in nx.connected_components(graph):
            want[list(comp)] = min(comp)
        assert np.array_equal(_components(n, i, j), want)
    # a long chain, given in either direction, is one component
    chain = np.arange(4999)
    assert not _components(5000, chain, chain + 1).any()
    assert not _components(5000, chain[::-1] + 1, chain[::-1]).any()


# ------------------------------------------------------------------ scalar validators and options
@dataclasses.dataclass(frozen=True, kw_only=True)
class _Leaf:
    x: int = 1
    y: float = 2.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Tree:
    leaf: _Leaf = dataclasses.field(default_factory=_Leaf)
    z: str = "q"


def test_scalar_validators_accept_and_name_bad_values() -> None:
    from modeling.validation import boolean, integer, number

    assert number(3, "a", low=0.0) == 3.0
    assert number(0.0, "a", low=0.0, strict=False) == 0.0
    assert integer(np.int64(4), "n", low=1) == 4
    assert boolean(False, "flag") is False
    for bad in (True, float("nan"), float("inf"), "1", None):
        with pytest.raises(ValueError, match=r"^a must be a finite number"):
            number(bad, "a")
    with pytest.raises(ValueError, match="a must be > 0"):
        number(0.0, "a", low=0.0)
    with pytest.raises(ValueError, match="a must be <= 1"):
        number(1.5, "a", high=1.0, strict=False)
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        integer(0, "n", low=1)
    with pytest.raises(ValueError, match="n must be an integer"):
        integer(True, "n")
    with pytest.raises(ValueError, match="flag must be True or False"):
        boolean(1, "flag")


def test_from_flat_maps_flat_and_nested_keys() -> None:
    from modeling.validation import from_flat

    assert from_flat(_Tree, {"x": 5, "z": "w"}) == _Tree(leaf=_Leaf(x=5), z="w")
    assert from_flat(_Tree, {"leaf": {"y": 3.0}, "x": 7}) == _Tree(leaf=_Leaf(x=7, y=3.0))
    assert from_flat(_Tree, {"leaf": _Leaf(x=9), "y": 1.5}) == _Tree(leaf=_Leaf(x=9, y=1.5))
    assert from_flat(_Tree, {}) == _Tree()
    with pytest.raises(ValueError, match=r"unknown _Tree option\(s\) \['bad'\]; known: \['leaf'"):
        from_flat(_Tree, {"bad": 1})
    with pytest.raises(ValueError, match=r"unknown _Tree\.leaf option"):
        from_flat(_Tree, {"leaf": {"w": 1}})
    with pytest.raises(ValueError, match="leaf must be a _Leaf or a dict, got int"):
        from_flat(_Tree, {"leaf": 3})


def test_with_overrides_replaces_named_fields_only() -> None:
    from modeling.validation import with_overrides

    assert with_overrides(None, _Leaf, {}) == _Leaf()
    assert with_overrides(_Leaf(x=2), _Leaf, {"y": 0.5}) == _Leaf(x=2, y=0.5)
    with pytest.raises(ValueError, match=r"unknown _Leaf option\(s\) \['q'\]"):
        with_overrides(None, _Leaf, {"q": 1})
    with pytest.raises(ValueError, match="options must be a _Leaf, got _Tree"):
        with_overrides(_Tree(), _Leaf, {})
