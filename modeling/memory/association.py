"""Association and Gaussian fusion of floor segments across views (issue 16; paper section 6).

Two floor segments are the same edge when the difference of their endpoints is small against its
uncertainty: with endpoint means ``a_0, a_1`` (covariances ``A_0, A_1``) and ``b_0, b_1``
(``B_0, B_1``), all independent, the squared Mahalanobis distance of the 4-vector
``(b_0 - a_0, b_1 - a_1)`` is ``sum_e d_e^T (A_e + B_e)^-1 d_e`` (4 degrees of freedom: the summed
covariance is block diagonal). Both endpoint orders are tried (a segment has no direction) and
the smaller distance counts; a pair is *gated* when it is at most the chi-square gate (e.g.
``chi2.ppf(0.99, 4) = 13.28``). Gated pairs are assigned one-to-one by
:func:`scipy.optimize.linear_sum_assignment` (most pairs first, then the smallest total
distance). An associated pair fuses endpoint by endpoint as the product of Gaussians
(:func:`gaussian_product`, information form; the new factor's information optionally weighted,
for views that share errors with earlier ones), its covariances raised to a floor in every
direction when one is given (:func:`floored_covariances`: the part of a view's error that views
share does not average away).

Only the endpoint gate is used: a segment seen from a new viewpoint as a longer or shorter piece
of the same edge (clipped by the image border or by an occluder) fails the gate at the clipped
end and enters the memory as a segment of its own; the old piece keeps its existence while its
ends are out of view. The memory bounds the duplicates that this leaves.

:func:`gated_pairs` and :func:`fused_segments` run compiled loops
(:mod:`modeling.memory._kernels.association`); :func:`gated_pairs_reference` and
:func:`fused_segments_reference` are the readable NumPy versions they equal.

Frames: world, metres; covariances m^2.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment

from modeling.memory._kernels.association import (
    FusedPairs,
    GaussianSegments,
    fuse_pairs,
    gate_pairs,
)
from modeling.observation import FloorSegment
from modeling.types import FloatArray

__all__ = [
    "Association",
    "SegmentStack",
    "assign",
    "concat",
    "endpoint_distances",
    "floored_covariances",
    "fused_segments",
    "fused_segments_reference",
    "gated_pairs",
    "gated_pairs_reference",
    "gaussian_product",
    "odds_update",
    "replaced",
    "stack_of",
    "subset",
    "take",
    "trusted_segment",
]

# Cost of a pair outside the gate in the assignment: above any sum of gated costs, so the
# assignment first maximises the number of gated pairs.
_BIG = 1e12


class Association(NamedTuple):
    """Gated pairs between new segments (rows) and remembered ones (columns).

    Attributes:
        rows: (k,) int64, index of the new segment.
        cols: (k,) int64, index of the remembered segment.
        d2: (k,) squared Mahalanobis distance of the endpoint difference (the better order).
        swapped: (k,) bool, the new segment's endpoints match the remembered ones in reverse.
    """

    rows: np.ndarray
    cols: np.ndarray
    d2: FloatArray
    swapped: np.ndarray


_EMPTY = Association(
    rows=np.zeros(0, dtype=np.int64),
    cols=np.zeros(0, dtype=np.int64),
    d2=np.zeros(0),
    swapped=np.zeros(0, dtype=bool),
)


def _mahalanobis2(d: FloatArray, S: FloatArray) -> FloatArray:
    """``d^T S^-1 d`` for stacks d (..., 2), S (..., 2, 2) (closed-form 2x2 inverse)."""
    a, b, c = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    x, y = d[..., 0], d[..., 1]
    out: FloatArray = (c * x * x - 2.0 * b * x * y + a * y * y) / (a * c - b * b)
    return out


def endpoint_distances(
    new_ends: FloatArray, new_cov: FloatArray, mem_ends: FloatArray, mem_cov: FloatArray
) -> tuple[FloatArray, np.ndarray]:
    """The 4-dof squared Mahalanobis distance of the endpoint difference, for aligned pairs.

    Args:
        new_ends: (k, 2, 2) endpoint means of the new segments, metres.
        new_cov: (k, 2, 2, 2) their endpoint covariances, m^2.
        mem_ends: (k, 2, 2) endpoint means of the remembered segments paired with them.
        mem_cov: (k, 2, 2, 2) their covariances.

    Returns:
        ``(d2, swapped)``: (k,) the smaller of the two orders' distances, and (k,) whether the
        reversed order (new endpoint 1 with remembered endpoint 0) gave it.
    """
    straight = _mahalanobis2(new_ends - mem_ends, new_cov + mem_cov).sum(axis=-1)
    rev_ends, rev_cov = new_ends[:, ::-1], new_cov[:, ::-1]
    reverse = _mahalanobis2(rev_ends - mem_ends, rev_cov + mem_cov).sum(axis=-1)
    swapped = reverse < straight
    return np.where(swapped, reverse, straight), swapped


def gated_pairs(
    new_ends: FloatArray,
    new_cov: FloatArray,
    mem_ends: FloatArray,
    mem_cov: FloatArray,
    gate_chi2: float,
) -> Association:
    """Every (new, remembered) pair whose endpoint distance is within the gate, ordered by row
    then column: :func:`gated_pairs_reference` (its prefilter, its distances), compiled
    (:func:`modeling.memory._kernels.association.gate_pairs`; the same results).

    Args:
        new_ends: (n, 2, 2) new segments' endpoint means, metres; new_cov (n, 2, 2, 2), m^2.
        mem_ends: (m, 2, 2) remembered segments' endpoint means; mem_cov (m, 2, 2, 2).
        gate_chi2: The gate on the squared Mahalanobis distance (4 dof).
    """
    if new_ends.shape[0] == 0 or mem_ends.shape[0] == 0:
        return _EMPTY
    rows, cols, d2, swapped = gate_pairs(
        np.ascontiguousarray(new_ends, dtype=np.float64),
        np.ascontiguousarray(new_cov, dtype=np.float64),
        np.ascontiguousarray(mem_ends, dtype=np.float64),
        np.ascontiguousarray(mem_cov, dtype=np.float64),
        float(gate_chi2),
    )
    return Association(rows=rows, cols=cols, d2=d2, swapped=swapped)


def gated_pairs_reference(
    new_ends: FloatArray,
    new_cov: FloatArray,
    mem_ends: FloatArray,
    mem_cov: FloatArray,
    gate_chi2: float,
) -> Association:
    """Every (new, remembered) pair whose endpoint distance is within the gate (the readable
    version of :func:`gated_pairs`, which runs the compiled loop
    :func:`modeling.memory._kernels.association.gate_pairs`).

    A prefilter on the midpoints drops pairs that cannot pass: a gated pair has
    ``|d_e|^2 <= gate * lambda_max(A_e + B_e) <= gate * (tr A_e + tr B_e)`` at each endpoint, so
    its midpoints are at most ``sqrt(gate * (t_new + t_mem))`` apart, ``t`` the larger endpoint
    trace of each segment (exact: no gated pair is lost).

    Args:
        new_ends: (n, 2, 2) new segments' endpoint means, metres; new_cov (n, 2, 2, 2), m^2.
        mem_ends: (m, 2, 2) remembered segments' endpoint means; mem_cov (m, 2, 2, 2).
        gate_chi2: The gate on the squared Mahalanobis distance (4 dof).

    Returns:
        The gated pairs, ordered by row then column.
    """
    n, m = new_ends.shape[0], mem_ends.shape[0]
    if n == 0 or m == 0:
        return _EMPTY
    t_new = np.trace(new_cov, axis1=-2, axis2=-1).max(axis=1)
    t_mem = np.trace(mem_cov, axis1=-2, axis2=-1).max(axis=1)
    diff = new_ends.mean(axis=1)[:, None, :] - mem_ends.mean(axis=1)[None, :, :]
    near = np.einsum("nmi,nmi->nm", diff, diff) <= gate_chi2 * (t_new[:, None] + t_mem[None, :])
    rows, cols = np.nonzero(near)
    if rows.shape[0] == 0:
        return _EMPTY
    d2, swapped = endpoint_distances(new_ends[rows], new_cov[rows], mem_ends[cols], mem_cov[cols])
    ok = d2 <= gate_chi2
    return Association(rows=rows[ok], cols=cols[ok], d2=d2[ok], swapped=swapped[ok])


def assign(pairs: Association) -> Association:
    """The one-to-one subset of gated ``pairs`` with the most pairs, then the least total
    distance (:func:`scipy.optimize.linear_sum_assignment` on the rows and columns that have a
    gated pair; deterministic). Ordered by row."""
    if pairs.rows.shape[0] == 0:
        return pairs
    if np.bincount(pairs.rows).max() == 1 and np.bincount(pairs.cols).max() == 1:
        return pairs  # already one-to-one
    urows, ri = np.unique(pairs.rows, return_inverse=True)
    ucols, ci = np.unique(pairs.cols, return_inverse=True)
    cost = np.full((urows.shape[0], ucols.shape[0]), _BIG)
    cost[ri, ci] = pairs.d2
    index = np.full(cost.shape, -1, dtype=np.int64)
    index[ri, ci] = np.arange(pairs.rows.shape[0])
    r, c = linear_sum_assignment(cost)
    chosen = index[r, c]
    chosen = np.sort(chosen[chosen >= 0])
    return Association(
        rows=pairs.rows[chosen],
        cols=pairs.cols[chosen],
        d2=pairs.d2[chosen],
        swapped=pairs.swapped[chosen],
    )


def gaussian_product(
    mean_a: FloatArray,
    cov_a: FloatArray,
    mean_b: FloatArray,
    cov_b: FloatArray,
    weight_b: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """The product of Gaussians ``N(mean_a, cov_a) N(mean_b, cov_b)``, normalised, in information
    form: ``P = (A^-1 + B^-1)^-1``, ``m = P (A^-1 a + B^-1 b)``; with ``weight_b`` ``w``, the
    second factor's information is ``w B^-1`` (the Gaussian raised to the power ``w``: a
    measurement worth a fraction ``w`` of an independent one).

    Args:
        mean_a: (..., 2) means, metres; cov_a (..., 2, 2) covariances, m^2 (positive definite).
        mean_b: (..., 2) and cov_b (..., 2, 2): the other factor.
        weight_b: (...) weights in (0, 1] of the second factor (default: 1).

    Returns:
        ``(mean, cov)`` of the same shapes (the covariance exactly symmetric: closed-form 2x2
        inverses of the symmetrised inputs).
    """
    inv_a = _inverse(cov_a)
    inv_b = _inverse(cov_b)
    if weight_b is not None:
        inv_b = inv_b * np.asarray(weight_b)[..., None, None]
    cov = _inverse(inv_a + inv_b)
    info = np.einsum("...ij,...j->...i", inv_a, mean_a) + np.einsum(
        "...ij,...j->...i", inv_b, mean_b
    )
    mean = np.einsum("...ij,...j->...i", cov, info)
    return mean, cov


def _inverse(S: FloatArray) -> FloatArray:
    """The inverses of a stack of symmetric 2x2 matrices (..., 2, 2), in closed form (exactly
    symmetric)."""
    a, b, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    det = a * d - b * b
    out = np.empty_like(S)
    out[..., 0, 0] = d / det
    out[..., 1, 1] = a / det
    out[..., 0, 1] = out[..., 1, 0] = -b / det
    return out


def odds_update(p: FloatArray, ratio: FloatArray, high: float) -> FloatArray:
    """Bayes' rule in odds form: ``p`` (probabilities) times the likelihood ``ratio``
    (``P(evidence | real) / P(evidence | not real)``), clipped to ``[0, high]``."""
    num = p * ratio
    out: FloatArray = np.minimum(num / (num + (1.0 - p)), high)
    return out


# ------------------------------------------------------------------- segments as arrays
_SEGMENT_FIELDS = ("endpoints", "cov", "height_m", "source")
_EXTRA_FIELDS = tuple(
    (f.name, f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default)
    for f in dataclasses.fields(FloorSegment)
    if f.name not in _SEGMENT_FIELDS
)


def trusted_segment(
    ends: FloatArray, cov: FloatArray, heights: FloatArray, source: int, *, copy: bool = True
) -> FloorSegment:
    """A :class:`~modeling.observation.FloorSegment` of values computed by the memory (finite;
    covariances positive definite by construction: products of positive-definite Gaussians),
    made without its validation, which costs 30 us a segment on the project machine (the largest
    cost of a fuse otherwise). The arrays are copied and made read-only, as the validated
    constructor does; with ``copy`` False they are taken as they are (float64 arrays of no one
    else: the caller's fresh results) and only made read-only."""
    seg: FloorSegment = object.__new__(FloorSegment)
    for name, value in (("endpoints", ends), ("cov", cov), ("height_m", heights)):
        arr = np.array(value, dtype=np.float64) if copy else value
        arr.setflags(write=False)
        object.__setattr__(seg, name, arr)
    object.__setattr__(seg, "source", int(source))
    for name, default in _EXTRA_FIELDS:
        object.__setattr__(seg, name, default)
    return seg


class SegmentStack(NamedTuple):
    """Segments as arrays.

    Attributes:
        ends: (n, 2, 2) endpoint means, world frame, metres.
        cov: (n, 2, 2, 2) endpoint covariances, m^2.
        heights: (n, 2) endpoint heights, metres.
        source: (n,) int64 provenance.
    """

    ends: FloatArray
    cov: FloatArray
    heights: FloatArray
    source: np.ndarray


def _read_only(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    for arr in arrays:
        arr.setflags(write=False)
    return arrays


_EMPTY_STACK = SegmentStack(
    *_read_only(
        np.zeros((0, 2, 2)), np.zeros((0, 2, 2, 2)), np.zeros((0, 2)), np.zeros(0, np.int64)
    )
)


def stack_of(segs: tuple[FloorSegment, ...] | list[FloorSegment]) -> SegmentStack:
    """The arrays of ``segs`` (one concatenation per field)."""
    n = len(segs)
    if n == 0:
        return _EMPTY_STACK
    return SegmentStack(
        np.concatenate([s.endpoints for s in segs]).reshape(n, 2, 2),
        np.concatenate([s.cov for s in segs]).reshape(n, 2, 2, 2),
        np.concatenate([s.height_m for s in segs]).reshape(n, 2),
        np.array([s.source for s in segs], dtype=np.int64),
    )


def floored_covariances(cov: FloatArray, min_var: float) -> FloatArray:
    """``cov`` (..., 2, 2) with every variance below ``min_var`` (m^2) raised to it: the
    eigenvalues of each symmetric 2x2 covariance clipped from below at ``min_var``, its
    eigenvectors kept (the covariances above the floor are returned bit for bit); ``cov`` itself
    when ``min_var`` is 0 or nothing is below it.

    In closed form: with eigenvalues ``lo <= hi`` (mean ``m``, half-difference ``r``), a
    covariance with ``lo < min_var <= hi`` becomes ``C + (min_var - lo) u u^T`` for its minor
    axis ``u``, where ``u u^T = (hi I - C) / (2 r)``; one with ``hi < min_var`` (or ``r = 0``)
    becomes ``min_var I``."""
    flat = cov.reshape(-1, 2, 2)
    if min_var <= 0.0 or flat.shape[0] == 0:
        return cov
    a, b, c = flat[:, 0, 0], flat[:, 0, 1], flat[:, 1, 1]
    m, r = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    low = np.flatnonzero(m - r < min_var)
    if low.shape[0] == 0:
        return cov
    out = flat.copy()
    C, m, r = flat[low], m[low], r[low]
    hi = m + r
    thin = (hi >= min_var) & (r > 0.0)
    k = np.where(thin, (min_var - (m - r)) / np.where(thin, 2.0 * r, 1.0), 0.0)
    raised = C + k[:, None, None] * (hi[:, None, None] * np.eye(2) - C)
    out[low] = np.where(thin[:, None, None], raised, min_var * np.eye(2))
    return out.reshape(cov.shape)


def fused_segments(
    mem: SegmentStack,
    new: SegmentStack,
    pairs: Association,
    weight: FloatArray | None = None,
    *,
    min_var: float = 0.0,
) -> tuple[list[FloorSegment], SegmentStack]:
    """The remembered segments ``pairs.cols`` fused with the new ones ``pairs.rows`` (aligned by
    ``pairs.swapped``): the product of the endpoint Gaussians (the new one's information times
    ``weight`` (k,), one per pair, when given; the product's variances raised to at least
    ``min_var`` in every direction, :func:`floored_covariances`), the larger heights, the new
    segment's source. One segment per pair, in the pairs' order, and their arrays:
    :func:`fused_segments_reference`, compiled
    (:func:`modeling.memory._kernels.association.fuse_pairs`; the same results)."""
    rows, cols = pairs.rows, pairs.cols
    if rows.shape[0] == 0:
        return [], stack_of([])
    mean, P, top = fuse_pairs(
        GaussianSegments(mem.ends, mem.cov, mem.heights),
        GaussianSegments(new.ends, new.cov, new.heights),
        FusedPairs(
            rows,
            cols,
            pairs.swapped,
            np.ones(rows.shape[0]) if weight is None else np.asarray(weight, dtype=np.float64),
        ),
        float(min_var),
    )
    src = new.source[rows]
    # rows of fresh arrays: each segment's arrays are views (made read-only), not copies
    segs = [
        trusted_segment(mean[k], P[k], top[k], s, copy=False) for k, s in enumerate(src.tolist())
    ]
    return segs, SegmentStack(mean, P, top, src)


def fused_segments_reference(
    mem: SegmentStack,
    new: SegmentStack,
    pairs: Association,
    weight: FloatArray | None = None,
    *,
    min_var: float = 0.0,
) -> tuple[list[FloorSegment], SegmentStack]:
    """The remembered segments ``pairs.cols`` fused with the new ones ``pairs.rows`` (aligned by
    ``pairs.swapped``): the product of the endpoint Gaussians (the new one's information times
    ``weight`` (k,), one per pair, when given; the variances floored at ``min_var``), the larger
    heights, the new segment's source. One segment per pair, in the pairs' order, and their
    arrays (the readable version of :func:`fused_segments`)."""
    rows, cols, swapped = pairs.rows, pairs.cols, pairs.swapped
    if rows.shape[0] == 0:
        return [], stack_of([])
    ends = np.where(swapped[:, None, None], new.ends[rows][:, ::-1], new.ends[rows])
    cov = np.where(swapped[:, None, None, None], new.cov[rows][:, ::-1], new.cov[rows])
    heights = np.where(swapped[:, None], new.heights[rows][:, ::-1], new.heights[rows])
    w = None if weight is None else np.repeat(np.asarray(weight)[:, None], 2, axis=1)
    mean, P = gaussian_product(mem.ends[cols], mem.cov[cols], ends, cov, w)
    P = floored_covariances(P, min_var)
    top = np.maximum(mem.heights[cols], heights)
    src = new.source[rows]
    # rows of fresh arrays: each segment's arrays are views (made read-only), not copies
    segs = [
        trusted_segment(mean[k], P[k], top[k], s, copy=False) for k, s in enumerate(src.tolist())
    ]
    return segs, SegmentStack(mean, P, top, src)


def take(stack: SegmentStack, index: np.ndarray) -> SegmentStack:
    """The rows ``index`` of ``stack``."""
    return SegmentStack(*(arr[index] for arr in stack))


def concat(*stacks: SegmentStack) -> SegmentStack:
    """The stacks one after another."""
    return SegmentStack(*(np.concatenate(parts) for parts in zip(*stacks, strict=True)))


def replaced(stack: SegmentStack, index: np.ndarray, rows: SegmentStack) -> SegmentStack:
    """``stack`` with its rows ``index`` replaced by ``rows`` (a copy)."""
    out = SegmentStack(*(arr.copy() for arr in stack))
    for arr, new in zip(out, rows, strict=True):
        arr[index] = new
    return out


def subset(pairs: Association, keep: np.ndarray) -> Association:
    """The pairs where ``keep`` (a bool mask or indices)."""
    return Association(
        rows=pairs.rows[keep], cols=pairs.cols[keep], d2=pairs.d2[keep], swapped=pairs.swapped[keep]
    )
