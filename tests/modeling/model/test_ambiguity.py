"""Ambiguous segments (section 4.2, Figs 7-9): the effect tags of a unit's choices."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from modeling.model.ambiguity import NONE, Effect, _signature
from modeling.model.build import build_model
from modeling.model.gaps import Relation
from tests.modeling.model.test_figures import W, amb, box, observe, seg


def test_a_unit_whose_candidates_all_join_two_obstacles_has_one_merge_effect() -> None:
    left, right = box(0.0, 0.0, 1.0, 1.0), box(1.3, 0.0, 2.3, 1.0)  # a 0.3 m gap: impassable
    far_left, far_right = box(-3.0, 0.0, -2.0, 1.0), box(4.0, 0.0, 5.0, 1.0)
    # both candidates bridge the two far boxes' gaps to the middle pair in the same way
    cands = [seg((-1.9, 0.5), (-0.1, 0.5)), seg((-1.9, 0.6), (-0.1, 0.6))]
    obs = observe([*far_left, *left, *right, *far_right], [amb(cands, [0.6, 0.4])])
    m = build_model(obs, W)
    assert m.eliminated_ambiguous == (0,)
    assert m.merged_ambiguous == {0: 0}  # the most probable candidate, in every situation
    assert len(m.situations) == 1
    # the candidate joins the far-left box to the middle pair: two obstacles are left
    assert len(m.situations[0].obstacles) == 2


def test_signature_tags_merges_new_undecided_spaces_and_near_spaces() -> None:
    imp, und = int(Relation.IMPASSABLE), int(Relation.UNDECIDED)
    labels = np.arange(6)
    active = np.ones(6, dtype=bool)
    # candidate 5 joins obstacles 0 and 1 and is undecided to 2: 0-1 merge, 0-2 and 1-2 undecided
    # (but 1-2 was undecided already)
    adjacency = {5: {0: imp, 1: imp, 2: und}}
    got = _signature((5,), adjacency, labels, {(1, 2)}, active)
    assert got == {(Effect.MERGE, 0, 1), (Effect.UNDECIDED, 0, 2)}
    # a free-standing candidate undecided to one obstacle: a new space near it, and a new obstacle
    new1 = (Effect.NEW, 1, 1)
    assert _signature((5,), {5: {3: und}}, labels, set(), active) == {(Effect.NEAR, 3, 3), new1}
    # an inactive neighbour makes no space, but the candidate is still a new obstacle
    active[3] = False
    assert _signature((5,), {5: {3: und}}, labels, set(), active) == {new1}
    # two candidates impassable to each other, to nothing active: one new obstacle; apart: two
    active[4] = active[5] = False  # candidates are not in the base model
    assert _signature((4, 5), {4: {5: imp}, 5: {4: imp}}, labels, set(), active) == {new1}
    assert _signature((4, 5), {}, labels, set(), active) == {(Effect.NEW, 2, 2)}
    # a candidate joined to an active obstacle makes none; "none" (no item) has no effect
    assert _signature((5,), {5: {0: imp}}, labels, set(), active) == frozenset()
    assert _signature((), {}, labels, set(), active) == frozenset()


def test_a_candidate_with_no_obstacle_mass_gives_a_none_situation() -> None:
    # Issue 16c: one candidate of probability 0.4 in the 1.0 m gap between two boxes, the rest
    # (0.6) no obstacle here (its other match lay above the height band). The gap is closed with
    # probability 0.4, open with 0.6, never certainly closed.
    A, C = box(0.0, 0.0, 1.0, 1.0), box(2.0, 0.0, 3.0, 1.0)
    door = amb([seg((1.0, 0.5), (2.0, 0.5))], [0.4])
    assert door.p_none == pytest.approx(0.6)
    m = build_model(observe(A + C, [door]), W)
    assert m.units == ((0,),) and m.eliminated_ambiguous == ()
    assert [s.probability for s in m.situations] == pytest.approx([0.6, 0.4])
    none, closed = m.situations
    assert none.choice == {0: NONE} and closed.choice == {0: 0}
    assert len(none.obstacles) == 2 and all(o.candidates == () for o in none.obstacles)
    assert len(closed.obstacles) == 1 and closed.obstacles[0].candidates == ((0, 0),)
    assert math.fsum(m.probabilities) + m.residual_probability == pytest.approx(1.0, abs=1e-12)


def test_situations_with_none_choices_follow_eq2_and_sum_to_one_with_the_residual() -> None:
    # three gaps, each with an ambiguous segment: (bridge, far copy) plus "none" for two of them
    A, B, C, D = box(0, 0, 1, 1), box(2.5, 0, 3.5, 1), box(5, 0, 6, 1), box(7.5, 0, 8.5, 1)
    probs = [(0.5, 0.3), (0.6, 0.4), (0.7,)]
    ambs = [
        amb([seg((1.0, 0.5), (2.5, 0.5)), seg((1.0, 6.0), (1.8, 6.0))], list(probs[0])),
        amb([seg((3.5, 0.5), (5.0, 0.5)), seg((3.5, 9.0), (4.3, 9.0))], list(probs[1])),
        amb([seg((6.0, 0.5), (7.5, 0.5))], list(probs[2])),
    ]
    with_none = [(*p, 1.0 - sum(p)) if sum(p) < 1.0 else p for p in probs]
    expected = sorted((math.prod(c) for c in itertools.product(*with_none)), reverse=True)
    m = build_model(observe(A + B + C + D, ambs), W, max_situations=64)
    assert len(m.situations) == 3 * 2 * 2 == len(expected)
    assert [s.probability for s in m.situations] == pytest.approx(expected, abs=1e-12)
    assert math.fsum(m.probabilities) + m.residual_probability == pytest.approx(1.0, abs=1e-12)
    for s in m.situations:
        p = math.prod(with_none[a][c] for a, c in s.choice.items())  # NONE = -1: the last entry
        assert s.probability == pytest.approx(p, abs=1e-15)
        chosen = {(a, c) for o in s.obstacles for a, c in o.candidates}
        assert chosen == {(a, c) for a, c in s.choice.items() if c != NONE}
    m3 = build_model(observe(A + B + C + D, ambs), W, max_situations=3)
    assert [s.probability for s in m3.situations] == pytest.approx(expected[:3])
    assert m3.residual_probability == pytest.approx(math.fsum(expected[3:]))


def test_segments_moving_together_share_their_none_choice() -> None:
    A, B = box(0, 0, 1, 1), box(2.0, 0, 3, 1)  # 1.0 m gap
    a1 = amb([seg((1.0, 0.5), (1.5, 0.5)), seg((1.0, 3.5), (1.5, 3.5))], [0.5, 0.3])
    a2 = amb([seg((1.55, 0.5), (2.0, 0.5)), seg((1.55, 3.5), (2.0, 3.5))], [0.5, 0.3])
    m = build_model(observe(A + B, [a1, a2]), W)
    assert m.units == ((0, 1),)
    assert [s.probability for s in m.situations] == pytest.approx([0.5, 0.3, 0.2])
    assert [s.choice for s in m.situations] == [{0: 0, 1: 0}, {0: 1, 1: 1}, {0: NONE, 1: NONE}]
    # one with a none mass and one without do not move together: their choices differ
    a3 = amb([seg((1.55, 0.5), (2.0, 0.5)), seg((1.55, 3.5), (2.0, 3.5))], [0.7, 0.3])
    units = build_model(observe(A + B, [a1, a3]), W).units
    assert units[0] == (0,) and all(len(u) == 1 for u in units)
