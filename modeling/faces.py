"""Plain faces between two vertical edges: closing the gap that is not one.

A flat, untextured face (the side of a box, the back of a bookshelf, a stretch of wall) shows only
its two vertical edges to segment stereo: their floor points look exactly like the two sides of a
gap, and a face wider than the robot becomes a "passable gap" that the robot drives into. What
tells them apart is the face's top or bottom edge: a near-horizontal image line (unmatchable along
the epipolar rows, so :mod:`modeling.segments` keeps it aside, unfitted, in
``ImageSegments.horizontal``) that runs from the lower (or upper) end of one vertical edge to the
lower (or upper) end of the other. Through a real gap the floor continues, and what lies behind
it meets the floor on other image rows.

:func:`close_faces` adds, for each such pair of unambiguous floor segments, the floor segment
between their floor points (the face's outline on the floor), so that the model of section 2 sees
an obstacle where there is one. Both edges must be near-vertical in the image, within
``max_range_m`` of the camera and at most ``max_length_m`` apart on the floor, and both must reach
down to the floor (their lowest kept point at most ``floor_reach_m`` high). The near-horizontal
lines must cover at least ``min_cover`` of the image line between the two lower ends, each line
within ``tol_px`` of it. Top edges (``tops=True``: both tops below the kept band's top, at equal
heights within ``top_match_m``) are off by default: in furnished rooms the long top edges of
tables and shelves pass by the tops of other objects' edges, and about one top join in four was
false on the evaluation scenes, against about one bottom join in twenty (``scripts/evaluate.py``
suite, checked against the true footprints).

This is an addition to the paper's pipeline (which uses vertical and oblique segments only); it
can be turned off where the paper's pipeline alone is wanted (``close_faces=False`` in the env).
"""

from __future__ import annotations

import numpy as np
import shapely

from modeling._validation import positive
from modeling.observation import FloorObservation, FloorSegment
from modeling.segments import ImageSegments

__all__ = ["FACE_SOURCE", "close_faces", "face_pairs"]

#: ``FloorSegment.source`` of a face's segment (it joins two measured segments, is not one).
FACE_SOURCE = -2


def face_pairs(
    left: ImageSegments,
    floor: FloorObservation,
    *,
    tol_px: float = 3.0,
    extend_px: float = 3.0,
    min_cover: float = 0.8,
    max_slope: float = 0.2,
    max_range_m: float = 5.0,
    max_length_m: float = 4.0,
    floor_reach_m: float = 0.1,
    top_match_m: float = 0.1,
    max_height_m: float = 1.0,
    tops: bool = False,
) -> list[tuple[int, int, int]]:
    """The pairs of floor segments joined by the top or bottom edge of a face.

    Args:
        left: The left image's segments (with their ``horizontal`` lines) that ``floor`` was
            triangulated from (``FloorSegment.source`` indexes them).
        floor: The floor observation; only its unambiguous segments are paired.
        tol_px: Largest distance of a horizontal line's ends from the image line joining the two
            ends, px.
        extend_px: The ends are first moved this far along their edges (down for the bottom,
            up for the top), px: an edge's fit stops short of the corner (trimmed, blurred rows).
        min_cover: Smallest fraction of that image line the horizontal lines must cover.
        max_slope: Largest ``|du/dv|`` of a vertical edge (in the left image).
        max_range_m: Both edges within this distance of the camera, metres.
        max_length_m: Largest distance between the two floor points, metres.
        floor_reach_m: A bottom edge joins edges whose lowest kept points are at most this high.
        top_match_m: A top edge joins edges whose top heights differ by at most this, metres.
        max_height_m: Top of the height band the floor segments were kept in (a top at it was cut
            off, not seen), metres.
        tops: Also join the upper ends (see the module docstring: off by default).

    Returns:
        ``(i, j, end)`` triples: indices into ``floor.segments`` (image order, ``i`` left of
        ``j``) and the end they are joined at (1: bottom, 0: top).

    Raises:
        ValueError: ``left`` or ``floor`` of the wrong type, or an option out of range.
    """
    if not isinstance(left, ImageSegments):
        raise ValueError(f"left must be ImageSegments, got {type(left).__name__}")
    if not isinstance(floor, FloorObservation):
        raise ValueError(f"floor must be a FloorObservation, got {type(floor).__name__}")
    for name, value in (
        ("tol_px", tol_px),
        ("max_slope", max_slope),
        ("max_range_m", max_range_m),
        ("max_length_m", max_length_m),
        ("floor_reach_m", floor_reach_m),
        ("top_match_m", top_match_m),
        ("max_height_m", max_height_m),
    ):
        positive(value, name)
    positive(extend_px, "extend_px", allow_zero=True)
    if not (0.0 < min_cover <= 1.0):
        raise ValueError(f"min_cover must be in (0, 1], got {min_cover!r}")
    hor = left.horizontal
    segs = floor.segments
    if hor.shape[0] == 0 or len(segs) < 2:
        return []
    src = np.array([s.source for s in segs], dtype=np.int64)
    ok = (src >= 0) & (src < len(left))
    cand = np.flatnonzero(ok)
    if cand.shape[0] < 2:
        return []
    src = src[cand]
    ends_img = left.endpoints[src]  # (c, 2, 2): top, bottom end in the image
    slope = left.slope[src]
    floor_pts = np.array([segs[k].endpoints for k in cand])  # (c, 2, 2)
    heights = np.array([segs[k].height_m for k in cand])  # (c, 2)
    vp = floor.viewpoint[:2]
    rng = np.hypot(*(floor_pts.mean(axis=1) - vp).T)
    vertical = (np.abs(slope) <= max_slope) & (rng <= max_range_m)
    reach_floor = heights.min(axis=1) <= floor_reach_m
    top_h = heights.max(axis=1)
    top_seen = top_h < max_height_m - 0.02
    ia, ib = np.triu_indices(cand.shape[0], 1)
    keep = vertical[ia] & vertical[ib]
    ia, ib = ia[keep], ib[keep]
    out: list[tuple[int, int, int]] = []
    ends = (1, 0) if tops else (1,)
    for end in ends:
        if end == 1:
            ok_pair = reach_floor[ia] & reach_floor[ib]
        else:
            ok_pair = top_seen[ia] & top_seen[ib] & (np.abs(top_h[ia] - top_h[ib]) <= top_match_m)
        a, b = ia[ok_pair], ib[ok_pair]
        if a.shape[0] == 0:
            continue
        pa_floor = floor_pts[a, end]
        pb_floor = floor_pts[b, end]
        short = np.hypot(*(pb_floor - pa_floor).T) <= max_length_m
        a, b = a[short], b[short]
        if a.shape[0] == 0:
            continue
        # the image ends, moved along their edges by ``extend_px`` past the last edge point
        # (the fit stops short of a corner: the rows next to it are trimmed or blurred)
        step = (1.0 if end == 1 else -1.0) * extend_px
        P = ends_img[a, end] + step * np.stack([slope[a], np.ones(a.shape[0])], axis=1)
        Q = ends_img[b, end] + step * np.stack([slope[b], np.ones(b.shape[0])], axis=1)
        D = Q - P
        L2 = np.einsum("qi,qi->q", D, D)
        wide = L2 >= 1.0
        a, b, P, D, L2 = a[wide], b[wide], P[wide], D[wide], L2[wide]
        if a.shape[0] == 0:
            continue
        L = np.sqrt(L2)
        # each line's two ends against each pair's image line: offset across it and parameter
        rel = hor[None, :, :, :] - P[:, None, None, :]  # (q, k, 2 ends, 2)
        across = np.abs(D[:, None, None, 0] * rel[..., 1] - D[:, None, None, 1] * rel[..., 0])
        along = (D[:, None, None, 0] * rel[..., 0] + D[:, None, None, 1] * rel[..., 1]) / L2[
            :, None, None
        ]
        near = (across / L[:, None, None] <= tol_px).all(axis=2)  # (q, k)
        t0 = np.clip(along.min(axis=2), 0.0, 1.0)
        t1 = np.clip(along.max(axis=2), 0.0, 1.0)
        for q in range(a.shape[0]):
            lines = np.flatnonzero(near[q] & (t1[q] > t0[q]))
            if lines.size == 0:
                continue
            if _union_length(t0[q, lines], t1[q, lines]) >= min_cover:
                i, j = int(cand[a[q]]), int(cand[b[q]])
                if ends_img[a[q], end, 0] > ends_img[b[q], end, 0]:
                    i, j = j, i
                out.append((i, j, end))
    return out


def close_faces(
    left: ImageSegments,
    floor: FloorObservation,
    **options: float,
) -> FloorObservation:
    """``floor`` with a floor segment along each face found by :func:`face_pairs`.

    The new segment joins the two edges' floor points at the joined end (the lower kept points
    for a bottom edge, the upper ones for a top edge), with their covariances; its ``source`` is
    :data:`FACE_SOURCE` (not one image segment).

    Args:
        left: As :func:`face_pairs`.
        floor: As :func:`face_pairs`.
        **options: The keyword options of :func:`face_pairs`.

    Returns:
        A new observation (``floor`` itself when no face is found).
    """
    pairs = face_pairs(left, floor, **options)
    if not pairs:
        return floor
    segs = floor.segments
    done: set[tuple[int, int]] = set()
    added: list[FloorSegment] = []
    for i, j, end in pairs:
        if (i, j) in done:  # top and bottom both found: one segment
            continue
        done.add((i, j))
        a, b = segs[i], segs[j]
        added.append(
            FloorSegment(
                endpoints=np.array([a.endpoints[end], b.endpoints[end]]),
                cov=np.array([a.cov[end], b.cov[end]]),
                height_m=np.array([a.height_m[end], b.height_m[end]]),
                source=FACE_SOURCE,
            )
        )
    return FloorObservation(
        segments=(*segs, *added),
        ambiguous=floor.ambiguous,
        viewpoint=floor.viewpoint,
        fov_rad=floor.fov_rad,
        max_range_m=floor.max_range_m,
    )


def _union_length(t0: np.ndarray, t1: np.ndarray) -> float:
    """Total length of the union of the intervals ``[t0, t1]`` (on a line, by shapely)."""
    pieces = shapely.linestrings(
        np.stack([t0, np.zeros_like(t0), t1, np.zeros_like(t1)], 1).reshape(-1, 2, 2)
    )
    return float(shapely.union_all(pieces).length)
