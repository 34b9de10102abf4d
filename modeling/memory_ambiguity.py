"""Bayes re-weighting of remembered ambiguous segments with each new view (issue 16; paper 3.3:
"the ambiguity is resolved by the subsequent observations").

A remembered ambiguity has candidates ``c_i`` with probabilities ``p_i`` and the none mass
``p_none = 1 - sum p_i`` ("no obstacle here"). The hypotheses are "candidate ``i`` is the real
one" and "none is", and every other candidate is then a false match. With the sensor model of
the memory (a real segment in the floor seen free is detected with ``pd``; a false one appears
with ``pf``), the likelihood of a new view under hypothesis ``i`` divided by that under "none"
depends on ``c_i`` alone: ``r_i = pd / pf`` when ``c_i`` is detected, ``(1 - pd) / (1 - pf)``
when it lies in the floor seen free and is not, 1 when the view does not see it. So
``p_i' ∝ p_i r_i`` and ``p_none' ∝ p_none``. A detection by candidate ``j`` of a new ambiguous
segment, itself real with probability ``q_j``, counts as ``r_i = 1 + q_j (pd / pf - 1)`` (the
expected ratio). :func:`reweight` applies one view; :mod:`modeling.memory` calls it.

Frames: world, metres; covariances m^2.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from modeling.memory_association import (
    Association,
    SegmentStack,
    assign,
    fused_segments,
    gated_pairs,
    stack_of,
    subset,
)
from modeling.observation import AmbiguousSegment, FloorSegment
from modeling.validation import FloatArray

__all__ = ["AmbiguityUpdate", "Candidates", "candidates_of", "reweight"]


class Candidates(NamedTuple):
    """The candidates of some ambiguous segments, flattened.

    Attributes:
        stack: Their arrays (ends, covariances, heights, sources).
        owner: (C,) int64, the ambiguous segment of each.
        prob: (C,) their probabilities.
        segments: The candidates themselves, in order.
    """

    stack: SegmentStack
    owner: np.ndarray
    prob: FloatArray
    segments: list[FloorSegment]


def candidates_of(ambiguous: tuple[AmbiguousSegment, ...]) -> Candidates:
    """The flattened candidates of ``ambiguous``."""
    segs = [c for a in ambiguous for c in a.candidates]
    counts = [len(a.candidates) for a in ambiguous]
    return Candidates(
        stack=stack_of(segs),
        owner=np.repeat(np.arange(len(ambiguous), dtype=np.int64), counts),
        prob=np.array([p for a in ambiguous for p in a.probabilities], dtype=np.float64),
        segments=segs,
    )


class AmbiguityUpdate(NamedTuple):
    """The outcome of one view for the remembered ambiguities.

    Attributes:
        ambiguous: The open ambiguities (remembered ones first, then the new unassociated ones).
        seen: The view that last detected each of them.
        consumed: Indices of the new unambiguous segments that matched a candidate (they are
            evidence for it, not new segments).
        resolved: The candidates that resolved their ambiguity, as ``(segment, posterior,
            last_seen)``.
    """

    ambiguous: tuple[AmbiguousSegment, ...]
    seen: tuple[int, ...]
    consumed: np.ndarray
    resolved: list[tuple[FloorSegment, float, int]]


def _ambiguity_pairs(
    cand_pairs: Association, new_owner: np.ndarray, mem_owner: np.ndarray
) -> Association:
    """Per (new ambiguity, remembered ambiguity) with a gated candidate pair, the smallest
    distance (rows: new ambiguity, cols: remembered)."""
    b, a = new_owner[cand_pairs.rows], mem_owner[cand_pairs.cols]
    order = np.lexsort((cand_pairs.d2, a, b))
    b, a, d2 = b[order], a[order], cand_pairs.d2[order]
    first = np.r_[True, (b[1:] != b[:-1]) | (a[1:] != a[:-1])]
    return Association(
        rows=b[first], cols=a[first], d2=d2[first], swapped=np.zeros(first.sum(), bool)
    )


def reweight(
    remembered: tuple[AmbiguousSegment, ...],
    remembered_seen: tuple[int, ...],
    new_segments: SegmentStack,
    new_ambiguous: tuple[AmbiguousSegment, ...],
    vis_free: Any,
    *,
    opts: Any,
    view: int,
) -> AmbiguityUpdate:
    """One view's evidence on the remembered ambiguities (see the module docstring).

    Args:
        remembered: The open ambiguities of the memory.
        remembered_seen: The view that last detected each.
        new_segments: The new view's unambiguous segments that matched no remembered segment.
        new_ambiguous: The new view's ambiguous segments.
        vis_free: A function (n, 2, 2) ends -> (n,) bool, "seen free by the new view".
        opts: The :class:`~modeling.memory.MemoryOptions`.
        view: The number of the new view (1-based).
    """
    pd, pf, gate = opts.detection_probability, opts.false_match_rate, opts.gate_chi2
    hit_ratio = pd / pf
    mem = candidates_of(remembered)
    n_mem = len(mem.segments)
    ratio = np.ones(n_mem)
    touched = np.zeros(n_mem, dtype=bool)
    cand = list(mem.segments)
    # (a) new unambiguous segments that coincide with a remembered candidate
    seg_pairs = assign(
        gated_pairs(new_segments.ends, new_segments.cov, mem.stack.ends, mem.stack.cov, gate)
    )
    for k, seg in zip(
        seg_pairs.cols.tolist(), fused_segments(mem.stack, new_segments, seg_pairs), strict=True
    ):
        cand[k] = seg
    ratio[seg_pairs.cols] = hit_ratio
    touched[seg_pairs.cols] = True
    # (b) new ambiguous segments whose candidates match a remembered ambiguity's
    new = candidates_of(new_ambiguous)
    matched_new = np.zeros(len(new_ambiguous), dtype=bool)
    pairs = gated_pairs(new.stack.ends, new.stack.cov, mem.stack.ends, mem.stack.cov, gate)
    pairs = subset(pairs, ~touched[pairs.cols])
    if pairs.rows.shape[0]:
        chosen = assign(_ambiguity_pairs(pairs, new.owner, mem.owner))
        partner = np.full(len(new_ambiguous), -1, dtype=np.int64)
        partner[chosen.rows] = chosen.cols
        matched_new[chosen.rows] = True
        cand_pairs = assign(subset(pairs, partner[new.owner[pairs.rows]] == mem.owner[pairs.cols]))
        fused = fused_segments(mem.stack, new.stack, cand_pairs)
        for k, seg in zip(cand_pairs.cols.tolist(), fused, strict=True):
            cand[k] = seg
        ratio[cand_pairs.cols] = 1.0 + new.prob[cand_pairs.rows] * (hit_ratio - 1.0)
        touched[cand_pairs.cols] = True
    # (c) candidates in the floor seen free, not detected
    if n_mem:
        free = ~touched & vis_free(mem.stack.ends)
        ratio[free] = (1.0 - pd) / (1.0 - pf)
    # (d) the posterior of each remembered ambiguity; resolution; pruning
    out: list[AmbiguousSegment] = []
    seen: list[int] = []
    resolved: list[tuple[FloorSegment, float, int]] = []
    detected_amb = np.zeros(len(remembered), dtype=bool)
    if n_mem:
        detected_amb[mem.owner[touched]] = True
    start = 0
    ratio_l, prob_l = ratio.tolist(), mem.prob.tolist()
    for a, amb in enumerate(remembered):
        stop = start + len(amb.candidates)
        last = view if detected_amb[a] else remembered_seen[a]
        if all(r == 1.0 for r in ratio_l[start:stop]):
            out.append(amb)
            seen.append(last)
            start = stop
            continue
        p = np.array(prob_l[start:stop]) * np.array(ratio_l[start:stop])
        none = max(0.0, 1.0 - sum(prob_l[start:stop]))
        total = float(p.sum()) + none
        p, none = p / total, none / total
        segs = cand[start:stop]
        start = stop
        best = int(np.argmax(p))
        if p[best] >= opts.resolve_probability:
            resolved.append((segs[best], float(p[best]), last))
            continue
        if none >= opts.resolve_probability:
            continue
        order = np.argsort(-p, kind="stable")
        keep = np.sort(
            order[(p[order] >= opts.min_candidate_probability) | (np.arange(p.shape[0]) < 2)]
        )
        if keep.shape[0] < p.shape[0]:
            total = float(p[keep].sum()) + none
            p, none = p / total, none / total
        out.append(
            AmbiguousSegment(
                candidates=tuple(segs[i] for i in keep.tolist()),
                probabilities=tuple(p[keep].tolist()),
            )
        )
        seen.append(last)
    # (e) the new ambiguous segments that matched no remembered ambiguity enter as they are
    for b, amb in enumerate(new_ambiguous):
        if matched_new[b]:
            continue
        out.append(_with_none_prior(amb, opts.none_prior))
        seen.append(view)
    return AmbiguityUpdate(
        ambiguous=tuple(out), seen=tuple(seen), consumed=seg_pairs.rows, resolved=resolved
    )


def _with_none_prior(amb: AmbiguousSegment, none_prior: float) -> AmbiguousSegment:
    """``amb`` with its none mass raised to ``none_prior`` (the candidates scaled down)."""
    total = sum(amb.probabilities)
    if 1.0 - total >= none_prior:
        return amb
    scale = (1.0 - none_prior) / total
    return AmbiguousSegment(
        candidates=amb.candidates, probabilities=tuple(p * scale for p in amb.probabilities)
    )
