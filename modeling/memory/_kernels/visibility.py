"""Compiled loop of the memory's free-space test (:mod:`modeling.memory.fusion`,
:mod:`modeling.memory.visibility`).

:func:`segments_seen_free` is ``_seen_free`` of :mod:`modeling.memory.fusion` (its reference: the
segments' two endpoints and midpoint through
:meth:`modeling.memory.visibility.Visibility.seen_free`, each at the limit of the segment's top
height) as one pass over the segments, with the same arithmetic in the same order. A fuse tests
every remembered segment and candidate each view; in NumPy that is some twenty array operations,
here one loop.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not import
Numba. ``tests/modeling/memory/test_compiled_visibility.py`` compares it with the reference on
seeded random inputs.
"""

from __future__ import annotations

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call


@compiled_helper
def _point_free(
    x: float,
    y: float,
    near: float,
    origin: np.ndarray,
    heading: float,
    half_fov: float,
    reach: np.ndarray,
    margin: float,
) -> bool:
    """One point seen free (``Visibility.seen_free``'s test)."""
    rx, ry = x - origin[0], y - origin[1]
    dist = np.hypot(rx, ry)
    ang = (np.arctan2(ry, rx) - heading + np.pi) % (2.0 * np.pi) - np.pi
    n = reach.shape[0]
    step = 2.0 * half_fov / (n - 1)
    k = int(min(max(np.rint((ang + half_fov) / step), 0.0), n - 1.0))
    return bool(abs(ang) <= half_fov and dist > near and dist < reach[k] - margin)


@compiled_on_first_call
def segments_seen_free(
    ends: np.ndarray,
    tops: np.ndarray,
    origin: np.ndarray,
    heading: float,
    half_fov: float,
    reach: np.ndarray,
    margin: float,
    limits: np.ndarray,
) -> np.ndarray:
    """(n,) bool: both endpoints and the midpoint of each segment ``ends`` (n, 2, 2) seen free,
    each at the near limit of the segment's top height ``tops`` (n,); ``limits`` is
    ``(near_range_m, head_height_m, tan(half_vfov_rad))`` (no vertical limit when the head
    height is 0)."""
    near_range, head, tan_v = limits[0], limits[1], limits[2]
    out = np.empty(ends.shape[0], dtype=np.bool_)
    for s in range(ends.shape[0]):
        near = near_range if head <= 0.0 else max(near_range, (head - tops[s]) / tan_v)
        mx = (ends[s, 0, 0] + ends[s, 1, 0]) / 2.0
        my = (ends[s, 0, 1] + ends[s, 1, 1]) / 2.0
        out[s] = (
            _point_free(
                ends[s, 0, 0], ends[s, 0, 1], near, origin, heading, half_fov, reach, margin
            )
            and _point_free(
                ends[s, 1, 0], ends[s, 1, 1], near, origin, heading, half_fov, reach, margin
            )
            and _point_free(mx, my, near, origin, heading, half_fov, reach, margin)
        )
    return out
