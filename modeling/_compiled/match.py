"""Compiled loops of segment matching (:mod:`modeling.matching`): the candidate grid, the inputs
and sums of the local histograms, the decision from the region histograms (peaks, agreement,
uniqueness, Eq. 1) and the output rows.

Each loop computes every value with the same floating-point operations, in the same order, as
the NumPy expressions it replaced, so the matches are identical; the gain is the seventy-odd NumPy
calls per image pair that a few dozen segments cost. The exponentials and the product of the
region weights with the histograms stay in NumPy (its own ``exp`` and BLAS), between the loops.

Compiled with Numba on first use (:mod:`modeling._compiled.jit`); importing this module does not import
Numba.
"""

from __future__ import annotations

import numpy as np

from modeling._compiled.jit import compiled_on_first_call


@compiled_on_first_call
def candidate_grid(
    ends_l: np.ndarray,
    angle_l: np.ndarray,
    polarity_l: np.ndarray,
    greys_l: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    line_l: tuple[np.ndarray, np.ndarray, np.ndarray],
    ends_r: np.ndarray,
    angle_r: np.ndarray,
    polarity_r: np.ndarray,
    greys_r: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    line_r: tuple[np.ndarray, np.ndarray, np.ndarray],
    min_overlap_px: float,
    min_overlap_frac: float,
    max_angle_rad: float,
    allow_opposite: bool,
    max_grey_diff: float,
    max_near_grey_diff: float,
    dmin: float,
    dmax: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of the (nL, nR) grid that pass every constraint, row-major (by left, then right).

    Args:
        ends_l: (nL, 2, 2) the left segments' endpoints ``(u, v)``, top first.
        angle_l: (nL,) their angles from the image vertical, radians.
        polarity_l: (nL,) their contrast polarities.
        greys_l: Their grey levels far left, far right, near left, near right, (nL,) each.
        line_l: Their fitted lines: centre column, slope du/dv, centre row, (nL,) each.
        ends_r, angle_r, polarity_r, greys_r, line_r: The same for the right segments.
        min_overlap_px, min_overlap_frac, max_angle_rad, allow_opposite, max_grey_diff,
            max_near_grey_diff: The constraints of ``modeling.matching._candidates``.
        dmin, dmax: The disparity range (already widened by the margin), px.

    Returns:
        ``(li, rj, rows, ov, disp, opposite)``: left and right index (k,), first and last row of
        the overlap (k, 2), overlap (k,), disparity at those rows (k, 2), opposite polarity (k,).
    """
    n_left, n_right = ends_l.shape[0], ends_r.shape[0]
    far_left_l, far_right_l, near_left_l, near_right_l = greys_l
    far_left_r, far_right_r, near_left_r, near_right_r = greys_r
    u_l, slope_l, v_l = line_l
    u_r, slope_r, v_r = line_r
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
            if not abs(angle_l[i] - angle_r[j]) <= max_angle_rad:
                continue
            opposite = polarity_l[i] != polarity_r[j]
            if opposite and not allow_opposite:
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
            if not (min(d_lo, d_hi) >= dmin and max(d_lo, d_hi) <= dmax):
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
    return li[:k], rj[:k], rows[:k], ov_out[:k], disp[:k], opposite_out[:k]


@compiled_on_first_call
def decide(
    hist: np.ndarray,
    cand_row: np.ndarray,
    li: np.ndarray,
    rj: np.ndarray,
    d_mid: np.ndarray,
    weight: np.ndarray,
    d_base: float,
    bin_px: float,
    half: int,
    rel_peak: float,
    span: float,
    agree_px: float,
    unique_right: bool,
    n_left: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The kept candidates of ``modeling.matching.match_segments`` from its region histograms.

    Args:
        hist: (nrow, nbins) the region histogram of each left segment that has candidates.
        cand_row: (k,) the histogram row of each candidate.
        li, rj: (k,) left and right segment of each candidate (sorted by left, then right).
        d_mid: (k,) mid disparity of each candidate, px.
        weight: (k,) length of each candidate's overlapping part, px.
        d_base: Disparity of bin 0, px.
        bin_px: Bin width, px.
        half: A peak is the maximum of the bins within ``half`` of it.
        rel_peak: A prominent peak is at least this fraction of its row's highest bin.
        span: Key stride between rows (exceeds the disparity range by more than ``agree_px``).
        agree_px: A candidate agrees with the nearest peak of its row within this, px.
        unique_right: Apply the uniqueness rule (module docstring of ``modeling.matching``).
        n_left: Number of left segments.

    Returns:
        ``(sel, peak_height, probability, peak_disparity)``: the kept candidates (indices into
        the k candidates) sorted by left segment then decreasing peak height, the height of the
        peak each agrees with, their probabilities (Eq. 1) and their peaks' disparities, px.
        ``sel`` is empty when nothing is kept.
    """
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
        return empty_i, empty_f, empty_f, empty_f
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
    if unique_right and n_sel > 0:
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
    return sel, a_k, prob, peak_disp


@compiled_on_first_call
def histogram_inputs(
    disp: np.ndarray,
    ov: np.ndarray,
    opposite: np.ndarray,
    li: np.ndarray,
    slope_l: np.ndarray,
    opposite_weight: float,
    sig_bins: float,
    radius: int,
    bin_px: float,
    norm: float,
) -> tuple[
    np.ndarray, np.ndarray, np.ndarray, float, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray
]:
    """What the local histograms are made of, for k >= 1 candidates sorted by left segment.

    Args:
        disp: (k, 2) each candidate's disparity at both ends of its overlap, px.
        ov: (k,) its overlap, rows.
        opposite: (k,) whether its polarities are opposite.
        li: (k,) its left segment.
        slope_l: (nL,) the left segments' slopes du/dv.
        opposite_weight: Factor on the weight of an opposite-polarity candidate.
        sig_bins: Standard deviation of the splat, bins.
        radius: The splat covers the nearest bin and ``radius`` bins on each side.
        bin_px: Bin width, px.
        norm: ``sqrt(2 pi) sig_bins``, the Gaussian's normalisation.

    Returns:
        ``(d_mid, weight, scale, d_base, nbins, bins, exponent, cand_row, rows)``: mid disparity
        (k,), length of the overlapping part (k,), splat factor (k,: histogram weight / norm),
        disparity of bin 0, number of bins, the (k, 2 radius + 1) bins of each splat and the
        Gaussian's exponent there, the histogram row of each candidate (k,), the left segment
        of each row (nrow,).
    """
    k = li.shape[0]
    d_mid = np.empty(k)
    weight = np.empty(k)
    scale = np.empty(k)
    d_lo = np.inf
    d_hi = -np.inf
    for c in range(k):
        d = 0.5 * (disp[c, 0] + disp[c, 1])
        d_mid[c] = d
        s = slope_l[li[c]]
        w = ov[c] * np.sqrt(1.0 + s * s)
        weight[c] = w
        scale[c] = (opposite_weight * w if opposite[c] else w) / norm
        d_lo = min(d_lo, d)
        d_hi = max(d_hi, d)
    d_base = np.floor(d_lo) - (radius + 2) * bin_px
    nbins = int(np.ceil((d_hi - d_base) / bin_px)) + radius + 3
    width = 2 * radius + 1
    bins = np.empty((k, width), np.int64)
    exponent = np.empty((k, width))
    cand_row = np.empty(k, np.int64)
    rows = np.empty(k, np.int64)
    row = -1
    for c in range(k):
        if c == 0 or li[c] != li[c - 1]:
            row += 1
            rows[row] = li[c]
        cand_row[c] = row
        x = (d_mid[c] - d_base) / bin_px
        nearest = np.int64(np.rint(x))
        for t in range(width):
            b = nearest + (t - radius)
            bins[c, t] = b
            z = (b - x) / sig_bins
            exponent[c, t] = -0.5 * z * z
    return d_mid, weight, scale, d_base, nbins, bins, exponent, cand_row, rows[: row + 1]


@compiled_on_first_call
def histograms(
    gauss: np.ndarray,
    scale: np.ndarray,
    bins: np.ndarray,
    cand_row: np.ndarray,
    n_rows: int,
    nbins: int,
    mid: np.ndarray,
    sigma_u: float,
    sigma_v: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Each left segment's own histogram, and the exponents of the region weights.

    Args:
        gauss: (k, w) the Gaussian at each candidate's splat bins.
        scale: (k,) each candidate's splat factor.
        bins, cand_row: As :func:`histogram_inputs` returns them.
        n_rows, nbins: Histogram rows and bins.
        mid: (n_rows, 2) midpoint of each row's left segment, px.
        sigma_u, sigma_v: The region Gaussian's standard deviations, px.

    Returns:
        ``(own, exponent)``: (n_rows, nbins) the splats summed per row, in candidate order;
        (n_rows, n_rows) the exponent of the Gaussian of the distance between two rows' segments.
    """
    own = np.zeros((n_rows, nbins))
    for c in range(bins.shape[0]):
        for t in range(bins.shape[1]):
            own[cand_row[c], bins[c, t]] += gauss[c, t] * scale[c]
    exponent = np.empty((n_rows, n_rows))
    for i in range(n_rows):
        for j in range(n_rows):
            du = (mid[i, 0] - mid[j, 0]) / sigma_u
            dv = (mid[i, 1] - mid[j, 1]) / sigma_v
            exponent[i, j] = -0.5 * (du * du + dv * dv)
    return own, exponent


@compiled_on_first_call
def match_rows(
    sel: np.ndarray,
    li: np.ndarray,
    rj: np.ndarray,
    rows_px: np.ndarray,
    disp: np.ndarray,
    fit_l: tuple[np.ndarray, ...],
    var_r: tuple[np.ndarray, ...],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The output rows of the kept candidates ``sel``.

    Args:
        sel: (m,) the kept candidates.
        li, rj, rows_px, disp: The candidates' left and right segments, (k,) each, their overlap's
            first and last row and the disparity there, (k, 2) each.
        fit_l: The left segments' ``u_center, slope, v_center, point_var, n_points, s_vv`` and
            ``bias_var`` (:class:`~modeling.segments.ImageSegments`; ``u_at``, ``u_var_at``).
        var_r: The right segments' ``v_center, point_var, n_points, s_vv, bias_var``.

    Returns:
        ``(left_index, right_index, left_endpoints, disparity, disparity_var, u_left_var)``:
        (m,), (m,), (m, 2, 2), (m, 2), (m, 2), (m, 2).
    """
    u_l, slope_l, v_l, pvar_l, npts_l, svv_l, bias_l = fit_l
    v_r, pvar_r, npts_r, svv_r, bias_r = var_r
    m = sel.shape[0]
    left_index = np.empty(m, np.int64)
    right_index = np.empty(m, np.int64)
    ends = np.empty((m, 2, 2))
    disparity = np.empty((m, 2))
    disparity_var = np.empty((m, 2))
    u_left_var = np.empty((m, 2))
    for s in range(m):
        c = sel[s]
        i, j = li[c], rj[c]
        left_index[s] = i
        right_index[s] = j
        for e in range(2):
            v = rows_px[c, e]
            ends[s, e, 0] = u_l[i] + slope_l[i] * (v - v_l[i])
            ends[s, e, 1] = v
            dv = v - v_l[i]
            var_l = pvar_l[i] * (1.0 / npts_l[i] + dv * dv / svv_l[i]) + bias_l[i]
            dv = v - v_r[j]
            var_r_ = pvar_r[j] * (1.0 / npts_r[j] + dv * dv / svv_r[j]) + bias_r[j]
            u_left_var[s, e] = var_l
            disparity_var[s, e] = var_l + var_r_
            disparity[s, e] = disp[c, e]
    return left_index, right_index, ends, disparity, disparity_var, u_left_var
