"""Plain faces between two vertical edges: closing the gap that is not one.

A flat, untextured face (the side of a box, the back of a bookshelf, a stretch of wall) shows only
its two vertical edges to segment stereo: their floor points look exactly like the two sides of a
gap, and a face wider than the robot becomes a "passable gap" that the robot drives into. What
tells them apart is the face's top or bottom edge: a near-horizontal image line (unmatchable along
the epipolar rows, so :mod:`modeling.stereo.segments` keeps it aside, unfitted, in
``ImageSegments.horizontal``) that runs from the lower (or upper) end of one vertical edge to the
lower (or upper) end of the other. Through a real gap the floor continues, and what lies behind
it meets the floor on other image rows.

:func:`close_faces` adds, for each such pair of unambiguous floor segments, the floor segment
between their floor points (the face's outline on the floor), so that the model of section 2 sees
an obstacle where there is one. Both edges must be near-vertical in the image, within
``max_range_m`` of the camera and at most ``max_length_m`` apart on the floor, and both must reach
down to the floor (their lowest kept point at most ``floor_reach_m`` high) (the options are
:class:`FaceOptions`). The near-horizontal
lines must cover at least ``min_cover`` of the image line between the two lower ends, each line
within ``tol_px`` of it. Top edges (``tops=True``: both tops below the kept band's top, at equal
heights within ``top_match_m``) are off by default: in furnished rooms the long top edges of
tables and shelves pass by the tops of other objects' edges, and about one top join in four was
false on the evaluation scenes, against about one bottom join in twenty (``scripts/evaluate.py``
suite, checked against the true footprints).

This is an addition to the paper's pipeline (which uses vertical and oblique segments only); it
can be turned off where the paper's pipeline alone is wanted (``close_faces=False`` in the env and
in :func:`modeling.stereo.pipeline.stereo_to_floor`).

The pair test is one compiled pass (:func:`modeling.stereo._kernels.face.face_joins`);
:func:`face_joins_reference` is the same test in plain NumPy, the one to read (and to change
first: a test holds the two equal).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from modeling.observation import FloorObservation, FloorSegment
from modeling.stereo._kernels.face import FaceEdges, FaceJoins, FaceTest, face_joins
from modeling.stereo.segments import ImageSegments
from modeling.types import IntArray
from modeling.validation import boolean, positive, with_overrides

__all__ = ["FACE_SOURCE", "FaceOptions", "close_faces", "face_joins_reference", "face_pairs"]


#: ``FloorSegment.source`` of a face's segment (it joins two measured segments, is not one).
FACE_SOURCE = -2


@dataclass(frozen=True, slots=True, kw_only=True)
class FaceOptions:
    """Options of :func:`face_pairs` and :func:`close_faces`.

    Attributes:
        tol_px: Largest distance of a horizontal line's ends from the image line joining the two
            ends, px (> 0).
        extend_px: The ends are first moved this far along their edges (down for the bottom,
            up for the top), px (>= 0): an edge's fit stops short of the corner (trimmed, blurred
            rows).
        min_cover: Smallest fraction of that image line the horizontal lines must cover, in
            (0, 1].
        max_slope: Largest ``|du/dv|`` of a vertical edge (in the left image), > 0.
        max_range_m: Both edges within this distance of the camera, metres (> 0).
        max_length_m: Largest distance between the two floor points, metres (> 0).
        floor_reach_m: A bottom edge joins edges whose lowest kept points are at most this high,
            metres (> 0).
        top_match_m: A top edge joins edges whose top heights differ by at most this, metres
            (> 0).
        max_height_m: Top of the height band the floor segments were kept in (a top at it was cut
            off, not seen), metres (> 0).
        tops: Also join the upper ends (see the module docstring: off by default).

    Raises:
        ValueError: an option out of range (naming it).
    """

    tol_px: float = 3.0
    extend_px: float = 3.0
    min_cover: float = 0.8
    max_slope: float = 0.2
    max_range_m: float = 5.0
    max_length_m: float = 4.0
    floor_reach_m: float = 0.1
    top_match_m: float = 0.1
    max_height_m: float = 1.0
    tops: bool = False

    def __post_init__(self) -> None:
        for name in (
            "tol_px",
            "max_slope",
            "max_range_m",
            "max_length_m",
            "floor_reach_m",
            "top_match_m",
            "max_height_m",
        ):
            object.__setattr__(self, name, positive(getattr(self, name), name))
        object.__setattr__(
            self, "extend_px", positive(self.extend_px, "extend_px", allow_zero=True)
        )
        if not (0.0 < self.min_cover <= 1.0):
            raise ValueError(f"min_cover must be in (0, 1], got {self.min_cover!r}")
        object.__setattr__(self, "min_cover", float(self.min_cover))
        boolean(self.tops, "tops")


def face_joins_reference(edges: FaceEdges, eligible: IntArray, test: FaceTest) -> FaceJoins:
    """The pairs of ``eligible`` edges whose ``test.end``s a near-horizontal line joins: the
    readable NumPy form of the compiled :func:`modeling.stereo._kernels.face.face_joins`, which
    gives the same pairs (an addition to the paper, see the module docstring).

    For each pair of eligible edges (tops: at equal heights within ``top_match_m``) at most
    ``max_length_m`` apart on the floor, the two image ends are moved ``step`` rows along their
    edges and joined by an image line (at least 1 px long). The lines whose two ends lie within
    ``tol_px`` of it are projected onto it (parameters clipped to [0, 1]); the pair is joined
    when the union of those intervals covers at least ``min_cover``.

    Args:
        edges: The candidate edges and the lines.
        eligible: (e,) the candidates that may be joined at this end, ascending.
        test: The end and the thresholds.

    Returns:
        The joined pairs, the left one in the image first, in the order of
        ``itertools.combinations(eligible, 2)``.
    """
    end = test.end
    floor_pts, ends_img, slope, top_h, hor = edges
    pairs = [
        (i, j)
        for i, j in itertools.combinations(eligible.tolist(), 2)
        if end == 1 or abs(top_h[i] - top_h[j]) <= test.top_match_m
    ]
    none = FaceJoins(np.zeros(0, np.int64), np.zeros(0, np.int64))
    if not pairs:
        return none
    a, b = np.array(pairs, dtype=np.int64).T
    d_floor = floor_pts[b, end] - floor_pts[a, end]
    short = np.hypot(d_floor[:, 0], d_floor[:, 1]) <= test.max_length_m
    # the image ends, moved along their edges past the last edge point
    P = ends_img[a, end]
    P[:, 0] += test.step * slope[a]
    P[:, 1] += test.step
    D = ends_img[b, end]
    D[:, 0] += test.step * slope[b]
    D[:, 1] += test.step
    D -= P
    L2 = D[:, 0] * D[:, 0] + D[:, 1] * D[:, 1]
    keep = np.flatnonzero(short & (L2 >= 1.0))
    a, b, P, D, L2 = a[keep], b[keep], P[keep], D[keep], L2[keep]
    # each line's two ends against each pair's image line: offset across it and parameter
    rx = hor[None, :, :, 0] - P[:, None, None, 0]  # (q, k, 2 ends)
    ry = hor[None, :, :, 1] - P[:, None, None, 1]
    dx, dy = D[:, None, None, 0], D[:, None, None, 1]
    inv = (1.0 / L2)[:, None, None]
    near = (np.abs(dx * ry - dy * rx) <= test.tol_px * np.sqrt(L2)[:, None, None]).all(axis=2)
    along = (dx * rx + dy * ry) * inv
    t0 = along.min(axis=2).clip(0.0, 1.0)
    t1 = along.max(axis=2).clip(0.0, 1.0)
    first: list[int] = []
    second: list[int] = []
    for q in range(a.shape[0]):
        lines = np.flatnonzero(near[q])
        if lines.size and _covered(t0[q, lines].tolist(), t1[q, lines].tolist()) >= test.min_cover:
            i, j = int(a[q]), int(b[q])
            if ends_img[i, end, 0] > ends_img[j, end, 0]:
                i, j = j, i
            first.append(i)
            second.append(j)
    if not first:
        return none
    return FaceJoins(np.array(first, np.int64), np.array(second, np.int64))


def _covered(starts: list[float], stops: list[float]) -> float:
    """Length of the union of the intervals ``[starts[k], stops[k]]``."""
    total, lo, hi = 0.0, 0.0, -1.0
    for s0, s1 in sorted(zip(starts, stops, strict=True)):
        if s0 > hi:  # a new run
            total += max(hi - lo, 0.0)
            lo, hi = s0, s1
        else:
            hi = max(hi, s1)
    return total + max(hi - lo, 0.0)


def face_pairs(
    left: ImageSegments,
    floor: FloorObservation,
    options: FaceOptions | None = None,
    **overrides: Any,
) -> list[tuple[int, int, int]]:
    """The pairs of floor segments joined by the top or bottom edge of a face.

    Args:
        left: The left image's segments (with their ``horizontal`` lines) that ``floor`` was
            triangulated from (``FloorSegment.source`` indexes them).
        floor: The floor observation; only its unambiguous segments are paired.
        options: The thresholds (defaults: ``FaceOptions()``).
        **overrides: Fields of :class:`FaceOptions` replacing those of ``options``.

    Returns:
        ``(i, j, end)`` triples: indices into ``floor.segments`` (image order, ``i`` left of
        ``j``) and the end they are joined at (1: bottom, 0: top).

    Raises:
        ValueError: ``left`` or ``floor`` of the wrong type, an unknown option or one out of
            range.
    """
    if not isinstance(left, ImageSegments):
        raise ValueError(f"left must be ImageSegments, got {type(left).__name__}")
    if not isinstance(floor, FloorObservation):
        raise ValueError(f"floor must be a FloorObservation, got {type(floor).__name__}")
    opts = with_overrides(options, FaceOptions, overrides)
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
    vertical = (np.abs(slope) <= opts.max_slope) & (rng <= opts.max_range_m)
    reach_floor = vertical & (heights_lo <= opts.floor_reach_m)
    top_seen = vertical & (top_h < opts.max_height_m - 0.02)
    edges = FaceEdges(floor_pts, left.endpoints[src], slope, top_h, hor)
    out: list[tuple[int, int, int]] = []
    for end in (1, 0) if opts.tops else (1,):
        # bottoms: both edges reach the floor; tops: both seen, at equal heights
        test = FaceTest(
            end=end,
            step=(1.0 if end == 1 else -1.0) * opts.extend_px,
            top_match_m=opts.top_match_m,
            max_length_m=opts.max_length_m,
            tol_px=opts.tol_px,
            min_cover=opts.min_cover,
        )
        joins = face_joins(edges, np.flatnonzero(reach_floor if end == 1 else top_seen), test)
        out.extend(
            (i, j, end)
            for i, j in zip(cand[joins.first].tolist(), cand[joins.second].tolist(), strict=True)
        )
    return out


def close_faces(
    left: ImageSegments,
    floor: FloorObservation,
    options: FaceOptions | None = None,
    **overrides: Any,
) -> FloorObservation:
    """``floor`` with a floor segment along each face found by :func:`face_pairs`.

    The new segment joins the two edges' floor points at the joined end (the lower kept points
    for a bottom edge, the upper ones for a top edge), with their covariances; its ``source`` is
    :data:`FACE_SOURCE` (not one image segment).

    Args:
        left: As :func:`face_pairs`.
        floor: As :func:`face_pairs`.
        options: As :func:`face_pairs`.
        **overrides: As :func:`face_pairs`.

    Returns:
        A new observation (``floor`` itself when no face is found).
    """
    pairs = face_pairs(left, floor, options, **overrides)
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
