"""Compiled loops of the occlusion sweep (:func:`modeling.model._occlusion`): the nearest segment
along each ray, and the shadow polygons of the runs of blocked rays.

Compiled with Numba on first use (:mod:`modeling._compiled.jit`); importing this module does not import
Numba.
"""

from __future__ import annotations

import numpy as np

from modeling._compiled.jit import compiled_on_first_call


@compiled_on_first_call
def nearest_hits(
    u: np.ndarray, p: np.ndarray, e: np.ndarray, k0: np.ndarray, count: np.ndarray
) -> np.ndarray:
    """Distance along each ray to the nearest segment it crosses (``inf``: none).

    Args:
        u: (B, 2) unit direction of each ray.
        p: (n, 2) first endpoint of each segment, relative to the rays' origin.
        e: (n, 2) each segment's second endpoint minus its first.
        k0: (n,) first ray within each segment's angular span.
        count: (n,) number of consecutive rays from ``k0`` to intersect with it (0: none).

    Returns:
        (B,) the smallest ``r > 1e-9`` with ``r u = p + s e``, ``s`` in [0, 1] (1e-9 slack).
    """
    out = np.full(u.shape[0], np.inf)
    for k in range(p.shape[0]):
        px, py, ex, ey = p[k, 0], p[k, 1], e[k, 0], e[k, 1]
        for ray in range(k0[k], k0[k] + count[k]):
            ux, uy = u[ray, 0], u[ray, 1]
            denom = ux * ey - uy * ex
            if abs(denom) <= 1e-15:  # parallel to the ray
                continue
            r = (px * ey - py * ex) / denom
            s = (px * uy - py * ux) / denom
            if s >= -1e-9 and s <= 1.0 + 1e-9 and r > 1e-9 and r < out[ray]:
                out[ray] = r
    return out


@compiled_on_first_call
def shadow_rings(
    origin: np.ndarray, u: np.ndarray, hit: np.ndarray, max_range: float
) -> tuple[np.ndarray, np.ndarray]:
    """The occluded polygons of a ray sweep: one ring per run of consecutive blocked rays.

    A ray is blocked when its hit is nearer than ``max_range``. A run's ring goes through the
    hit points of its rays, then back along the range arc, which reaches one ray beyond each end
    of the run (the shadow's edge lies between a blocked and a free ray).

    Args:
        origin: (2,) the rays' origin.
        u: (B, 2) unit direction of each ray, in angular order.
        hit: (B,) distance to the nearest hit of each ray (``inf``: none).
        max_range: Range, metres.

    Returns:
        ``(vertices, sizes)``: (v, 2) the rings (not closed) one after another, and (r,) the
        vertices of each.
    """
    n = hit.shape[0]
    n_blocked = 0
    n_runs = 0
    for k in range(n):
        if hit[k] < max_range:
            n_blocked += 1
            if k == 0 or not hit[k - 1] < max_range:
                n_runs += 1
    # a run of m rays has m hit points and at most m + 2 arc points
    out = np.empty((2 * n_blocked + 2 * n_runs, 2))
    sizes = np.zeros(n_runs, np.int64)
    v = 0
    run = -1
    k = 0
    while k < n:
        if not hit[k] < max_range:
            k += 1
            continue
        s0 = k
        while k < n and hit[k] < max_range:
            k += 1
        s1 = k  # exclusive
        run += 1
        start = v
        for r in range(s0, s1):
            out[v, 0] = origin[0] + hit[r] * u[r, 0]
            out[v, 1] = origin[1] + hit[r] * u[r, 1]
            v += 1
        for r in range(min(s1 + 1, n) - 1, max(s0 - 1, 0) - 1, -1):
            out[v, 0] = origin[0] + max_range * u[r, 0]
            out[v, 1] = origin[1] + max_range * u[r, 1]
            v += 1
        sizes[run] = v - start
    return out[:v], sizes
