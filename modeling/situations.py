"""Situations (paper section 4.1 per situation, section 4.2 / Eq. 2): partitions, critical
regions, passages and the k-best enumeration.

A situation is one choice of candidate per remaining unit of ambiguous segments; its items are the
base model's (kept segments and merged candidates) plus the chosen candidates. A unit whose
segments may be no obstacle (``AmbiguousSegment.p_none > 0``) has the choice "none" too, with
probability ``p_none`` and no item; ``Situation.choice`` maps its members to ``-1`` then.

* *Partition*: its obstacles are the connected components of impassable relations among its
  items, numbered in the order of their smallest item (:func:`_partition`).
* *Critical regions*: between two obstacles, all undecided relations form one
  :class:`~modeling.records.CriticalRegion` (convex hull of the relation endpoints) whose width
  distribution is that of its narrowest (least passable) relation. Undecided relations inside one
  obstacle make no region, as in the paper.
* *Passages*: passable relations shorter than 3 robot widths give, per obstacle pair, the
  narrowest :class:`~modeling.records.Passage` (used by the path graph).
* *Eq. 2*: a situation's probability is the product of its choices' probabilities ("none"
  included, so that all situations sum to 1 with the residual). Since the
  product factorises over units, the ``max_situations`` most probable situations are enumerated
  best-first (:func:`k_best`): exact probabilities, ``O(k log k)``, no enumeration of the full
  product.

Situations share most obstacles and region polygons (they differ by a few candidates): a
:class:`_Context` builds each once, identified by its items or relation rows, and caches the
width moments per relation row.

Frames: world, metres; probabilities in [0, 1].
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from modeling.ambiguity import Elimination, Unit
from modeling.gaps import Relation, gap_width_moments
from modeling.items import Items
from modeling.obstacles import components, make_obstacles
from modeling.records import CriticalRegion, Obstacle, Passage, Situation
from modeling.relations import SegmentRelations
from modeling.validation import FloatArray

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

    Computed for every situation first (:func:`_partition`), so that the obstacles and region
    polygons that no earlier situation built are built for all situations in one batch
    (:meth:`_Context.prepare`) before the situations are assembled (:func:`_situations`).

    Attributes:
        n_obst: Number of obstacles.
        items: (k,) active items sorted by (obstacle, item index).
        counts: (n_obst,) number of items of each obstacle.
        bounds: Where each obstacle's items start in ``items`` (n_obst + 1 entries).
        imp_rows: (q,) rows of the impassable relations inside obstacles (ascending).
        link_obst: (q,) obstacle of each of those rows.
        oi: (m,) obstacle of each relation's first item (-1: inactive).
        oj: (m,) obstacle of each relation's second item.
        und: Undecided rows between obstacles grouped by pair (see :func:`_pair_groups`).
        region_rows: The rows of each group of ``und``.
        pas_rows: (p,) short passable rows between obstacles (ascending).
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
        "oi",
        "oj",
        "pas_rows",
        "region_polygons",
        "region_rows",
        "und",
    )

    def __init__(
        self,
        *,
        items: np.ndarray,
        counts: np.ndarray,
        imp_rows: np.ndarray,
        link_obst: np.ndarray,
        oi: np.ndarray,
        oj: np.ndarray,
        und: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        pas_rows: np.ndarray,
    ) -> None:
        self.n_obst = int(counts.shape[0])
        self.items = items
        self.counts = counts
        self.bounds = [0, *np.cumsum(counts).tolist()]
        self.imp_rows = imp_rows
        self.link_obst = link_obst
        self.oi = oi
        self.oj = oj
        self.und = und
        rows, starts = und[0], und[1]
        stops = [*starts[1:].tolist(), rows.shape[0]] if starts.shape[0] else []
        self.region_rows = [rows[s0:s1] for s0, s1 in zip(starts.tolist(), stops, strict=True)]
        self.pas_rows = pas_rows
        self.obstacles: list[Obstacle] = []
        self.region_polygons: list[FloatArray] = []

    def keys(self) -> list[bytes]:
        """Cache key of each obstacle (its items' bytes)."""
        b = self.bounds
        return [self.items[b[c] : b[c + 1]].tobytes() for c in range(self.n_obst)]

    def region_keys(self) -> list[bytes]:
        """Cache key of each group of ``und`` (its rows' bytes)."""
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
        self.is_imp = rel.kind == _IMP
        self.is_und = rel.kind == _UND
        # Passable relations short enough to be a passage (the same in every situation).
        self.is_short_pas = (rel.kind == _PAS) & (rel.distance_m <= passage_max_m)

    def prepare(self, parts: list[_Partition]) -> None:
        """Build, in one batch, the obstacles and region polygons of ``parts`` (each once, from
        the first situation that has it; shared by content, their items' and relation rows'
        bytes, between situations), and set each part's ``obstacles`` and ``region_polygons``."""
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
        obstacles, region_polygons = make_obstacles(
            ends=self.ends,
            links=self.links,
            item_segment=self.item_segment,
            item_candidate=self.item_candidate,
            items=it,
            counts=np.bincount(ob, minlength=t),
            link_rows=link_rows,
            link_counts=np.bincount(lob, minlength=t),
            link_order=np.argsort(np.concatenate((ob, lob)), kind="stable"),
            outline_buffer_m=self.outline_buffer_m,
            region_rows=list(new_regions.values()),
        )
        by_key = dict(zip(new_keys, obstacles, strict=True))
        region_by_key = dict(zip(new_regions, region_polygons, strict=True))
        for part, part_keys, part_region_keys in zip(parts, keys, region_keys, strict=True):
            part.obstacles = [by_key[k] for k in part_keys]
            part.region_polygons = [region_by_key[k] for k in part_region_keys]

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


def _oriented(ctx: _Context, rows: np.ndarray, i_first: np.ndarray) -> FloatArray:
    """(k, 2, 2) closest points of relation rows, the point on the lower-index obstacle first."""
    out: FloatArray = ctx.links[rows]
    out[~i_first] = out[~i_first, ::-1]
    out.setflags(write=False)
    return out


def _pair_groups(
    rows: np.ndarray, oi: np.ndarray, oj: np.ndarray, n_obst: int, within: FloatArray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relation rows grouped by obstacle pair, each group sorted by ``within`` (ascending).

    Returns:
        ``(rows, starts, lo, hi)``: the sorted rows, the start of each group in them, and the
        group's obstacle pair ``lo < hi``.
    """
    a, b = oi[rows], oj[rows]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (n_obst + 1) + hi
    srt = np.lexsort((within[rows], key))
    rows, key = rows[srt], key[srt]
    starts = np.concatenate(([True], key[1:] != key[:-1])).nonzero()[0]
    return rows, starts, lo[srt][starts], hi[srt][starts]


def _obstacle_labels(ctx: _Context, actives: list[np.ndarray]) -> list[np.ndarray]:
    """For each situation (its active items), the component label of each item: the smallest
    item of its obstacle (a component of the impassable relations among its active items).

    All situations are labelled in one call: situation ``k``'s item ``x`` is node ``k N + x`` of
    one graph, so no component spans two situations and its smallest node is ``k N`` plus the
    smallest item.
    """
    rel = ctx.rel
    n = ctx.ends.shape[0]
    rows = [(active[rel.i] & active[rel.j] & ctx.is_imp).nonzero()[0] for active in actives]
    shift = [np.full(r.shape[0], k * n, dtype=np.int64) for k, r in enumerate(rows)]
    i = np.concatenate([rel.i[r] for r in rows]) + np.concatenate(shift)
    j = np.concatenate([rel.j[r] for r in rows]) + np.concatenate(shift)
    labels = components(len(actives) * n, i, j).reshape(len(actives), n)
    return list(labels - n * np.arange(len(actives))[:, None])


def _partition(ctx: _Context, active: np.ndarray, labels: np.ndarray) -> _Partition:
    """Obstacles of the situation whose items are ``active``, and its relations between them.

    Args:
        ctx: The model's context.
        active: (N,) the situation's items.
        labels: (N,) their obstacle labels (see :func:`_obstacle_labels`).
    """
    rel = ctx.rel
    n = active.shape[0]
    both = active[rel.i] & active[rel.j]
    imp_rows = (both & ctx.is_imp).nonzero()[0]
    act_idx = active.nonzero()[0]
    # Obstacles numbered in order of their smallest item (a component's label): the roots (the
    # active items that are their own label) in ascending order.
    act_labels = labels[act_idx]
    roots = act_idx[act_labels == act_idx]
    obst_of_root = np.empty(n, dtype=np.int64)
    obst_of_root[roots] = np.arange(roots.shape[0])
    obst_active = obst_of_root[act_labels]
    obst_of_item = np.full(n, -1, dtype=np.int64)
    obst_of_item[act_idx] = obst_active
    oi = obst_of_item[rel.i]
    oj = obst_of_item[rel.j]
    between = both & (oi != oj)
    n_obst = roots.shape[0]
    und_rows = (between & ctx.is_und).nonzero()[0]
    # The narrowest relation of a region is its least passable one (first in its group).
    und = (
        _pair_groups(und_rows, oi, oj, n_obst, rel.p_passable)
        if und_rows.shape[0]
        else (und_rows, und_rows, und_rows, und_rows)
    )
    return _Partition(
        items=act_idx[np.argsort(obst_active, kind="stable")],
        counts=np.bincount(obst_active, minlength=n_obst),
        imp_rows=imp_rows,
        link_obst=obst_of_item[rel.i[imp_rows]],
        oi=oi,
        oj=oj,
        und=und,
        pas_rows=(between & ctx.is_short_pas).nonzero()[0],
    )


def _regions(ctx: _Context, part: _Partition) -> list[CriticalRegion]:
    """One critical region per obstacle pair with undecided relations between them.

    Args:
        ctx: The model's context (region polygons already built by :meth:`_Context.prepare`).
        part: The situation's partition.
    """
    rows, starts, ra, rb = part.und
    if rows.size == 0:
        return []
    rel = ctx.rel
    oi, oj = part.oi, part.oj
    stops = [*starts[1:].tolist(), rows.shape[0]]
    narrowest = rows[starts]
    polys = part.region_polygons
    w_mean, w_std = ctx.moments(narrowest)
    narrow_pts = list(_oriented(ctx, narrowest, oi[narrowest] <= oj[narrowest]))
    rel_lines = ctx.links[rows]
    rel_lines.setflags(write=False)
    rows_list = rows.tolist()
    return [
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
        for a_, b_, poly, wm, ws, p_, nw, s0, s1 in zip(
            ra.tolist(),
            rb.tolist(),
            polys,
            w_mean,
            w_std,
            rel.p_passable[narrowest].tolist(),
            narrow_pts,
            starts.tolist(),
            stops,
            strict=True,
        )
    ]


def _passages(ctx: _Context, part: _Partition) -> list[Passage]:
    """The narrowest passage per obstacle pair among the situation's short passable relations.

    Args: as :func:`_regions`.
    """
    rows = part.pas_rows
    if rows.size == 0:
        return []
    rel = ctx.rel
    oi, oj = part.oi, part.oj
    rows, starts, ra, rb = _pair_groups(rows, oi, oj, part.n_obst, rel.distance_m)
    first = rows[starts]
    narrow_pts = list(_oriented(ctx, first, oi[first] <= oj[first]))
    return [
        Passage(obstacles=(a_, b_), narrowest=nw, width_mean_m=d_, p_passable=p_, relation=r0)
        for a_, b_, nw, d_, p_, r0 in zip(
            ra.tolist(),
            rb.tolist(),
            narrow_pts,
            rel.distance_m[first].tolist(),
            rel.p_passable[first].tolist(),
            first.tolist(),
            strict=True,
        )
    ]


def _situations(
    ctx: _Context,
    actives: list[np.ndarray],
    probabilities: list[float],
    choices: list[dict[int, int]],
    robot_width_m: float,
) -> list[Situation]:
    """Obstacles, critical regions and passages of each situation whose items are ``actives``.

    Three passes: the partitions of all situations, then one batch for every obstacle and region
    polygon not cached yet, then the situations (their width moments in situation order).
    """
    labels = _obstacle_labels(ctx, actives)
    parts = [_partition(ctx, a, lab) for a, lab in zip(actives, labels, strict=True)]
    ctx.prepare(parts)
    return [
        Situation(
            probability=float(probability),
            obstacles=tuple(part.obstacles),
            critical_regions=tuple(_regions(ctx, part)),
            choice=dict(sorted(choice.items())),
            passages=tuple(_passages(ctx, part)),
            robot_width_m=robot_width_m,
        )
        for part, probability, choice in zip(parts, probabilities, choices, strict=True)
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
