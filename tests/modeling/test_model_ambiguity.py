"""Ambiguous segments (section 4.2, Figs 7-9): the effect tags of a unit's choices."""

from __future__ import annotations

import numpy as np

from modeling.ambiguity import Effect, _signature
from modeling.gaps import Relation
from modeling.model import build_model
from tests.modeling.test_model_figures import W, amb, box, observe, seg


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
    # a free-standing candidate undecided to one obstacle: a new space near it
    assert _signature((5,), {5: {3: und}}, labels, set(), active) == {(Effect.NEAR, 3, 3)}
    # an inactive neighbour has no effect
    active[3] = False
    assert _signature((5,), {5: {3: und}}, labels, set(), active) == frozenset()
