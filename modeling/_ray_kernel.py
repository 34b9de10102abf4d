"""Compiled loop of the occlusion sweep (:func:`modeling.model._occlusion`): the nearest segment
along each ray.

Compiled with Numba on first use (:mod:`modeling._jit`); importing this module does not import
Numba.
"""

from __future__ import annotations

import numpy as np

from modeling._jit import compiled_on_first_call


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
