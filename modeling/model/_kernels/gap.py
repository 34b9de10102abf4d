"""Compiled loops of the relations between floor segments (:mod:`modeling.model.relations`,
:mod:`modeling.model.gaps`): closest points, their interpolated uncertainty, and ``P(||d|| <= w)``.

The method is that of :mod:`modeling.model.gaps` (screening by Gaussian tail bounds, a 12-node
Gauss-Hermite rule for smooth pairs (8 nodes for the smoothest), 16-node Gauss-Legendre panels in
``tau = tan(theta / 2)`` between the breakpoints otherwise), written as one pass per pair so that
a model costs a few array allocations instead of a few hundred small array operations. Loops take
and return the small named structures below. ``Phi(x)`` is ``erfc(-x / sqrt 2) / 2``.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not
import Numba. Each loop has a readable reference beside its public function (in
:mod:`modeling.model.gaps` or :mod:`modeling.model.relations`), and
``tests/modeling/model/test_compiled_gap.py`` compares the two on seeded random inputs.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call

_SQRT1_2 = 1.0 / math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
K_SIGMA = 8.5  # integration window, in standard deviations of the minor axis (tail < 1e-15)
K_SCREEN_BATCH = 4.5  # answer 0 or 1 beyond this many sigmas (error < exp(-10.1) < 4.1e-5)
GH_MAX_REACH = 0.95  # smooth pairs: |m_u| + K_SIGMA s_u <= this fraction of the width
GH_MAX_SLOPE = 1.0  # ... and s_u |u| / (h s_v) <= this over the window: 12 nodes (error < 1e-7)
GH_FEW_SLOPE = 0.25  # up to this slope 8 nodes are enough (error < 1e-12)


class QuadratureRules(NamedTuple):
    """The batch rules: Gauss-Hermite nodes and weights (weights summing to 1) for smooth pairs,
    the shorter such rule for the flattest ones, Gauss-Legendre nodes and weights on [-1, 1]."""

    gh_nodes: np.ndarray
    gh_weights: np.ndarray
    gh_few_nodes: np.ndarray
    gh_few_weights: np.ndarray
    gl_nodes: np.ndarray
    gl_weights: np.ndarray


class Differences(NamedTuple):
    """Gap vectors ``d ~ N(mean, cov)`` and robot widths: (m, 2), (m, 2, 2), (m,) (metres, m^2)."""

    mean: np.ndarray
    cov: np.ndarray
    width: np.ndarray


class HermiteGrid(NamedTuple):
    """Tensor Gauss-Hermite rule of the 2-D standard normal: nodes along the major axis, along the
    minor axis, weights summing to 1; each (q,)."""

    major: np.ndarray
    minor: np.ndarray
    weight: np.ndarray


class Moments(NamedTuple):
    """Mean and standard deviation of ``||d||``: each (m,), metres."""

    mean: np.ndarray
    std: np.ndarray


class SegmentPairs(NamedTuple):
    """Endpoints of m pairs of segments ``p1-q1`` and ``p2-q2``: each (m, 2), metres."""

    p1: np.ndarray
    q1: np.ndarray
    p2: np.ndarray
    q2: np.ndarray


class ClosestParams(NamedTuple):
    """Parameters in [0, 1] of the closest points ``p1 + s (q1 - p1)``, ``p2 + t (q2 - p2)``."""

    s: np.ndarray
    t: np.ndarray


class Segments(NamedTuple):
    """Uncertain segments: mean endpoints (n, 2, 2), metres; endpoint covariances (n, 2, 2, 2)."""

    ends: np.ndarray
    cov: np.ndarray


class GrownBoxes(NamedTuple):
    """Each segment's sigma bound (n,) and its grown box (n, 4): x_min, y_min, x_max, y_max."""

    sigma: np.ndarray
    box: np.ndarray


class PairParams(NamedTuple):
    """Pairs ``i < j`` of segments (m,) and the parameters ``s``, ``t`` (m,) of their closest
    points."""

    i: np.ndarray
    j: np.ndarray
    s: np.ndarray
    t: np.ndarray


class RelationRows(NamedTuple):
    """Closest points (m, 2), their covariances (m, 2, 2), distance (m,) and ``P(||d|| > w)``."""

    point_i: np.ndarray
    point_j: np.ndarray
    cov_i: np.ndarray
    cov_j: np.ndarray
    distance: np.ndarray
    p_passable: np.ndarray


class Segment(NamedTuple):
    """One mean segment from ``(px, py)`` to ``(qx, qy)``, metres (scalars of a compiled loop)."""

    px: float
    py: float
    qx: float
    qy: float


class Gap(NamedTuple):
    """One gap vector ``d ~ N((mx, my), [[sxx, sxy], [syx, syy]])`` and the robot width ``w > 0``
    (scalars of a compiled loop)."""

    mx: float
    my: float
    sxx: float
    sxy: float
    syx: float
    syy: float
    w: float


@compiled_helper
def closest_params(first: Segment, second: Segment) -> tuple[float, float]:
    """Parameters ``(s, t)`` in [0, 1] of the closest points of two segments (after Ericson,
    Real-Time Collision Detection, 5.1.9; parallel overlapping segments: the middle of the
    overlap)."""
    d1x, d1y = first.qx - first.px, first.qy - first.py
    d2x, d2y = second.qx - second.px, second.qy - second.py
    rx, ry = first.px - second.px, first.py - second.py
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
def segment(ends: np.ndarray, a: int) -> Segment:
    """Segment ``a`` of the (n, 2, 2) mean endpoints ``ends``."""
    return Segment(ends[a, 0, 0], ends[a, 0, 1], ends[a, 1, 0], ends[a, 1, 1])


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
def eigen_frame(gap: Gap) -> tuple[float, float, float, float]:
    """Mean and standard deviation of the gap vector along the minor (u) and major (v) axes of its
    covariance: ``(m_u, s_u, m_v, s_v)``; the deviations are floored at ``1e-9`` of the problem's
    scale (``w + |mu| + s_v``)."""
    mx, my = gap.mx, gap.my
    l_major, l_minor, c, s = principal_axes(gap.sxx, gap.sxy, gap.syy)
    floor = 1e-9 * (gap.w + math.hypot(mx, my) + math.sqrt(l_major)) + 1e-300
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
def _gauss_hermite(
    m_u: float, s_u: float, abs_mv: float, s_v: float, w: float, x: np.ndarray, wt: np.ndarray
) -> float:
    """Smooth pairs: the inner term averaged over ``u ~ N(m_u, s_u^2)`` by the rule ``(x, wt)``."""
    total = 0.0
    for q in range(x.shape[0]):
        u = m_u + s_u * x[q]
        total += wt[q] * _inner(math.sqrt(w * w - u * u), abs_mv, s_v)
    return min(max(total, 0.0), 1.0)


@compiled_helper
def _legendre_panels(
    m_u: float,
    s_u: float,
    abs_mv: float,
    s_v: float,
    w: float,
    gl: QuadratureRules,
    bps: np.ndarray,
) -> float:
    """The others: Gauss-Legendre panels in ``tau = tan(theta / 2)``, ``u = w sin(theta)``,
    between the sorted breakpoints ``bps`` (7,)."""
    gl_x, gl_w = gl.gl_nodes, gl.gl_weights
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


@compiled_helper
def p_inside(gap: Gap, rules: QuadratureRules, bps: np.ndarray) -> float:
    """``P(||d|| <= w)`` for one gap (``rules``: :data:`modeling.model.gaps.QUADRATURE_RULES`;
    ``bps``: scratch space of 7 floats). Screening by tail bounds, then a Gauss-Hermite rule or
    Gauss-Legendre panels (see :func:`modeling.model.gaps.passable_from_difference`)."""
    mx, my, w = gap.mx, gap.my, gap.w
    m_u, s_u, m_v, s_v = eigen_frame(gap)
    dist = math.hypot(mx, my)
    k = K_SCREEN_BATCH
    if w - dist > k * s_v:
        return 1.0
    if dist - w > k * s_v or abs(m_u) - w > k * s_u or abs(m_v) - w > k * s_v:
        return 0.0
    if dist > 0.0:
        ex, ey = mx / dist, my / dist
        s_e = math.sqrt(ex * (gap.sxx * ex + gap.sxy * ey) + ey * (gap.syx * ex + gap.syy * ey))
        if dist - w > k * s_e:
            return 0.0
    abs_mv = abs(m_v)
    slope = gh_slope(m_u, s_u, s_v, w)
    if slope <= GH_FEW_SLOPE:
        return _gauss_hermite(m_u, s_u, abs_mv, s_v, w, rules.gh_few_nodes, rules.gh_few_weights)
    if slope <= GH_MAX_SLOPE:
        return _gauss_hermite(m_u, s_u, abs_mv, s_v, w, rules.gh_nodes, rules.gh_weights)
    if not breakpoints(m_u, s_u, m_v, w, bps):
        return 0.0
    return _legendre_panels(m_u, s_u, abs_mv, s_v, w, rules, bps)


@compiled_on_first_call
def p_inside_batch(gaps: Differences, rules: QuadratureRules) -> np.ndarray:
    """(m,) ``P(||d|| <= w)`` of each gap (``w > 0``); ``rules`` as :func:`p_inside`."""
    mu, S, w = gaps.mean, gaps.cov, gaps.width
    m = mu.shape[0]
    out = np.empty(m)
    bps = np.empty(7)
    for k in range(m):
        gap = Gap(mu[k, 0], mu[k, 1], S[k, 0, 0], S[k, 0, 1], S[k, 1, 0], S[k, 1, 1], w[k])
        out[k] = p_inside(gap, rules, bps)
    return out


@compiled_on_first_call
def closest_params_batch(pairs: SegmentPairs) -> ClosestParams:
    """:func:`closest_params` of each of m pairs of segments."""
    p1, q1, p2, q2 = pairs.p1, pairs.q1, pairs.p2, pairs.q2
    m = p1.shape[0]
    s = np.empty(m)
    t = np.empty(m)
    for k in range(m):
        s[k], t[k] = closest_params(
            Segment(p1[k, 0], p1[k, 1], q1[k, 0], q1[k, 1]),
            Segment(p2[k, 0], p2[k, 1], q2[k, 0], q2[k, 1]),
        )
    return ClosestParams(s, t)


@compiled_on_first_call
def grown_boxes(segments: Segments, half_width: float, k: float) -> GrownBoxes:
    """Each segment's sigma bound (the square root of the larger endpoint covariance trace) and
    its bounding box grown by ``half_width + k sigma``."""
    ends, cov = segments.ends, segments.cov
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
    return GrownBoxes(sigma, box)


@compiled_on_first_call
def near_pairs(
    ends: np.ndarray, sigma: np.ndarray, hits: np.ndarray, limit: float, k: float
) -> PairParams:
    """The pairs ``i < j`` among the query hits whose mean segments are at most
    ``limit + k (sigma[i] + sigma[j])`` apart, sorted by ``(i, j)``, with their closest-point
    parameters.

    Args:
        ends: (n, 2, 2) mean endpoints.
        sigma: (n,) bound on each segment's endpoint standard deviations.
        hits: (2, m) candidate pairs, either order, repeats allowed only as the two orders of
            one pair (an STRtree's hits of the boxes against themselves).
        limit: The distance limit without uncertainty (the robot width).
        k: Multiple of the summed sigmas.
    """
    n = ends.shape[0]
    m = hits.shape[1]
    key = np.empty(m, dtype=np.int64)
    c = 0
    for r in range(m):
        if hits[0, r] < hits[1, r]:
            key[c] = hits[0, r] * n + hits[1, r]
            c += 1
    key = np.sort(key[:c])  # unique keys: sorted by (i, j)
    i_out = np.empty(c, dtype=np.int64)
    j_out = np.empty(c, dtype=np.int64)
    s_out = np.empty(c)
    t_out = np.empty(c)
    n_keep = 0
    for r in range(c):
        a, b = key[r] // n, key[r] % n
        first, second = segment(ends, a), segment(ends, b)
        s, t = closest_params(first, second)
        dx = (second.px + t * (second.qx - second.px)) - (first.px + s * (first.qx - first.px))
        dy = (second.py + t * (second.qy - second.py)) - (first.py + s * (first.qy - first.py))
        if math.hypot(dx, dy) <= limit + k * (sigma[a] + sigma[b]):
            i_out[n_keep] = a
            j_out[n_keep] = b
            s_out[n_keep] = s
            t_out[n_keep] = t
            n_keep += 1
    return PairParams(i_out[:n_keep], j_out[:n_keep], s_out[:n_keep], t_out[:n_keep])


@compiled_helper
def _relation_row(
    ends: np.ndarray,
    cov: np.ndarray,
    pairs: PairParams,
    k: int,
    width: float,
    rules: QuadratureRules,
    bps: np.ndarray,
    out: RelationRows,
) -> None:
    """Row ``k`` of :func:`relation_rows`, written into ``out``."""
    pi, pj, ci, cj, dist, p = out
    a, b = pairs.i[k], pairs.j[k]
    sa, sb = pairs.s[k], pairs.t[k]
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
        gap = Gap(
            dx, dy,
            ci[k, 0, 0] + cj[k, 0, 0], ci[k, 0, 1] + cj[k, 0, 1],
            ci[k, 1, 0] + cj[k, 1, 0], ci[k, 1, 1] + cj[k, 1, 1],
            width,
        )  # fmt: skip
        p[k] = 1.0 - p_inside(gap, rules, bps)
    else:
        p[k] = 1.0


@compiled_helper
def _empty_rows(m: int) -> RelationRows:
    """Uninitialised :class:`RelationRows` of ``m`` rows."""
    return RelationRows(
        np.empty((m, 2)), np.empty((m, 2)), np.empty((m, 2, 2)), np.empty((m, 2, 2)),
        np.empty(m), np.empty(m),
    )  # fmt: skip


@compiled_on_first_call
def relation_rows(
    segments: Segments, pairs: PairParams, width: float, rules: QuadratureRules
) -> RelationRows:
    """Closest points of the pairs, their covariances (interpolated from the endpoints':
    ``(1 - s)^2 C_0 + s^2 C_1``), distance and ``P(||d|| > width)`` (1 for ``width == 0``)."""
    out = _empty_rows(pairs.i.shape[0])
    bps = np.empty(7)
    for k in range(pairs.i.shape[0]):
        _relation_row(segments.ends, segments.cov, pairs, k, width, rules, bps, out)
    return out


@compiled_on_first_call
def relation_rows_taking(
    segments: Segments,
    pairs: PairParams,
    width: float,
    rules: QuadratureRules,
    take: np.ndarray,
    earlier: RelationRows,
) -> RelationRows:
    """:func:`relation_rows`, with row ``k`` copied from row ``take[k]`` of ``earlier`` where
    ``take[k] >= 0`` (rows made before for the same pair of segments and width) instead of
    computed."""
    out = _empty_rows(pairs.i.shape[0])
    bps = np.empty(7)
    for k in range(pairs.i.shape[0]):
        o = take[k]
        if o < 0:
            _relation_row(segments.ends, segments.cov, pairs, k, width, rules, bps, out)
            continue
        for r in range(2):
            out.point_i[k, r] = earlier.point_i[o, r]
            out.point_j[k, r] = earlier.point_j[o, r]
            for c in range(2):
                out.cov_i[k, r, c] = earlier.cov_i[o, r, c]
                out.cov_j[k, r, c] = earlier.cov_j[o, r, c]
        out.distance[k] = earlier.distance[o]
        out.p_passable[k] = earlier.p_passable[o]
    return out


@compiled_on_first_call
def width_moments(
    mu: np.ndarray, S: np.ndarray, grid: HermiteGrid, grid_thin: HermiteGrid
) -> Moments:
    """Mean and standard deviation of ``||d||`` for ``d ~ N(mu, S)`` (see
    :func:`modeling.model.gaps.gap_width_moments`): a tensor Gauss-Hermite rule in the eigenbasis of
    ``S``, ``grid_thin`` where the minor standard deviation is below a tenth of the major one;
    the second moment exact."""
    m = mu.shape[0]
    mean = np.empty(m)
    std = np.empty(m)
    for k in range(m):
        a, d = S[k, 0, 0], S[k, 1, 1]
        l_major, l_minor, c, s = principal_axes(a, S[k, 0, 1], d)
        sd_major, sd_minor = math.sqrt(l_major), math.sqrt(l_minor)
        g = grid_thin if sd_minor < 0.1 * sd_major else grid
        total = 0.0
        for q in range(g.weight.shape[0]):
            # Node mu + z1 sd_major e_major + z2 sd_minor e_minor; e_major = (c, s),
            # e_minor = (-s, c).
            u = sd_major * g.major[q]
            v = sd_minor * g.minor[q]
            px = mu[k, 0] + c * u - s * v
            py = mu[k, 1] + s * u + c * v
            total += math.sqrt(px * px + py * py) * g.weight[q]
        mean[k] = total
        second = mu[k, 0] * mu[k, 0] + mu[k, 1] * mu[k, 1] + a + d
        std[k] = math.sqrt(max(second - total * total, 0.0))
    return Moments(mean, std)
