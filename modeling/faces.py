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
can be turned off where the paper's pipeline alone is wanted (``close_faces=False`` in the env and
in :func:`modeling.pipeline.stereo_to_floor`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modeling._compiled.face import face_joins
from modeling.validation import positive
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
    # per segment: image index, lowest and highest kept heights, floor points (one pass)
    n_left = len(left)
    src_l, h_lo, h_hi, pts = [], [], [], []
    for k, seg in enumerate(segs):
        if 0 <= seg.source < n_left:
            h0, h1 = seg.height_m.tolist()
            src_l.append((k, seg.source))
            h_lo.append(min(h0, h1))
            h_hi.append(max(h0, h1))
            pts.append(seg.endpoints)
    if len(src_l) < 2:
        return []
    cand, src = np.array(src_l, dtype=np.int64).T
    heights_lo, top_h = np.array(h_lo), np.array(h_hi)
    floor_pts = np.array(pts)  # (c, 2, 2)
    slope = left.slope[src]
    mid = 0.5 * (floor_pts[:, 0] + floor_pts[:, 1]) - floor.viewpoint[:2]
    rng = np.hypot(mid[:, 0], mid[:, 1])
    vertical = (np.abs(slope) <= max_slope) & (rng <= max_range_m)
    reach_floor = vertical & (heights_lo <= floor_reach_m)
    top_seen = vertical & (top_h < max_height_m - 0.02)
    ends_img = left.endpoints[src]  # (c, 2, 2): top, bottom end in the image
    out: list[tuple[int, int, int]] = []
    for end in (1, 0) if tops else (1,):
        # every pair of eligible edges (bottoms: both reach the floor; tops: both seen, at equal
        # heights), short enough on the floor, whose image ends a horizontal line joins (one
        # compiled pass: ``_face_kernel.face_joins``)
        first, second = face_joins(
            np.flatnonzero(reach_floor if end == 1 else top_seen),
            end,
            top_h,
            float(top_match_m),
            floor_pts,
            ends_img,
            slope,
            hor,
            (1.0 if end == 1 else -1.0) * extend_px,
            float(max_length_m),
            float(tol_px),
            float(min_cover),
        )
        out.extend(
            (i, j, end) for i, j in zip(cand[first].tolist(), cand[second].tolist(), strict=True)
        )
    return out


def close_faces(
    left: ImageSegments,
    floor: FloorObservation,
    **options: Any,
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
