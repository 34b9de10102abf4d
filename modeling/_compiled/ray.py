"""Compiled loops of the occlusion sweep (:func:`modeling.occlusion.occluded_area`): the nearest
segment along each ray, and the shadow polygons of the runs of blocked rays. Their readable
references are :func:`modeling.occlusion.nearest_hits_reference` and
:func:`modeling.occlusion.shadow_rings_reference`.

Compiled with Numba on first use (:mod:`modeling._compiled.jit`); importing this module does not
import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling._compiled.jit import compiled_on_first_call


class RaysAndSegments(NamedTuple):
    """Rays from one origin and the segments to intersect them with.

    Attributes:
        u: (B, 2) float64, unit direction of each ray.
        p: (n, 2) float64, first endpoint of each segment, relative to the rays' origin, metres.
        e: (n, 2) float64, each segment's second endpoint minus its first, metres.
        k0: (n,) int64, first ray within each segment's angular span.
        n_rays: (n,) int64, number of consecutive rays from ``k0`` to intersect with it (0:
            none).
    """

    u: np.ndarray
    p: np.ndarray
    e: np.ndarray
    k0: np.ndarray
    n_rays: np.ndarray


class RaySweep(NamedTuple):
    """The rays of a sweep and their nearest hits.

    Attributes:
        origin: (2,) float64, the rays' origin, world frame, metres.
        u: (B, 2) float64, unit direction of each ray, in angular order.
        hit: (B,) float64, distance to the nearest hit of each ray (``inf``: none), metres.
        max_range: Range, metres.
    """

    origin: np.ndarray
    u: np.ndarray
    hit: np.ndarray
    max_range: float


class Rings(NamedTuple):
    """Polygon rings one after another.

    Attributes:
        vertices: (v, 2) float64, the rings (not closed), metres.
        sizes: (r,) int64, the vertices of each ring.
    """

    vertices: np.ndarray
    sizes: np.ndarray


@compiled_on_first_call
def nearest_hits(rays: RaysAndSegments) -> np.ndarray:
    """Distance along each ray to the nearest segment it crosses (``inf``: none).

    Returns:
        (B,) the smallest ``r > 1e-9`` with ``r u = p + s e``, ``s`` in [0, 1] (1e-9 slack).
    """
    u, p, e, k0, count = rays.u, rays.p, rays.e, rays.k0, rays.n_rays
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
def shadow_rings(sweep: RaySweep) -> Rings:
    """The occluded polygons of a ray sweep: one ring per run of consecutive blocked rays.

    A ray is blocked when its hit is nearer than ``max_range``. A run's ring goes through the
    hit points of its rays, then back along the range arc, which reaches one ray beyond each end
    of the run (the shadow's edge lies between a blocked and a free ray).

    Returns:
        The rings, one per run.
    """
    origin, u, hit, max_range = sweep.origin, sweep.u, sweep.hit, sweep.max_range
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
    return Rings(out[:v], sizes)
