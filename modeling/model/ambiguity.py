"""Ambiguous segments (paper section 4.2, Figs 7-9): units moving together, the elimination of
those with one effect, and the independent groups.

* Fig. 7, *moving together*: two ambiguous segments with the same number of candidates whose
  candidates, ordered by distance from the viewpoint, are displaced consistently (the k-th
  displacement of each agrees within ``0.1 m + 0.2 |displacement|``) and lie within a robot width
  of each other form one :class:`Unit`; a unit chooses one candidate rank for all its members and
  counts once (its probabilities are the mean of its members'). A segment whose candidates do not
  hold all its mass (``p_none > 0``) has one more choice, "none", with no item and an empty effect;
  it moves together only with segments that have it too.
* The *effect* of a unit's choice on the base model is the set of changes of space passability it
  causes (:class:`Effect`): a merge of two obstacles it is impassable to both (space becomes
  impassable), a new undecided relation between an obstacle it joins and another one where the
  space was passable, or, for a free-standing candidate, a new undecided space near the obstacles
  it is undecided to; and a *new obstacle*: candidates impassable to no obstacle of the base model
  are an obstacle of their own, which paths must go around. Changes of width within an already
  undecided space are neglected, as in the paper. The "none" choice (``p_none``) has no effect.
* Fig. 8: a unit whose every choice has the same effect is eliminated. If that common effect is
  not empty, its most probable candidate is added to every situation: when every position joins
  obstacles A and C, the obstacles are merged; when every position is a free-standing object, the
  object is kept, at its most probable position. The paper eliminates a segment whose ambiguity
  "does not change the topological structure of possible paths" and neglects the cost changes of
  its positions (segment p of Fig. 8): an object present in every choice changes that structure
  (it is a hole of the free space in every situation), where it stands changes only costs, so it
  is kept once rather than as a unit of situations that differ only in cost. A unit with a "none"
  choice has a choice without the object, so its choices differ and it stays. Otherwise (the
  common effect is empty: every position only extends one obstacle) the unit is dropped. This
  repeats until no unit is eliminated.
* Fig. 9: the remaining units are split into independent groups: two units are in one group when
  they affect a common space (obstacle pair) or when any of their candidates are not passable to
  each other (connected components).

Items: every unambiguous segment and every candidate of every ambiguous segment (see
:func:`modeling.model.build.build_model`). Frames: world, metres.

Fig. 7's ranks and pairs and Fig. 8's effects of each round run as compiled loops
(:mod:`modeling.model._kernels.ambiguity`); their readable references are here
(:func:`units_moving_together_reference`; :func:`eliminate_units_of_one_effect_reference`, with
each choice's :func:`_signature`), and tests hold the two equal.
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from modeling.model._kernels import ambiguity as _ambiguity_kernel
from modeling.model.gaps import Relation
from modeling.model.obstacles import components
from modeling.model.relations import SegmentRelations, closest_points
from modeling.observation import FloorObservation
from modeling.types import FloatArray

__all__ = [
    "NONE",
    "Effect",
    "Elimination",
    "Unit",
    "candidate_adjacency",
    "eliminate_units_of_one_effect",
    "eliminate_units_of_one_effect_reference",
    "independent_groups",
    "units_moving_together",
    "units_moving_together_reference",
]

_IMP = int(Relation.IMPASSABLE)
_PAS = int(Relation.PASSABLE)

NONE = -1
"""The candidate index of the "none" choice: the segment is no obstacle here (``p_none``)."""

Adjacency = dict[int, dict[int, int]]  # candidate item -> {other item: relation kind}


class Effect(enum.Enum):
    """A change of space passability caused by choosing a candidate (Fig. 8)."""

    MERGE = "merge"  # two obstacles are joined: the space between them becomes impassable
    UNDECIDED = "undecided"  # a space that was passable becomes undecided
    NEAR = "near"  # a free-standing candidate makes an undecided space near one obstacle
    NEW = "new"  # candidates impassable to no obstacle of the base model: new obstacles


Change = tuple[Effect, int, int]  # the effect and the obstacle pair (labels ``a <= b``); for
# ``Effect.NEW``: ``(NEW, k, k)``, k the number of new obstacles
Signature = frozenset[Change]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Unit:
    """Ambiguous segments moving together (Fig. 7): one choice of candidate rank for all.

    When its members' candidates do not hold all their mass (``AmbiguousSegment.p_none > 0``),
    the last choice is "none": no item, every member mapped to :data:`NONE`.

    Attributes:
        members: The ambiguous indices, ascending.
        items: ``items[k]``: the items of the members' candidates of rank ``k`` (rank: order of
            distance from the viewpoint); ``()`` for the "none" choice.
        probabilities: (m,) probability of each choice (the members' mean, normalised to 1 over
            the candidates and "none").
        choices: ``choices[k]``: ``{ambiguous index: candidate index}`` of choice ``k``
            (:data:`NONE` for "none").
    """

    members: tuple[int, ...]
    items: tuple[tuple[int, ...], ...]
    probabilities: FloatArray
    choices: tuple[dict[int, int], ...]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Elimination:
    """The result of Fig. 8's elimination.

    Attributes:
        remaining: Indices of the units left (ascending).
        eliminated: Ambiguous indices of the eliminated units.
        fixed_items: Items of the candidates added to every situation (common effect not empty).
        merged: ``{ambiguous index: candidate index}`` of those candidates.
        active: (N,) the items of the base model after the elimination.
        affected: For each remaining unit, the obstacle pairs (labels of the last base model)
            its choices affect.
    """

    remaining: tuple[int, ...]
    eliminated: tuple[int, ...]
    fixed_items: tuple[int, ...]
    merged: dict[int, int]
    active: np.ndarray
    affected: dict[int, set[tuple[int, int]]]


def units_moving_together(
    observation: FloorObservation,
    live: list[int],
    cand_item: list[list[int]],
    ends: FloatArray,
    width: float,
) -> list[Unit]:
    """Fig. 7: the units of the ambiguous segments ``live`` whose candidates move together.

    The candidate ranks and the pairs moving together are one compiled pass
    (:func:`modeling.model._kernels.ambiguity.moving_together`); its reference is
    :func:`units_moving_together_reference`, and a test holds the two equal.

    Args:
        observation: The observation (its viewpoint and ambiguous segments' probabilities).
        live: The ambiguous indices not eliminated as isolated and short, ascending.
        cand_item: ``cand_item[a][c]``: the item of candidate ``c`` of ambiguous segment ``a``.
        ends: (N, 2, 2) endpoint means of every item, world frame, metres.
        width: Robot width, metres.

    Returns:
        The units, in order of their first member.
    """
    if not live:
        return []
    amb = observation.ambiguous
    counts = [len(cand_item[a]) for a in live]
    p_none = [amb[a].p_none for a in live]
    offsets = np.zeros(len(live) + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    candidates = _ambiguity_kernel.LiveCandidates(
        ends=np.ascontiguousarray(ends, dtype=np.float64),
        items=np.array([x for a in live for x in cand_item[a]], dtype=np.int64),
        offsets=offsets,
        has_none=np.array([p > 0.0 for p in p_none]),
    )
    vx, vy = (float(v) for v in observation.viewpoint[:2])
    result = _ambiguity_kernel.moving_together(candidates, vx, vy, float(width))
    order, start = result.order.tolist(), offsets.tolist()
    by_unit: dict[int, list[int]] = {}  # the labels are first members: in order of those
    for k, label in enumerate(result.labels.tolist()):
        by_unit.setdefault(label, []).append(k)
    units = []
    for ks in by_unit.values():
        members = tuple(live[k] for k in ks)
        m = counts[ks[0]]
        ranks = [order[start[k] : start[k] + m] for k in ks]
        # the members' mean of (probabilities by rank, p_none), summed in member order
        total = [0.0] * (m + 1)
        for k, a, rank in zip(ks, members, ranks, strict=True):
            row = [*(amb[a].probabilities[c] for c in rank), p_none[k]]
            total = row if k == ks[0] else [t + r for t, r in zip(total, row, strict=True)]
        pr = np.array([t / len(ks) for t in total])
        items = [
            tuple(cand_item[a][r[k]] for a, r in zip(members, ranks, strict=True)) for k in range(m)
        ]
        choices = [{a: r[k] for a, r in zip(members, ranks, strict=True)} for k in range(m)]
        units.append(_unit(members, items, choices, pr, p_none[ks[0]] > 0.0))
    return units


def _unit(
    members: tuple[int, ...],
    items: list[tuple[int, ...]],
    choices: list[dict[int, int]],
    pr: FloatArray,
    has_none: bool,
) -> Unit:
    """The :class:`Unit` of ``members`` moving together from its choices' items and candidate
    indices and ``pr``, one probability per choice, then the "none" mass; with the "none"
    choice, which has no item, where the members may all be no match (``has_none``)."""
    m = len(items)
    if has_none:
        items = [*items, ()]
        choices = [*choices, dict.fromkeys(members, NONE)]
    else:
        pr = pr[:m]
    return Unit(
        members=members,
        items=tuple(items),
        probabilities=pr / pr.sum(),
        choices=tuple(choices),
    )


def units_moving_together_reference(
    observation: FloorObservation,
    live: list[int],
    cand_item: list[list[int]],
    ends: FloatArray,
    width: float,
) -> list[Unit]:
    """:func:`units_moving_together` in NumPy and Python: the readable reference of its
    compiled loop (:func:`modeling.model._kernels.ambiguity.moving_together`; equal results)."""
    order_of: dict[int, list[int]] = {}
    if live:
        # Distance of every item's midpoint from the viewpoint, then a stable sort per segment.
        vp = np.asarray(observation.viewpoint[:2])
        mid_dist = np.hypot(*(ends.mean(axis=1) - vp).T).tolist()
        for a in live:
            dist = [mid_dist[x] for x in cand_item[a]]
            order_of[a] = sorted(range(len(dist)), key=dist.__getitem__)
    amb = observation.ambiguous
    has_none = {a: amb[a].p_none > 0.0 for a in live}
    units = []
    for members in _moving_together(live, cand_item, order_of, has_none, ends, width):
        m = len(cand_item[members[0]])
        pr = np.mean(
            [[*np.asarray(amb[a].probabilities)[order_of[a]], amb[a].p_none] for a in members],
            axis=0,
        )
        items = [tuple(cand_item[a][order_of[a][k]] for a in members) for k in range(m)]
        choices = [{a: order_of[a][k] for a in members} for k in range(m)]
        units.append(_unit(tuple(members), items, choices, pr, has_none[members[0]]))
    return units


def _moving_together(
    live: list[int],
    cand_item: list[list[int]],
    order_of: dict[int, list[int]],
    has_none: dict[int, bool],
    ends: FloatArray,
    width: float,
) -> list[list[int]]:
    """Fig. 7: the members (ambiguous indices) of each unit, vectorised per candidate count (and
    whether "none" is a choice: only segments with the same choices move together)."""
    if not live:
        return []
    pos = {a: k for k, a in enumerate(live)}
    ii: list[np.ndarray] = []
    jj: list[np.ndarray] = []
    by_m: dict[tuple[int, bool], list[int]] = {}
    for a in live:
        by_m.setdefault((len(cand_item[a]), has_none[a]), []).append(a)
    for (m, _), members in by_m.items():
        if len(members) < 2:
            continue
        E = np.stack([ends[cand_item[a]][order_of[a]] for a in members])  # (q, m, 2, 2)
        mids = E.mean(axis=2)
        disp = mids - mids[:, :1]  # (q, m, 2)
        # Every pair x < y of members, in row-major order.
        x, y = np.array(list(itertools.combinations(range(len(members)), 2)), np.int64).T
        tol = 0.1 + 0.2 * np.hypot(disp[x, :, 0], disp[x, :, 1])
        ok = (np.hypot(*np.moveaxis(disp[x] - disp[y], -1, 0)) <= tol).all(axis=1)
        x, y = x[ok], y[ok]
        if x.size == 0:
            continue
        ea = E[x].reshape(-1, 2, 2)
        eb = E[y].reshape(-1, 2, 2)
        s, t = closest_points(ea[:, 0], ea[:, 1], eb[:, 0], eb[:, 1])
        pa = ea[:, 0] + s[:, None] * (ea[:, 1] - ea[:, 0])
        pb = eb[:, 0] + t[:, None] * (eb[:, 1] - eb[:, 0])
        close = (np.hypot(*(pa - pb).T) <= width).reshape(-1, m).all(axis=1)
        ii.append(np.array([pos[members[k]] for k in x[close]], dtype=np.int64))
        jj.append(np.array([pos[members[k]] for k in y[close]], dtype=np.int64))
    empty = np.zeros(0, dtype=np.int64)
    labels = components(
        len(live), np.concatenate(ii) if ii else empty, np.concatenate(jj) if jj else empty
    )
    out: dict[int, list[int]] = {}
    for k, a in enumerate(live):
        out.setdefault(int(labels[k]), []).append(a)
    return sorted(out.values(), key=lambda m: m[0])


def candidate_adjacency(rel: SegmentRelations, item_amb: np.ndarray) -> Adjacency:
    """For every candidate item: ``{other item: relation kind}`` of its non-passable relations.

    Args:
        rel: The relations between items.
        item_amb: (N,) ambiguous index of each item (-1: an unambiguous segment).
    """
    adj: Adjacency = {}
    rows = ((rel.kind != _PAS) & ((item_amb[rel.i] >= 0) | (item_amb[rel.j] >= 0))).nonzero()[0]
    is_cand = (item_amb >= 0).tolist()
    for i, j, k in zip(
        rel.i[rows].tolist(), rel.j[rows].tolist(), rel.kind[rows].tolist(), strict=True
    ):
        if is_cand[i]:
            adj.setdefault(i, {})[j] = k
        if is_cand[j]:
            adj.setdefault(j, {})[i] = k
    return adj


def eliminate_units_of_one_effect(
    units: list[Unit], rel: SegmentRelations, item_amb: np.ndarray, base_active: np.ndarray
) -> Elimination:
    """Fig. 8: eliminate the units whose every choice has the same effect, to a fixed point:
    :func:`eliminate_units_of_one_effect_reference`, each round's effects (signatures) made by
    one compiled pass over the choices (:func:`modeling.model._kernels.ambiguity.
    choice_effects`; the same results, which a test holds equal).

    Args:
        units: The units (Fig. 7).
        rel: The relations between items.
        item_amb: (N,) ambiguous index of each item (-1: an unambiguous segment).
        base_active: (N,) the items of the base model (the kept segments).

    Returns:
        The remaining units, the eliminated ones and the base model after the elimination.
    """
    size = base_active.shape[0] + 1  # the codes' base (see choice_effects)
    is_cand = np.ascontiguousarray(item_amb >= 0)
    active = base_active.copy()
    fixed: list[int] = []
    merged: dict[int, int] = {}
    eliminated: list[int] = []
    remaining = list(range(len(units)))
    signatures: dict[int, list[bytes]] = {}
    codes = np.zeros(0, dtype=np.int64)
    bounds: list[int] = [0]
    while remaining:
        choices = [items for u in remaining for items in units[u].items]
        starts = np.zeros(len(choices) + 1, dtype=np.int64)
        np.cumsum([len(items) for items in choices], out=starts[1:])
        codes, code_starts = _ambiguity_kernel.choice_effects(
            _ambiguity_kernel.ChoiceEffects(
                ri=rel.i,
                rj=rel.j,
                kind=rel.kind,
                is_cand=is_cand,
                active=active,
                items=np.array([x for items in choices for x in items], dtype=np.int64),
                starts=starts,
            ),
            _IMP,
            int(Relation.UNDECIDED),
        )
        bounds = code_starts.tolist()
        raw = codes.tobytes()  # 8 bytes a code: each choice's signature as bytes
        signatures, k = {}, 0
        for u in remaining:
            m = len(units[u].items)
            signatures[u] = [raw[8 * bounds[k + q] : 8 * bounds[k + q + 1]] for q in range(m)]
            k += m
        if not _eliminate_round(units, remaining, signatures, eliminated, fixed, merged):
            break
        active[fixed] = True
    return Elimination(
        remaining=tuple(remaining),
        eliminated=tuple(eliminated),
        fixed_items=tuple(fixed),
        merged=merged,
        active=active,
        affected=_affected(units, remaining, signatures, codes, bounds, size),
    )


def _eliminate_round(
    units: list[Unit],
    remaining: list[int],
    signatures: Mapping[int, Sequence[Any]],
    eliminated: list[int],
    fixed: list[int],
    merged: dict[int, int],
) -> bool:
    """One round of Fig. 8's elimination, given each remaining unit's choice signatures (any
    values that compare equal when two choices have the same effect and are false for none):
    the units whose choices all have one effect leave ``remaining`` for ``eliminated``; where
    that effect is not none, the most probable choice's items join ``fixed`` and its merges
    ``merged``. Returns whether any unit left."""
    gone = [u for u in remaining if all(s == signatures[u][0] for s in signatures[u])]
    for u in gone:
        remaining.remove(u)
        eliminated.extend(units[u].members)
        if signatures[u][0]:
            best = int(np.argmax(units[u].probabilities))
            fixed.extend(units[u].items[best])
            merged.update(units[u].choices[best])
    return bool(gone)


def _affected(
    units: list[Unit],
    remaining: list[int],
    signatures: dict[int, list[bytes]],
    codes: np.ndarray,
    bounds: list[int],
    size: int,
) -> dict[int, set[tuple[int, int]]]:
    """The spaces (obstacle pairs) each remaining unit's choices affect: :func:`_spaces` of
    the signatures of the last round (``codes``, choice ``k``'s in ``bounds[k]:bounds[k +
    1]``, the units of ``signatures`` in order), none for a unit not in that round."""
    effect = (codes // (size * size)).tolist()
    first, second = (codes // size % size).tolist(), (codes % size).tolist()
    at: dict[int, tuple[int, int]] = {}  # unit: its codes' range in the last round
    k = 0
    for u in signatures:
        m = len(units[u].items)
        at[u] = (bounds[k], bounds[k + m])
        k += m
    out: dict[int, set[tuple[int, int]]] = {}
    for u in remaining:
        lo, hi = at.get(u, (0, 0))
        out[u] = {
            (first[c], second[c])
            for c in range(lo, hi)
            if effect[c] != _ambiguity_kernel.EFFECT_NEW
        }
    return out


def eliminate_units_of_one_effect_reference(
    units: list[Unit], rel: SegmentRelations, adjacency: Adjacency, base_active: np.ndarray
) -> Elimination:
    """Fig. 8: eliminate the units whose every choice has the same effect, to a fixed point
    (the readable reference of :func:`eliminate_units_of_one_effect`: each choice's
    :func:`_signature` in Python).

    Args:
        units: The units (Fig. 7).
        rel: The relations between items.
        adjacency: :func:`candidate_adjacency` of ``rel``.
        base_active: (N,) the items of the base model (the kept segments).

    Returns:
        The remaining units, the eliminated ones and the base model after the elimination.
    """
    active = base_active.copy()
    fixed: list[int] = []
    merged: dict[int, int] = {}
    eliminated: list[int] = []
    remaining = list(range(len(units)))
    signatures: dict[int, list[Signature]] = {}
    while remaining:
        labels, und_pairs = _base_state(rel, active)
        # as lists: the signatures read them item by item
        label_of, is_active = labels.tolist(), active.tolist()
        signatures = {
            u: [
                _signature(items, adjacency, label_of, und_pairs, is_active)
                for items in units[u].items
            ]
            for u in remaining
        }
        if not _eliminate_round(units, remaining, signatures, eliminated, fixed, merged):
            break
        active[fixed] = True
    affected = {
        u: set().union(*(_spaces(s) for s in signatures[u])) if u in signatures else set()
        for u in remaining
    }
    return Elimination(
        remaining=tuple(remaining),
        eliminated=tuple(eliminated),
        fixed_items=tuple(fixed),
        merged=merged,
        active=active,
        affected=affected,
    )


def _base_state(
    rel: SegmentRelations, active: np.ndarray
) -> tuple[np.ndarray, set[tuple[int, int]]]:
    """Component labels of the active items and the set of undecided component pairs."""
    both = active[rel.i] & active[rel.j]
    imp = both & (rel.kind == _IMP)
    labels = components(active.shape[0], rel.i[imp], rel.j[imp])
    und = both & (rel.kind == int(Relation.UNDECIDED))
    li, lj = labels[rel.i[und]], labels[rel.j[und]]
    apart = li != lj
    lo, hi = np.minimum(li[apart], lj[apart]), np.maximum(li[apart], lj[apart])
    return labels, set(zip(lo.tolist(), hi.tolist(), strict=True))


def _signature(
    items: tuple[int, ...],
    adjacency: Adjacency,
    labels: Sequence[int],
    und_pairs: set[tuple[int, int]],
    active: Sequence[bool],
) -> Signature:
    """The changes of space passability caused by adding ``items`` to the base model
    (``labels``, ``active``: the component label and whether active, of each item)."""
    joined: set[int] = set()
    undecided: set[int] = set()
    # and, for the new obstacles, the items impassable to an active one (anchored) and the
    # impassable links among them
    pos = {it: k for k, it in enumerate(items)}
    anchored: set[int] = set()
    links: list[tuple[int, int]] = []
    for k, it in enumerate(items):
        for other, kind in adjacency.get(it, {}).items():
            if active[other]:
                if kind == _IMP:
                    joined.add(labels[other])
                    anchored.add(k)
                else:
                    undecided.add(labels[other])
            elif kind == _IMP and other in pos:
                links.append((k, pos[other]))
    undecided -= joined
    changes: set[Change] = set()
    new = _unanchored_components(len(items), anchored, links)
    if new:
        changes.add((Effect.NEW, new, new))
    js = sorted(joined)
    for x, a in enumerate(js):
        for b in js[x + 1 :]:
            changes.add((Effect.MERGE, a, b))
    if js:
        for b in undecided:
            for a in js:
                pair = (min(a, b), max(a, b))
                if pair not in und_pairs:
                    changes.add((Effect.UNDECIDED, *pair))
    elif undecided:
        us = sorted(undecided)
        if len(us) == 1:
            changes.add((Effect.NEAR, us[0], us[0]))
        for x, a in enumerate(us):
            for b in us[x + 1 :]:
                if (a, b) not in und_pairs:
                    changes.add((Effect.UNDECIDED, a, b))
    return frozenset(changes)


def _unanchored_components(n: int, anchored: set[int], links: list[tuple[int, int]]) -> int:
    """How many new obstacles a choice's ``n`` items make: the components of the impassable
    ``links`` among them (pairs of positions) none of whose items is in ``anchored``
    (impassable to an active item); a plain union-find, a choice has a few items."""
    if not links:  # each item is a component of its own
        return n - len(anchored)
    parent = list(range(n))

    def root(x: int) -> int:
        while parent[x] != x:
            x = parent[x]
        return x

    for a, b in links:
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = [root(x) for x in range(n)]
    return len(set(roots) - {roots[x] for x in anchored})


def _spaces(signature: Signature) -> set[tuple[int, int]]:
    """The obstacle pairs (spaces) a signature's changes concern (a new obstacle is no space)."""
    return {(a, b) for e, a, b in signature if e is not Effect.NEW}


def independent_groups(
    units: list[Unit], elimination: Elimination, rel: SegmentRelations, item_amb: np.ndarray
) -> tuple[tuple[int, ...], ...]:
    """Fig. 9: connected components of units sharing a space or with interacting candidates
    (two candidates of two units with a non-passable relation: an edge of
    :func:`candidate_adjacency`).

    Args:
        units: The units (Fig. 7).
        elimination: Fig. 8's result (its remaining units and the spaces they affect).
        rel: The relations between items.
        item_amb: (N,) ambiguous index of each item (-1: an unambiguous segment).

    Returns:
        The groups, each the sorted ambiguous indices of its units, sorted.
    """
    remaining = elimination.remaining
    if not remaining:
        return ()
    # The position in ``remaining`` of the unit of each item (-1: none), from its segment's.
    members = [(k, a) for k, u in enumerate(remaining) for a in units[u].members]
    unit_of_amb = np.full(max(a for _, a in members) + 1, -1, dtype=np.int64)
    for k, a in members:
        unit_of_amb[a] = k
    known = (item_amb >= 0) & (item_amb < unit_of_amb.shape[0])
    item_unit = np.where(known, unit_of_amb[np.where(known, item_amb, 0)], -1)
    ui, uj = item_unit[rel.i], item_unit[rel.j]
    link = (rel.kind != _PAS) & (ui >= 0) & (uj >= 0) & (ui != uj)
    ii: list[int] = ui[link].tolist()
    jj: list[int] = uj[link].tolist()
    by_space: dict[tuple[int, int], list[int]] = {}
    for k, u in enumerate(remaining):
        for sp in elimination.affected[u]:
            by_space.setdefault(sp, []).append(k)
    for chain in by_space.values():
        ii.extend(chain[:-1])
        jj.extend(chain[1:])
    labels = components(len(remaining), np.asarray(ii, np.int64), np.asarray(jj, np.int64))
    out: dict[int, list[int]] = {}
    for k, u in enumerate(remaining):
        out.setdefault(int(labels[k]), []).extend(units[u].members)
    return tuple(sorted(tuple(sorted(g)) for g in out.values()))
