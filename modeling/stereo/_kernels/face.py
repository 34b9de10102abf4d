"""Compiled loop of the face test (:func:`modeling.stereo.faces.face_pairs`): which pairs of
vertical edges a near-horizontal image line joins.

:func:`face_joins` computes every value with the same floating-point operations, in the same
order, as the readable NumPy reference beside the public function
(:func:`modeling.stereo.faces.face_joins_reference`), so the pairs found are identical; a test
compares the two on seeded random inputs.

Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not
import Numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_on_first_call
from modeling.types import FloatArray, IntArray


class FaceEdges(NamedTuple):
    """The candidate edges (unambiguous floor segments of near-vertical image segments) and the
    near-horizontal image lines that may join them.

    Attributes:
        floor_pts: (c, 2, 2) each edge's floor points (top end, bottom end), metres.
        ends_img: (c, 2, 2) each edge's image ends (top, bottom), px.
        slope: (c,) each edge's du/dv.
        top_h: (c,) each edge's top height, metres.
        lines: (k, 2, 2) the near-horizontal image lines, px.
    """

    floor_pts: FloatArray
    ends_img: FloatArray
    slope: FloatArray
    top_h: FloatArray
    lines: FloatArray


class FaceTest(NamedTuple):
    """What a join at one end must satisfy.

    Attributes:
        end: 1 (bottom) or 0 (top).
        step: How far each image end is moved along its edge first (signed rows), px.
        top_match_m: Largest difference of two joined tops (tops only), metres.
        max_length_m: Largest floor distance between the two joined points, metres.
        tol_px: Largest distance of a line's ends from the image line joining the two ends, px.
        min_cover: Smallest fraction of that image line the lines must cover.
    """

    end: int
    step: float
    top_match_m: float
    max_length_m: float
    tol_px: float
    min_cover: float


class FaceJoins(NamedTuple):
    """The joined pairs (indices into the candidate edges), the left one in the image first, in
    the order of ``itertools.combinations(eligible, 2)``.

    Attributes:
        first: (p,) int64.
        second: (p,) int64.
    """

    first: IntArray
    second: IntArray


@compiled_on_first_call
def face_joins(edges: FaceEdges, eligible: IntArray, test: FaceTest) -> FaceJoins:
    """The pairs of ``eligible`` edges (ascending) whose ``test.end``s a line joins (as the
    reference).

    Args:
        edges: The candidate edges and the lines.
        eligible: (e,) the candidates that may be joined at this end, ascending.
        test: The end and the thresholds.

    Returns:
        The joined pairs.
    """
    floor_pts, ends_img, slope = edges.floor_pts, edges.ends_img, edges.slope
    top_h, hor = edges.top_h, edges.lines
    end, step, top_match_m = test.end, test.step, test.top_match_m
    max_length_m, tol_px, min_cover = test.max_length_m, test.tol_px, test.min_cover
    n = eligible.shape[0]
    n_lines = hor.shape[0]
    first = np.empty(n * n, np.int64)
    second = np.empty(n * n, np.int64)
    t0 = np.empty(n_lines)
    t1 = np.empty(n_lines)
    found = 0
    for x in range(n):
        a = eligible[x]
        for y in range(x + 1, n):
            b = eligible[y]
            if end == 0 and not abs(top_h[a] - top_h[b]) <= top_match_m:
                continue
            fx = floor_pts[b, end, 0] - floor_pts[a, end, 0]
            fy = floor_pts[b, end, 1] - floor_pts[a, end, 1]
            if not np.hypot(fx, fy) <= max_length_m:
                continue
            # the image ends, moved along their edges past the last edge point
            px = ends_img[a, end, 0] + step * slope[a]
            py = ends_img[a, end, 1] + step
            dx = ends_img[b, end, 0] + step * slope[b] - px
            dy = ends_img[b, end, 1] + step - py
            l2 = dx * dx + dy * dy
            if not l2 >= 1.0:
                continue
            inv = 1.0 / l2
            tol = tol_px * np.sqrt(l2)
            # the lines whose two ends lie near the pair's image line, and the part they cover
            m = 0
            for k in range(n_lines):
                rx0, ry0 = hor[k, 0, 0] - px, hor[k, 0, 1] - py
                rx1, ry1 = hor[k, 1, 0] - px, hor[k, 1, 1] - py
                if not (abs(dx * ry0 - dy * rx0) <= tol and abs(dx * ry1 - dy * rx1) <= tol):
                    continue
                s0 = (dx * rx0 + dy * ry0) * inv
                s1 = (dx * rx1 + dy * ry1) * inv
                lo = min(max(min(s0, s1), 0.0), 1.0)
                hi = min(max(max(s0, s1), 0.0), 1.0)
                # insertion in (start, stop) order
                p = m
                while p > 0 and (t0[p - 1] > lo or (t0[p - 1] == lo and t1[p - 1] > hi)):
                    t0[p] = t0[p - 1]
                    t1[p] = t1[p - 1]
                    p -= 1
                t0[p] = lo
                t1[p] = hi
                m += 1
            if m == 0:
                continue
            total, run_lo, run_hi = 0.0, 0.0, -1.0
            for q in range(m):
                if t0[q] > run_hi:  # a new run
                    total += max(run_hi - run_lo, 0.0)
                    run_lo, run_hi = t0[q], t1[q]
                else:
                    run_hi = max(run_hi, t1[q])
            if total + max(run_hi - run_lo, 0.0) >= min_cover:
                if ends_img[a, end, 0] > ends_img[b, end, 0]:
                    a_, b_ = b, a
                else:
                    a_, b_ = a, b
                first[found] = a_
                second[found] = b_
                found += 1
    return FaceJoins(first[:found], second[:found])
