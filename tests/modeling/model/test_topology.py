"""The graph of possible paths of a situation (modeling.model.topology): gates, routes,
clearance."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
import shapely

from modeling.model.build import build_model
from modeling.model.topology import model_routes, path_graph, routes, situation_graph
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

W = 0.5  # robot width, metres
R = W / 2


def seg(a, b, sigma: float = 0.01) -> FloorSegment:
    return FloorSegment(
        endpoints=np.array([a, b], dtype=float), cov=np.stack([np.eye(2) * sigma**2] * 2)
    )


def observe(segments, ambiguous=()) -> FloorObservation:
    return FloorObservation(
        segments=tuple(segments), ambiguous=tuple(ambiguous), viewpoint=np.array([0.0, -5, 1.57])
    )


def long_wall(gaps: list[tuple[float, float]], half: float = 20.0) -> list[FloorSegment]:
    """A wall along y = 0 from -half to half with the given (x0, x1) openings."""
    xs = [-half] + [x for g in gaps for x in g] + [half]
    return [seg((xs[k], 0.0), (xs[k + 1], 0.0)) for k in range(0, len(xs), 2)]


def test_two_undecided_gaps_give_two_routes_with_their_probabilities() -> None:
    # Two openings exactly as wide as the robot: two critical regions, p near 0.5 each.
    m = build_model(observe(long_wall([(-1.75, -1.25), (1.25, 1.75)])), W)
    (s,) = m.situations
    assert [r.obstacles for r in s.critical_regions] == [(0, 1), (1, 2)]
    g = situation_graph(m, 0, [0.0, -2.0], [0.0, 2.0])
    gates = [e for e in g.edges(data=True) if e[2]["kind"] == "critical"]
    assert sorted(e[2]["region"] for e in gates) == [0, 1]
    found = routes(g, max_routes=3)
    assert [r.regions for r in found[:2]] in ([(0,), (1,)], [(1,), (0,)])
    for r in found[:2]:
        (k,) = r.regions
        assert r.p_passable == pytest.approx(s.critical_regions[k].p_passable)
        assert 0.3 < r.p_passable < 0.7
        # Through the opening: about 2 * hypot(1.5, 2) long, and the waypoints cross y = 0 there.
        assert 5.0 <= r.length_m < 5.6
        (a, b) = r.waypoints[np.flatnonzero(np.diff(np.sign(r.waypoints[:, 1])))[0] :][:2]
        x_at_0 = a[0] + (b[0] - a[0]) * a[1] / (a[1] - b[1])
        assert abs(abs(x_at_0) - 1.5) < 0.25
    # The third route goes around the end of the wall: certain and long.
    assert found[2].regions == () and found[2].p_passable == 1.0
    assert found[2].length_m > 38.0
    # The same from the situation itself.
    again = s.routes([0.0, -2.0], [0.0, 2.0], max_routes=3)
    assert [(r.regions, r.length_m) for r in again] == [(r.regions, r.length_m) for r in found]


def test_a_closed_enclosure_has_no_route() -> None:
    c = [(-2, -2), (2, -2), (2, 2), (-2, 2)]
    box = [seg(c[k], c[(k + 1) % 4]) for k in range(4)]
    m = build_model(observe(box), W)
    g = situation_graph(m, m.situations[0], [0.0, -4.0], [0.0, 0.0])
    assert not nx.has_path(g, "start", "goal")
    assert routes(g) == []
    # From inside to inside: the direct route.
    (r,) = routes(situation_graph(m, 0, [-1.0, -1.0], [1.0, 1.0]), max_routes=1)
    assert r.nodes == ("start", "goal") and r.length_m == pytest.approx(math.sqrt(8))


def test_a_clear_gap_and_an_undecided_one() -> None:
    # A 1.2 m opening (clear) and a 0.5 m one (undecided): a certain and an uncertain route.
    m = build_model(observe(long_wall([(-2.6, -1.4), (1.25, 1.75)])), W)
    (s,) = m.situations
    (reg,) = s.critical_regions
    found = routes(path_graph(s, [0.0, -2.0], [0.0, 2.0]), max_routes=2)
    assert sorted(r.regions for r in found) == [(), (0,)]
    certain = next(r for r in found if r.regions == ())
    assert certain.p_passable == 1.0
    uncertain = next(r for r in found if r.regions == (0,))
    assert uncertain.p_passable == pytest.approx(reg.p_passable)


def test_routes_follow_a_concave_obstacle() -> None:
    # A U of walls open towards -y, the goal inside it, the start below: in through the opening.
    u_walls = [seg((-2, 0), (-2, 3)), seg((-2, 3), (2, 3)), seg((2, 3), (2, 0))]
    m = build_model(observe(u_walls), W)
    (r,) = routes(situation_graph(m, 0, [0.0, -3.0], [0.0, 2.0]), max_routes=1)
    assert r.length_m == pytest.approx(5.0)  # straight in
    (r,) = routes(situation_graph(m, 0, [0.0, 5.0], [0.0, 2.0]), max_routes=1)
    # From above: around a corner of the U and in, at least 2 + 5 + 2 metres.
    assert r.length_m > 8.5 and r.p_passable == 1.0


def test_free_edges_keep_the_robot_off_every_obstacle() -> None:
    rng = np.random.default_rng(4)
    segs = []
    for _ in range(25):
        a = rng.uniform(0, 8, 2)
        ang = rng.uniform(0, math.pi)
        segs.append(seg(a, a + rng.uniform(0.2, 1.5) * np.array([math.cos(ang), math.sin(ang)])))
    m = build_model(observe(segs), W)
    for s in m.situations:
        g = path_graph(s, [-1.0, -1.0], [9.0, 9.0])
        skeleton = shapely.MultiLineString(
            [ln for o in s.obstacles for ln in (o.lines if len(o.lines) else [])]
        )
        barriers = shapely.union_all([shapely.Polygon(r.polygon) for r in s.critical_regions])
        n_free = 0
        for u, v, e in g.edges(data=True):
            if e["kind"] != "free" or {g.nodes[u]["kind"], g.nodes[v]["kind"]} & {
                "start",
                "goal",
                "region",
                "passage",
            }:
                continue
            line = shapely.LineString([g.nodes[u]["xy"], g.nodes[v]["xy"]])
            assert line.distance(skeleton) >= R - 1e-9
            assert not line.intersects(barriers)
            n_free += 1
        assert n_free > 20
        # Every edge carries what a planner needs.
        for _, _, e in g.edges(data=True):
            assert e["length_m"] >= 0 and 0.0 <= e["p_passable"] <= 1.0
            assert e["kind"] in ("free", "critical", "passage")


def test_model_routes_per_situation() -> None:
    # One opening of 1.2 m; an ambiguous segment closes it (p = 0.7) or lies far away (0.3).
    wall = long_wall([(-0.6, 0.6)])
    door = AmbiguousSegment(
        candidates=(seg((-0.6, 0.0), (0.6, 0.0)), seg((-10.0, 10.0), (-9.0, 10.0))),
        probabilities=(0.7, 0.3),
    )
    m = build_model(observe(wall, [door]), W)
    assert [s.probability for s in m.situations] == pytest.approx([0.7, 0.3])
    per_situation = model_routes(m, [0.0, -2.0], [0.0, 2.0], max_routes=1)
    assert len(per_situation) == 2
    closed, open_ = per_situation[0][0], per_situation[1][0]
    assert open_.length_m == pytest.approx(4.0, abs=0.01)  # straight through
    assert closed.length_m > 38.0  # around the wall


def test_graph_api_and_bad_input() -> None:
    m = build_model(observe(long_wall([(1.25, 1.75)])), W)
    with pytest.raises(ValueError, match="situation"):
        situation_graph(m, 5, [0, -2], [0, 2])
    other = build_model(observe([seg((0, 0), (1, 0))]), W)
    with pytest.raises(ValueError, match="situation"):
        situation_graph(m, other.situations[0], [0, -2], [0, 2])
    with pytest.raises(ValueError, match="start_xy"):
        situation_graph(m, 0, [np.nan, 0], [0, 2])
    with pytest.raises(ValueError, match="robot_width_m"):
        situation_graph(m, 0, [0, -2], [0, 2], robot_width_m=-1.0)
    g = situation_graph(m, 0, [0, -2], [0, 2])
    with pytest.raises(ValueError, match="max_routes"):
        routes(g, max_routes=0)
    # The clearance of free edges is the robot's: a 1.2 m opening lets a 0.5 m robot through
    # straight, not a 1.5 m one (the critical regions stay those of the model's width).
    clear = build_model(observe(long_wall([(-0.6, 0.6)])), W)
    (narrow,) = routes(situation_graph(clear, 0, [0, -2], [0, 2]), max_routes=1)
    assert narrow.length_m == pytest.approx(4.0)
    (wide,) = routes(situation_graph(clear, 0, [0, -2], [0, 2], robot_width_m=1.5), max_routes=1)
    assert wide.length_m > 38.0
    plain = routes(g, max_routes=4, distinct=False)
    assert [r.length_m for r in plain] == sorted(r.length_m for r in plain)
    assert g.nodes["start"]["kind"] == "start" and g.nodes["goal"]["kind"] == "goal"


def test_a_narrow_clear_opening_is_a_passage_gate() -> None:
    # 0.6 m for a 0.5 m robot with 1 cm sigma: clearly passable, but close enough to be examined:
    # a passage, whose gate the route must take (its line is a barrier for free edges).
    m = build_model(observe(long_wall([(-0.3, 0.3)])), W)
    (s,) = m.situations
    assert s.critical_regions == ()
    (pas,) = s.passages
    assert pas.width_mean_m == pytest.approx(0.6) and pas.p_passable > 1 - m.eps
    g = situation_graph(m, 0, [0.0, -2.0], [0.0, 2.0])
    (r,) = routes(g, max_routes=1)
    assert r.passages == (0,) and r.regions == ()
    assert r.p_passable == pytest.approx(pas.p_passable)
    assert r.length_m == pytest.approx(4.0, abs=0.2)
