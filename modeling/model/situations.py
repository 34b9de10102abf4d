"""Situations (paper section 4.1 per situation, section 4.2 / Eq. 2): partitions, critical
regions, passages and the k-best enumeration.

A situation is one choice of candidate per remaining unit of ambiguous segments; its items are the
base model's (kept segments and merged candidates) plus the chosen candidates. A unit whose
segments may be no obstacle (``AmbiguousSegment.p_none > 0``) has the choice "none" too, with
probability ``p_none`` and no item; ``Situation.choice`` maps its members to ``-1`` then.

* *Partition*: its obstacles are the connected components of impassable relations among its
  items, numbered in the order of their smallest item (:meth:`_Context.partitions`).
* *Critical regions*: between two obstacles, all undecided relations form one
  :class:`~modeling.model.records.CriticalRegion` (convex hull of the relation endpoints) whose
  width distribution is that of its narrowest (least passable) relation. Undecided relations inside
  one obstacle make no region, as in the paper.
* *Passages*: passable relations shorter than 3 robot widths give, per obstacle pair, the
  narrowest :class:`~modeling.model.records.Passage` (used by the path graph).
* *Eq. 2*: a situation's probability is the product of its choices' probabilities ("none"
  included, so that all situations sum to 1 with the residual). Since the
  product factorises over units, the ``max_situations`` most probable situations are enumerated
  best-first (:func:`k_best`): exact probabilities, ``O(k log k)``, no enumeration of the full
  product.

Situations share most obstacles and region polygons (they differ by a few candidates): the
partitions of all situations are made in one compiled pass over (situation, relation) arrays
(:func:`modeling.model.partitions.situation_partitions`) that lists each distinct obstacle once
(and joins the items active in every situation once), so each is built once; region polygons
are shared by their relation rows, and width moments are cached per relation row. Their regions
and passages are made in one more pass, each distinct one once (situations that have the same
one hold the same record): a fused model holds tens of situations, and per-situation NumPy calls
on a few hundred relations cost more than the work they do (a property test holds the situations
made together equal to each made alone). Eq. 2's best-first enumeration is a compiled loop
(:func:`k_best_arrays`, reference :func:`k_best_reference`), and the situations' items and
choices are taken from its ranks in array operations.

Frames: world, metres; probabilities in [0, 1].
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence

import numpy as np

from modeling.model._kernels import kbest as _kbest_kernel
from modeling.model.ambiguity import Elimination, Unit
from modeling.model.gaps import Relation, gap_width_moments
from modeling.model.items import Items
from modeling.model.obstacles import make_obstacles
from modeling.model.partitions import FlipGroups, SituationPartitions, situation_partitions
from modeling.model.records import CriticalRegion, Obstacle, Passage, Situation
from modeling.model.relations import SegmentRelations
from modeling.types import FloatArray

__all__ = ["enumerate_situations", "k_best", "k_best_arrays", "k_best_reference"]

_IMP = int(Relation.IMPASSABLE)
_UND = int(Relation.UNDECIDED)
_PAS = int(Relation.PASSABLE)


def enumerate_situations(
    items: Items,
    rel: SegmentRelations,
    units: list[Unit],
    elimination: Elimination,
    *,
    max_situations: int,
    robot_width_m: float,
    outline_buffer_m: float,
) -> tuple[list[Situation], float]:
    """Eq. 2: the ``max_situations`` most probable situations, most probable first.

    Args:
        items: The model's items.
        rel: Their relations.
        units: The units of ambiguous segments (Fig. 7).
        elimination: Fig. 8's result: the remaining units and the base model's items.
        max_situations: At most this many situations.
        robot_width_m: Robot width, metres.
        outline_buffer_m: Half-width of the rectangle of a flat obstacle, metres.

    Returns:
        ``(situations, residual)``: the situations, and the probability mass left out.
    """
    ctx = _Context(items, rel, outline_buffer_m, passage_max_m=3.0 * robot_width_m)
    remaining = [units[u] for u in elimination.remaining]
    order_u = [np.argsort(-unit.probabilities, kind="stable") for unit in remaining]
    sorted_p = [unit.probabilities[o] for unit, o in zip(remaining, order_u, strict=True)]
    if remaining:
        # The probability of each situation and the rank of each remaining unit's choice in it.
        probs, ranks = k_best_arrays(sorted_p, max_situations)  # (S,), (S, units)
        actives = np.repeat(elimination.active[None], len(probs), axis=0)  # (S, N)
        actives[_chosen_items(remaining, order_u, ranks)] = True
        choices = _chosen_candidates(remaining, order_u, ranks)
    else:  # the one situation of no choice (what k_best_arrays gives), most views' case
        probs, actives, choices = [1.0], elimination.active[None].copy(), [{}]
    situations = _situations(ctx, actives, probs, choices, robot_width_m)
    situations.sort(key=lambda s: -s.probability)
    total = math.fsum(s.probability for s in situations)
    return situations, max(0.0, 1.0 - total)


def _chosen_items(
    remaining: list[Unit], order_u: list[np.ndarray], ranks: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(situation, item)`` of every item of the candidates the situations choose: situation
    ``s`` takes, of remaining unit ``u``, the choice of rank ``ranks[s, u]`` in ``order_u[u]``
    (the unit's choices, most probable first)."""
    n_sit, n_units = ranks.shape
    items = [unit.items[k] for unit, o in zip(remaining, order_u, strict=True) for k in o.tolist()]
    counts = np.array([len(x) for x in items], dtype=np.int64)  # per (unit, rank)
    flat = np.array([x for its in items for x in its], dtype=np.int64)
    first_rank = np.zeros(n_units, dtype=np.int64)  # where each unit's choices start
    np.cumsum(np.array([o.shape[0] for o in order_u[:-1]], dtype=np.int64), out=first_rank[1:])
    chosen = (first_rank[None, :] + ranks).reshape(-1)  # (S * units,) by situation, then unit
    n = counts[chosen]
    starts = (np.cumsum(counts) - counts)[chosen]
    # each chosen choice's items: its start in ``flat``, then the next ones
    at = np.repeat(starts - (np.cumsum(n) - n), n) + np.arange(int(n.sum()))
    return np.repeat(np.arange(n_sit * n_units) // max(n_units, 1), n), flat[at]


def _chosen_candidates(
    remaining: list[Unit], order_u: list[np.ndarray], ranks: np.ndarray
) -> list[dict[int, int]]:
    """Each situation's ``{ambiguous index: candidate index}`` (sorted by ambiguous index) of
    the choices ``ranks`` (see :func:`_chosen_items`): the members of every remaining unit (no
    two units share one), with the candidate of its chosen choice."""
    members = sorted(a for unit in remaining for a in unit.members)
    if not members:
        return [{} for _ in range(ranks.shape[0])]
    # Per unit, its choices' candidates as rows (most probable first), columns its members.
    values: list[int] = []
    column: dict[int, tuple[int, int, int, int]] = {}  # member: unit, table start, width, col
    for u, (unit, o) in enumerate(zip(remaining, order_u, strict=True)):
        own = sorted(unit.members)
        for c, a in enumerate(own):
            column[a] = (u, len(values), len(own), c)
        values.extend(unit.choices[k][a] for k in o.tolist() for a in own)
    unit_of, start, width, col = np.array([column[a] for a in members], dtype=np.int64).T
    at = start[None, :] + ranks[:, unit_of] * width[None, :] + col[None, :]  # (S, members)
    table = np.array(values, dtype=np.int64)[at].tolist()
    return [dict(zip(members, row, strict=True)) for row in table]


class _Context:
    """Item arrays and caches shared by the situations of one model.

    Obstacles are identified by their member items and region polygons by their relation rows,
    so situations that share them (most do: they differ by a few ambiguous candidates) build
    them once; width moments are cached per relation row.
    """

    def __init__(
        self, items: Items, rel: SegmentRelations, outline_buffer_m: float, passage_max_m: float
    ) -> None:
        self.ends = items.ends
        self.rel = rel
        self.item_segment = items.segment
        self.item_candidate = items.candidate
        self.outline_buffer_m = outline_buffer_m
        m = len(rel)
        self.width_mean = np.full(m, np.nan)
        self.width_std = np.full(m, np.nan)
        self.links = np.stack([rel.point_i, rel.point_j], axis=1)  # (m, 2, 2)
        self.links.setflags(write=False)
        self.ri = np.ascontiguousarray(rel.i, dtype=np.int64)
        self.rj = np.ascontiguousarray(rel.j, dtype=np.int64)
        self.is_imp = rel.kind == _IMP
        self.is_und = rel.kind == _UND
        # Passable relations short enough to be a passage (the same in every situation).
        self.is_short_pas = (rel.kind == _PAS) & (rel.distance_m <= passage_max_m)

    def partitions(self, actives: np.ndarray | Sequence[np.ndarray]) -> SituationPartitions:
        """Obstacles of each situation whose items are ``actives``, each distinct one once, and
        its relations between them: all situations in one compiled pass
        (:func:`modeling.model.partitions.situation_partitions`)."""
        rel = self.rel
        act = np.asarray(actives, dtype=bool).reshape(len(actives), self.ends.shape[0])
        return situation_partitions(
            act,
            self.ri,
            self.rj,
            self.is_imp,
            self.is_und,
            self.is_short_pas,
            rel.p_passable,
            rel.distance_m,
        )

    def build(
        self, parts: SituationPartitions, region_rows: list[np.ndarray]
    ) -> tuple[list[Obstacle], list[FloatArray]]:
        """:func:`make_obstacles` of the distinct obstacles of ``parts`` and the polygons of the
        regions of ``region_rows``, in one batch."""
        u = parts.counts.shape[0]
        ob = np.repeat(np.arange(u), parts.counts)
        lob = np.repeat(np.arange(u), parts.link_counts)
        return make_obstacles(
            ends=self.ends,
            links=self.links,
            item_segment=self.item_segment,
            item_candidate=self.item_candidate,
            items=parts.items,
            counts=parts.counts,
            link_rows=parts.links,
            link_counts=parts.link_counts,
            link_order=np.argsort(np.concatenate((ob, lob)), kind="stable"),
            outline_buffer_m=self.outline_buffer_m,
            region_rows=region_rows,
        )

    def moments(self, rows: np.ndarray) -> tuple[list[float], list[float]]:
        """Mean and standard deviation (metres) of the width of each relation row (cached)."""
        todo = rows[np.isnan(self.width_mean[rows])]
        if todo.size:
            rel = self.rel
            mean, std = gap_width_moments(
                rel.point_j[todo] - rel.point_i[todo], rel.cov_i[todo] + rel.cov_j[todo]
            )
            self.width_mean[todo] = mean
            self.width_std[todo] = std
        return self.width_mean[rows].tolist(), self.width_std[rows].tolist()


def _group_rows(groups: FlipGroups) -> list[np.ndarray]:
    """The rows of each group of ``groups`` (views of its sorted rows)."""
    rows, starts = groups[0], groups[1]
    return [rows[s0:s1] for s0, s1 in zip(starts.tolist(), _stops(groups), strict=True)]


def _stops(groups: FlipGroups) -> list[int]:
    """Where each group of ``groups`` ends in its sorted rows."""
    rows, starts = groups[0], groups[1]
    return [*starts[1:].tolist(), rows.shape[0]] if starts.shape[0] else []


def _distinct(row_groups: list[np.ndarray]) -> tuple[list[np.ndarray], list[int]]:
    """The distinct groups of ``row_groups`` (by content, in the order of first occurrence) and
    the index of each group among them."""
    index: dict[bytes, int] = {}
    distinct: list[np.ndarray] = []
    which: list[int] = []
    for rows in row_groups:
        key = rows.tobytes()
        k = index.get(key)
        if k is None:
            k = index[key] = len(distinct)
            distinct.append(rows)
        which.append(k)
    return distinct, which


def _narrowest_points(ctx: _Context, rows: np.ndarray, flip: np.ndarray) -> list[FloatArray]:
    """(2, 2) closest points of each of relation ``rows``, the point on the lower-index obstacle
    first (``flip``: the relation's first item is on the higher one; read-only views of one
    array)."""
    out: FloatArray = ctx.links[rows]
    out[flip] = out[flip, ::-1]
    out.setflags(write=False)
    return list(out)


def _regions(
    ctx: _Context, n_sit: int, groups: FlipGroups, polygons: list[FloatArray], which: list[int]
) -> list[list[CriticalRegion]]:
    """Each situation's critical regions: one per obstacle pair with undecided relations
    between them (``groups``; the rows of group ``g`` are the ``which[g]``-th distinct rows,
    whose polygon is ``polygons[which[g]]``).

    Situations share most regions (the same rows between the same obstacle pair): each is made
    once, and the situations that have it hold the same record."""
    rows, starts, s, lo, hi, flip = groups
    out: list[list[CriticalRegion]] = [[] for _ in range(n_sit)]
    if rows.size == 0:
        return out
    keys = list(zip(which, lo.tolist(), hi.tolist(), flip.tolist(), strict=True))
    index: dict[tuple[int, int, int, bool], int] = {}
    first: list[int] = []  # the first group of each distinct region
    for g, key in enumerate(keys):
        if key not in index:
            index[key] = len(first)
            first.append(g)
    at = np.array(first, dtype=np.int64)
    rel = ctx.rel
    narrowest = rows[starts[at]]
    w_mean, w_std = ctx.moments(narrowest)
    rel_lines = ctx.links[rows]
    rel_lines.setflags(write=False)
    rows_list = rows.tolist()
    stops = _stops(groups)
    made = [
        CriticalRegion(
            obstacles=(a_, b_),
            polygon=polygons[d],
            width_mean_m=wm,
            width_std_m=ws,
            p_passable=p_,
            narrowest=nw,
            relations=tuple(rows_list[s0 : stops[g]]),
            relation_lines=rel_lines[s0 : stops[g]],
        )
        for (d, a_, b_, _), g, s0, wm, ws, p_, nw in zip(
            index,
            at.tolist(),
            starts[at].tolist(),
            w_mean,
            w_std,
            rel.p_passable[narrowest].tolist(),
            _narrowest_points(ctx, narrowest, flip[at]),
            strict=True,
        )
    ]
    for k, key in zip(s.tolist(), keys, strict=True):
        out[k].append(made[index[key]])
    return out


def _passages(ctx: _Context, n_sit: int, groups: FlipGroups) -> list[list[Passage]]:
    """Each situation's passages: the narrowest per obstacle pair among its short passable
    relations."""
    rows, starts, s, lo, hi, flip = groups
    out: list[list[Passage]] = [[] for _ in range(n_sit)]
    if rows.size == 0:
        return out
    # Situations share most passages (the same obstacle pair and row): each is made once.
    first = rows[starts]
    keys = list(zip(lo.tolist(), hi.tolist(), first.tolist(), flip.tolist(), strict=True))
    index: dict[tuple[int, int, int, bool], int] = {}
    for key in keys:
        index.setdefault(key, len(index))
    distinct = list(index)
    rel = ctx.rel
    at = np.array([key[2] for key in distinct], dtype=np.int64)
    made = [
        Passage(obstacles=(a_, b_), narrowest=nw, width_mean_m=d_, p_passable=p_, relation=r0)
        for (a_, b_, r0, _), nw, d_, p_ in zip(
            distinct,
            _narrowest_points(ctx, at, np.array([key[3] for key in distinct], dtype=bool)),
            rel.distance_m[at].tolist(),
            rel.p_passable[at].tolist(),
            strict=True,
        )
    ]
    for k, key in zip(s.tolist(), keys, strict=True):
        out[k].append(made[index[key]])
    return out


def _situations(
    ctx: _Context,
    actives: np.ndarray | Sequence[np.ndarray],
    probabilities: list[float],
    choices: list[dict[int, int]],
    robot_width_m: float,
) -> list[Situation]:
    """Obstacles, critical regions and passages of each situation whose items are ``actives``
    ((S, N) bool, or S rows) and whose choices are ``choices`` (each sorted by ambiguous index).

    Three passes: the partitions of all situations (each distinct obstacle once), then one batch
    for the distinct obstacles and region polygons, then the situations' regions and passages,
    all situations at once.
    """
    n_sit = len(actives)
    if n_sit == 0:
        return []
    parts = ctx.partitions(actives)
    region_rows, which = _distinct(_group_rows(parts.und))
    obstacles, region_polygons = ctx.build(parts, region_rows)
    regions = _regions(ctx, n_sit, parts.und, region_polygons, which)
    passages = _passages(ctx, n_sit, parts.pas)
    of_situations = [obstacles[u] for u in parts.obstacle.tolist()]
    first = parts.first_obst.tolist()
    return [
        Situation(
            probability=float(probability),
            obstacles=tuple(of_situations[first[k] : first[k + 1]]),
            critical_regions=tuple(r),
            choice=choice,
            passages=tuple(ps),
            robot_width_m=robot_width_m,
        )
        for k, (probability, choice, r, ps) in enumerate(
            zip(probabilities, choices, regions, passages, strict=True)
        )
    ]


def k_best(probs: list[np.ndarray], k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The ``k`` most probable joint choices of independent factors, best first (exact
    products): :func:`k_best_arrays` as ``(probability, ranks)`` pairs, as
    :func:`k_best_reference` gives them."""
    prob, ranks = k_best_arrays(probs, k)
    return list(zip(prob, map(tuple, ranks.tolist()), strict=True))


def k_best_arrays(probs: list[np.ndarray], k: int) -> tuple[list[float], np.ndarray]:
    """:func:`k_best_reference` by a compiled loop
    (:func:`modeling.model._kernels.kbest.k_best`; the same results, as arrays).

    Args:
        probs: One (m_u,) array per factor, sorted descending.
        k: How many to return (>= 1).

    Returns:
        ``(probabilities, ranks)``: the probabilities, most probable first, and (k', n) int64
        ``ranks[s, u]`` indexing ``probs[u]``.
    """
    n = len(probs)
    plist = [p.tolist() for p in probs]
    logs = [[math.log(max(x, 1e-300)) for x in p] for p in plist]
    seq = sorted((u for u in range(n) if len(plist[u]) > 1), key=lambda u: logs[u][0] - logs[u][1])
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.array([len(p) for p in plist], dtype=np.int64), out=start[1:])
    factors = _kbest_kernel.Factors(
        probs=np.array([x for p in plist for x in p], dtype=np.float64),
        logs=np.array([x for lg in logs for x in lg], dtype=np.float64),
        start=start,
        seq=np.array(seq, dtype=np.int64),
    )
    best = _kbest_kernel.k_best(factors, -math.fsum(lg[0] for lg in logs), int(k))
    return best.prob.tolist(), best.ranks


def k_best_reference(probs: list[np.ndarray], k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The readable reference of :func:`k_best` (equal results): the ``k`` most probable joint
    choices of independent factors, best first (exact products).

    Best-first search in which every joint choice has exactly one parent that is at least as
    probable: factors are ordered by the loss of their first step down (``p[1] / p[0]``,
    largest first); a choice's children raise the rank of its last moved factor, move the next
    factor to rank 1, or, when the last moved factor is at rank 1, hand that step to the next
    factor. So each choice is generated once, with at most three heap pushes per output, and
    ``O(k log k + k n)`` work in all.

    Args:
        probs: One (m_u,) array per factor, sorted descending.
        k: How many to return.

    Returns:
        ``(probability, ranks)`` pairs, most probable first; ``ranks[u]`` indexes ``probs[u]``.
    """
    n = len(probs)
    plist = [p.tolist() for p in probs]
    logs = [[math.log(max(x, 1e-300)) for x in p] for p in plist]
    seq = sorted((u for u in range(n) if len(plist[u]) > 1), key=lambda u: logs[u][0] - logs[u][1])
    q = len(seq)
    start = (0,) * n
    heap: list[tuple[float, int, tuple[int, ...], int]] = [
        (-math.fsum(lg[0] for lg in logs), 0, start, -1)
    ]
    count = 1
    out: list[tuple[float, tuple[int, ...]]] = []
    while heap and len(out) < k:
        neg, _, state, last = heapq.heappop(heap)
        out.append((math.prod(plist[u][s] for u, s in enumerate(state)), state))
        children: list[tuple[float, tuple[int, ...], int]] = []
        if last >= 0:
            u = seq[last]
            r = state[u]
            if r + 1 < len(plist[u]):
                children.append((logs[u][r] - logs[u][r + 1], _with(state, u, r + 1), last))
        if last + 1 < q:
            v = seq[last + 1]
            loss = logs[v][0] - logs[v][1]
            children.append((loss, _with(state, v, 1), last + 1))
            if last >= 0 and state[seq[last]] == 1:
                u = seq[last]
                back = logs[u][1] - logs[u][0]
                children.append((loss + back, _with(_with(state, u, 0), v, 1), last + 1))
        for loss, child, pos in children:
            heapq.heappush(heap, (neg + loss, count, child, pos))
            count += 1
    return out


def _with(state: tuple[int, ...], u: int, value: int) -> tuple[int, ...]:
    """``state`` with entry ``u`` set to ``value``."""
    return (*state[:u], value, *state[u + 1 :])
