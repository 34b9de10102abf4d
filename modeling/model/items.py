"""The items of a model and their relations, and the isolated short segments (paper section 4.1).

Every unambiguous segment and every candidate of every ambiguous segment is an *item*; relations
(:mod:`modeling.model.relations`) are computed once between nearby items (candidates of the same
ambiguous segment are never related: they never coexist). An unambiguous segment whose 3D length
is below ``min_isolated_3d_length_m`` and whose relations to all other unambiguous segments are
passable is dropped as isolated and short (a likely false match); an ambiguous segment is dropped
when every candidate is short and isolated (from every other item). The length is that of the 3D
segment, not of its floor projection: ``hypot(floor length, height extent)``, the height extent
being ``|height_m[1] - height_m[0]|``. A vertical edge (a table leg: both ends at one floor point,
0.05 to 0.75 m high) is a long segment with a zero floor length, and is kept.

Frames: world, metres; covariances m^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modeling.model.gaps import Relation
from modeling.model.relations import EarlierRelations, SegmentRelations, segment_relations
from modeling.observation import FloorObservation
from modeling.types import FloatArray

__all__ = [
    "Isolation",
    "Items",
    "isolated_short_segments",
    "item_relations",
    "items_of",
    "length_3d",
]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Items:
    """The items of an observation: its segments, then its ambiguous segments' candidates.

    Attributes:
        ends: (N, 2, 2) endpoint means, world frame, metres.
        covs: (N, 2, 2, 2) endpoint covariances, m^2.
        heights: (N, 2) heights of the 3D endpoints above the floor, metres.
        segment: (N,) read-only, index into ``observation.segments`` (-1: a candidate).
        candidate: (N, 2) read-only, ``(ambiguous index, candidate index)`` (-1: a segment).
        of_ambiguous: ``of_ambiguous[a][c]``: the item of candidate ``c`` of ambiguous ``a``.
    """

    ends: FloatArray
    covs: FloatArray
    heights: FloatArray
    segment: np.ndarray
    candidate: np.ndarray
    of_ambiguous: list[list[int]]

    @property
    def ambiguous(self) -> np.ndarray:
        """(N,) ambiguous index of each item (-1: an unambiguous segment)."""
        return self.candidate[:, 0]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Isolation:
    """The outcome of the isolated-short-segment test.

    Attributes:
        kept_segments: Indices of the unambiguous segments kept.
        eliminated_segments: Indices of those eliminated as isolated and short.
        live_ambiguous: Ambiguous indices kept, ascending.
        eliminated_ambiguous: Ambiguous indices whose every candidate is isolated and short.
    """

    kept_segments: tuple[int, ...]
    eliminated_segments: tuple[int, ...]
    live_ambiguous: list[int]
    eliminated_ambiguous: list[int]


def items_of(observation: FloorObservation) -> Items:
    """The items of ``observation``: item ``k < n_seg`` is segment ``k``, then the candidates."""
    segs = observation.segments
    amb = observation.ambiguous
    n_seg = len(segs)
    ends_l = [s.endpoints for s in segs]
    cov_l = [s.cov for s in segs]
    h_l = [s.height_m for s in segs]
    cand_item: list[list[int]] = []
    for am in amb:
        cand_item.append(list(range(len(ends_l), len(ends_l) + len(am.candidates))))
        ends_l.extend(cand.endpoints for cand in am.candidates)
        cov_l.extend(cand.cov for cand in am.candidates)
        h_l.extend(cand.height_m for cand in am.candidates)
    n = len(ends_l)
    # one concatenation of the (2, 2) and (2, 2, 2) arrays (np.asarray of a list of arrays
    # inspects every element first, at twice the cost)
    ends = np.concatenate(ends_l, dtype=np.float64).reshape(n, 2, 2) if n else np.zeros((0, 2, 2))
    covs = (
        np.concatenate(cov_l, dtype=np.float64).reshape(n, 2, 2, 2) if n else np.zeros((0, 2, 2, 2))
    )
    heights = np.concatenate(h_l, dtype=np.float64).reshape(n, 2) if n else np.zeros((0, 2))
    segment = np.full(n, -1, dtype=np.int64)
    segment[:n_seg] = np.arange(n_seg)
    candidate = np.full((n, 2), -1, dtype=np.int64)
    if n > n_seg:
        candidate[n_seg:] = [(a, c) for a, am in enumerate(amb) for c in range(len(am.candidates))]
    for arr in (segment, candidate):
        arr.setflags(write=False)
    return Items(
        ends=ends,
        covs=covs,
        heights=heights,
        segment=segment,
        candidate=candidate,
        of_ambiguous=cand_item,
    )


def length_3d(items: Items) -> FloatArray:
    """(N,) the 3D length of each item, metres: ``hypot(floor length, height extent)``."""
    if items.ends.shape[0] == 0:
        return np.zeros(0)
    d = items.ends[:, 1] - items.ends[:, 0]
    dz = items.heights[:, 1] - items.heights[:, 0]
    out: FloatArray = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + dz**2)
    return out


def item_relations(
    items: Items, robot_width_m: float, eps: float, earlier: EarlierRelations | None = None
) -> SegmentRelations:
    """Relations among all items, never between candidates of one ambiguous segment (``earlier``:
    relations made before, whose rows equal pairs take again)."""
    return segment_relations(
        items.ends, items.covs, robot_width_m, eps, group=items.ambiguous, earlier=earlier
    )


def isolated_short_segments(
    items: Items, rel: SegmentRelations, min_isolated_3d_length_m: float
) -> Isolation:
    """Section 4.1: the isolated short segments, and the ambiguous ones whose every candidate is.

    Args:
        items: The model's items.
        rel: Their relations.
        min_isolated_3d_length_m: Isolated segments whose 3D length (floor length and height
            extent, see the module docstring) is below this are dropped, metres.
    """
    n = items.ends.shape[0]
    nonpass = rel.kind != int(Relation.PASSABLE)
    length = length_3d(items)
    is_seg = items.segment >= 0
    seg_pair = nonpass & is_seg[rel.i] & is_seg[rel.j]
    deg_seg = np.bincount(np.concatenate((rel.i[seg_pair], rel.j[seg_pair])), minlength=n)
    drop_seg = is_seg & (deg_seg == 0) & (length < min_isolated_3d_length_m)
    deg_all = np.bincount(np.concatenate((rel.i[nonpass], rel.j[nonpass])), minlength=n)
    live: list[int] = []
    eliminated: list[int] = []
    length_l, deg_l = length.tolist(), deg_all.tolist()  # Python scalars for the loop
    for a, ids in enumerate(items.of_ambiguous):
        if all(length_l[x] < min_isolated_3d_length_m and deg_l[x] == 0 for x in ids):
            eliminated.append(a)
        else:
            live.append(a)
    return Isolation(
        kept_segments=tuple((is_seg & ~drop_seg).nonzero()[0].tolist()),
        eliminated_segments=tuple(drop_seg.nonzero()[0].tolist()),
        live_ambiguous=live,
        eliminated_ambiguous=eliminated,
    )
