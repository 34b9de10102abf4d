"""Bayes re-weighting of remembered ambiguous segments with each new view (issue 16; paper 3.3:
"the ambiguity is resolved by the subsequent observations").

A remembered ambiguity has candidates ``c_i`` with probabilities ``p_i`` and the none mass
``p_none = 1 - sum p_i`` ("no obstacle here"). The hypotheses are "candidate ``i`` is the real
one" and "none is", and every other candidate is then a false match. With the sensor model of
the memory (a real segment in the floor seen free is detected with ``pd``; a false one appears
with ``pf``), the likelihood of a new view under hypothesis ``i`` divided by that under "none"
depends on ``c_i`` alone: ``r_i = pd / pf`` when ``c_i`` is detected (by a new unambiguous
segment, or by the new view's detection of a remembered segment that coincides with it: one
edge, remembered twice), ``(1 - pd) / (1 - pf)``
when it lies in the floor seen free and is not, 1 when the view does not see it. So
``p_i' ∝ p_i r_i`` and ``p_none' ∝ p_none``. A detection by candidate ``j`` of a new ambiguous
segment, itself real with probability ``q_j``, counts as ``r_i = 1 + q_j (pd / pf - 1)`` (the
expected ratio). :func:`reweight` applies one view; :mod:`modeling.memory.fusion` calls it.

Frames: world, metres; covariances m^2.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any, NamedTuple

import numpy as np

from modeling.memory.association import (
    Association,
    SegmentStack,
    assign,
    fused_segments,
    gated_pairs,
    stack_of,
    subset,
)
from modeling.observation import P_NONE_ATOL, AmbiguousSegment, FloorSegment, none_mass
from modeling.types import FloatArray

__all__ = [
    "AmbiguityUpdate",
    "Candidates",
    "NewAmbiguities",
    "candidates_of",
    "explain_new",
    "posterior",
    "reweight",
    "trusted_ambiguous",
]


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
        new_unmatched: Indices of the new view's ambiguities that matched no remembered one.
        new_candidates: The new view's candidates, flattened.
    """

    ambiguous: tuple[AmbiguousSegment, ...]
    seen: tuple[int, ...]
    consumed: np.ndarray
    resolved: list[tuple[FloorSegment, float, int]]
    new_unmatched: np.ndarray
    new_candidates: Candidates


def _ambiguity_pairs(
    cand_pairs: Association, new_owner: np.ndarray, mem_owner: np.ndarray
) -> Association:
    """Per (new ambiguity, remembered ambiguity) with a gated candidate pair, the smallest
    distance (rows: new ambiguity, cols: remembered)."""
    b, a = new_owner[cand_pairs.rows], mem_owner[cand_pairs.cols]
    order = np.lexsort((cand_pairs.d2, a, b))
    b, a, d2 = b[order], a[order], cand_pairs.d2[order]
    first = np.concatenate(([True], (b[1:] != b[:-1]) | (a[1:] != a[:-1])))
    return Association(
        rows=b[first], cols=a[first], d2=d2[first], swapped=np.zeros(first.sum(), bool)
    )


def reweight(
    remembered: tuple[AmbiguousSegment, ...],
    mem: Candidates,
    remembered_seen: tuple[int, ...],
    new_segments: SegmentStack,
    new_ambiguous: tuple[AmbiguousSegment, ...],
    new: Candidates,
    vis_free: Any,
    *,
    opts: Any,
    view: int,
    detected_segments: SegmentStack,
) -> AmbiguityUpdate:
    """One view's evidence on the remembered ambiguities (see the module docstring).

    Args:
        remembered: The open ambiguities of the memory.
        mem: Their candidates (:func:`candidates_of`).
        remembered_seen: The view that last detected each.
        new_segments: The new view's unambiguous segments that matched no remembered segment.
        new_ambiguous: The new view's ambiguous segments.
        new: Their candidates (:func:`candidates_of`).
        vis_free: A function :class:`SegmentStack` -> (n,) bool, "seen free by the new view".
        opts: The :class:`~modeling.memory.fusion.MemoryOptions`.
        view: The number of the new view (1-based).
        detected_segments: The remembered segments the new view detected, after their fusion: a
            candidate that coincides with one (gate, one-to-one) and has no other detection gains
            ``pd / pf`` (its geometry is not fused).
    """
    pd, pf, gate = opts.detection_probability, opts.false_match_rate, opts.gate_chi2
    hit_ratio = pd / pf
    n_mem = len(mem.segments)
    ratio = np.ones(n_mem)
    touched = np.zeros(n_mem, dtype=bool)
    cand = list(mem.segments)
    # (a) new unambiguous segments that coincide with a remembered candidate
    seg_pairs = assign(
        gated_pairs(new_segments.ends, new_segments.cov, mem.stack.ends, mem.stack.cov, gate)
    )
    for k, seg in zip(
        seg_pairs.cols.tolist(),
        fused_segments(mem.stack, new_segments, seg_pairs, min_var=opts.min_sigma_m**2)[0],
        strict=True,
    ):
        cand[k] = seg
    ratio[seg_pairs.cols] = hit_ratio
    touched[seg_pairs.cols] = True
    # (a') remembered segments detected by this view that coincide with a candidate
    det = detected_segments
    if det.ends.shape[0] and n_mem:
        det_pairs = gated_pairs(det.ends, det.cov, mem.stack.ends, mem.stack.cov, gate)
        det_pairs = assign(subset(det_pairs, ~touched[det_pairs.cols]))
        ratio[det_pairs.cols] = hit_ratio
        touched[det_pairs.cols] = True
    # (b) new ambiguous segments whose candidates match a remembered ambiguity's
    matched_new = np.zeros(len(new_ambiguous), dtype=bool)
    pairs = gated_pairs(new.stack.ends, new.stack.cov, mem.stack.ends, mem.stack.cov, gate)
    pairs = subset(pairs, ~touched[pairs.cols])
    if pairs.rows.shape[0]:
        chosen = assign(_ambiguity_pairs(pairs, new.owner, mem.owner))
        partner = np.full(len(new_ambiguous), -1, dtype=np.int64)
        partner[chosen.rows] = chosen.cols
        matched_new[chosen.rows] = True
        cand_pairs = assign(subset(pairs, partner[new.owner[pairs.rows]] == mem.owner[pairs.cols]))
        fused, _ = fused_segments(mem.stack, new.stack, cand_pairs, min_var=opts.min_sigma_m**2)
        for k, seg in zip(cand_pairs.cols.tolist(), fused, strict=True):
            cand[k] = seg
        ratio[cand_pairs.cols] = 1.0 + new.prob[cand_pairs.rows] * (hit_ratio - 1.0)
        touched[cand_pairs.cols] = True
    # (c) candidates in the floor seen free, not detected
    if n_mem:
        free = ~touched & vis_free(mem.stack)
        ratio[free] = (1.0 - pd) / (1.0 - pf)
    # (d) the posterior of each remembered ambiguity (all at once); resolution; pruning
    out: list[AmbiguousSegment] = []
    seen: list[int] = []
    resolved: list[tuple[FloorSegment, float, int]] = []
    n_amb = len(remembered)
    if n_amb:
        counts = np.bincount(mem.owner, minlength=n_amb)
        starts = np.cumsum(counts) - counts
        changed = np.add.reduceat((ratio != 1.0).astype(np.int64), starts) > 0
        detected = np.add.reduceat(touched.astype(np.int64), starts) > 0
        w = mem.prob * ratio
        none = np.array([amb.p_none for amb in remembered])
        total = np.add.reduceat(w, starts) + none
        post = w / total[mem.owner]
        special = (
            (np.maximum.reduceat(post, starts) >= opts.resolve_probability)
            | (none / total >= opts.resolve_probability)
            | (
                np.add.reduceat((post < opts.min_candidate_probability).astype(np.int64), starts)
                > 0
            )
        )
        ratio_l, prob_l, post_l = ratio.tolist(), mem.prob.tolist(), post.tolist()
        bounds = list(zip(starts.tolist(), (starts + counts).tolist(), strict=True))
        for a, amb in enumerate(remembered):
            last = view if detected[a] else remembered_seen[a]
            lo, hi = bounds[a]
            if not changed[a]:
                out.append(amb)
                seen.append(last)
            elif not special[a]:
                out.append(trusted_ambiguous(tuple(cand[lo:hi]), post_l[lo:hi]))
                seen.append(last)
            else:
                result = posterior(cand[lo:hi], prob_l[lo:hi], ratio_l[lo:hi], opts)
                if isinstance(result, AmbiguousSegment):
                    out.append(result)
                    seen.append(last)
                elif result is not None:
                    resolved.append((result[0], result[1], last))
    return AmbiguityUpdate(
        ambiguous=tuple(out),
        seen=tuple(seen),
        consumed=seg_pairs.rows,
        resolved=resolved,
        new_unmatched=np.flatnonzero(~matched_new),
        new_candidates=new,
    )


def posterior(
    candidates: list[FloorSegment],
    probabilities: list[float],
    ratios: list[float],
    opts: Any,
) -> AmbiguousSegment | tuple[FloorSegment, float] | None:
    """One ambiguity after the evidence ``ratios`` (one likelihood ratio per candidate, against
    "none"): the open ambiguity (candidates below ``min_candidate_probability`` pruned; two
    kept when the none mass is 0, one otherwise), or ``(candidate, posterior)`` when one reaches
    ``resolve_probability``, or None when the none mass does."""
    p = np.array(probabilities) * np.array(ratios)
    none = none_mass(probabilities)
    total = float(p.sum()) + none
    p, none = p / total, none / total
    best = int(np.argmax(p))
    if p[best] >= opts.resolve_probability:
        return candidates[best], float(p[best])
    if none >= opts.resolve_probability:
        return None
    order = np.argsort(-p, kind="stable")
    least = 2 if none <= P_NONE_ATOL else 1
    keep = np.sort(
        order[(p[order] >= opts.min_candidate_probability) | (np.arange(p.shape[0]) < least)]
    )
    if keep.shape[0] < p.shape[0]:
        total = float(p[keep].sum()) + none
        p = p / total
    return trusted_ambiguous(tuple(candidates[i] for i in keep.tolist()), p[keep].tolist())


_NO_PAIRS = Association(
    rows=np.zeros(0, dtype=np.int64),
    cols=np.zeros(0, dtype=np.int64),
    d2=np.zeros(0),
    swapped=np.zeros(0, dtype=bool),
)


class NewAmbiguities(NamedTuple):
    """The new view's ambiguities that matched no remembered one, against the remembered
    segments.

    Attributes:
        ambiguous: Those that stay open (re-weighted).
        resolved: ``(candidate, posterior)`` of those resolved to a candidate that coincides with
            no remembered segment.
        absorbed: Pairs (rows: index into the new view's flattened candidates, cols: remembered
            segment) of those resolved to a candidate that coincides with a remembered segment:
            it is that segment seen again, and fuses into it.
        segment_ratio: (n,) likelihood ratio of each remembered segment from these ambiguities
            (``1 + q_j (pd / pf - 1)`` for a segment that candidate ``j`` coincides with).
    """

    ambiguous: list[AmbiguousSegment]
    resolved: list[tuple[FloorSegment, float]]
    absorbed: Association
    segment_ratio: FloatArray


def explain_new(
    new_ambiguous: tuple[AmbiguousSegment, ...],
    update: AmbiguityUpdate,
    segments: SegmentStack,
    existence: FloatArray,
    opts: Any,
) -> NewAmbiguities:
    """The new ambiguities that matched no remembered one, re-weighted by the remembered
    segments their candidates coincide with.

    A candidate ``j`` that coincides (gate, one-to-one) with a remembered segment of existence
    ``e >= report_existence`` gains by ``1 + e (pd / pf - 1)`` (the memory's evidence for an
    obstacle there, taken as a soft detection), the others by 1; the segment gains by
    ``1 + q_j (pd / pf - 1)``. An ambiguity whose posterior resolves to a coinciding candidate is
    absorbed by that segment.
    """
    hit = opts.detection_probability / opts.false_match_rate
    new = update.new_candidates
    n_seg = segments.ends.shape[0]
    ratio_seg = np.ones(n_seg)
    if update.new_unmatched.shape[0] == 0:
        return NewAmbiguities(
            ambiguous=[], resolved=[], absorbed=_NO_PAIRS, segment_ratio=ratio_seg
        )
    partner = np.full(len(new.segments), -1, dtype=np.int64)
    open_new = np.zeros(len(new_ambiguous), dtype=bool)
    open_new[update.new_unmatched] = True
    pairs = gated_pairs(new.stack.ends, new.stack.cov, segments.ends, segments.cov, opts.gate_chi2)
    eligible = open_new[new.owner[pairs.rows]] & (existence[pairs.cols] >= opts.report_existence)
    pairs = assign(subset(pairs, eligible))
    partner[pairs.rows] = pairs.cols
    swapped = np.zeros(len(new.segments), dtype=bool)
    swapped[pairs.rows] = pairs.swapped
    np.multiply.at(ratio_seg, pairs.cols, 1.0 + new.prob[pairs.rows] * (hit - 1.0))
    out: list[AmbiguousSegment] = []
    resolved: list[tuple[FloorSegment, float]] = []
    absorbed: list[tuple[int, int, bool]] = []
    offsets = [0, *itertools.accumulate(len(a.candidates) for a in new_ambiguous)]
    for b in update.new_unmatched.tolist():
        amb = _with_none_prior(new_ambiguous[b], opts.none_prior)
        lo, hi = offsets[b], offsets[b + 1]
        ks = partner[lo:hi]
        if not np.any(ks >= 0):
            out.append(amb)
            continue
        ratios = np.where(ks >= 0, 1.0 + existence[np.maximum(ks, 0)] * (hit - 1.0), 1.0)
        post = posterior(list(amb.candidates), list(amb.probabilities), ratios.tolist(), opts)
        if isinstance(post, AmbiguousSegment):
            out.append(post)
        elif post is not None:
            j = amb.candidates.index(post[0])
            if ks[j] >= 0:
                absorbed.append((lo + j, int(ks[j]), bool(swapped[lo + j])))
            else:
                resolved.append(post)
    rows, cols, swap = (
        (np.array(v) for v in zip(*absorbed, strict=True))
        if absorbed
        else (
            np.zeros(0, np.int64),
            np.zeros(0, np.int64),
            np.zeros(0, bool),
        )
    )
    return NewAmbiguities(
        ambiguous=out,
        resolved=resolved,
        absorbed=Association(
            rows=rows.astype(np.int64),
            cols=cols.astype(np.int64),
            d2=np.zeros(rows.shape[0]),
            swapped=swap.astype(bool),
        ),
        segment_ratio=ratio_seg,
    )


_AMBIGUOUS_FIELDS = ("candidates", "probabilities")
_EXTRA_FIELDS = tuple(
    (f.name, f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default)
    for f in dataclasses.fields(AmbiguousSegment)
    if f.name not in _AMBIGUOUS_FIELDS
)


def trusted_ambiguous(
    candidates: tuple[FloorSegment, ...], probabilities: list[float]
) -> AmbiguousSegment:
    """An :class:`~modeling.observation.AmbiguousSegment` of a posterior computed here (at least
    two candidates, or one with a none mass; probabilities in [0, 1] summing to at most 1 by
    construction), made without
    its validation (the memory re-weights every ambiguity in view at every step)."""
    amb: AmbiguousSegment = object.__new__(AmbiguousSegment)
    object.__setattr__(amb, "candidates", candidates)
    object.__setattr__(amb, "probabilities", tuple(float(p) for p in probabilities))
    for name, default in _EXTRA_FIELDS:
        object.__setattr__(amb, name, default)
    return amb


def _with_none_prior(amb: AmbiguousSegment, none_prior: float) -> AmbiguousSegment:
    """``amb`` with its none mass raised to ``none_prior`` (the candidates scaled down)."""
    total = sum(amb.probabilities)
    if 1.0 - total >= none_prior:
        return amb
    scale = (1.0 - none_prior) / total
    return trusted_ambiguous(amb.candidates, [p * scale for p in amb.probabilities])
