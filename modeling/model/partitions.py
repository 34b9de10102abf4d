"""The obstacles of every situation and the relation groups between them (paper section 4.2,
Eq. 2: what each possible situation's active items make).

A situation's obstacles are the connected components of the impassable relations among its
active items (section 4.1), numbered in the order of their smallest item. Between two obstacles
of a situation, its undecided relations make one critical region and its short passable ones one
passage: the relation rows are grouped by (situation, obstacle pair), each group sorted by
passability or distance. :func:`situation_partitions` does it for all the situations of a model
in one compiled pass (:mod:`modeling.model._kernels.partition`), each distinct obstacle once (the
situations share most: they differ by a few candidates), and what every situation shares (the
components of the items active in all of them) once;
:func:`situation_partitions_reference` is its readable NumPy reference, each situation on its own
(:func:`partition_arrays_reference`), then the obstacles identified by their items (equal
results; ``tests/modeling/model/test_compiled_model.py``).
"""

from __future__ import annotations

import numpy as np

from modeling.model._kernels import partition as _kernel
from modeling.model._kernels.partition import (
    FlipGroups,
    Groups,
    PartitionArrays,
    SituationPartitions,
)
from modeling.model.obstacles import components
from modeling.types import FloatArray

__all__ = [
    "FlipGroups",
    "Groups",
    "PartitionArrays",
    "SituationPartitions",
    "partition_arrays_reference",
    "situation_partitions",
    "situation_partitions_reference",
]


def situation_partitions(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    is_und: np.ndarray,
    is_short_pas: np.ndarray,
    p_passable: FloatArray,
    distance_m: FloatArray,
) -> SituationPartitions:
    """The obstacles of the situations whose active items are ``act`` (S, N) bool, each
    distinct one once, and their relation groups (:class:`SituationPartitions`), by the compiled
    :func:`modeling.model._kernels.partition.situation_partitions`.

    Args:
        act: (S, N) bool, the active items of each situation.
        ri, rj: (m,) int64, the items of each relation.
        is_imp, is_und, is_short_pas: (m,) bool, the impassable relations, the undecided ones
            and the passable ones short enough to be a passage.
        p_passable: (m,) the order within an undecided group (least passable first).
        distance_m: (m,) the order within a passage group (narrowest first).
    """
    arrays: SituationPartitions = _kernel.situation_partitions(
        np.ascontiguousarray(act),
        ri,
        rj,
        is_imp,
        _sorted_rows(is_und, p_passable),
        _sorted_rows(is_short_pas, distance_m),
    )
    return arrays


def _sorted_rows(mask: np.ndarray, within: FloatArray) -> np.ndarray:
    """(k,) int64 the rows of ``mask`` sorted by ``within`` (ascending; ties in row order)."""
    rows = np.flatnonzero(mask)
    out: np.ndarray = rows[np.argsort(within[rows], kind="stable")]
    return out


def situation_partitions_reference(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    is_und: np.ndarray,
    is_short_pas: np.ndarray,
    p_passable: FloatArray,
    distance_m: FloatArray,
) -> SituationPartitions:
    """The readable reference of :func:`situation_partitions` (equal results): every
    situation's partition by :func:`partition_arrays_reference`, then each obstacle identified
    by its items (their bytes), the first situation that has it giving its links."""
    arrays = partition_arrays_reference(
        act, ri, rj, is_imp, is_und, is_short_pas, p_passable, distance_m
    )
    distinct: dict[bytes, int] = {}
    obstacle: list[int] = []
    items: list[np.ndarray] = []
    links: list[np.ndarray] = []
    item_at, imp_at = arrays.item_bounds, arrays.imp_bounds
    for s in range(act.shape[0]):
        its = arrays.items[item_at[s] : item_at[s + 1]]
        counts = arrays.counts[arrays.first_obst[s] : arrays.first_obst[s + 1]]
        rows = arrays.imp_rows[imp_at[s] : imp_at[s + 1]]
        link_obst = arrays.link_obst[imp_at[s] : imp_at[s + 1]]
        starts = np.concatenate(([0], np.cumsum(counts)))
        for c in range(counts.shape[0]):
            members = its[starts[c] : starts[c + 1]]
            key = members.tobytes()
            if key not in distinct:
                distinct[key] = len(distinct)
                items.append(members)
                links.append(rows[link_obst == c])
            obstacle.append(distinct[key])
    empty = np.zeros(0, dtype=np.int64)
    return SituationPartitions(
        obstacle=np.array(obstacle, dtype=np.int64),
        first_obst=arrays.first_obst,
        items=np.concatenate(items) if items else empty,
        counts=np.array([a.shape[0] for a in items], dtype=np.int64),
        links=np.concatenate(links) if links else empty,
        link_counts=np.array([a.shape[0] for a in links], dtype=np.int64),
        und=_with_flip(arrays.und, arrays.oi, arrays.oj),
        und_bounds=arrays.und_bounds,
        pas=_with_flip(arrays.pas, arrays.oi, arrays.oj),
    )


def _with_flip(groups: Groups, oi: np.ndarray, oj: np.ndarray) -> FlipGroups:
    """``groups`` and whether each one's first row has its first item on the higher obstacle
    (``oi``, ``oj``: (S, m) the obstacle of each relation's items in each situation)."""
    rows, starts, s = groups[0], groups[1], groups[2]
    first = rows[starts]
    return (*groups, oi[s, first] > oj[s, first])


def partition_arrays_reference(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    is_und: np.ndarray,
    is_short_pas: np.ndarray,
    p_passable: np.ndarray,
    distance_m: np.ndarray,
) -> PartitionArrays:
    """Every situation's partition, in NumPy (:class:`PartitionArrays`): the obstacles of the
    situations whose active items are ``act`` (S, N) and their relation groups; the readable
    core of :func:`situation_partitions_reference`.

    All situations are labelled by one call: situation ``k``'s item ``x`` is node ``k N + x`` of
    one graph, so no component spans two situations and its smallest node is ``k N`` plus the
    smallest item; obstacles are numbered by their roots (the active items that are their own
    label), ascending.
    """
    n_sit, n = act.shape
    both = act[:, ri] & act[:, rj]  # (S, m)
    imp = both & is_imp
    s_imp, imp_rows = imp.nonzero()
    shift = s_imp * n
    labels = components(n_sit * n, ri[imp_rows] + shift, rj[imp_rows] + shift)
    roots = act & (labels == np.arange(n_sit * n)).reshape(n_sit, n)
    n_obst = roots.sum(axis=1)
    rank = (np.cumsum(roots, axis=1) - 1).reshape(-1)[labels].reshape(n_sit, n)
    obst = np.where(act, rank, -1)
    oi, oj = obst[:, ri], obst[:, rj]  # (S, m)
    between = both & (oi != oj)
    s_it, it = act.nonzero()  # the active items by (situation, obstacle, item)
    ob_it = obst[act]
    first_obst = np.zeros(n_sit + 1, dtype=np.int64)
    np.cumsum(n_obst, out=first_obst[1:])
    span = int(n_obst.max()) + 1
    und = _groups(between & is_und, oi, oj, p_passable, span)
    sit = np.arange(n_sit + 1)
    return PartitionArrays(
        items=it[np.lexsort((ob_it, s_it))],
        counts=np.bincount(first_obst[s_it] + ob_it, minlength=int(first_obst[-1])),
        first_obst=first_obst,
        item_bounds=np.searchsorted(s_it, sit),
        imp_rows=imp_rows,
        link_obst=oi[imp],
        imp_bounds=np.searchsorted(s_imp, sit),
        oi=oi,
        oj=oj,
        und=und,
        und_bounds=np.searchsorted(und[2], sit),
        pas=_groups(between & is_short_pas, oi, oj, distance_m, span),
    )


def _groups(
    mask: np.ndarray, oi: np.ndarray, oj: np.ndarray, within: FloatArray, span: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relation rows of every situation grouped by (situation, obstacle pair), each group
    sorted by ``within`` (ascending; ties in row order).

    Args:
        mask: (S, m) the relations of each situation to group.
        oi, oj: (S, m) obstacle of each relation's items in each situation.
        within: (m,) the order within a group.
        span: More than any obstacle number.

    Returns:
        ``(rows, starts, s, lo, hi)``: the sorted rows, the start of each group in them, and
        the group's situation and obstacle pair ``lo < hi``.
    """
    s, rows = mask.nonzero()  # situation-major, then by row
    if rows.shape[0] == 0:
        return rows, rows, s, rows, rows
    a, b = oi[mask], oj[mask]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = (s * span + lo) * span + hi  # ordered as (situation, lo, hi)
    srt = np.lexsort((within[rows], key))
    rows, key = rows[srt], key[srt]
    new = np.ones(rows.shape[0], dtype=bool)
    np.not_equal(key[1:], key[:-1], out=new[1:])
    starts = new.nonzero()[0]
    return rows, starts, s[srt][starts], lo[srt][starts], hi[srt][starts]
