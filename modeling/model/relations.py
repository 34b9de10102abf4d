"""Relations between uncertain floor segments (paper sections 2 and 4.1).

Two segments are related through their closest points (computed on the mean geometry), so a gap in
the middle of a long wall is found, not only gaps between endpoints. The uncertainty of the point at
parameter ``t`` of a segment with endpoints ``a ~ N(A, Ca)`` and ``b ~ N(B, Cb)`` is interpolated:
mean ``(1 - t) A + t B``, covariance ``(1 - t)^2 Ca + t^2 Cb``, which assumes the two endpoints of a
segment are independent (the stereo fit of a segment correlates them positively, so this slightly
understates the uncertainty in the middle of a segment; it is exact at the endpoints). Points of two
different segments are independent.

Only nearby pairs are examined: an envelope query of a shapely STRtree (the mean segments' boxes,
each grown by ``width / 2 + k sigma_i``, against each other), then an exact filter
``distance <= width + k (sigma_i + sigma_j)`` where ``sigma_i`` bounds the endpoint standard
deviations of segment ``i`` and ``k = sqrt(2 ln(1000 / eps))``; the cost grows with the number of
nearby pairs, not with the square of the number of segments. Pairs not listed
are passable with probability above ``1 - eps / 1000`` (a Gaussian tail bound), so their
classification (passable) is certain. The two endpoints of one segment are impassable to each other
by construction: a segment is one node of the relation graph.

The steps run as compiled loops (:mod:`modeling.model._kernels.gap`); each has its readable NumPy
reference at the end of this module, which the tests compare it with.

Relations made before (:class:`EarlierRelations`: the fused memory's model is made after every
view, and most remembered segments did not change since the last) lend their rows: a pair of
segments equal bit for bit to an earlier pair, in the same order, has the same row, so only the
other rows are computed. When the earlier relations were listed for the same width and ``eps``
and the segments that did not change kept their order (and their groups, up to renumbering),
the pairs among those are the earlier pairs too (the envelope query and the exact filter judge a
pair by its two segments alone): only the pairs with a changed segment are looked for, the boxes
of the changed segments against all others, and the rest come from the earlier rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from modeling.model._kernels import gap as _gap_kernel
from modeling.model._kernels.gap import PairParams, Segments
from modeling.model.gaps import (
    QUADRATURE_RULES,
    Relation,
    classify_gaps,
    gap_passable_probability,
)
from modeling.types import FloatArray

__all__ = [
    "EarlierRelations",
    "SegmentRelations",
    "candidate_pairs",
    "closest_points",
    "closest_points_reference",
    "earlier_rows",
    "grown_boxes_reference",
    "near_pairs_reference",
    "prune_sigmas",
    "relation_rows_reference",
    "relation_rows_taking_reference",
    "segment_relations",
]


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class SegmentRelations:
    """Relations between pairs of segments (one row per examined unordered pair, ``i < j``).

    Attributes:
        i: (m,) index of the first segment of each pair.
        j: (m,) index of the second segment (``j > i``).
        point_i: (m, 2) mean of the closest point on segment ``i``, world frame, metres.
        point_j: (m, 2) mean of the closest point on segment ``j``, metres.
        cov_i: (m, 2, 2) covariance of ``point_i``, m^2.
        cov_j: (m, 2, 2) covariance of ``point_j``, m^2.
        distance_m: (m,) distance between the two means, metres.
        p_passable: (m,) probability that the gap exceeds the robot width.
        kind: (m,) int8 :class:`~modeling.model.gaps.Relation` codes.
    """

    i: np.ndarray
    j: np.ndarray
    point_i: FloatArray
    point_j: FloatArray
    cov_i: FloatArray
    cov_j: FloatArray
    distance_m: FloatArray
    p_passable: FloatArray
    kind: np.ndarray

    def __len__(self) -> int:
        return int(self.i.shape[0])

    def kind_of(self, a: int, b: int) -> Relation:
        """The relation between segments ``a`` and ``b`` (symmetric; unlisted pairs: passable)."""
        lo, hi = min(a, b), max(a, b)
        hit = np.flatnonzero((self.i == lo) & (self.j == hi))
        return Relation(int(self.kind[hit[0]])) if hit.size else Relation.PASSABLE

    def p_of(self, a: int, b: int) -> float:
        """``p_passable`` between segments ``a`` and ``b`` (1.0 for unlisted pairs)."""
        lo, hi = min(a, b), max(a, b)
        hit = np.flatnonzero((self.i == lo) & (self.j == hi))
        return float(self.p_passable[hit[0]]) if hit.size else 1.0

    def subset(self, mask: np.ndarray) -> SegmentRelations:
        """The rows where ``mask`` (m,) is true."""
        return SegmentRelations(
            i=self.i[mask],
            j=self.j[mask],
            point_i=self.point_i[mask],
            point_j=self.point_j[mask],
            cov_i=self.cov_i[mask],
            cov_j=self.cov_j[mask],
            distance_m=self.distance_m[mask],
            p_passable=self.p_passable[mask],
            kind=self.kind[mask],
        )


@dataclass(frozen=True, slots=True)
class EarlierRelations:
    """Relations made before, whose rows :func:`segment_relations` may take again.

    Attributes:
        endpoints: (n, 2, 2) their segments' mean endpoints, metres.
        cov: (n, 2, 2, 2) their endpoint covariances, m^2.
        width_m: The robot width they were made for, metres.
        relations: The relations.
        eps: The classification tolerance whose candidate pairs they list (None: not known;
            then only their rows are taken, never their pairs).
        group: (n,) the group of each of their segments (-1: none; None: no groups), as
            :func:`segment_relations` took it.
    """

    endpoints: FloatArray
    cov: FloatArray
    width_m: float
    relations: SegmentRelations
    eps: float | None = None
    group: np.ndarray | None = None


def closest_points(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Parameters of the closest points of segments ``p1-q1`` and ``p2-q2`` (vectorised).

    Args:
        p1: (m, 2) first endpoints of the first segments.
        q1: (m, 2) second endpoints of the first segments.
        p2: (m, 2) first endpoints of the second segments.
        q2: (m, 2) second endpoints of the second segments.

    Returns:
        ``(s, t)``, each (m,) in [0, 1]: the closest points are ``p1 + s (q1 - p1)`` and
        ``p2 + t (q2 - p2)`` (after Ericson, Real-Time Collision Detection, 5.1.9). For parallel
        overlapping segments the middle of the overlap is chosen. A compiled loop; its reference
        is :func:`closest_points_reference`.
    """
    pairs = _gap_kernel.SegmentPairs(
        np.ascontiguousarray(p1, dtype=np.float64),
        np.ascontiguousarray(q1, dtype=np.float64),
        np.ascontiguousarray(p2, dtype=np.float64),
        np.ascontiguousarray(q2, dtype=np.float64),
    )
    s, t = _gap_kernel.closest_params_batch(pairs)
    return s, t


def candidate_pairs(
    endpoints: FloatArray, cov: FloatArray, width_m: float, eps: float = 0.05
) -> np.ndarray:
    """Unordered pairs (p, 2) with ``i < j`` of segments close enough to be not surely passable.

    Args:
        endpoints: (n, 2, 2) mean endpoints, metres.
        cov: (n, 2, 2, 2) endpoint covariances, m^2.
        width_m: Robot width, metres.
        eps: Classification tolerance; unlisted pairs are passable with probability above
            ``1 - eps / 1000`` (see :func:`prune_sigmas`).
    """
    pairs = _pairs_and_params(
        np.ascontiguousarray(endpoints, dtype=np.float64),
        np.ascontiguousarray(cov, dtype=np.float64),
        width_m,
        eps,
    )
    return np.stack([pairs.i, pairs.j], axis=1)


def _pairs_and_params(
    endpoints: FloatArray, cov: FloatArray, width_m: float, eps: float
) -> PairParams:
    """Candidate pairs ``(i, j)``, sorted, and the closest-point parameters ``(s, t)`` of each
    (compiled loops; references :func:`grown_boxes_reference`, :func:`near_pairs_reference`)."""
    if endpoints.shape[0] < 2:
        empty = np.zeros(0, dtype=np.int64)
        return PairParams(empty, empty, np.zeros(0), np.zeros(0))
    k = prune_sigmas(eps)
    # Envelope query: the mean segments i and j are at least as far apart as their boxes along
    # either axis, so a pair within width + k (s_i + s_j) has intersecting boxes when each box is
    # grown by width / 2 + k s_i, with s_i the square root of the larger endpoint covariance
    # trace (an upper bound of the largest eigenvalue).
    sigma, box = _gap_kernel.grown_boxes(Segments(endpoints, cov), 0.5 * width_m, k)
    boxes = shapely.box(box[:, 0], box[:, 1], box[:, 2], box[:, 3])
    hits = shapely.STRtree(boxes).query(boxes).astype(np.int64, copy=False)
    # Exact filter on the mean distance between the segments, pairs sorted by (i, j).
    return _gap_kernel.near_pairs(endpoints, sigma, hits, float(width_m), k)


def prune_sigmas(eps: float) -> float:
    """Multiple of the summed sigmas beyond which a gap is surely passable for tolerance ``eps``.

    For ``d ~ N(mu, S)`` with ``S``'s largest eigenvalue at most ``s^2``,
    ``P(||d|| <= w) <= exp(-(|mu| - w)^2 / (2 s^2))``; requiring this to be below ``eps / 1000``
    gives ``|mu| - w >= s sqrt(2 ln(1000 / eps))``.
    """
    return math.sqrt(2.0 * math.log(1000.0 / eps))


def segment_relations(
    endpoints: FloatArray,
    cov: FloatArray,
    width_m: float,
    eps: float,
    *,
    pairs: np.ndarray | None = None,
    group: np.ndarray | None = None,
    earlier: EarlierRelations | None = None,
) -> SegmentRelations:
    """Relations of nearby segment pairs: closest points, their uncertainty, ``p_passable``, kind.

    Args:
        endpoints: (n, 2, 2) mean endpoints, world frame, metres.
        cov: (n, 2, 2, 2) endpoint covariances, m^2.
        width_m: Robot width (diameter), metres.
        eps: Classification tolerance (see :func:`~modeling.model.gaps.classify_gap`).
        pairs: (p, 2) pairs to examine; default: :func:`candidate_pairs`.
        group: (n,) int, a group of each segment (-1: none): two segments of one group are not
            related (no row). Default: no groups.
        earlier: Relations made before: the rows of pairs equal to theirs are taken from them
            (the same rows as computed; see the module docstring).

    Returns:
        The :class:`SegmentRelations`, rows sorted by ``(i, j)``.
    """
    endpoints = np.ascontiguousarray(endpoints, dtype=np.float64)
    cov = np.ascontiguousarray(cov, dtype=np.float64)
    width = float(width_m)
    along = None
    if pairs is None and earlier is not None:
        along = _pairs_along_earlier(endpoints, cov, width, eps, group, earlier)
    take: np.ndarray | None = None  # the row of ``earlier`` of each pair (-1: to compute)
    if along is not None:
        # The pairs of unchanged segments from ``earlier``, the others found (the same
        # relations: see the module docstring).
        params, take = along
    else:
        if pairs is None:
            params = _pairs_and_params(endpoints, cov, width_m, eps)
        else:
            i = np.minimum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
            j = np.maximum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
            Ei, Ej = endpoints[i], endpoints[j]
            s, t = closest_points(Ei[:, 0], Ei[:, 1], Ej[:, 0], Ej[:, 1])
            params = PairParams(i, j, s, t)
        params = _ungrouped(params, group)
        if earlier is not None and earlier.width_m == width and len(earlier.relations):
            take = earlier_rows(endpoints, cov, params, earlier)
    # Closest points, covariances, distance and p_passable of each pair: a compiled loop (its
    # references: relation_rows_reference, relation_rows_taking_reference), taking the rows
    # ``take`` names from ``earlier``.
    if take is None or earlier is None:
        rows = _gap_kernel.relation_rows(Segments(endpoints, cov), params, width, QUADRATURE_RULES)
    else:
        rel = earlier.relations
        rows = _gap_kernel.relation_rows_taking(
            Segments(endpoints, cov),
            params,
            width,
            QUADRATURE_RULES,
            take,
            _gap_kernel.RelationRows(
                rel.point_i, rel.point_j, rel.cov_i, rel.cov_j, rel.distance_m, rel.p_passable
            ),
        )
    return SegmentRelations(
        i=params.i,
        j=params.j,
        point_i=rows.point_i,
        point_j=rows.point_j,
        cov_i=rows.cov_i,
        cov_j=rows.cov_j,
        distance_m=rows.distance,
        p_passable=rows.p_passable,
        kind=classify_gaps(rows.p_passable, eps),
    )


def _ungrouped(params: PairParams, group: np.ndarray | None) -> PairParams:
    """The pairs of ``params`` whose two segments are not of one group (``group`` (n,), -1:
    none)."""
    if group is None:
        return params
    same = (group[params.i] >= 0) & (group[params.i] == group[params.j])
    if not same.any():
        return params
    keep = ~same
    return PairParams(params.i[keep], params.j[keep], params.s[keep], params.t[keep])


def _pairs_along_earlier(
    endpoints: FloatArray,
    cov: FloatArray,
    width_m: float,
    eps: float,
    group: np.ndarray | None,
    earlier: EarlierRelations,
) -> tuple[PairParams, np.ndarray] | None:
    """The pairs of :func:`segment_relations` (sorted by ``(i, j)``, not of one group) and the
    row of ``earlier`` of each (-1: to compute), the pairs of two unchanged segments taken from
    ``earlier``'s rows; None where that cannot be done (``earlier`` made for another width or
    ``eps``, duplicate segments, unchanged segments reordered or regrouped), and then
    :func:`segment_relations` makes the pairs anew.

    A segment is unchanged when equal bit for bit (endpoints and covariances) to one of
    ``earlier``. Two unchanged segments are a pair exactly when their earlier selves were (the
    grown boxes, the distance filter and the group test read only the two segments), and their
    row is the earlier one when they kept their order. The pairs with a changed segment are
    found as :func:`candidate_pairs` finds them, with the changed segments' boxes tested
    against every box (inclusive bounds, as the STRtree's envelope query).
    """
    rel = earlier.relations
    n, n_old = endpoints.shape[0], earlier.endpoints.shape[0]
    if earlier.eps != eps or earlier.width_m != width_m or len(rel) == 0 or n < 2:
        return None
    old, distinct = _earlier_of(endpoints, cov, earlier)
    if not distinct:  # duplicates among the earlier segments
        return None
    kept = np.flatnonzero(old >= 0)
    if np.any(np.diff(old[kept]) <= 0):  # reordered, or one earlier segment twice
        return None
    if not _same_grouping(
        None if group is None else group[kept],
        None if earlier.group is None else earlier.group[old[kept]],
    ):
        return None
    new_of_old = np.full(n_old, -1, dtype=np.int64)
    new_of_old[old[kept]] = kept
    ni, nj = new_of_old[rel.i], new_of_old[rel.j]
    taken = np.flatnonzero((ni >= 0) & (nj >= 0))
    found = _pairs_of_changed(endpoints, cov, width_m, eps, old < 0)
    found = _ungrouped(found, group)
    i = np.concatenate((ni[taken], found.i))
    j = np.concatenate((nj[taken], found.j))
    order = np.argsort(i * n + j, kind="stable")
    zeros = np.zeros(taken.shape[0])  # parameters of taken rows: not read
    params = PairParams(
        i[order],
        j[order],
        np.concatenate((zeros, found.s))[order],
        np.concatenate((zeros, found.t))[order],
    )
    take = np.concatenate((taken, np.full(found.i.shape[0], -1, dtype=np.int64)))[order]
    return params, take


def _same_grouping(new: np.ndarray | None, old: np.ndarray | None) -> bool:
    """Whether two segments are of one group in ``new`` exactly when they are in ``old`` (the
    groups of the same segments then and now; None: no groups)."""
    if new is None and old is None:
        return True
    a = np.full(0 if new is None else new.shape[0], -1) if old is None else old
    b = np.full(a.shape[0], -1) if new is None else new
    if np.any((a < 0) != (b < 0)):
        return False
    a, b = a[a >= 0], b[b >= 0]
    if a.shape[0] == 0:
        return True
    # the distinct (old group, new group) links: one per old group and one per new group
    links = np.unique(a * (int(b.max()) + 1) + b).shape[0]
    return bool(np.unique(a).shape[0] == links == np.unique(b).shape[0])


def _pairs_of_changed(
    endpoints: FloatArray, cov: FloatArray, width_m: float, eps: float, changed: np.ndarray
) -> PairParams:
    """The pairs of :func:`_pairs_and_params` with at least one segment where ``changed`` (n,)
    bool, sorted by ``(i, j)``: the grown boxes of the changed segments tested against every
    box, then the exact filter."""
    k = prune_sigmas(eps)
    sigma, box = _gap_kernel.grown_boxes(Segments(endpoints, cov), 0.5 * width_m, k)
    rows = np.flatnonzero(changed)
    b = box[rows]
    hit = (
        (b[:, None, 0] <= box[None, :, 2])
        & (box[None, :, 0] <= b[:, None, 2])
        & (b[:, None, 1] <= box[None, :, 3])
        & (box[None, :, 1] <= b[:, None, 3])
    )
    # A pair of two changed segments once (from the lower one), and no segment with itself.
    hit &= ~changed[None, :] | (np.arange(changed.shape[0])[None, :] > rows[:, None])
    a, other = np.nonzero(hit)
    a = rows[a]
    hits = np.stack((np.minimum(a, other), np.maximum(a, other)))
    return _gap_kernel.near_pairs(endpoints, sigma, hits, float(width_m), k)


def earlier_rows(
    endpoints: FloatArray, cov: FloatArray, params: PairParams, earlier: EarlierRelations
) -> np.ndarray:
    """(m,) the row of ``earlier`` of each pair of ``params`` (-1: none): a pair whose two
    segments are equal bit for bit (endpoints and covariances) to two earlier segments, in the
    same order, that have a row there."""
    n_old = earlier.endpoints.shape[0]
    old, _ = _earlier_of(endpoints, cov, earlier)
    oi, oj = old[params.i], old[params.j]
    rel = earlier.relations
    old_code = rel.i * n_old + rel.j  # ascending: the rows are sorted by (i, j)
    code = oi * n_old + oj
    at = np.minimum(np.searchsorted(old_code, code), old_code.shape[0] - 1)
    found = (oi >= 0) & (oj > oi) & (old_code[at] == code)
    return np.where(found, at, -1)


def _earlier_of(
    endpoints: FloatArray, cov: FloatArray, earlier: EarlierRelations
) -> tuple[np.ndarray, bool]:
    """(n,) the earlier segment equal bit for bit to each segment (-1: none; of equal earlier
    segments, the last), and whether the earlier segments are all distinct."""
    index = {key: k for k, key in enumerate(_segment_keys(earlier.endpoints, earlier.cov))}
    old = np.array([index.get(key, -1) for key in _segment_keys(endpoints, cov)], dtype=np.int64)
    return old, len(index) == earlier.endpoints.shape[0]


def _segment_keys(endpoints: FloatArray, cov: FloatArray) -> list[bytes]:
    """Each segment's endpoints and covariances as bytes (equal keys: equal segments)."""
    n = endpoints.shape[0]
    both = np.ascontiguousarray(
        np.concatenate((endpoints.reshape(n, 4), cov.reshape(n, 8)), axis=1)
    )
    keys: list[bytes] = both.view(np.dtype((np.void, 96))).reshape(n).tolist()
    return keys


# ------------------------------------------------------- readable references (paper 4.1)
def closest_points_reference(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """:func:`closest_points` in NumPy (the reference of the compiled loop): Ericson's closest
    points of two segments (Real-Time Collision Detection, 5.1.9), vectorised over m pairs."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        # Segment 2's endpoints projected onto segment 1, clamped: the parallel case takes the
        # middle of the overlap; they also clamp s when t is clamped, and serve a point segment 2.
        s_at_p2 = np.clip(-c / a, 0.0, 1.0)
        s_at_q2 = np.clip((b - c) / a, 0.0, 1.0)
        general = denom > 1e-12 * a * e
        s = np.where(general, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.5 * (s_at_p2 + s_at_q2))
        t = (b * s + f) / e
        s = np.where(t < 0.0, s_at_p2, np.where(t > 1.0, s_at_q2, s))
        t = np.clip(t, 0.0, 1.0)
        t_point_1 = np.clip(f / e, 0.0, 1.0)  # segment 1 is a point
    point_1, point_2 = a <= 1e-18, e <= 1e-18
    s = np.where(point_1, 0.0, np.where(point_2, s_at_p2, s))
    t = np.where(point_2, 0.0, np.where(point_1, t_point_1, t))
    return s, t


def grown_boxes_reference(
    endpoints: FloatArray, cov: FloatArray, half_width: float, k: float
) -> tuple[FloatArray, FloatArray]:
    """Each segment's sigma bound (n,) (the square root of the larger endpoint covariance trace)
    and its box (n, 4) ``x_min, y_min, x_max, y_max`` grown by ``half_width + k sigma`` (the
    reference of the compiled loop)."""
    sigma = np.sqrt((cov[:, :, 0, 0] + cov[:, :, 1, 1]).max(axis=1))
    grow = (half_width + k * sigma)[:, None]
    return sigma, np.hstack([endpoints.min(axis=1) - grow, endpoints.max(axis=1) + grow])


def near_pairs_reference(
    endpoints: FloatArray, sigma: FloatArray, hits: np.ndarray, limit: float, k: float
) -> PairParams:
    """The hits (2, m) ``i < j`` whose mean segments are at most ``limit + k (sigma_i +
    sigma_j)`` apart, sorted by ``(i, j)``, with their closest-point parameters (the reference
    of the compiled loop)."""
    upper = hits[0] < hits[1]
    i, j = hits[0][upper], hits[1][upper]
    order = np.lexsort((j, i))
    i, j = i[order].astype(np.int64), j[order].astype(np.int64)
    Ei, Ej = endpoints[i], endpoints[j]
    s, t = closest_points_reference(Ei[:, 0], Ei[:, 1], Ej[:, 0], Ej[:, 1])
    pa = Ei[:, 0] + s[:, None] * (Ei[:, 1] - Ei[:, 0])
    pb = Ej[:, 0] + t[:, None] * (Ej[:, 1] - Ej[:, 0])
    keep = np.hypot(*(pb - pa).T) <= limit + k * (sigma[i] + sigma[j])
    return PairParams(i[keep], j[keep], s[keep], t[keep])


def relation_rows_reference(
    endpoints: FloatArray, cov: FloatArray, pairs: PairParams, width_m: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The closest points of the pairs, their interpolated covariances ``(1 - s)^2 C_0 + s^2
    C_1``, the distance and :func:`~modeling.model.gaps.gap_passable_probability` (the reference of
    the compiled loop, whose passability agrees to 1e-4).

    Returns:
        ``(point_i, point_j, cov_i, cov_j, distance_m, p_passable)``.
    """

    def interpolate(seg: np.ndarray, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        mean = (1.0 - u)[:, None] * endpoints[seg, 0] + u[:, None] * endpoints[seg, 1]
        c = ((1.0 - u) ** 2)[:, None, None] * cov[seg, 0] + (u**2)[:, None, None] * cov[seg, 1]
        return mean, c

    mi, ci = interpolate(pairs.i, pairs.s)
    mj, cj = interpolate(pairs.j, pairs.t)
    p = np.array(
        [gap_passable_probability(*args, width_m) for args in zip(mi, ci, mj, cj, strict=True)]
    )
    return mi, mj, ci, cj, np.hypot(*(mj - mi).T), p.reshape(-1)


def relation_rows_taking_reference(
    endpoints: FloatArray,
    cov: FloatArray,
    pairs: PairParams,
    width_m: float,
    take: np.ndarray,
    earlier: tuple[FloatArray, ...],
) -> tuple[FloatArray, ...]:
    """:func:`relation_rows_reference` with the rows where ``take >= 0`` copied from those rows
    of ``earlier`` (``(point_i, point_j, cov_i, cov_j, distance_m, p_passable)``): the reference
    of the compiled loop :func:`modeling.model._kernels.gap.relation_rows_taking`."""
    computed = relation_rows_reference(endpoints, cov, pairs, width_m)
    taken = take >= 0
    out = []
    for mine, theirs in zip(computed, earlier, strict=True):
        rows = np.array(mine, dtype=np.float64)
        rows[taken] = theirs[take[taken]]
        out.append(rows)
    return tuple(out)
