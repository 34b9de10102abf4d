"""Situations (paper section 4.1 per situation, section 4.2 / Eq. 2): partitions, critical
regions, passages and the k-best enumeration.

A situation is one choice of candidate per remaining unit of ambiguous segments; its items are the
base model's (kept segments and merged candidates) plus the chosen candidates. A unit whose
segments may be no obstacle (``AmbiguousSegment.p_none > 0``) has the choice "none" too, with
probability ``p_none`` and no item; ``Situation.choice`` maps its members to ``-1`` then.

* *Partition*: its obstacles are the connected components of impassable relations among its
  items, numbered in the order of their smallest item (:func:`_partitions`).
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

Situations share most obstacles and region polygons (they differ by a few candidates): a
:class:`_Context` builds each once, identified by its items or relation rows, and caches the
width moments per relation row. The partitions of all situations are made in one pass over
(situation, relation) arrays, and their regions and passages in one more: a fused model holds
tens of situations, and per-situation NumPy calls on a few hundred relations cost more than
the work they do (a property test holds the situations made together equal to each made alone).

Frames: world, metres; probabilities in [0, 1].
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from modeling.model.ambiguity import Elimination, Unit
from modeling.model.gaps import Relation, gap_width_moments
from modeling.model.items import Items
from modeling.model.obstacles import make_obstacles
from modeling.model.partitions import partition_arrays
from modeling.model.records import CriticalRegion, Obstacle, Passage, Situation
from modeling.model.relations import SegmentRelations
from modeling.types import FloatArray

__all__ = ["enumerate_situations", "k_best"]

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
    # Items and choice of each remaining unit's k-th most probable candidate rank.
    ranked = [
        [(unit.items[k], unit.choices[k]) for k in o.tolist()]
        for unit, o in zip(remaining, order_u, strict=True)
    ]
    actives: list[np.ndarray] = []
    probs: list[float] = []
    choices: list[dict[int, int]] = []
    for prob, state in k_best(sorted_p, max_situations):
        active = elimination.active.copy()
        choice: dict[int, int] = {}
        chosen: list[int] = []
        for pos, rank in enumerate(state):
            unit_items, cands = ranked[pos][rank]
            chosen.extend(unit_items)
            choice.update(cands)
        active[chosen] = True
        actives.append(active)
        probs.append(prob)
        choices.append(choice)
    situations = _situations(ctx, actives, probs, choices, robot_width_m)
    situations.sort(key=lambda s: -s.probability)
    total = math.fsum(s.probability for s in situations)
    return situations, max(0.0, 1.0 - total)


class _Partition:
    """What one situation's active items make: obstacles, and relation rows between them.

    Computed for every situation first (:func:`_partitions`), so that the obstacles and region
    polygons that no earlier situation built are built for all situations in one batch
    (:meth:`_Context.prepare`) before the situations are assembled (:func:`_situations`).

    Attributes:
        n_obst: Number of obstacles.
        items: (k,) active items sorted by (obstacle, item index).
        counts: (n_obst,) number of items of each obstacle.
        bounds: Where each obstacle's items start in ``items`` (n_obst + 1 entries).
        imp_rows: (q,) rows of the impassable relations inside obstacles (ascending).
        link_obst: (q,) obstacle of each of those rows.
        region_rows: The undecided rows between each pair of its obstacles that have any, the
            narrowest (least passable) first: one critical region each.
        obstacles: Its :class:`Obstacle` records, and
        region_polygons: the polygon of each group of ``und``, both set by
            :meth:`_Context.prepare`.
    """

    __slots__ = (
        "bounds",
        "counts",
        "imp_rows",
        "items",
        "link_obst",
        "n_obst",
        "obstacles",
        "region_polygons",
        "region_rows",
    )

    def __init__(
        self,
        *,
        items: np.ndarray,
        counts: np.ndarray,
        imp_rows: np.ndarray,
        link_obst: np.ndarray,
        region_rows: list[np.ndarray],
    ) -> None:
        self.n_obst = int(counts.shape[0])
        self.items = items
        self.counts = counts
        self.bounds = [0, *np.cumsum(counts).tolist()]
        self.imp_rows = imp_rows
        self.link_obst = link_obst
        self.region_rows = region_rows
        self.obstacles: list[Obstacle] = []
        self.region_polygons: list[FloatArray] = []

    def keys(self) -> list[bytes]:
        """Cache key of each obstacle (its items' bytes)."""
        b = self.bounds
        return [self.items[b[c] : b[c + 1]].tobytes() for c in range(self.n_obst)]

    def region_keys(self) -> list[bytes]:
        """Cache key of each group of ``region_rows`` (its rows' bytes)."""
        return [r.tobytes() for r in self.region_rows]


class _Context:
    """Item arrays and caches shared by the situations of one model.

    Obstacles are identified by their member items and region polygons by their relation rows,
    so situations that share them (most do: they differ by a few ambiguous candidates) build
    them once (:meth:`prepare`); width moments are cached per relation row.
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

    def prepare(self, parts: list[_Partition]) -> None:
        """Build, in one batch, the obstacles and region polygons of ``parts`` (each once, from
        the first situation that has it; shared by content, their items' and relation rows'
        bytes, between situations), and set each part's ``obstacles`` and ``region_polygons``."""
        if len(parts) == 1:  # one situation: every obstacle and region is new, none shared
            part = parts[0]
            ob = np.repeat(np.arange(part.n_obst), part.counts)
            part.obstacles, part.region_polygons = self._build(
                part.items, ob, part.imp_rows, part.link_obst, part.region_rows
            )
            return
        new_keys: list[bytes] = []  # the new obstacles, in the order of their new id
        seen: set[bytes] = set()
        it_parts: list[np.ndarray] = []  # their items, grouped by new id
        ob_parts: list[np.ndarray] = []  # the new id of each of those items
        link_parts: list[np.ndarray] = []  # their impassable links (relation rows)
        lob_parts: list[np.ndarray] = []  # the new id of each of those links
        new_regions: dict[bytes, np.ndarray] = {}
        keys: list[list[bytes]] = []
        region_keys: list[list[bytes]] = []
        for part in parts:
            keys.append(part.keys())
            region_keys.append(part.region_keys())
            todo = []
            for c, key in enumerate(keys[-1]):
                if key not in seen:
                    seen.add(key)
                    todo.append(c)
            for key, rows in zip(region_keys[-1], part.region_rows, strict=True):
                if key not in new_regions:
                    new_regions[key] = rows
            if todo:
                # Vectorised selection of the new obstacles' items and links (new ids follow
                # the obstacle order, so items stay grouped by new id).
                new_id = np.full(part.n_obst, -1, dtype=np.int64)
                new_id[todo] = np.arange(len(new_keys), len(new_keys) + len(todo))
                new_keys.extend(keys[-1][c] for c in todo)
                ob = new_id[np.repeat(np.arange(part.n_obst), part.counts)]
                keep = ob >= 0
                it_parts.append(part.items[keep])
                ob_parts.append(ob[keep])
                lob = new_id[part.link_obst]
                lk = lob >= 0
                link_parts.append(part.imp_rows[lk])
                lob_parts.append(lob[lk])
        t = len(new_keys)
        empty = np.zeros(0, dtype=np.int64)
        it = np.concatenate(it_parts) if t else empty
        ob = np.concatenate(ob_parts) if t else empty
        link_rows = np.concatenate(link_parts) if t else empty
        lob = np.concatenate(lob_parts) if t else empty
        obstacles, region_polygons = self._build(it, ob, link_rows, lob, list(new_regions.values()))
        by_key = dict(zip(new_keys, obstacles, strict=True))
        region_by_key = dict(zip(new_regions, region_polygons, strict=True))
        for part, part_keys, part_region_keys in zip(parts, keys, region_keys, strict=True):
            part.obstacles = [by_key[k] for k in part_keys]
            part.region_polygons = [region_by_key[k] for k in part_region_keys]

    def _build(
        self,
        items: np.ndarray,
        ob: np.ndarray,
        link_rows: np.ndarray,
        lob: np.ndarray,
        region_rows: list[np.ndarray],
    ) -> tuple[list[Obstacle], list[FloatArray]]:
        """:func:`make_obstacles` of the obstacles whose ``items`` (grouped by obstacle) are of
        obstacles ``ob`` (0 .. t - 1, ascending) and whose links ``link_rows`` are of ``lob``."""
        t = int(ob[-1]) + 1 if ob.shape[0] else 0
        return make_obstacles(
            ends=self.ends,
            links=self.links,
            item_segment=self.item_segment,
            item_candidate=self.item_candidate,
            items=items,
            counts=np.bincount(ob, minlength=t),
            link_rows=link_rows,
            link_counts=np.bincount(lob, minlength=t),
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


def _group_rows(
    groups: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> list[np.ndarray]:
    """The rows of each group of ``groups`` (views of its sorted rows)."""
    rows, starts = groups[0], groups[1]
    return [rows[s0:s1] for s0, s1 in zip(starts.tolist(), _stops(groups), strict=True)]


def _stops(groups: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> list[int]:
    """Where each group of ``groups`` ends in its sorted rows."""
    rows, starts = groups[0], groups[1]
    return [*starts[1:].tolist(), rows.shape[0]] if starts.shape[0] else []


def _partitions(ctx: _Context, actives: list[np.ndarray]) -> tuple[list[_Partition], _Groups]:
    """Obstacles of each situation whose items are ``actives``, and its relations between them:
    all situations in one compiled pass (:func:`modeling.model.partitions.partition_arrays`)."""
    rel = ctx.rel
    act = actives[0][None] if len(actives) == 1 else np.stack(actives)  # (S, N)
    arrays = partition_arrays(
        act,
        ctx.ri,
        ctx.rj,
        ctx.is_imp,
        ctx.is_und,
        ctx.is_short_pas,
        rel.p_passable,
        rel.distance_m,
    )
    items, counts, first_obst = arrays.items, arrays.counts, arrays.first_obst.tolist()
    imp_rows, link_obst = arrays.imp_rows, arrays.link_obst
    region_rows = _group_rows(arrays.und)
    at_item, at_imp = arrays.item_bounds.tolist(), arrays.imp_bounds.tolist()
    at_group = arrays.und_bounds.tolist()
    parts = [
        _Partition(
            items=items[at_item[k] : at_item[k + 1]],
            counts=counts[first_obst[k] : first_obst[k + 1]],
            imp_rows=imp_rows[at_imp[k] : at_imp[k + 1]],
            link_obst=link_obst[at_imp[k] : at_imp[k + 1]],
            region_rows=region_rows[at_group[k] : at_group[k + 1]],
        )
        for k in range(act.shape[0])
    ]
    return parts, _Groups(oi=arrays.oi, oj=arrays.oj, und=arrays.und, pas=arrays.pas)


class _Groups:
    """The relation groups of all situations (the undecided and the short passable rows'
    groups of :func:`~modeling.model.partitions.partition_arrays`), and each relation's obstacles in
    each situation."""

    __slots__ = ("oi", "oj", "pas", "und")

    def __init__(
        self,
        *,
        oi: np.ndarray,
        oj: np.ndarray,
        und: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        pas: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    ) -> None:
        self.oi, self.oj, self.und, self.pas = oi, oj, und, pas


def _narrowest_points(
    ctx: _Context, groups: _Groups, rows: np.ndarray, s: np.ndarray
) -> list[FloatArray]:
    """(2, 2) closest points of each of relation ``rows`` (of situations ``s``), the point on the
    lower-index obstacle first (read-only views of one array)."""
    out: FloatArray = ctx.links[rows]
    flip = groups.oi[s, rows] > groups.oj[s, rows]
    out[flip] = out[flip, ::-1]
    out.setflags(write=False)
    return list(out)


def _regions(ctx: _Context, parts: list[_Partition], groups: _Groups) -> list[list[CriticalRegion]]:
    """Each situation's critical regions: one per obstacle pair with undecided relations
    between them (region polygons already built by :meth:`_Context.prepare`)."""
    rows, starts, s, lo, hi = groups.und
    out: list[list[CriticalRegion]] = [[] for _ in parts]
    if rows.size == 0:
        return out
    rel = ctx.rel
    narrowest = rows[starts]
    w_mean, w_std = ctx.moments(narrowest)
    rel_lines = ctx.links[rows]
    rel_lines.setflags(write=False)
    rows_list = rows.tolist()
    polygons = [poly for part in parts for poly in part.region_polygons]
    for k, a_, b_, poly, wm, ws, p_, nw, s0, s1 in zip(
        s.tolist(),
        lo.tolist(),
        hi.tolist(),
        polygons,
        w_mean,
        w_std,
        rel.p_passable[narrowest].tolist(),
        _narrowest_points(ctx, groups, narrowest, s),
        starts.tolist(),
        _stops(groups.und),
        strict=True,
    ):
        out[k].append(
            CriticalRegion(
                obstacles=(a_, b_),
                polygon=poly,
                width_mean_m=wm,
                width_std_m=ws,
                p_passable=p_,
                narrowest=nw,
                relations=tuple(rows_list[s0:s1]),
                relation_lines=rel_lines[s0:s1],
            )
        )
    return out


def _passages(ctx: _Context, n_sit: int, groups: _Groups) -> list[list[Passage]]:
    """Each situation's passages: the narrowest per obstacle pair among its short passable
    relations."""
    rows, starts, s, lo, hi = groups.pas
    out: list[list[Passage]] = [[] for _ in range(n_sit)]
    if rows.size == 0:
        return out
    rel = ctx.rel
    first = rows[starts]
    for k, a_, b_, nw, d_, p_, r0 in zip(
        s.tolist(),
        lo.tolist(),
        hi.tolist(),
        _narrowest_points(ctx, groups, first, s),
        rel.distance_m[first].tolist(),
        rel.p_passable[first].tolist(),
        first.tolist(),
        strict=True,
    ):
        out[k].append(
            Passage(obstacles=(a_, b_), narrowest=nw, width_mean_m=d_, p_passable=p_, relation=r0)
        )
    return out


def _situations(
    ctx: _Context,
    actives: list[np.ndarray],
    probabilities: list[float],
    choices: list[dict[int, int]],
    robot_width_m: float,
) -> list[Situation]:
    """Obstacles, critical regions and passages of each situation whose items are ``actives``.

    Three passes: the partitions of all situations, then one batch for every obstacle and region
    polygon not cached yet, then the situations' regions and passages, all situations at once.
    """
    if not actives:
        return []
    parts, groups = _partitions(ctx, actives)
    ctx.prepare(parts)
    regions = _regions(ctx, parts, groups)
    passages = _passages(ctx, len(parts), groups)
    return [
        Situation(
            probability=float(probability),
            obstacles=tuple(part.obstacles),
            critical_regions=tuple(r),
            choice=dict(sorted(choice.items())),
            passages=tuple(ps),
            robot_width_m=robot_width_m,
        )
        for part, probability, choice, r, ps in zip(
            parts, probabilities, choices, regions, passages, strict=True
        )
    ]


def k_best(probs: list[np.ndarray], k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The ``k`` most probable joint choices of independent factors, best first (exact products).

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
