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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from modeling._compiled import gap as _gap_kernel
from modeling.validation import FloatArray
from modeling._compiled.worker import worker
from modeling.gaps import Relation, classify_gaps, quadrature_rules

__all__ = ["SegmentRelations", "closest_points", "segment_relations"]

# Up to this many segments, candidate pairs come from testing every pair's boxes (a compiled
# loop); beyond, from an STRtree of the boxes.
_ALL_PAIRS_MAX = 128


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
        kind: (m,) int8 :class:`~modeling.gaps.Relation` codes.
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
        overlapping segments the middle of the overlap is chosen.
    """
    return _gap_kernel.closest_params_batch(
        np.ascontiguousarray(p1, dtype=np.float64),
        np.ascontiguousarray(q1, dtype=np.float64),
        np.ascontiguousarray(p2, dtype=np.float64),
        np.ascontiguousarray(q2, dtype=np.float64),
    )


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
    i, j, _, _ = _pairs_and_params(
        np.ascontiguousarray(endpoints, dtype=np.float64),
        np.ascontiguousarray(cov, dtype=np.float64),
        width_m,
        eps,
    )
    return np.stack([i, j], axis=1)


def _pairs_and_params(
    endpoints: FloatArray, cov: FloatArray, width_m: float, eps: float
) -> tuple[np.ndarray, np.ndarray, FloatArray, FloatArray]:
    """Candidate pairs ``(i, j)``, sorted, and the closest-point parameters ``(s, t)`` of each."""
    n = endpoints.shape[0]
    if n < 2:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros(0), np.zeros(0)
    k = prune_sigmas(eps)
    # Envelope query: the mean segments i and j are at least as far apart as their boxes along
    # either axis, so a pair within width + k (s_i + s_j) has intersecting boxes when each box is
    # grown by width / 2 + k s_i, with s_i the square root of the larger endpoint covariance
    # trace (an upper bound of the largest eigenvalue). Up to _ALL_PAIRS_MAX segments every pair
    # is tested in one compiled loop; beyond, an STRtree of the boxes is queried with them (the
    # same envelope test: the same pairs).
    sigma, box = _gap_kernel.grown_boxes(endpoints, cov, 0.5 * width_m, k)
    if n <= _ALL_PAIRS_MAX:
        q0, q1 = _gap_kernel.box_pairs(box)
    else:
        boxes = shapely.box(box[:, 0], box[:, 1], box[:, 2], box[:, 3])
        q0, q1 = shapely.STRtree(boxes).query(boxes).astype(np.int64, copy=False)
    # Exact filter on the mean distance between the segments, pairs sorted by (i, j).
    return _gap_kernel.near_pairs(endpoints, sigma, q0, q1, float(width_m), k)


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
) -> SegmentRelations:
    """Relations of nearby segment pairs: closest points, their uncertainty, ``p_passable``, kind.

    Args:
        endpoints: (n, 2, 2) mean endpoints, world frame, metres.
        cov: (n, 2, 2, 2) endpoint covariances, m^2.
        width_m: Robot width (diameter), metres.
        eps: Classification tolerance (see :func:`~modeling.gaps.classify_gap`).
        pairs: (p, 2) pairs to examine; default: :func:`candidate_pairs`.

    Returns:
        The :class:`SegmentRelations`, rows sorted by ``(i, j)``.
    """
    endpoints = np.ascontiguousarray(endpoints, dtype=np.float64)
    cov = np.ascontiguousarray(cov, dtype=np.float64)
    if pairs is None:
        i, j, s, t = _pairs_and_params(endpoints, cov, width_m, eps)
    else:
        i = np.minimum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
        j = np.maximum(pairs[:, 0], pairs[:, 1]).astype(np.int64)
        Ei, Ej = endpoints[i], endpoints[j]
        s, t = closest_points(Ei[:, 0], Ei[:, 1], Ej[:, 0], Ej[:, 1])
    mi, mj, ci, cj, dist, p = _relation_rows(endpoints, cov, i, j, s, t, float(width_m))
    return SegmentRelations(
        i=i,
        j=j,
        point_i=mi,
        point_j=mj,
        cov_i=ci,
        cov_j=cj,
        distance_m=dist,
        p_passable=p,
        kind=classify_gaps(p, eps),
    )


# Below this many pairs, handing half of them to the worker thread costs more than it saves.
_SPLIT_MIN_PAIRS = 1024


def _relation_rows(
    endpoints: FloatArray,
    cov: FloatArray,
    i: np.ndarray,
    j: np.ndarray,
    s: FloatArray,
    t: FloatArray,
    width_m: float,
) -> tuple[FloatArray, ...]:
    """:func:`modeling._compiled.gap.relation_rows` of the pairs, a large batch in two halves at
    once (the compiled loop releases the interpreter lock; each row is computed on its own, so
    the result is the same)."""
    rules = quadrature_rules()
    m = i.shape[0]
    if m < _SPLIT_MIN_PAIRS:
        return _gap_kernel.relation_rows(endpoints, cov, i, j, s, t, width_m, rules)
    h = m // 2
    second = worker().submit(
        _gap_kernel.relation_rows, endpoints, cov, i[h:], j[h:], s[h:], t[h:], width_m, rules
    )
    first = _gap_kernel.relation_rows(endpoints, cov, i[:h], j[:h], s[:h], t[:h], width_m, rules)
    return tuple(np.concatenate(halves) for halves in zip(first, second.result(), strict=True))
