"""The compiled loops of segment matching (:mod:`modeling.stereo.matching`, sections 3.1, 3.3): the
candidate grid and the decision from the region histograms (peaks, agreement, uniqueness, Eq. 1).

Each computes every value with the same floating-point operations, in the same order, as its
readable NumPy reference, so the matches are identical: :func:`candidate_grid` as
:func:`modeling.stereo.matching.candidates_reference` (0.2-0.4 ms per env step saved) and
:func:`decide` as :func:`modeling.stereo.disparity_histograms.decide_matches_reference` (some forty
NumPy calls per image pair, 0.5-0.9 ms per env step). They take and return the small named tuples
below.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not
import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_on_first_call


class SegmentColumns(NamedTuple):
    """The arrays of one image's :class:`~modeling.stereo.segments.ImageSegments` that
    :func:`candidate_grid` reads, (n,) each unless stated."""

    endpoints: np.ndarray  # (n, 2, 2) ``(u, v)`` px, top first
    angle: np.ndarray  # from the image vertical, radians
    polarity: np.ndarray  # int8
    grey_far_left: np.ndarray
    grey_far_right: np.ndarray
    grey_near_left: np.ndarray
    grey_near_right: np.ndarray
    u_center: np.ndarray  # px
    slope: np.ndarray  # du/dv
    v_center: np.ndarray  # px


class Constraints(NamedTuple):
    """The candidate constraints of :class:`~modeling.stereo.matching.MatchOptions`, in the units
    the grid uses."""

    min_overlap_px: float
    min_overlap_frac: float
    max_angle_rad: float
    allow_opposite: bool
    max_grey_diff: float
    max_near_grey_diff: float
    min_disparity_px: float  # the rig's range, widened by the agreement margin
    max_disparity_px: float


class Candidates(NamedTuple):
    """Candidate pairs as parallel arrays (``k`` rows), sorted by left, then right index."""

    li: np.ndarray  # (k,) left segment
    rj: np.ndarray  # (k,) right segment
    rows: np.ndarray  # (k, 2) first and last row of the overlap, px
    overlap: np.ndarray  # (k,) overlap, rows
    disparity: np.ndarray  # (k, 2) disparity at those rows, px
    opposite: np.ndarray  # (k,) opposite polarity


class Splat(NamedTuple):
    """How a candidate's vote is spread over the histogram bins (:func:`histogram_rows`)."""

    opposite_weight: float  # factor on an opposite-polarity candidate's weight
    sigma_bins: float  # the Gaussian's standard deviation, bins
    radius: int  # the nearest bin and ``radius`` bins on each side
    bin_px: float  # bin width, px
    norm: float  # ``sqrt(2 pi) sigma_bins``, the Gaussian's normalisation


class HistogramInputs(NamedTuple):
    """What the local histograms are made of (:func:`histogram_inputs`)."""

    d_mid: np.ndarray  # (k,) mid disparity of each candidate, px
    weight: np.ndarray  # (k,) length of its overlapping part, px
    scale: np.ndarray  # (k,) histogram weight / norm
    d_base: float  # disparity of bin 0, px
    n_bins: int
    bins: np.ndarray  # (k, 2 radius + 1) the bins of each splat
    exponent: np.ndarray  # (k, 2 radius + 1) the Gaussian's exponent there
    cand_row: np.ndarray  # (k,) histogram row of each candidate
    rows: np.ndarray  # (n_rows,) left segment of each row


class PeakRule(NamedTuple):
    """The decision's parameters (:func:`decide`)."""

    bin_px: float  # bin width, px
    half: int  # a peak is the maximum of the bins within ``half`` of it
    rel_peak: float  # a prominent peak is at least this fraction of its row's highest bin
    span: float  # key stride between rows (exceeds the disparity range by > agree_px)
    agree_px: float  # a candidate agrees with the nearest peak of its row within this, px
    unique_right: bool  # apply the uniqueness rule
    n_left: int  # number of left segments


class Decision(NamedTuple):
    """The kept candidates (:func:`decide`), ``m`` rows, by left segment then decreasing peak."""

    sel: np.ndarray  # (m,) indices into the k candidates
    peak_height: np.ndarray  # (m,) ``a_k`` of the peak each agrees with
    probability: np.ndarray  # (m,) Eq. 1
    peak_disparity: np.ndarray  # (m,) px


@compiled_on_first_call
def candidate_grid(left: SegmentColumns, right: SegmentColumns, c: Constraints) -> Candidates:
    """The pairs of the (nL, nR) grid that pass every constraint, row-major (by left, then right).

    Reference: :func:`modeling.stereo.matching.candidates_reference` (section 3.1).
    """
    ends_l, ends_r = left.endpoints, right.endpoints
    n_left, n_right = ends_l.shape[0], ends_r.shape[0]
    angle_l, angle_r = left.angle, right.angle
    polarity_l, polarity_r = left.polarity, right.polarity
    far_left_l, far_right_l = left.grey_far_left, left.grey_far_right
    near_left_l, near_right_l = left.grey_near_left, left.grey_near_right
    far_left_r, far_right_r = right.grey_far_left, right.grey_far_right
    near_left_r, near_right_r = right.grey_near_left, right.grey_near_right
    u_l, slope_l, v_l = left.u_center, left.slope, left.v_center
    u_r, slope_r, v_r = right.u_center, right.slope, right.v_center
    min_overlap_px, min_overlap_frac = c.min_overlap_px, c.min_overlap_frac
    max_grey_diff, max_near_grey_diff = c.max_grey_diff, c.max_near_grey_diff
    cap = n_left * n_right
    li = np.empty(cap, np.int64)
    rj = np.empty(cap, np.int64)
    rows = np.empty((cap, 2))
    ov_out = np.empty(cap)
    disp = np.empty((cap, 2))
    opposite_out = np.empty(cap, np.bool_)
    k = 0
    for i in range(n_left):
        v0l, v1l = ends_l[i, 0, 1], ends_l[i, 1, 1]
        len_l = v1l - v0l
        a_l = u_l[i] - slope_l[i] * v_l[i]
        for j in range(n_right):
            v0r, v1r = ends_r[j, 0, 1], ends_r[j, 1, 1]
            lo = max(v0l, v0r)
            hi = min(v1l, v1r)
            ov = hi - lo
            if not ov >= max(min_overlap_px, min_overlap_frac * min(len_l, v1r - v0r)):
                continue
            if not abs(angle_l[i] - angle_r[j]) <= c.max_angle_rad:
                continue
            opposite = polarity_l[i] != polarity_r[j]
            if opposite and not c.allow_opposite:
                continue
            # photometric agreement of the four side samples (module docstring of matching)
            far_l = abs(far_left_l[i] - far_left_r[j]) <= max_grey_diff
            far_r = abs(far_right_l[i] - far_right_r[j]) <= max_grey_diff
            near_l = abs(near_left_l[i] - near_left_r[j]) <= max_near_grey_diff
            near_r = abs(near_right_l[i] - near_right_r[j]) <= max_near_grey_diff
            if opposite:
                photometric = (far_l and near_l) or (far_r and near_r)
            else:
                photometric = (far_l or far_r) and near_l and near_r
            if not photometric:
                continue
            # disparity along the pair: d(v) = u_left(v) - u_right(v) = (a_l - a_r) + (s_l - s_r) v
            # with u(v) = a + s v the fitted lines, at both ends of the overlap
            a_r = u_r[j] - slope_r[j] * v_r[j]
            d_a = a_l - a_r
            d_s = slope_l[i] - slope_r[j]
            d_lo = d_a + d_s * lo
            d_hi = d_a + d_s * hi
            if not (
                min(d_lo, d_hi) >= c.min_disparity_px and max(d_lo, d_hi) <= c.max_disparity_px
            ):
                continue
            li[k] = i
            rj[k] = j
            rows[k, 0] = lo
            rows[k, 1] = hi
            ov_out[k] = ov
            disp[k, 0] = d_lo
            disp[k, 1] = d_hi
            opposite_out[k] = opposite
            k += 1
    return Candidates(
        li=li[:k],
        rj=rj[:k],
        rows=rows[:k],
        overlap=ov_out[:k],
        disparity=disp[:k],
        opposite=opposite_out[:k],
    )


@compiled_on_first_call
def histogram_rows(cand: Candidates, slope_l: np.ndarray, splat: Splat) -> HistogramInputs:
    """What the local histograms are made of, for k >= 1 candidates sorted by left segment.

    Args:
        cand: The candidates (sorted by left segment); their left segments ``li``, the
            disparities at the ends of each overlap (px), the overlaps (rows) and polarities are
            read.
        slope_l: (nL,) the left segments' slopes du/dv.
        splat: How each candidate's vote is spread: the opposite-polarity factor, the Gaussian's
            standard deviation (bins), its radius (bins), the bin width (px) and the
            normalisation.

    Returns:
        The histogram inputs. Reference:
        :func:`modeling.stereo.disparity_histograms.histogram_inputs_reference` (section 3.1).
    """
    li, disparity, overlap, opposite = cand.li, cand.disparity, cand.overlap, cand.opposite
    opposite_weight, sigma_bins, radius = splat.opposite_weight, splat.sigma_bins, splat.radius
    bin_px, norm = splat.bin_px, splat.norm
    k = li.shape[0]
    width = 2 * radius + 1
    d_mid = np.empty(k)
    weight = np.empty(k)
    scale = np.empty(k)
    d_min = np.inf
    d_max = -np.inf
    for c in range(k):
        d = 0.5 * (disparity[c, 0] + disparity[c, 1])
        d_mid[c] = d
        if d < d_min or d != d:  # a NaN sticks, as in ndarray.min
            d_min = d
        if d > d_max:
            d_max = d
        s = slope_l[li[c]]
        w = overlap[c] * np.sqrt(1.0 + s * s)  # length of the overlap, px
        weight[c] = w
        scale[c] = (opposite_weight * w if opposite[c] else w) / norm
    if d_min != d_min:  # as math.floor and math.ceil in the reference
        raise ValueError("cannot convert float NaN to integer")
    if not (np.isfinite(d_min) and np.isfinite(d_max)):
        raise OverflowError("cannot convert float infinity to integer")
    d_base = np.floor(d_min) - (radius + 2) * bin_px
    n_bins = int(np.ceil((d_max - d_base) / bin_px)) + radius + 3
    bins = np.empty((k, width), np.int64)
    exponent = np.empty((k, width))
    cand_row = np.empty(k, np.int64)
    rows = np.empty(k, li.dtype)
    n_rows = 0
    for c in range(k):
        x = (d_mid[c] - d_base) / bin_px
        b0 = np.int64(np.rint(x))
        for t in range(width):
            b = b0 + (t - radius)
            bins[c, t] = b
            z = (b - x) / sigma_bins
            exponent[c, t] = -0.5 * z * z
        if c == 0 or li[c] != li[c - 1]:
            rows[n_rows] = li[c]
            n_rows += 1
        cand_row[c] = n_rows - 1
    return HistogramInputs(
        d_mid=d_mid,
        weight=weight,
        scale=scale,
        d_base=d_base,
        n_bins=n_bins,
        bins=bins,
        exponent=exponent,
        cand_row=cand_row,
        rows=rows[:n_rows],
    )


@compiled_on_first_call
def decide(hist: np.ndarray, cand: Candidates, inputs: HistogramInputs, rule: PeakRule) -> Decision:
    """The kept candidates of ``modeling.stereo.matching.match_segments`` from its region
    histograms.

    Args:
        hist: (n_rows, n_bins) the region histogram of each left segment that has candidates.
        cand: The candidates (sorted by left, then right).
        inputs: Their mid disparities, weights, histogram rows and the disparity of bin 0.
        rule: Peaks, agreement and uniqueness.

    Returns:
        The kept candidates sorted by left segment then decreasing peak height, the height of the
        peak each agrees with, their probabilities (Eq. 1) and their peaks' disparities, px;
        empty when nothing is kept. Reference:
        :func:`modeling.stereo.disparity_histograms.decide_matches_reference` (section 3.1; Eq. 1 of
        3.3).
    """
    li, rj = cand.li, cand.rj
    d_mid, weight, cand_row, d_base = inputs.d_mid, inputs.weight, inputs.cand_row, inputs.d_base
    bin_px, half, rel_peak, span = rule.bin_px, rule.half, rule.rel_peak, rule.span
    agree_px, n_left = rule.agree_px, rule.n_left
    nrow, nbins = hist.shape
    # prominent peaks, row-major: the maximum of their window (zeros past the ends), the first
    # bin of a flat top, at least rel_peak of the row's highest bin, above zero
    n_peaks = 0
    peak_row = np.empty(nrow * nbins, np.int64)
    peak_bin = np.empty(nrow * nbins, np.int64)
    for row in range(nrow):
        top = hist[row, 0]
        for b in range(1, nbins):
            top = max(top, hist[row, b])
        for b in range(nbins):
            h = hist[row, b]
            if not (h > 0.0 and h >= rel_peak * top):
                continue
            if b > 0 and not h > hist[row, b - 1]:
                continue
            local_max = 0.0 if (b - half < 0 or b + half >= nbins) else hist[row, b]
            for c in range(max(b - half, 0), min(b + half + 1, nbins)):
                local_max = max(local_max, hist[row, c])
            if h == local_max:
                peak_row[n_peaks] = row
                peak_bin[n_peaks] = b
                n_peaks += 1
    empty_i = np.empty(0, np.int64)
    empty_f = np.empty(0)
    if n_peaks == 0:
        return Decision(
            sel=empty_i, peak_height=empty_f, probability=empty_f, peak_disparity=empty_f
        )
    # sub-bin position by a parabola through the three bins around each peak
    h0 = np.empty(n_peaks)
    peak_pos = np.empty(n_peaks)
    peak_key = np.empty(n_peaks)
    for p in range(n_peaks):
        row, b = peak_row[p], peak_bin[p]
        h0[p] = hist[row, b]
        hm = hist[row, max(b - 1, 0)]
        hp = hist[row, min(b + 1, nbins - 1)]
        off = 0.5 * (hm - hp) / min(hm - 2.0 * h0[p] + hp, -1e-300)
        peak_pos[p] = d_base + (b + off) * bin_px
        peak_key[p] = row * span + (peak_pos[p] - d_base)
    # the nearest peak of each candidate's row; for each peak, its closest agreeing candidate
    # (ties: the longer overlap, then the first)
    n_cand = li.shape[0]
    best = np.full(n_peaks, -1, np.int64)
    best_dist = np.empty(n_peaks)
    best_peak = np.empty(n_cand, np.int64)
    for c in range(n_cand):
        key = cand_row[c] * span + (d_mid[c] - d_base)
        j_hi = min(np.searchsorted(peak_key, key), n_peaks - 1)
        j_lo = max(j_hi - 1, 0)
        dist_hi = abs(key - peak_key[j_hi])
        dist_lo = abs(key - peak_key[j_lo])
        if dist_lo < dist_hi:
            p, dist = j_lo, dist_lo
        else:
            p, dist = j_hi, dist_hi
        best_peak[c] = p
        if not dist <= agree_px:
            continue
        b = best[p]
        if b < 0 or dist < best_dist[p] or (dist == best_dist[p] and weight[c] > weight[b]):
            best[p] = c
            best_dist[p] = dist
    n_sel = 0
    sel = np.empty(n_peaks, np.int64)
    for p in range(n_peaks):
        if best[p] >= 0:
            sel[n_sel] = best[p]
            n_sel += 1
    sel = sel[:n_sel]
    a_k = np.empty(n_sel)
    for s in range(n_sel):
        a_k[s] = h0[best_peak[sel[s]]]
    if rule.unique_right and n_sel > 0:
        # a certain claim on a shared right segment loses to another left segment's claim on it
        # at another disparity with a higher peak (ties: the longer overlap)
        right_count = np.zeros(rj.max() + 1, np.int64)
        left_count = np.zeros(n_left, np.int64)
        for s in range(n_sel):
            right_count[rj[sel[s]]] += 1
            left_count[li[sel[s]]] += 1
        survive = np.ones(n_sel, np.bool_)
        for x in range(n_sel):
            cx = sel[x]
            if right_count[rj[cx]] < 2 or left_count[li[cx]] != 1:
                continue
            for q in range(n_sel):
                cq = sel[q]
                if (
                    rj[cq] == rj[cx]
                    and li[cq] != li[cx]
                    and abs(d_mid[cx] - d_mid[cq]) > agree_px
                    and (a_k[q] > a_k[x] or (a_k[q] == a_k[x] and weight[cq] > weight[cx]))
                ):
                    survive[x] = False
                    break
        sel = sel[survive]
        a_k = a_k[survive]
        n_sel = sel.shape[0]
    # by left segment, then decreasing peak height (stable: two stable sorts, minor key first)
    order = np.argsort(-a_k, kind="mergesort")
    order = order[np.argsort(li[sel[order]], kind="mergesort")]
    sel = sel[order]
    a_k = a_k[order]
    total = np.zeros(n_left)
    for s in range(n_sel):
        total[li[sel[s]]] += a_k[s]
    prob = np.empty(n_sel)
    peak_disp = np.empty(n_sel)
    for s in range(n_sel):
        prob[s] = a_k[s] / total[li[sel[s]]]
        peak_disp[s] = peak_pos[best_peak[sel[s]]]
    return Decision(sel=sel, peak_height=a_k, probability=prob, peak_disparity=peak_disp)
