"""Local disparity histograms and the decision by their peaks (section 3.1, Eq. 1 of 3.3).

The matching rule of :func:`modeling.stereo.matching.match_segments`, after the candidates:

1. :func:`histogram_inputs`: each candidate (left segment ``i``, right segment ``j``) votes for its
   mid disparity in the histogram of its left segment (1 px bins), weighted by the length of the
   overlapping part (times ``opposite_weight`` for an opposite-polarity pair), spread as a
   Gaussian of ``smooth_px`` (the smoothing of the histogram).
2. :func:`region_histograms`: the histogram of the *region around* left segment ``i`` [Miura
   ICRA-94, ref. 9] is the sum of those of all left segments, each weighted by a Gaussian of the
   image distance between segment midpoints (``self_weight`` for ``i`` itself).
3. :func:`decide_matches_reference`: its prominent peaks decide. One peak: its closest candidate
   is certain. Several: each peak's closest candidate is kept with probability
   ``a_k / sum_j a_j`` (Eq. 1), ``a_k`` the peak's height. Then uniqueness of right segments.

Step 3 runs in the env as the compiled loop :func:`modeling.stereo._kernels.match.decide`, which
equals :func:`decide_matches_reference` bit for bit
(``tests/modeling/stereo/test_compiled_match.py``); it is the one loop of the matching that pays
(0.5-0.9 ms per env step). To change the rule, change the reference, then the loop the same way (the
test holds them together).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from modeling.stereo._kernels.match import (
    Candidates,
    Decision,
    HistogramInputs,
    PeakRule,
    Splat,
    histogram_rows,
)
from modeling.types import FloatArray, IntArray

__all__ = [
    "Splat",
    "decide_matches_reference",
    "histogram_inputs",
    "histogram_inputs_reference",
    "region_histograms",
]


def histogram_inputs(cand: Candidates, slope_l: FloatArray, splat: Splat) -> HistogramInputs:
    """What the local disparity histograms are made of (section 3.1), for k >= 1 candidates.

    Each candidate puts its mid disparity into the histogram of its left segment, weighted by the
    length of its overlapping part (times ``opposite_weight`` for an opposite polarity) and spread
    as a unit-area Gaussian of ``sigma_bins`` over the nearest bin and ``radius`` bins on each
    side; the bins cover the candidates' disparities with room for the Gaussian.

    Args:
        cand: The candidates, sorted by left segment.
        slope_l: (nL,) the left segments' slopes du/dv.
        splat: The spreading.

    Returns:
        Mid disparities, weights, splat factors, bin 0's disparity, the bins, the Gaussian's
        exponents there, each candidate's histogram row and each row's left segment.
    """
    return histogram_rows(cand, slope_l, splat)


def histogram_inputs_reference(
    cand: Candidates, slope_l: FloatArray, splat: Splat
) -> HistogramInputs:
    """The readable reference of the compiled loop
    :func:`modeling.stereo._kernels.match.histogram_rows` that :func:`histogram_inputs` runs (equal
    bit for bit; same arguments and result).

    Args:
        cand: The candidates, sorted by left segment.
        slope_l: (nL,) the left segments' slopes du/dv.
        splat: The spreading.

    Returns:
        As :func:`histogram_inputs`.
    """
    li, bin_px, radius = cand.li, splat.bin_px, splat.radius
    d_mid = 0.5 * (cand.disparity[:, 0] + cand.disparity[:, 1])
    weight = cand.overlap * np.sqrt(1.0 + slope_l[li] ** 2)  # length of the overlap, px
    hist_weight = np.where(cand.opposite, splat.opposite_weight * weight, weight)
    d_base = math.floor(float(d_mid.min())) - (radius + 2) * bin_px
    n_bins = math.ceil((float(d_mid.max()) - d_base) / bin_px) + radius + 3
    x = (d_mid - d_base) / bin_px
    bins = np.rint(x).astype(np.int64)[:, None] + np.arange(-radius, radius + 1)
    z = (bins - x[:, None]) / splat.sigma_bins
    # rows of the histogram: the left segments with candidates (li is sorted)
    new_row = np.empty(li.size, dtype=bool)
    new_row[0] = True
    np.not_equal(li[1:], li[:-1], out=new_row[1:])
    return HistogramInputs(
        d_mid=d_mid,
        weight=weight,
        scale=hist_weight / splat.norm,
        d_base=float(d_base),
        n_bins=int(n_bins),
        bins=bins,
        exponent=-0.5 * z * z,
        cand_row=new_row.cumsum() - 1,
        rows=li[new_row],
    )


def region_histograms(
    inputs: HistogramInputs,
    mid: FloatArray,
    region_sigma_px: tuple[float, float],
    self_weight: float,
) -> FloatArray:
    """The local disparity histogram of the region around each left segment (section 3.1).

    A segment's own histogram is the sum of its candidates' Gaussians; its region's is the sum
    of all segments' own histograms, each weighted by a Gaussian of the image distance between
    the segments' midpoints (``region_sigma_px``; ``self_weight`` for the segment itself).

    Args:
        inputs: As :func:`histogram_inputs` returns them.
        mid: (n_rows, 2) midpoint ``(u, v)`` of each row's left segment, px.
        region_sigma_px: ``(sigma_u, sigma_v)`` of the region Gaussian, px.
        self_weight: The weight of a segment's own histogram in its region's.

    Returns:
        (n_rows, n_bins) the region histograms (px of segment per px of disparity).
    """
    n_rows, n_bins = inputs.rows.size, inputs.n_bins
    splat = np.exp(inputs.exponent) * inputs.scale[:, None]
    flat_bins = (inputs.bins + (inputs.cand_row * n_bins)[:, None]).ravel()
    own = np.bincount(flat_bins, weights=splat.ravel(), minlength=n_rows * n_bins)
    su, sv = region_sigma_px
    du = (mid[:, None, 0] - mid[:, 0]) / su
    dv = (mid[:, None, 1] - mid[:, 1]) / sv
    w_region = np.exp(-0.5 * (du * du + dv * dv))
    w_region.flat[:: n_rows + 1] = self_weight
    hist: FloatArray = w_region @ own.reshape(n_rows, n_bins)
    return hist


def decide_matches_reference(
    hist: FloatArray, cand: Candidates, inputs: HistogramInputs, rule: PeakRule
) -> Decision:
    """The matching rule: which candidates the region histograms keep (section 3.1; Eq. 1 of 3.3).

    1. The prominent peaks of each left segment's region histogram: the local maxima within
       ``half`` bins (the first bin of a flat top) of at least ``rel_peak`` times the row's
       highest bin, located to a fraction of a bin by a parabola.
    2. For each peak, the candidate of that segment closest to it in disparity, within
       ``agree_px`` (each candidate is compared with the nearest peak of its row; ties: the
       longer overlap, then the first).
    3. Uniqueness (``unique_right``): a certain claim (its left segment's only kept candidate) on
       a right segment that another left segment also keeps, at a disparity more than
       ``agree_px`` away and with a higher peak (ties: the longer overlap), is dropped.
    4. Eq. 1: one kept candidate is certain; several get ``a_k / sum_j a_j``, ``a_k`` the height
       of the peak each agrees with.

    Args:
        hist: (n_rows, n_bins) the region histograms (:func:`region_histograms`).
        cand: The candidates.
        inputs: Their mid disparities, weights and rows (:func:`histogram_inputs`).
        rule: The peak and agreement parameters (``MatchOptions.peak_rule``).

    Returns:
        The kept candidates sorted by left segment, then decreasing peak height; empty when none.
    """
    li, d_mid, weight, d_base = cand.li, inputs.d_mid, inputs.weight, inputs.d_base
    n_rows, n_bins = hist.shape
    nothing = Decision(
        sel=np.zeros(0, np.int64),
        peak_height=np.zeros(0),
        probability=np.zeros(0),
        peak_disparity=np.zeros(0),
    )
    # 1. prominent peaks: the maximum of their window (zeros past the ends), the first bin of a
    # flat top, at least rel_peak of the row's highest bin, above zero
    half = rule.half
    padded = np.zeros((n_rows, n_bins + 2 * half))
    padded[:, half : half + n_bins] = hist
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1, axis=1)
    is_peak = hist == windows.max(axis=2)
    is_peak[:, 1:] &= hist[:, 1:] > hist[:, :-1]
    is_peak &= (hist >= rule.rel_peak * hist.max(axis=1)[:, None]) & (hist > 0)
    pr, pb = np.nonzero(is_peak)  # sorted by row, then bin
    if pr.size == 0:
        return nothing
    h0 = hist[pr, pb]
    hm = hist[pr, np.maximum(pb - 1, 0)]
    hp = hist[pr, np.minimum(pb + 1, n_bins - 1)]
    # parabola vertex: at a maximum |off| <= 0.5 (a flat top, den 0, has hm == hp: off 0)
    off = 0.5 * (hm - hp) / np.minimum(hm - 2.0 * h0 + hp, -1e-300)
    peak_pos = d_base + (pb + off) * rule.bin_px
    # 2. the nearest peak of each candidate's own row (keys: row * span + disparity, both sorted;
    # span exceeds the disparity range by more than agree_px, so other rows never agree)
    peak_key = pr * rule.span + (peak_pos - d_base)
    cand_key = inputs.cand_row * rule.span + (d_mid - d_base)
    j_hi = np.minimum(np.searchsorted(peak_key, cand_key), peak_key.size - 1)
    j_lo = np.maximum(j_hi - 1, 0)
    dist_hi = np.abs(cand_key - peak_key[j_hi])
    dist_lo = np.abs(cand_key - peak_key[j_lo])
    use_lo = dist_lo < dist_hi
    best_peak = np.where(use_lo, j_lo, j_hi)
    best_dist = np.where(use_lo, dist_lo, dist_hi)
    agree = np.flatnonzero(best_dist <= rule.agree_px)
    if agree.size == 0:
        return nothing
    # the closest candidate of each peak; ties: the longer overlap, then the first
    agree = agree[np.lexsort((-weight[agree], best_dist[agree], best_peak[agree]))]
    bp = best_peak[agree]
    first = np.empty(bp.size, dtype=bool)
    first[0] = True
    np.not_equal(bp[1:], bp[:-1], out=first[1:])
    sel = agree[first]
    a_k = h0[best_peak[sel]]
    # 3. uniqueness
    if rule.unique_right:
        survive = _exclusive_right(sel, a_k, cand, d_mid, weight, rule.n_left, rule.agree_px)
        sel, a_k = sel[survive], a_k[survive]
        if sel.size == 0:
            return nothing
    # 4. Eq. 1, rows sorted by left segment, then decreasing peak height
    order = np.lexsort((-a_k, li[sel]))
    sel, a_k = sel[order], a_k[order]
    total = np.bincount(li[sel], weights=a_k, minlength=rule.n_left)
    return Decision(
        sel=sel,
        peak_height=a_k,
        probability=a_k / total[li[sel]],
        peak_disparity=peak_pos[best_peak[sel]],
    )


def _exclusive_right(
    sel: IntArray,
    a_k: FloatArray,
    cand: Candidates,
    d_mid: FloatArray,
    weight: FloatArray,
    n_left: int,
    agree_px: float,
) -> NDArray[np.bool_]:
    """Which kept claims survive uniqueness: a certain claim loses to a stronger claim of another
    left segment on the same right segment at another disparity."""
    lsel, rsel = cand.li[sel], cand.rj[sel]
    survive = np.ones(sel.size, dtype=bool)
    shared = np.flatnonzero(np.bincount(rsel)[rsel] > 1)
    if shared.size == 0:
        return survive
    single = np.bincount(lsel, minlength=n_left)[lsel[shared]] == 1
    if not single.any():
        return survive
    x = shared[single]  # certain claims on shared right segments: the ones that can lose
    r, owner, d, a, w = (
        rsel[shared],
        lsel[shared],
        d_mid[sel[shared]],
        a_k[shared],
        weight[sel[shared]],
    )
    rx, ox, dx, ax, wx = r[single], owner[single], d[single], a[single], w[single]
    loses = (
        (rx[:, None] == r)
        & (ox[:, None] != owner)
        & (np.abs(dx[:, None] - d) > agree_px)
        & ((a > ax[:, None]) | ((a == ax[:, None]) & (w > wx[:, None])))
    ).any(axis=1)
    survive[x[loses]] = False
    return survive
