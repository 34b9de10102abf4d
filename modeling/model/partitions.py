"""The obstacles of every situation and the relation groups between them (paper section 4.2,
Eq. 2: what each possible situation's active items make).

A situation's obstacles are the connected components of the impassable relations among its
active items (section 4.1), numbered in the order of their smallest item. Between two obstacles
of a situation, its undecided relations make one critical region and its short passable ones one
passage: the relation rows are grouped by (situation, obstacle pair), each group sorted by
passability or distance. :func:`partition_arrays` does it for all the situations of a model in
one compiled pass (:mod:`modeling.model._kernels.partition`); :func:`partition_arrays_reference` is
its readable NumPy reference (equal results; ``tests/modeling/model/test_compiled_model.py``).
"""

from __future__ import annotations

import numpy as np

from modeling.model._kernels import partition as _kernel
from modeling.model._kernels.partition import Groups, PartitionArrays
from modeling.model.obstacles import components
from modeling.types import FloatArray

__all__ = ["Groups", "PartitionArrays", "partition_arrays", "partition_arrays_reference"]


def partition_arrays(
    act: np.ndarray,
    ri: np.ndarray,
    rj: np.ndarray,
    is_imp: np.ndarray,
    is_und: np.ndarray,
    is_short_pas: np.ndarray,
    p_passable: FloatArray,
    distance_m: FloatArray,
) -> PartitionArrays:
    """The obstacles of the situations whose active items are ``act`` (S, N) bool, and their
    relation groups (:class:`PartitionArrays`).

    Args:
        act: (S, N) bool, the active items of each situation.
        ri, rj: (m,) int64, the items of each relation.
        is_imp, is_und, is_short_pas: (m,) bool, the impassable relations, the undecided ones
            and the passable ones short enough to be a passage.
        p_passable: (m,) the order within an undecided group (least passable first).
        distance_m: (m,) the order within a passage group (narrowest first).
    """
    arrays: PartitionArrays = _kernel.partition_arrays(
        np.ascontiguousarray(act), ri, rj, is_imp, is_und, is_short_pas, p_passable, distance_m
    )
    return arrays


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
    """The readable reference of the compiled
    :func:`modeling.model._kernels.partition.partition_arrays`, in NumPy (equal results): the
    obstacles of the situations whose active items are ``act`` (S, N) and their relation groups.

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
