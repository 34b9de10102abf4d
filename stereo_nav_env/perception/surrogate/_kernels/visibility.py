"""The compiled loops of the surrogate's visibility sweep
(:mod:`stereo_nav_env.perception.surrogate.visibility`,
:mod:`stereo_nav_env.perception.surrogate.floor`).

Each loop has a NumPy reference there (``seen_runs_reference``, ``floor_hidden_reference``: the
sight lines clipped to every part at once by ``clip_to_parts``; ``visible_floor_lines_reference``,
``visible_edges_reference``) that a test holds it equal to, bit for bit. Per sight line, from the
head (:class:`Sight`) to a target stopped ``pull_back`` short of it, every part's footprint is
clipped by Cyrus-Beck (:class:`Parts`: each part's corners and outward side normals, padded by
repeating the last), in the reference's arithmetic order. The loops take the small named tuples
below. Frames and units: world metres, z up.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_helper, compiled_on_first_call
from modeling.types import BoolArray, FloatArray, IntArray

__all__ = [
    "FloorSides",
    "Parts",
    "Sight",
    "crossing",
    "edge_candidates_loop",
    "floor_hidden_loop",
    "floor_lines_loop",
    "seen_runs_loop",
]


class Sight(NamedTuple):
    """Where the sight lines start, and how short of its target each stops."""

    x: float  # the head, world metres
    y: float
    height: float  # its height above the floor, metres
    pull_back: float  # a line stops this short of its target, metres


class Parts(NamedTuple):
    """The scene's parts that hide what is behind them (``SceneEdges``), ``P`` parts of at most
    ``V`` corners."""

    side_start: FloatArray  # (P, V, 2) each part's corners (the last repeated up to V), metres
    side_normal: FloatArray  # (P, V, 2) the outward unit normal of the side from each corner
    z_min: FloatArray  # (P,) bottom of each part, metres
    z_max: FloatArray  # (P,) its top, metres


class FloorSides(NamedTuple):
    """The floor sides of the parts standing on the floor (``SceneEdges``), ``L`` of them."""

    ends: FloatArray  # (L, 2, 2) their two ends, world metres
    normal: FloatArray  # (L, 2) their outward unit normals


@compiled_helper
def crossing(
    ox: float,
    oy: float,
    stepx: float,
    stepy: float,
    side_start: FloatArray,
    side_normal: FloatArray,
    p: int,
) -> tuple[float, float]:
    """``(t0, t1)``: the fractions of the line from ``(ox, oy)`` along ``(stepx, stepy)`` between
    which it is inside part ``p``'s footprint (Cyrus-Beck, in ``clip_to_parts``' arithmetic);
    ``t1 <= t0`` where it misses the part."""
    t_enter, t_leave = -np.inf, np.inf
    for v in range(side_start.shape[1]):
        nx, ny = side_normal[p, v, 0], side_normal[p, v, 1]
        num = nx * (side_start[p, v, 0] - ox) + ny * (side_start[p, v, 1] - oy)
        den = nx * stepx + ny * stepy
        if den == 0.0:
            if num < 0.0:
                return 0.0, 0.0  # parallel to a side, outside it
            continue
        t = num / den
        if den < 0.0:
            t_enter = max(t_enter, t)
        else:
            t_leave = min(t_leave, t)
    return max(t_enter, 0.0), min(t_leave, 1.0)


@compiled_on_first_call
def seen_runs_loop(
    sight: Sight,
    parts: Parts,
    targets: FloatArray,
    own_part: IntArray,
    low: FloatArray,
    high: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """``seen_runs_reference`` as loops: per edge, the sight line clipped to every part
    (Cyrus-Beck, as ``clip_to_parts``), the hidden intervals, the longest run left.

    Args:
        sight: The head and the lines' pull-back.
        parts: The parts that hide.
        targets: (n, 2) the edges' floor points, world metres.
        own_part: (n,) the part each edge belongs to.
        low, high: (n,) the heights of each edge to look along, metres.

    Returns:
        ``(low, high)``: (n,) each edge's longest unhidden run of heights, metres (new arrays).
    """
    hx, hy, hh, pull_back = sight
    side_start, side_normal, z_min, z_max = parts
    n = targets.shape[0]
    n_parts = side_start.shape[0]
    low, high = low.copy(), high.copy()
    hide_lo = np.empty(n_parts)
    hide_hi = np.empty(n_parts)
    for i in range(n):
        dx, dy = targets[i, 0] - hx, targets[i, 1] - hy
        length = max(np.hypot(dx, dy), 1e-9)
        sx = targets[i, 0] - dx * (pull_back / length)
        sy = targets[i, 1] - dy * (pull_back / length)
        stepx, stepy = sx - hx, sy - hy
        scale = 1.0 - pull_back / length
        k = 0
        for p in range(n_parts):
            t0, t1 = crossing(hx, hy, stepx, stepy, side_start, side_normal, p)
            if not t1 > t0:
                continue
            if p == own_part[i]:
                hide_lo[k], hide_hi[k] = -np.inf, np.inf
            else:
                inv0 = 1.0 / max(t0 * scale, 1e-9)
                inv1 = 1.0 / max(t1 * scale, 1e-9)
                s0, s1 = z_min[p] - hh, z_max[p] - hh
                c00, c01, c10, c11 = hh + s0 * inv0, hh + s0 * inv1, hh + s1 * inv0, hh + s1 * inv1
                hide_lo[k] = min(min(c00, c01), min(c10, c11))
                hide_hi[k] = max(max(c00, c01), max(c10, c11))
            k += 1
        if k == 1:
            below_hi = min(hide_lo[0], high[i])
            above_lo = max(hide_hi[0], low[i])
            if not below_hi - low[i] >= high[i] - above_lo:
                low[i] = above_lo
            else:
                high[i] = below_hi
        elif k > 1:
            # the intervals in order (of their low end, then high end), then the longest gap
            for a in range(1, k):
                lo_a, hi_a = hide_lo[a], hide_hi[a]
                b = a - 1
                while b >= 0 and (hide_lo[b] > lo_a or (hide_lo[b] == lo_a and hide_hi[b] > hi_a)):
                    hide_lo[b + 1], hide_hi[b + 1] = hide_lo[b], hide_hi[b]
                    b -= 1
                hide_lo[b + 1], hide_hi[b + 1] = lo_a, hi_a
            lo_i, hi_i = low[i], high[i]
            best_lo, best_hi = lo_i, lo_i
            cursor = lo_i
            for a in range(k):
                if hide_lo[a] > cursor and min(hide_lo[a], hi_i) - cursor > best_hi - best_lo:
                    best_lo, best_hi = cursor, min(hide_lo[a], hi_i)
                cursor = max(cursor, hide_hi[a])
                if cursor >= hi_i:
                    break
            if hi_i - cursor > best_hi - best_lo:
                best_lo, best_hi = cursor, hi_i
            low[i], high[i] = best_lo, best_hi
    return low, high


@compiled_helper
def point_hidden(sight: Sight, parts: Parts, tx: float, ty: float) -> bool:
    """Whether a part hides the floor point ``(tx, ty)`` (world metres) from the head
    (``floor_hidden_reference`` for one point)."""
    hx, hy, hh, pull_back = sight
    side_start, side_normal, z_min, z_max = parts
    dx, dy = tx - hx, ty - hy
    length = max(np.hypot(dx, dy), 1e-9)
    stepx = tx - dx * (pull_back / length) - hx
    stepy = ty - dy * (pull_back / length) - hy
    scale = 1.0 - pull_back / length
    for p in range(side_start.shape[0]):
        t0, t1 = crossing(hx, hy, stepx, stepy, side_start, side_normal, p)
        if not t1 > t0:
            continue
        if hh * (1.0 - t0 * scale) > z_min[p] and hh * (1.0 - t1 * scale) < z_max[p]:
            return True
    return False


@compiled_on_first_call
def floor_hidden_loop(sight: Sight, parts: Parts, targets: FloatArray) -> BoolArray:
    """``floor_hidden_reference`` as loops (the clipping of :func:`seen_runs_loop`): (n,) whether
    a part hides each floor point ``targets`` (n, 2), world metres."""
    n = targets.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        out[i] = point_hidden(sight, parts, targets[i, 0], targets[i, 1])
    return out


@compiled_on_first_call
def floor_lines_loop(
    head: FloatArray,
    camera: FloatArray,
    sides: FloorSides,
    seen_xy: FloatArray,
    samples: int,
    max_range_m: float,
    parts: Parts,
    pull_back: float,
) -> FloatArray:
    """``visible_floor_lines_reference`` as loops, in its arithmetic order.

    Args:
        head: ``(x, y, height, cos heading, sin heading)``, world metres.
        camera: ``(focal, cx, cy, fb, min depth, max depth, width, height)`` of the rig, px and
            metres.
        sides: The parts' floor sides.
        seen_xy: (c, 2) floor points of the seen corner edges, world metres.
        samples: Points sampled along each side.
        max_range_m: Farthest side midpoint looked at, metres.
        parts: The parts that hide the floor.
        pull_back: A sight line stops this short of its floor point, metres.

    Returns:
        (k, 2, 2) the image lines ``[[u, v], [u, v]]``, px, left end first.
    """
    hx, hy, hh, c, s = head[0], head[1], head[2], head[3], head[4]
    f, cx, cy, fb = camera[0], camera[1], camera[2], camera[3]
    z_lo, z_hi, width, height = camera[4], camera[5], camera[6], camera[7]
    line_ends, line_normal = sides
    sight = Sight(hx, hy, hh, pull_back)
    lo, hi = 1.0 - 0.5, width - 0.5 - 1.0  # both images' columns, a pixel inside
    n_lines = line_ends.shape[0]
    out = np.empty((n_lines * ((samples + 1) // 2), 2, 2))
    seen = np.zeros(samples + 1, dtype=np.bool_)
    k = 0
    half = 0.5 / samples
    for li in range(n_lines):
        ax, ay = line_ends[li, 0, 0], line_ends[li, 0, 1]
        bx, by = line_ends[li, 1, 0], line_ends[li, 1, 1]
        mx, my = (ax + bx) / 2.0, (ay + by) / 2.0
        if not np.hypot(mx - hx, my - hy) <= max_range_m:
            continue
        if not line_normal[li, 0] * (hx - mx) + line_normal[li, 1] * (hy - my) > 0.0:
            continue
        joined = True
        for e in range(2):
            ex, ey = line_ends[li, e, 0], line_ends[li, e, 1]
            best = np.inf
            for q in range(seen_xy.shape[0]):
                gx, gy = ex - seen_xy[q, 0], ey - seen_xy[q, 1]
                best = min(best, gx * gx + gy * gy)
            if not best <= 0.02**2:
                joined = False
        if not joined:
            continue
        abx, aby = bx - ax, by - ay
        for j in range(samples):
            t = (j + 0.5) / samples
            px, py = ax + t * abx, ay + t * aby
            dx, dy = px - hx, py - hy
            X, Z = s * dx - c * dy, c * dx + s * dy
            ok = Z >= z_lo and Z <= z_hi
            Zs = Z if ok else 1.0
            u = cx + f * X / Zs
            u_right = u - fb / Zs
            ok = ok and u >= lo and u <= hi and u_right >= lo and u_right <= hi
            ok = ok and cy + f * hh / (Z if Z > 0 else 1.0) <= height - 1.0
            seen[j] = ok and not point_hidden(sight, parts, px, py)
        first = -1
        for j in range(samples):
            if seen[j] and first < 0:
                first = j
            if seen[j] and not seen[j + 1]:  # seen[samples] stays False
                for m in range(2):
                    tt = (first + 0.5) / samples - half if m == 0 else (j + 0.5) / samples + half
                    ex, ey = ax + tt * abx, ay + tt * aby
                    dx, dy = ex - hx, ey - hy
                    Xe, Ze = s * dx - c * dy, max(c * dx + s * dy, 1e-6)
                    out[k, m, 0] = cx + f * Xe / Ze
                    out[k, m, 1] = cy + f * hh / Ze
                if out[k, 0, 0] > out[k, 1, 0]:
                    for d in range(2):
                        out[k, 0, d], out[k, 1, d] = out[k, 1, d], out[k, 0, d]
                k += 1
                first = -1
    return out[:k].copy()


@compiled_on_first_call
def edge_candidates_loop(
    head: FloatArray,
    camera: FloatArray,
    corner_xy: FloatArray,
    corner_normals: FloatArray,
    corner_z: FloatArray,
    trim_px: float,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, BoolArray]:
    """The first half of ``visible_edges_reference`` as one loop, in its arithmetic order: the
    edges in the disparity range and both images' columns with a side facing the head, and
    their heights inside the image's rows (trimmed by ``trim_px``).

    ``head`` and ``camera`` as in :func:`floor_lines_loop`. Returns ``(cand, X, Z, low, high,
    crease)``: the candidate corners, their camera coordinates, their height range and whether
    both sides face the head."""
    hx, hy, hh, c, s = head[0], head[1], head[2], head[3], head[4]
    f, cx, cy, fb = camera[0], camera[1], camera[2], camera[3]
    z_lo, z_hi, width, height = camera[4], camera[5], camera[6], camera[7]
    lo, hi = 1.0 - 0.5, width - 0.5 - 1.0
    n = corner_xy.shape[0]
    cand = np.empty(n, dtype=np.int64)
    X_out, Z_out = np.empty(n), np.empty(n)
    low, high = np.empty(n), np.empty(n)
    crease = np.empty(n, dtype=np.bool_)
    k = 0
    for i in range(n):
        dx, dy = corner_xy[i, 0] - hx, corner_xy[i, 1] - hy
        X, Z = s * dx - c * dy, c * dx + s * dy
        tx, ty = hx - corner_xy[i, 0], hy - corner_xy[i, 1]
        face0 = corner_normals[i, 0, 0] * tx + corner_normals[i, 0, 1] * ty > 0.0
        face1 = corner_normals[i, 1, 0] * tx + corner_normals[i, 1, 1] * ty > 0.0
        if not (face0 or face1):
            continue
        if not (Z >= z_lo and Z <= z_hi):
            continue
        u = cx + f * X / Z
        u_right = u - fb / Z
        if not (u >= lo and u <= hi and u_right >= lo and u_right <= hi):
            continue
        cand[k], X_out[k], Z_out[k] = i, X, Z
        low[k] = max(corner_z[i, 0], hh - (height - 1.0 - trim_px - cy) * Z / f)
        high[k] = min(corner_z[i, 1], hh - (trim_px - cy) * Z / f)
        crease[k] = face0 and face1
        k += 1
    return (
        cand[:k].copy(),
        X_out[:k].copy(),
        Z_out[:k].copy(),
        low[:k].copy(),
        high[:k].copy(),
        crease[:k].copy(),
    )
