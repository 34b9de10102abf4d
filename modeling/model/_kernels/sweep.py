"""Compiled loops of the occlusion sweep (:mod:`modeling.model.occlusion`): the rays within each
segment's angular span (:func:`ray_spans`; reference
:func:`modeling.model.occlusion.ray_spans_reference`), the nearest crossing of each ray
(:func:`nearest_hits`; reference :func:`modeling.model.occlusion.nearest_hits_reference`) and the
shadow polygons of the blocked runs of rays (:func:`shadow_rings`; reference
:func:`modeling.model.occlusion.shadow_rings_reference`).

The same arithmetic as the NumPy references, element by element (no fused or reordered
operations), so the results are equal to the last bit;
``tests/modeling/model/test_compiled_sweep.py`` compares them. Compiled with Numba on first use
(:mod:`modeling.jit`); importing this module does not import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_on_first_call


class RaysAndSegments(NamedTuple):
    """Rays from one origin and the segments to intersect them with.

    Attributes:
        u: (B, 2) unit direction of each ray.
        p: (n, 2) first endpoint of each segment, relative to the rays' origin, metres.
        e: (n, 2) each segment's second endpoint minus its first, metres.
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
        origin: (2,) the rays' origin, world frame, metres.
        u: (B, 2) unit direction of each ray, in angular order.
        hit: (B,) distance to the nearest hit of each ray (``inf``: none), metres.
        max_range: Range, metres.
    """

    origin: np.ndarray
    u: np.ndarray
    hit: np.ndarray
    max_range: float


class Rings(NamedTuple):
    """Polygon rings one after another.

    Attributes:
        vertices: (v, 2) the rings (not closed), metres.
        sizes: (r,) int64, the vertices of each ring.
    """

    vertices: np.ndarray
    sizes: np.ndarray


@compiled_on_first_call
def ray_spans(
    lo: np.ndarray, hi: np.ndarray, half: float, n_rays: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(k0, count)`` (n,) int64 each: the first ray and the number of rays of ``n_rays``
    (evenly spaced over ``[-half, half]``) within each span ``[lo, hi]`` (radians relative to
    the heading, 1e-9 ray steps of slack); none for a span of pi or more (or NaN), whose ``k0``
    is then 0."""
    step = 2.0 * half / (n_rays - 1)
    n = lo.shape[0]
    k0 = np.zeros(n, np.int64)
    count = np.zeros(n, np.int64)
    for i in range(n):
        if hi[i] - lo[i] < np.pi:
            first = min(max(np.ceil((lo[i] + half) / step - 1e-9), 0.0), float(n_rays))
            last = min(max(np.floor((hi[i] + half) / step + 1e-9), -1.0), float(n_rays - 1))
            k0[i] = int(first)
            count[i] = max(int(last) - int(first) + 1, 0)
    return k0, count


@compiled_on_first_call
def nearest_hits(rays: RaysAndSegments) -> np.ndarray:
    """(B,) the distance along each ray to the nearest segment it crosses (``inf``: none).

    Ray ``k`` meets segment ``p + s e`` at ``r u_k = p + s e``; the hit counts when ``|u_k x e|
    > 1e-15``, ``s`` is in [0, 1] (1e-9 slack) and ``r > 1e-9``. Only the rays ``k0 .. k0 +
    n_rays - 1`` of each segment are tried.
    """
    u, p, e, k0, count = rays.u, rays.p, rays.e, rays.k0, rays.n_rays
    out = np.full(u.shape[0], np.inf)
    for i in range(p.shape[0]):
        px, py, ex, ey = p[i, 0], p[i, 1], e[i, 0], e[i, 1]
        for k in range(k0[i], k0[i] + count[i]):
            ux, uy = u[k, 0], u[k, 1]
            denom = ux * ey - uy * ex
            if abs(denom) > 1e-15:
                r = (px * ey - py * ex) / denom
                s = (px * uy - py * ux) / denom
                if s >= -1e-9 and s <= 1.0 + 1e-9 and r > 1e-9 and r < out[k]:
                    out[k] = r
    return out


@compiled_on_first_call
def shadow_rings(sweep: RaySweep) -> Rings:
    """One ring per run of consecutive blocked rays (hit nearer than ``max_range``): the hit
    points of its rays, then back along the range arc from one ray beyond its end to one ray
    before its start (within the sweep)."""
    origin, u, hit, max_range = sweep.origin, sweep.u, sweep.hit, sweep.max_range
    n = hit.shape[0]
    # the runs [lo, hi) of blocked rays
    lo = np.empty(n, np.int64)
    hi = np.empty(n, np.int64)
    n_runs = 0
    k = 0
    while k < n:
        if hit[k] < max_range:
            start = k
            while k < n and hit[k] < max_range:
                k += 1
            lo[n_runs] = start
            hi[n_runs] = k
            n_runs += 1
        else:
            k += 1
    sizes = np.empty(n_runs, np.int64)
    total = 0
    for r in range(n_runs):
        sizes[r] = (hi[r] - lo[r]) + (min(hi[r] + 1, n) - max(lo[r] - 1, 0))
        total += sizes[r]
    vertices = np.empty((total, 2))
    ox, oy = origin[0], origin[1]
    v = 0
    for r in range(n_runs):
        for k in range(lo[r], hi[r]):
            vertices[v, 0] = ox + hit[k] * u[k, 0]
            vertices[v, 1] = oy + hit[k] * u[k, 1]
            v += 1
        for k in range(min(hi[r] + 1, n) - 1, max(lo[r] - 1, 0) - 1, -1):
            vertices[v, 0] = ox + max_range * u[k, 0]
            vertices[v, 1] = oy + max_range * u[k, 1]
            v += 1
    return Rings(vertices=vertices, sizes=sizes)
