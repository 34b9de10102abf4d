"""Exact expectations built on the paper's figures (Miura, ICRA-94, Figs. 2-10)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely

from modeling.model.build import build_model
from modeling.model.gaps import Relation, gap_passable_probability
from modeling.model.items import isolated_short_segments, item_relations, items_of
from modeling.model.topology import path_graph, routes
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

W = 0.5  # robot width, metres


def seg(a, b, sigma: float = 0.01) -> FloorSegment:
    return FloorSegment(
        endpoints=np.array([a, b], dtype=float), cov=np.stack([np.eye(2) * sigma**2] * 2)
    )


def box(x0: float, y0: float, x1: float, y1: float, sigma: float = 0.01) -> list[FloorSegment]:
    c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return [seg(c[k], c[(k + 1) % 4], sigma) for k in range(4)]


def amb(cands: list[FloorSegment], probs: list[float]) -> AmbiguousSegment:
    return AmbiguousSegment(candidates=tuple(cands), probabilities=tuple(probs))


def observe(segments, ambiguous=()) -> FloorObservation:
    return FloorObservation(
        segments=tuple(segments),
        ambiguous=tuple(ambiguous),
        viewpoint=np.array([0.0, -5.0, 1.5708]),
    )


def test_two_boxes_far_apart_give_two_obstacles_and_no_critical_region() -> None:
    m = build_model(observe(box(0, 0, 1, 1) + box(3, 0, 4, 1)), W)
    (s,) = m.situations
    assert s.probability == 1.0 and m.residual_probability == 0.0
    assert sorted(o.segments for o in s.obstacles) == [(0, 1, 2, 3), (4, 5, 6, 7)]
    assert s.critical_regions == ()


def test_gap_narrower_than_robot_gives_one_obstacle() -> None:
    m = build_model(observe(box(0, 0, 1, 1) + box(1.3, 0, 2.3, 1)), W)  # 0.3 m gap
    (s,) = m.situations
    assert len(s.obstacles) == 1
    assert s.obstacles[0].segments == tuple(range(8))
    assert s.critical_regions == ()
    assert m.relations.kind_of(1, 7) is Relation.IMPASSABLE  # facing sides of the two boxes


def test_gap_equal_to_robot_width_gives_one_critical_region_near_half() -> None:
    m = build_model(observe(box(0, 0, 1, 1) + box(1.5, 0, 2.5, 1)), W)  # gap exactly 0.5 m
    (s,) = m.situations
    assert len(s.obstacles) == 2
    (reg,) = s.critical_regions
    assert reg.obstacles == (0, 1)
    # The narrowest relation joins the middles of the facing sides, x = 1 and x = 1.5, whose
    # points have half the endpoint variance each (interpolated at t = 1/2): d ~ N(0.5, 1e-4 I).
    np.testing.assert_allclose(reg.narrowest, [[1.0, 0.5], [1.5, 0.5]], atol=1e-12)
    half = np.eye(2) * 0.5e-4
    exact = gap_passable_probability([1.0, 0.5], half, [1.5, 0.5], half, W)
    assert reg.p_passable == pytest.approx(exact, abs=1e-4)
    assert reg.p_passable == pytest.approx(0.504, abs=0.001)  # a little over 1/2: curvature
    assert reg.width_mean_m == pytest.approx(
        0.5 + 0.5e-4 / 0.5, abs=1e-5
    )  # E|d| ~ |mu| + s^2/2|mu|
    assert reg.width_std_m == pytest.approx(0.01, abs=1e-4)
    # Every undecided relation between the two boxes is in the region: the facing sides, the
    # bottom and top sides' near corners, and the corner-to-side pairs.
    assert len(reg.relations) >= 3
    assert all(m.relations.kind[r] == Relation.UNDECIDED for r in reg.relations)
    poly = shapely.Polygon(reg.polygon)
    assert all(poly.buffer(1e-9).covers(shapely.LineString(ln)) for ln in reg.relation_lines)
    # The path graph crosses the region with its probability.
    g = path_graph(s, [1.25, -1.0], [1.25, 2.0])
    best = max(routes(g, max_routes=8), key=lambda r: (r.regions == (0,), -r.length_m))
    assert best.regions == (0,)
    assert best.p_passable == pytest.approx(reg.p_passable)
    crit = [e for e in g.edges(data=True) if e[2]["kind"] == "critical"]
    assert len(crit) == 1 and crit[0][2]["region"] == 0


def test_gap_in_the_middle_of_a_long_wall_is_found() -> None:
    # A wall and a short post in front of its middle, 0.3 m away: impassable although every
    # endpoint pair is far apart.
    m = build_model(observe([seg((0, 0), (6, 0)), seg((2.9, 0.3), (3.1, 0.3))]), W)
    assert len(m.situations[0].obstacles) == 1
    assert m.relations.kind_of(0, 1) is Relation.IMPASSABLE


def test_fig8_common_effect_merges_obstacles_and_eliminates_the_segment() -> None:
    A = box(0, 0, 1, 1)
    C = box(2.2, 0, 3.2, 1)  # 1.2 m gap: passable without the ambiguous segments
    q = amb([seg((1.0, 0.5), (2.2, 0.5)), seg((1.0, 0.8), (2.2, 0.8))], [0.6, 0.4])
    # p: one position extends A, the other is a long free-standing segment: an obstacle in one
    # choice only, a change of the topology of paths (a new obstacle to go around): p stays.
    p = amb([seg((-1.5, 0.5), (0.0, 0.5)), seg((-6.0, 4.0), (-4.5, 4.0))], [0.7, 0.3])
    m = build_model(observe(A + C, [q, p]), W)
    assert m.eliminated_ambiguous == (0,)
    assert m.merged_ambiguous == {0: 0}
    assert m.units == ((1,),) and m.groups == ((1,),)
    assert [s.probability for s in m.situations] == pytest.approx([0.7, 0.3])
    extended, apart = m.situations
    assert extended.choice == {1: 0} and apart.choice == {1: 1}
    assert len(extended.obstacles) == 1 and len(apart.obstacles) == 2
    for s in m.situations:  # q's most probable position closes A-C in both
        assert s.obstacles[0].segments == tuple(range(8))
        assert (0, 0) in s.obstacles[0].candidates
    # p': both positions extend A (no change of the paths): eliminated, dropped
    p2 = amb([seg((-1.5, 0.5), (0.0, 0.5)), seg((-1.5, 0.2), (0.0, 0.2))], [0.7, 0.3])
    m2 = build_model(observe(A + C, [q, p2]), W)
    assert m2.eliminated_ambiguous == (0, 1) and m2.merged_ambiguous == {0: 0}
    (s2,) = m2.situations
    assert s2.obstacles[0].candidates == ((0, 0),)


def test_an_object_seen_only_through_ambiguous_segments_stays_in_every_situation() -> None:
    # Issue 16b: a free-standing object (two faces moving together, 2 m or 3.5 m ahead, nowhere
    # near the wall) is present in every choice. It changes the topology of paths and must not
    # vanish: every position is a new obstacle, so it is merged at its most probable position.
    wall = [seg((-4.0, 8.0), (4.0, 8.0))]
    near = [seg((-0.3, 2.0), (0.3, 2.0)), seg((0.3, 2.0), (0.3, 2.4))]
    far = [seg((-0.3, 3.5), (0.3, 3.5)), seg((0.3, 3.5), (0.3, 3.9))]
    ambs = [amb([near[k], far[k]], [0.7, 0.3]) for k in range(2)]
    m = build_model(observe(wall, ambs), W)
    assert m.merged_ambiguous == {0: 0, 1: 0} and m.units == ()
    (s,) = m.situations
    assert s.probability == 1.0
    assert sorted(o.candidates for o in s.obstacles) == [(), ((0, 0), (1, 0))]
    obj = next(o for o in s.obstacles if o.candidates)
    assert shapely.Polygon(obj.polygon).buffer(0.05).contains(shapely.Point(0.0, 2.1))
    # with a "none" mass the object may be absent: its choices differ, it stays a unit
    ambs_none = [amb([near[k], far[k]], [0.5, 0.3]) for k in range(2)]
    m_none = build_model(observe(wall, ambs_none), W)
    assert m_none.units == ((0, 1),) and m_none.merged_ambiguous == {}
    assert [len(s.obstacles) for s in m_none.situations] == [2, 2, 1]
    assert [s.probability for s in m_none.situations] == pytest.approx([0.5, 0.3, 0.2])


def test_fig9_independent_groups() -> None:
    A = box(0, 0, 1, 2)
    B = box(3, 0, 4, 2)
    C = box(1.5, 4, 2.5, 5)
    far = [(-8.0, -8.0), (8.0, -8.0), (-8.0, 8.0), (8.0, 8.0), (0.0, 10.0)]

    def far_seg(k: int) -> FloorSegment:
        x, y = far[k]
        return seg((x, y), (x + 0.6, y))

    p = amb([seg((1.0, 0.2), (3.0, 0.2)), far_seg(0)], [0.5, 0.5])  # space A-B
    q = amb([seg((1.0, 1.2), (3.0, 1.2)), far_seg(1)], [0.6, 0.4])  # space A-B
    r = amb([seg((4.0, 2.0), (2.5, 4.0)), far_seg(2)], [0.7, 0.3])  # space B-C
    s_ = amb([seg((3.0, 2.0), (2.5, 4.2)), seg((1.0, 2.0), (1.5, 4.2))], [0.5, 0.5])  # B-C or A-C
    t = amb([seg((0.0, 2.0), (1.5, 4.0)), far_seg(4)], [0.8, 0.2])  # space A-C
    m = build_model(observe(A + B + C, [p, q, r, s_, t]), W)
    # p and q never touch each other: they are grouped because they affect the same space.
    n = len(A + B + C)
    assert m.relations.kind_of(n + 0, n + 2) is Relation.PASSABLE
    assert m.eliminated_ambiguous == ()
    assert m.units == ((0,), (1,), (2,), (3,), (4,))
    assert m.groups == ((0, 1), (2, 3, 4))
    assert len(m.situations) == 32
    assert sum(s.probability for s in m.situations) == pytest.approx(1.0)


def test_fig10_eight_situations_with_eq2_probabilities() -> None:
    A, B, C, D = box(0, 0, 1, 1), box(2.5, 0, 3.5, 1), box(5, 0, 6, 1), box(7.5, 0, 8.5, 1)
    probs = [(0.7, 0.3), (0.6, 0.4), (0.55, 0.45)]
    ambs = [
        amb([seg((1.0, 0.5), (2.5, 0.5)), seg((1.0, 6.0), (1.8, 6.0))], list(probs[0])),
        amb([seg((3.5, 0.5), (5.0, 0.5)), seg((3.5, 9.0), (4.3, 9.0))], list(probs[1])),
        amb([seg((6.0, 0.5), (7.5, 0.5)), seg((6.0, 12.0), (6.8, 12.0))], list(probs[2])),
    ]
    m = build_model(observe(A + B + C + D, ambs), W, max_situations=64)
    assert len(m.situations) == 8
    expected = sorted((a * b * c for a, b, c in itertools.product(*probs)), reverse=True)
    got = [s.probability for s in m.situations]
    assert got == pytest.approx(expected, abs=1e-12)
    assert math.fsum(got) + m.residual_probability == pytest.approx(1.0, abs=1e-12)
    assert m.residual_probability == pytest.approx(0.0, abs=1e-12)
    for s in m.situations:
        assert s.probability == pytest.approx(
            math.prod(probs[a][c] for a, c in s.choice.items()), abs=1e-15
        )
        # Each bridging choice joins two neighbouring boxes.
        n_bridges = sum(c == 0 for c in s.choice.values())
        assert len([o for o in s.obstacles if o.segments]) == 4 - n_bridges
    # Bounded enumeration: the top 3 with the rest as residual.
    m3 = build_model(observe(A + B + C + D, ambs), W, max_situations=3)
    assert [s.probability for s in m3.situations] == pytest.approx(expected[:3])
    assert m3.residual_probability == pytest.approx(sum(expected[3:]))


def test_fig7_segments_moving_together_count_once() -> None:
    A, B = box(0, 0, 1, 1), box(2.0, 0, 3, 1)  # 1.0 m gap
    # Two short segments side by side; both have the same two candidate positions (in the gap,
    # or 3 m further away): one object.
    a1 = amb([seg((1.0, 0.5), (1.5, 0.5)), seg((1.0, 3.5), (1.5, 3.5))], [0.7, 0.3])
    a2 = amb([seg((1.55, 0.5), (2.0, 0.5)), seg((1.55, 3.5), (2.0, 3.5))], [0.7, 0.3])
    m = build_model(observe(A + B, [a1, a2]), W)
    assert m.units == ((0, 1),)
    assert len(m.situations) == 2
    assert [s.probability for s in m.situations] == pytest.approx([0.7, 0.3])
    assert m.situations[0].choice == {0: 0, 1: 0}
    assert len(m.situations[0].obstacles) == 1  # the gap is closed
    assert m.situations[1].choice == {0: 1, 1: 1}


def test_isolated_short_segments_are_eliminated() -> None:
    m = build_model(observe([*box(0, 0, 1, 1), seg((5, 5), (5.05, 5))]), W)
    assert m.eliminated_segments == (4,)
    assert m.kept_segments == (0, 1, 2, 3)
    assert len(m.situations[0].obstacles) == 1


def _vertical_edge(x: float, y: float, low: float, high: float) -> FloorSegment:
    """A vertical edge as triangulation makes it: both ends at one floor point, two heights."""
    cov = np.array([[0.02**2, 0.0], [0.0, 0.05**2]])  # elongated in depth
    return FloorSegment(
        endpoints=np.array([[x, y], [x, y]]),
        cov=np.stack([cov, cov]),
        height_m=np.array([high, low]),
    )


def test_isolated_vertical_edges_are_judged_by_their_3d_length() -> None:
    # Issue 16a: four table legs 0.75 m tall, 1.0 and 1.2 m apart: every leg is isolated (the
    # gaps pass the 0.5 m robot) and zero long on the floor, but 0.7 m long in 3D: all are kept.
    legs = [_vertical_edge(x, y, 0.05, 0.75) for x in (-0.5, 0.5) for y in (1.0, 2.2)]
    assert legs[0].length_m == 0.0 and legs[0].length_3d_m == pytest.approx(0.7)
    m = build_model(observe(legs), W)
    assert m.kept_segments == (0, 1, 2, 3) and m.eliminated_segments == ()
    (s,) = m.situations
    assert sorted(o.segments for o in s.obstacles) == [(0,), (1,), (2,), (3,)]
    # a segment short in 3D (3 cm on the floor, 5 cm of height) is still dropped as isolated
    short = FloorSegment(
        endpoints=np.array([[3.0, 3.0], [3.03, 3.0]]),
        cov=np.stack([np.eye(2) * 1e-4] * 2),
        height_m=np.array([0.35, 0.30]),
    )
    assert short.length_3d_m == pytest.approx(math.hypot(0.03, 0.05))
    m2 = build_model(observe([*legs, short]), W)
    assert m2.eliminated_segments == (4,) and m2.kept_segments == (0, 1, 2, 3)
    # an ambiguous segment whose every candidate is a short isolated point is dropped as
    # isolated; one whose candidates are legs is not
    dots = [_vertical_edge(6.0, 6.0, 0.3, 0.33), _vertical_edge(6.0, 8.0, 0.3, 0.33)]
    tall = [_vertical_edge(-6.0, 6.0, 0.05, 0.7), _vertical_edge(-6.0, 8.0, 0.05, 0.7)]
    items = items_of(observe(legs, [amb(dots, [0.6, 0.4]), amb(tall, [0.6, 0.4])]))
    rel = item_relations(items, W, 0.05)
    isolation = isolated_short_segments(items, rel, 0.1)
    assert isolation.eliminated_ambiguous == [0] and isolation.live_ambiguous == [1]
    assert isolated_short_segments(items, rel, 0.7).eliminated_ambiguous == [0, 1]


def test_occlusion_is_behind_the_obstacle() -> None:
    import shapely

    m = build_model(observe(box(-0.5, 0, 0.5, 1)), W)  # viewpoint at (0, -5) looking +y
    occ = m.occluded_geometry
    assert occ.contains(shapely.Point(0.0, 2.0))  # behind the box
    assert not occ.contains(shapely.Point(0.0, -1.0))  # in front of it
    assert not occ.contains(shapely.Point(2.0, 0.5))  # beside it, visible
    assert len(m.occluded) >= 1


def test_plot_model_draws_one_panel_per_situation_like_figs_6_and_11() -> None:
    import io
    import subprocess
    import sys

    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon as MplPolygon
    from matplotlib.text import Text

    from modeling.plotting import legend_handles, plot_model, region_label

    A, B = box(0, 0, 1, 1), box(1.5, 0, 2.5, 1)  # a 0.5 m gap: one critical region
    a1 = amb([seg((1.0, 0.5), (1.5, 0.5)), seg((1.0, 3.0), (1.5, 3.0))], [0.6, 0.4])
    m = build_model(observe(A + B, [a1]), W)
    assert len(m.situations) == 2 and len(m.occluded) >= 1 and m.units == ((0,),)
    fig = plot_model(m, max_panels=4)
    assert isinstance(fig, Figure)
    axes = [a for a in fig.axes if a.get_visible()]
    assert len(axes) == 2
    for k, (a, s) in enumerate(zip(axes, m.situations, strict=True)):
        # Fig. 11's caption: the probability and which candidate of unit a is true.
        assert a.get_title() == f"situation {k + 1} of 2: p = {s.probability:.2f}\na{k + 1} true"
        texts = {t.get_text() for t in a.texts}
        assert {region_label(r) for r in s.critical_regions} <= texts
        assert "w = 0.50 ± 0.01 m\nP(pass) = 0.50" in texts or not s.critical_regions
        assert {str(k) for k in range(len(s.obstacles))} <= texts
        assert {"a1", "a2"} <= texts  # the possible positions (Fig. 10)
        polys = [p for p in a.patches if isinstance(p, MplPolygon)]
        # occluded area + obstacles + critical regions
        assert len(polys) == len(m.occluded) + len(s.obstacles) + len(s.critical_regions)
        purple = [c for c in a.collections if isinstance(c, LineCollection)][-2:]
        assert sum(len(c.get_segments()) for c in purple) == 2  # both candidates drawn
        filled = [ln for ln in a.lines if ln.get_marker() == "o" and ln.get_mfc() != "none"]
        circled = [ln for ln in a.lines if ln.get_marker() == "o" and ln.get_mfc() == "none"]
        assert len(circled) == 1 and len(filled) == 2  # the other position; this one, viewpoint
    assert len(m.situations[1].critical_regions) == 1  # candidate away: the gap stays undecided
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=40)
    assert png.getvalue()[:4] == b"\x89PNG"
    # No two labels of a panel overlap (their text boxes, leader lines aside).
    fig.canvas.draw()
    for a in axes:
        boxes = [Text.get_window_extent(t) for t in a.texts]
        assert len(boxes) >= 3
        assert not any(b.overlaps(c) for i, b in enumerate(boxes) for c in boxes[i + 1 :])
    # On a given axes: the situation asked for (the most probable by default).
    fig2 = Figure()
    ax = fig2.add_subplot()
    assert plot_model(m, ax=ax, show_ellipses=False) is fig2
    assert ax.get_title().startswith(f"situation 1 of 2: p = {m.situations[0].probability:.2f}")
    ax2 = fig2.add_subplot(2, 1, 2)
    plot_model(m, ax=ax2, situation=1)
    assert ax2.get_title().startswith(f"situation 2 of 2: p = {m.situations[1].probability:.2f}")
    texts = [t for _, t in legend_handles()]
    assert {"occluded area", "true outline", "critical region (w, P(pass))"} <= set(texts)
    with pytest.raises(ValueError, match="max_panels"):
        plot_model(m, max_panels=0)
    with pytest.raises(ValueError, match="situation"):
        plot_model(m, ax=ax, situation=2)
    # Side by side (plot_models): obstacles numbered unless number_obstacles is False.
    from modeling.plotting import plot_models

    for number in (True, False):
        side = plot_models([m, m], titles=["one", "two"], number_obstacles=number)
        panels = [a for a in side.axes if a.get_title()]
        assert [a.get_title().split("\n")[0] for a in panels] == ["one", "two"]
        for a in panels:
            texts = {t.get_text() for t in a.texts}
            assert ("0" in texts) is number and {"a1", "a2"} <= texts
    # matplotlib is imported lazily.
    code = "import sys, modeling.plotting; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
