"""Compiled loops of the relations between floor segments (:mod:`modeling.relations`,
:mod:`modeling.gaps`): closest points, their interpolated uncertainty, and ``P(||d|| <= w)``.

The arithmetic is that of the vectorised NumPy formulation they replace (see
:mod:`modeling.gaps` for the method: screening by Gaussian tail bounds, a 12-node Gauss-Hermite
rule for smooth pairs (8 nodes for the smoothest), 16-node Gauss-Legendre panels in
``tau = tan(theta / 2)`` between the breakpoints otherwise), written as one pass per pair so that
a model costs a few array allocations instead of a few hundred small array operations.
``Phi(x)`` is ``erfc(-x / sqrt 2) / 2``.

Compiled with Numba on first use (:mod:`modeling._compiled.jit`); importing this module does not import
Numba.
"""

from __future__ import annotations

import math

import numpy as np

from modeling._compiled.jit import compiled_helper, compiled_on_first_call

_SQRT1_2 = 1.0 / math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
K_SIGMA = 8.5  # integration window, in standard deviations of the minor axis (tail < 1e-15)
K_SCREEN_BATCH = 4.5  # answer 0 or 1 beyond this many sigmas (error < exp(-10.1) < 4.1e-5)
GH_MAX_REACH = 0.95  # smooth pairs: |m_u| + K_SIGMA s_u <= this fraction of the width
GH_MAX_SLOPE = 1.0  # ... and s_u |u| / (h s_v) <= this over the window: 12 nodes (error < 1e-7)
GH_FEW_SLOPE = 0.25  # up to this slope 8 nodes are enough (error < 1e-12)


@compiled_helper
def closest_params(
    p1x: float,
    p1y: float,
    q1x: float,
    q1y: float,
    p2x: float,
    p2y: float,
    q2x: float,
    q2y: float,
) -> tuple[float, float]:
    """Parameters ``(s, t)`` in [0, 1] of the closest points of segments p1-q1 and p2-q2 (after
    Ericson, Real-Time Collision Detection, 5.1.9; parallel overlapping segments: the middle of
    the overlap)."""
    d1x, d1y = q1x - p1x, q1y - p1y
    d2x, d2y = q2x - p2x, q2y - p2y
    rx, ry = p1x - p2x, p1y - p2y
    a = d1x * d1x + d1y * d1y
    e = d2x * d2x + d2y * d2y
    f = d2x * rx + d2y * ry
    if a <= 1e-18:  # segment 1 is a point
        if e <= 1e-18:
            return 0.0, 0.0
        return 0.0, min(max(f / e, 0.0), 1.0)
    c = d1x * rx + d1y * ry
    # Segment 2's endpoints projected onto segment 1, clamped: the parallel case takes the
    # middle of the overlap; they also clamp s when t is clamped, and serve a point segment 2.
    s_at_p2 = min(max(-c / a, 0.0), 1.0)
    if e <= 1e-18:
        return s_at_p2, 0.0
    b = d1x * d2x + d1y * d2y
    s_at_q2 = min(max((b - c) / a, 0.0), 1.0)
    denom = a * e - b * b
    if denom > 1e-12 * a * e:
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
    else:
        s = 0.5 * (s_at_p2 + s_at_q2)
    t = (b * s + f) / e
    if t < 0.0:
        return s_at_p2, 0.0
    if t > 1.0:
        return s_at_q2, 1.0
    return s, t


@compiled_helper
def _inner(h: float, m_v: float, s_v: float) -> float:
    """``Phi((h - m_v) / s_v) - Phi((-h - m_v) / s_v)``."""
    return 0.5 * (math.erfc(-(h - m_v) / s_v * _SQRT1_2) - math.erfc(-(-h - m_v) / s_v * _SQRT1_2))


@compiled_helper
def principal_axes(sxx: float, sxy: float, syy: float) -> tuple[float, float, float, float]:
    """Eigen-decomposition of ``[[sxx, sxy], [sxy, syy]]``: the major and minor variances
    (the minor one at least 0) and ``(cos, sin)`` of the major axis's direction."""
    half_tr = 0.5 * (sxx + syy)
    r = math.hypot(0.5 * (sxx - syy), sxy)
    phi = 0.5 * math.atan2(2.0 * sxy, sxx - syy)  # direction of the major axis
    return half_tr + r, max(half_tr - r, 0.0), math.cos(phi), math.sin(phi)


@compiled_helper
def eigen_frame(
    mx: float, my: float, sxx: float, sxy: float, syy: float, w: float
) -> tuple[float, float, float, float]:
    """Mean and standard deviation of ``d ~ N((mx, my), S)`` along the minor (u) and major (v)
    axes of ``S``: ``(m_u, s_u, m_v, s_v)``; the deviations are floored at ``1e-9`` of the
    problem's scale (``w + |mu| + s_v``)."""
    l_major, l_minor, c, s = principal_axes(sxx, sxy, syy)
    floor = 1e-9 * (w + math.hypot(mx, my) + math.sqrt(l_major)) + 1e-300
    return (
        -s * mx + c * my,
        max(math.sqrt(l_minor), floor),
        c * mx + s * my,
        max(math.sqrt(l_major), floor),
    )


@compiled_helper
def breakpoints(m_u: float, s_u: float, m_v: float, w: float, bps: np.ndarray) -> bool:
    """The seven breakpoints in ``theta`` (``u = w sin(theta)``) of the integration window, sorted
    into ``bps``: the window's ends (``m_u +- K_SIGMA s_u`` within ``(-w, w)``), the steps of the
    inner term (``w cos(theta) = |m_v|``), the outer density's peak and the peak -+ 2 ``s_u``
    (clipped to the window). False if the window is empty."""
    lo = max(-w, m_u - K_SIGMA * s_u)
    hi = min(w, m_u + K_SIGMA * s_u)
    if not hi > lo:
        return False
    t_lo = math.asin(min(max(lo / w, -1.0), 1.0))
    t_hi = math.asin(min(max(hi / w, -1.0), 1.0))
    step = math.acos(min(max(abs(m_v) / w, 0.0), 1.0))
    bps[0] = t_lo
    bps[1] = min(max(-step, t_lo), t_hi)
    bps[2] = min(max(step, t_lo), t_hi)
    bps[3] = min(max(math.asin(min(max(m_u / w, -1.0), 1.0)), t_lo), t_hi)
    bps[4] = min(max(math.asin(min(max((m_u - 2.0 * s_u) / w, -1.0), 1.0)), t_lo), t_hi)
    bps[5] = min(max(math.asin(min(max((m_u + 2.0 * s_u) / w, -1.0), 1.0)), t_lo), t_hi)
    bps[6] = t_hi
    for a in range(1, 7):  # insertion sort of the seven breakpoints
        x = bps[a]
        b = a - 1
        while b >= 0 and bps[b] > x:
            bps[b + 1] = bps[b]
            b -= 1
        bps[b + 1] = x
    return True


@compiled_helper
def gh_slope(m_u: float, s_u: float, s_v: float, w: float) -> float:
    """How far the inner term's argument moves per outer standard deviation across the outer
    window ``m_u +- K_SIGMA s_u`` (``s_u |u| / (h s_v)`` at its widest), or ``inf`` where that
    window does not lie well inside ``(-w, w)`` (within ``GH_MAX_REACH w``)."""
    reach = abs(m_u) + K_SIGMA * s_u
    if reach > GH_MAX_REACH * w:
        return math.inf
    denom = math.sqrt(max(w * w - reach * reach, 0.0)) * s_v
    return s_u * reach / denom if denom > 0.0 else math.inf


@compiled_helper
def p_inside(
    mx: float,
    my: float,
    sxx: float,
    sxy: float,
    syx: float,
    syy: float,
    w: float,
    rules: tuple[np.ndarray, ...],
    bps: np.ndarray,
) -> float:
    """``P(||d|| <= w)`` for ``d ~ N((mx, my), [[sxx, sxy], [syx, syy]])``, ``w > 0``.

    ``rules``: :func:`modeling.gaps.quadrature_rules` (Gauss-Hermite nodes and weights, the
    shorter such rule for the flattest pairs, Gauss-Legendre nodes and weights on [-1, 1]);
    ``bps``: scratch space of 7 floats.
    """
    gh_x, gh_w, gh_few_x, gh_few_w, gl_x, gl_w = rules
    m_u, s_u, m_v, s_v = eigen_frame(mx, my, sxx, sxy, syy, w)
    dist = math.hypot(mx, my)
    # Screening by tail bounds (see modeling.gaps._p_inside_batch).
    k = K_SCREEN_BATCH
    if w - dist > k * s_v:
        return 1.0
    if dist - w > k * s_v or abs(m_u) - w > k * s_u or abs(m_v) - w > k * s_v:
        return 0.0
    if dist > 0.0:
        ex, ey = mx / dist, my / dist
        s_e = math.sqrt(ex * (sxx * ex + sxy * ey) + ey * (syx * ex + syy * ey))
        if dist - w > k * s_e:
            return 0.0
    abs_mv = abs(m_v)
    slope = gh_slope(m_u, s_u, s_v, w)
    if slope <= GH_MAX_SLOPE:
        # Smooth: Gauss-Hermite in u (the shorter rule where the inner term is flatter).
        nodes, weights = (gh_few_x, gh_few_w) if slope <= GH_FEW_SLOPE else (gh_x, gh_w)
        total = 0.0
        for q in range(nodes.shape[0]):
            u = m_u + s_u * nodes[q]
            total += weights[q] * _inner(math.sqrt(w * w - u * u), abs_mv, s_v)
        return min(max(total, 0.0), 1.0)
    # Gauss-Legendre panels in tau = tan(theta / 2), u = w sin(theta), between the breakpoints.
    if not breakpoints(m_u, s_u, m_v, w, bps):
        return 0.0
    norm = 2.0 * _INV_SQRT_2PI / s_u
    total = 0.0
    p0 = math.tan(0.5 * bps[0])
    for a_ in range(6):
        p1 = math.tan(0.5 * bps[a_ + 1])
        if p1 > p0:
            half = 0.5 * (p1 - p0)
            mid = 0.5 * (p1 + p0)
            panel = 0.0
            for q in range(gl_x.shape[0]):
                tau = mid + half * gl_x[q]
                t2 = tau * tau
                inv = 1.0 / (1.0 + t2)
                h = w * max((1.0 - t2) * inv, 0.0)
                z = (w * 2.0 * tau * inv - m_u) / s_u
                dens = math.exp(-0.5 * z * z) * (h * inv * norm)
                panel += gl_w[q] * dens * _inner(h, abs_mv, s_v)
            total += panel * half
        p0 = p1
    return min(max(total, 0.0), 1.0)


@compiled_on_first_call
def p_inside_batch(
    mu: np.ndarray,
    S: np.ndarray,
    w: np.ndarray,
    rules: tuple[np.ndarray, ...],
) -> np.ndarray:
    """(m,) ``P(||d|| <= w)`` for ``d ~ N(mu, S)``: mu (m, 2), S (m, 2, 2), w (m,) > 0;
    ``rules`` as :func:`p_inside`."""
    m = mu.shape[0]
    out = np.empty(m)
    bps = np.empty(7)
    for k in range(m):
        out[k] = p_inside(
            mu[k, 0], mu[k, 1], S[k, 0, 0], S[k, 0, 1], S[k, 1, 0], S[k, 1, 1], w[k], rules, bps
        )  # fmt: skip
    return out


@compiled_on_first_call
def closest_params_batch(
    p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(m,) parameters ``s`` and ``t`` of :func:`closest_params` for (m, 2) endpoint arrays."""
    m = p1.shape[0]
    s = np.empty(m)
    t = np.empty(m)
    for k in range(m):
        s[k], t[k] = closest_params(
            p1[k, 0], p1[k, 1], q1[k, 0], q1[k, 1], p2[k, 0], p2[k, 1], q2[k, 0], q2[k, 1]
        )
    return s, t


@compiled_on_first_call
def grown_boxes(
    ends: np.ndarray, cov: np.ndarray, half_width: float, k: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's sigma bound and its bounding box grown by ``half_width + k sigma``.

    Args:
        ends: (n, 2, 2) mean endpoints.
        cov: (n, 2, 2, 2) endpoint covariances.
        half_width: Half the robot width.
        k: Multiple of the sigma each box is grown by (besides ``half_width``).

    Returns:
        ``(sigma, box)``: (n,) the square root of the larger endpoint covariance trace, and (n, 4)
        ``x_min, y_min, x_max, y_max`` of each grown box.
    """
    n = ends.shape[0]
    sigma = np.empty(n)
    box = np.empty((n, 4))
    for a in range(n):
        sigma[a] = np.sqrt(
            max(cov[a, 0, 0, 0] + cov[a, 0, 1, 1], cov[a, 1, 0, 0] + cov[a, 1, 1, 1])
        )
        grow = half_width + k * sigma[a]
        box[a, 0] = min(ends[a, 0, 0], ends[a, 1, 0]) - grow
        box[a, 1] = min(ends[a, 0, 1], ends[a, 1, 1]) - grow
        box[a, 2] = max(ends[a, 0, 0], ends[a, 1, 0]) + grow
        box[a, 3] = max(ends[a, 0, 1], ends[a, 1, 1]) + grow
    return sigma, box


@compiled_on_first_call
def box_pairs(box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``i < j`` of boxes (n, 4) ``x_min, y_min, x_max, y_max`` that meet: what an
    STRtree of the boxes queried with themselves finds (its envelope test, bounds included), by
    testing every pair (for a few dozen boxes, cheaper than building the tree)."""
    n = box.shape[0]
    q0 = np.empty(n * (n - 1) // 2, np.int64)
    q1 = np.empty(n * (n - 1) // 2, np.int64)
    c = 0
    for a in range(n):
        for b in range(a + 1, n):
            if not (
                box[b, 0] > box[a, 2]
                or box[b, 2] < box[a, 0]
                or box[b, 1] > box[a, 3]
                or box[b, 3] < box[a, 1]
            ):
                q0[c] = a
                q1[c] = b
                c += 1
    return q0[:c], q1[:c]


@compiled_on_first_call
def near_pairs(
    ends: np.ndarray, sigma: np.ndarray, q0: np.ndarray, q1: np.ndarray, width: float, k: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``i < j`` among the query hits ``(q0[r], q1[r])`` (either order, repeats
    allowed only as the two orders of one pair) whose mean segments are at most
    ``width + k (sigma[i] + sigma[j])`` apart.

    Args:
        ends: (n, 2, 2) mean endpoints.
        sigma: (n,) bound on each segment's endpoint standard deviations.
        q0, q1: (m,) candidate pairs (e.g. an STRtree's hits of the segments against themselves).
        width: Robot width.
        k: Multiple of the summed sigmas.

    Returns:
        ``(i, j, s, t)``: the kept pairs sorted by ``(i, j)`` and their closest-point parameters.
    """
    n = ends.shape[0]
    m = q0.shape[0]
    key = np.empty(m, dtype=np.int64)
    c = 0
    for r in range(m):
        if q0[r] < q1[r]:
            key[c] = q0[r] * n + q1[r]
            c += 1
    key = np.sort(key[:c])  # unique keys: sorted by (i, j)
    i_out = np.empty(c, dtype=np.int64)
    j_out = np.empty(c, dtype=np.int64)
    s_out = np.empty(c)
    t_out = np.empty(c)
    n_keep = 0
    for r in range(c):
        a, b = key[r] // n, key[r] % n
        p1x, p1y, q1x, q1y = ends[a, 0, 0], ends[a, 0, 1], ends[a, 1, 0], ends[a, 1, 1]
        p2x, p2y, q2x, q2y = ends[b, 0, 0], ends[b, 0, 1], ends[b, 1, 0], ends[b, 1, 1]
        s, t = closest_params(p1x, p1y, q1x, q1y, p2x, p2y, q2x, q2y)
        dx = (p2x + t * (q2x - p2x)) - (p1x + s * (q1x - p1x))
        dy = (p2y + t * (q2y - p2y)) - (p1y + s * (q1y - p1y))
        if math.hypot(dx, dy) <= width + k * (sigma[a] + sigma[b]):
            i_out[n_keep] = a
            j_out[n_keep] = b
            s_out[n_keep] = s
            t_out[n_keep] = t
            n_keep += 1
    return i_out[:n_keep], j_out[:n_keep], s_out[:n_keep], t_out[:n_keep]


@compiled_on_first_call
def relation_rows(
    ends: np.ndarray,
    cov: np.ndarray,
    i: np.ndarray,
    j: np.ndarray,
    s: np.ndarray,
    t: np.ndarray,
    width: float,
    rules: tuple[np.ndarray, ...],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Closest points of pairs ``(i, j)`` at parameters ``(s, t)``, their covariances
    (interpolated from the endpoints': ``(1 - s)^2 C_0 + s^2 C_1``), distance and
    ``P(||d|| > width)`` (1 for ``width == 0``).

    Returns:
        ``(point_i, point_j, cov_i, cov_j, distance, p_passable)``: (m, 2), (m, 2),
        (m, 2, 2), (m, 2, 2), (m,), (m,).
    """
    m = i.shape[0]
    pi = np.empty((m, 2))
    pj = np.empty((m, 2))
    ci = np.empty((m, 2, 2))
    cj = np.empty((m, 2, 2))
    dist = np.empty(m)
    p = np.empty(m)
    bps = np.empty(7)
    for k in range(m):
        a, b = i[k], j[k]
        sa, sb = s[k], t[k]
        ua, ub = 1.0 - sa, 1.0 - sb
        for r in range(2):
            pi[k, r] = ua * ends[a, 0, r] + sa * ends[a, 1, r]
            pj[k, r] = ub * ends[b, 0, r] + sb * ends[b, 1, r]
            for c in range(2):
                ci[k, r, c] = ua * ua * cov[a, 0, r, c] + sa * sa * cov[a, 1, r, c]
                cj[k, r, c] = ub * ub * cov[b, 0, r, c] + sb * sb * cov[b, 1, r, c]
        dx = pj[k, 0] - pi[k, 0]
        dy = pj[k, 1] - pi[k, 1]
        dist[k] = math.hypot(dx, dy)
        if width > 0.0:
            p[k] = 1.0 - p_inside(
                dx, dy,
                ci[k, 0, 0] + cj[k, 0, 0], ci[k, 0, 1] + cj[k, 0, 1],
                ci[k, 1, 0] + cj[k, 1, 0], ci[k, 1, 1] + cj[k, 1, 1],
                width, rules, bps,
            )  # fmt: skip
        else:
            p[k] = 1.0
    return pi, pj, ci, cj, dist, p


@compiled_on_first_call
def width_moments(
    mu: np.ndarray,
    S: np.ndarray,
    grid: tuple[np.ndarray, np.ndarray, np.ndarray],
    grid_thin: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of ``||d||`` for ``d ~ N(mu, S)`` (see
    :func:`modeling.gaps.gap_width_moments`): a tensor Gauss-Hermite rule in the eigenbasis of
    ``S`` (``grid``: nodes along the major axis, nodes along the minor one, weights summing to 1),
    ``grid_thin`` where the minor standard deviation is below a tenth of the major one; the second
    moment exact."""
    m = mu.shape[0]
    mean = np.empty(m)
    std = np.empty(m)
    for k in range(m):
        a, d = S[k, 0, 0], S[k, 1, 1]
        l_major, l_minor, c, s = principal_axes(a, S[k, 0, 1], d)
        sd_major, sd_minor = math.sqrt(l_major), math.sqrt(l_minor)
        n1, n2, w = grid_thin if sd_minor < 0.1 * sd_major else grid
        total = 0.0
        for q in range(w.shape[0]):
            # Node mu + z1 sd_major e_major + z2 sd_minor e_minor; e_major = (c, s),
            # e_minor = (-s, c).
            u = sd_major * n1[q]
            v = sd_minor * n2[q]
            px = mu[k, 0] + c * u - s * v
            py = mu[k, 1] + s * u + c * v
            total += math.sqrt(px * px + py * py) * w[q]
        mean[k] = total
        second = mu[k, 0] * mu[k, 0] + mu[k, 1] * mu[k, 1] + a + d
        std[k] = math.sqrt(max(second - total * total, 0.0))
    return mean, std
