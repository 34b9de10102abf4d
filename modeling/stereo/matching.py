"""Segment matching with local disparity histograms and ambiguous candidates (section 3.1, 3.3).

Candidates (left segment ``i``, right segment ``j``) must satisfy

* the epipolar constraint: their row ranges overlap by at least ``min_overlap_px`` rows and by at
  least ``min_overlap_frac`` of the shorter one's row range;
* the direction constraint: their angles to the image vertical differ by at most
  ``max_angle_diff_deg``; the contrast polarity is the same ("similar direction") or, when
  ``allow_opposite``, opposite ("almost opposite direction": an occluding edge may show a different
  background in the two images);
* photometric consistency, from the grey levels each segment carries on both sides of its edge,
  "far" (3 px) and "near" (1.5 px). A same-polarity pair must agree on both near sides (within
  ``max_near_grey_diff``) and on at least one far side (within ``max_grey_diff``): the pixels right
  next to an edge are the two surfaces that meet there, and they look the same from both cameras.
  This rejects in particular the *view-dependent* contours of thick objects: where the right camera
  sees a narrow side face that the left one does not (or the converse), the two images' edges are
  different 3D lines a side face apart, and their disparity is wrong by a pixel or more. An
  opposite-polarity pair must agree on one side, near and far (the occluding surface; the other
  side is a background that differs between the views);
* the disparity range: the disparity ``u_left - u_right`` at both ends of the overlapping part lies
  in ``[rig.min_disparity_px, rig.max_disparity_px]`` (within ``agree_px``).

``match_candidates`` returns exactly these pairs (what the histograms then decide among).

Local disparity histogram [Miura ICRA-94, ref. 9] (:mod:`modeling.stereo.disparity_histograms`).
Each candidate puts its mid disparity into the histogram of its left segment (1 px bins), weighted
by the length of the overlapping part (times ``opposite_weight`` for an opposite-polarity pair) and
spread as a Gaussian of standard deviation ``smooth_px`` (the smoothing of the histogram). The
histogram of the *region around* left segment ``i`` is the sum of those of all left segments, each
weighted by a Gaussian of the image distance between segment midpoints (``region_sigma_px``;
``self_weight`` for ``i`` itself). Its prominent peaks are the local maxima (within
``min_peak_sep_px``) of at least ``rel_peak`` times the highest one, located to a fraction of a
bin by a parabola.

Decision (:func:`modeling.stereo.disparity_histograms.decide_matches_reference`, the readable rule;
:func:`modeling.stereo._kernels.match.decide` runs it). For every prominent peak ``k`` of segment
``i``'s region, the candidate of ``i`` whose disparity is closest to the peak (within
``agree_px``) is kept. If one peak is matched, the match is certain (probability 1); if several
are, each kept candidate gets ``a_k / sum_j a_j`` (Eq. 1), where ``a_k`` is the height of its
peak. Left segments with no agreeing candidate are dropped.

Uniqueness (``unique_right``). One right segment is the image of one 3D edge, so two left segments
cannot both be right about it at different disparities. A *certain* claim (the left segment's only
kept candidate) on a right segment that another left segment also keeps, at a disparity more than
``agree_px`` away and with a higher peak (ties: the longer overlap), is dropped with its left
segment (typically an edge occluded in the right image that took a visible edge's partner).
Ambiguous candidates are never removed this way: for a repeated pattern, candidates of neighbouring
left segments share right segments by nature, and the ambiguity is what section 3.3 keeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.stereo._kernels.match import (
    Candidates,
    Constraints,
    Decision,
    PeakRule,
    SegmentColumns,
    candidate_grid,
    decide,
)
from modeling.stereo.disparity_histograms import Splat, histogram_inputs, region_histograms
from modeling.stereo.rig import StereoRig
from modeling.stereo.segments import ImageSegments
from modeling.types import FloatArray, IntArray
from modeling.validation import positive, with_overrides

__all__ = [
    "MatchCandidates",
    "MatchOptions",
    "StereoMatches",
    "candidates_reference",
    "match_candidates",
    "match_segments",
]


BIN_PX = 1.0  # disparity histogram bin, px (peaks are refined to sub-bin by a parabola)


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class StereoMatches:
    """Kept (left segment, right candidate) pairs, one row each (``m`` rows, possibly zero).

    Rows are sorted by left segment index, then by decreasing probability.

    Attributes:
        left_index: (m,) index into the left ``ImageSegments``.
        right_index: (m,) index into the right ``ImageSegments``.
        probability: (m,) probability of the pair (Eq. 1); the rows of one left segment sum to 1.
        left_endpoints: (m, 2, 2) ``[[u, v], [u, v]]`` px: the vertically overlapping part of the
            pair, in the left image, top to bottom.
        disparity_px: (m, 2) disparity ``u_left - u_right`` at those two endpoints, px.
        disparity_var: (m, 2) variance of the disparity at the endpoints, px^2
            (``var u_left + var u_right``; the images are independent).
        u_left_var: (m, 2) variance of ``u_left`` at the endpoints, px^2 (also the covariance of
            ``u_left`` with the disparity).
        v_var: (m, 2) variance of the endpoint rows, px^2 (where along the edge it ends).
        peak_disparity_px: (m,) position of the histogram peak the pair agrees with, px.
        peak_height: (m,) that peak's height ``a_k`` in the region's histogram (overlap lengths
            smoothed along disparity: px of segment per px of disparity).
        opposite_polarity: (m,) whether the pair was accepted as "almost opposite direction".
        n_candidates: Number of candidate pairs that passed the constraints (before the histogram).
    """

    left_index: IntArray
    right_index: IntArray
    probability: FloatArray
    left_endpoints: FloatArray
    disparity_px: FloatArray
    disparity_var: FloatArray
    u_left_var: FloatArray
    v_var: FloatArray
    peak_disparity_px: FloatArray
    peak_height: FloatArray
    opposite_polarity: NDArray[np.bool_]
    n_candidates: int = field(default=0)

    def __post_init__(self) -> None:
        li = np.asarray(self.left_index, dtype=np.int64)
        if li.ndim != 1:
            raise ValueError(f"left_index must have shape (m,), got {li.shape}")
        m = li.shape[0]
        shapes: dict[str, tuple[tuple[int, ...], type]] = {
            "left_index": ((m,), np.int64),
            "right_index": ((m,), np.int64),
            "probability": ((m,), np.float64),
            "left_endpoints": ((m, 2, 2), np.float64),
            "disparity_px": ((m, 2), np.float64),
            "disparity_var": ((m, 2), np.float64),
            "u_left_var": ((m, 2), np.float64),
            "v_var": ((m, 2), np.float64),
            "peak_disparity_px": ((m,), np.float64),
            "peak_height": ((m,), np.float64),
            "opposite_polarity": ((m,), np.bool_),
        }
        for name, (shape, dtype) in shapes.items():
            arr: np.ndarray = np.asarray(getattr(self, name), dtype=dtype)
            if arr.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
            object.__setattr__(self, name, _readonly(arr))

    def __len__(self) -> int:
        return int(self.left_index.shape[0])

    @classmethod
    def _trusted(cls, n_candidates: int, **arrays: np.ndarray) -> StereoMatches:
        """Built from arrays that ``match_segments`` has produced with the right shapes and dtypes:
        skips the conversions and checks of ``__post_init__``."""
        obj = object.__new__(cls)
        for name, arr in arrays.items():
            object.__setattr__(obj, name, _readonly(arr))
        object.__setattr__(obj, "n_candidates", n_candidates)
        return obj

    @classmethod
    def empty(cls, n_candidates: int = 0) -> StereoMatches:
        """No matches."""
        z1, z2 = np.zeros(0), np.zeros((0, 2))
        zi = np.zeros(0, dtype=np.int64)
        return cls(
            left_index=zi,
            right_index=zi,
            probability=z1,
            left_endpoints=np.zeros((0, 2, 2)),
            disparity_px=z2,
            disparity_var=z2,
            u_left_var=z2,
            v_var=z2,
            peak_disparity_px=z1,
            peak_height=z1,
            opposite_polarity=np.zeros(0, dtype=bool),
            n_candidates=n_candidates,
        )

    @property
    def ambiguous(self) -> NDArray[np.bool_]:
        """(m,) whether the row's left segment has several kept candidates."""
        if len(self) == 0:
            return np.zeros(0, dtype=bool)
        counts = np.bincount(self.left_index)
        return counts[self.left_index] > 1


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class MatchCandidates:
    """Every (left, right) pair that passes the matching constraints, before any histogram.

    One row per pair (``k`` rows, possibly zero), sorted by left index then right index. This is
    what the local disparity histograms decide among; it is exposed for evaluation ("was the true
    partner a candidate at all?") and diagnostics.

    Attributes:
        left_index: (k,) index into the left ``ImageSegments``.
        right_index: (k,) index into the right ``ImageSegments``.
        rows_px: (k, 2) first and last row of the vertically overlapping part, px.
        disparity_px: (k, 2) disparity ``u_left - u_right`` at those rows, px.
        opposite_polarity: (k,) whether the two edges have opposite contrast polarity.
        overlap_px: (k,) number of overlapping rows, px.
    """

    left_index: IntArray
    right_index: IntArray
    rows_px: FloatArray
    disparity_px: FloatArray
    opposite_polarity: NDArray[np.bool_]
    overlap_px: FloatArray

    def __post_init__(self) -> None:
        k = np.asarray(self.left_index).shape[0]
        for name, shape, dtype in (
            ("left_index", (k,), np.int64),
            ("right_index", (k,), np.int64),
            ("rows_px", (k, 2), np.float64),
            ("disparity_px", (k, 2), np.float64),
            ("opposite_polarity", (k,), np.bool_),
            ("overlap_px", (k,), np.float64),
        ):
            arr = np.asarray(getattr(self, name), dtype=dtype)
            if arr.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
            object.__setattr__(self, name, _readonly(arr))

    def __len__(self) -> int:
        return int(self.left_index.shape[0])


@dataclass(frozen=True, slots=True, kw_only=True)
class MatchOptions:
    """The options of :func:`match_segments` and :func:`match_candidates` (sections 3.1, 3.3).

    Attributes:
        min_overlap_frac: Smallest vertical overlap of a pair, as a fraction of the shorter row
            range of the two, in [0, 1].
        min_overlap_px: Smallest vertical overlap, rows.
        max_angle_diff_deg: Largest difference of the two segments' angles, degrees.
        allow_opposite: Accept pairs of opposite contrast polarity (occluding edges).
        opposite_weight: Factor on the histogram weight of an opposite-polarity pair (a contrast
            reversal is the rarer explanation); in [0, 1].
        region_sigma_px: ``(sigma_u, sigma_v)`` of the Gaussian that weights neighbouring left
            segments into a segment's local histogram, px.
        smooth_px: Standard deviation of the histogram smoothing along disparity, px.
        rel_peak: A peak is prominent if at least this fraction of the region's highest peak,
            in (0, 1].
        min_peak_sep_px: Smallest distance between two prominent peaks, px.
        agree_px: A candidate agrees with a peak within this disparity difference, px (it also
            widens the rig's disparity range for the candidates).
        sigma_v_px: Standard deviation of where an overlapping part ends along the edge, px.
        max_grey_diff: Largest difference of the "far" grey level (3 px from the edge) of a side
            of the two segments for that side to agree, grey levels (``inf``: no check).
        max_near_grey_diff: The same for the "near" grey levels (1.5 px from the edge), grey
            levels (``inf``: no check).
        self_weight: Weight of a segment's own candidates in its region histogram (neighbours
            get the Gaussian weight, 1 at zero distance); below 1 favours the neighbours' support.
        unique_right: Drop certain claims on a right segment that another left segment keeps at
            another disparity with a higher peak (see the module docstring).

    Raises:
        ValueError: naming the option that is out of range.
    """

    min_overlap_frac: float = 0.5
    min_overlap_px: float = 8.0
    max_angle_diff_deg: float = 8.0
    allow_opposite: bool = True
    opposite_weight: float = 0.5
    region_sigma_px: tuple[float, float] = (16.0, 32.0)
    smooth_px: float = 2.5
    rel_peak: float = 0.5
    min_peak_sep_px: float = 2.5
    agree_px: float = 2.5
    sigma_v_px: float = 1.0
    max_grey_diff: float = 15.0
    max_near_grey_diff: float = 10.0
    self_weight: float = 1.0
    unique_right: bool = True

    def __post_init__(self) -> None:
        if not (0.0 <= self.min_overlap_frac <= 1.0):
            raise ValueError(f"min_overlap_frac must be in [0, 1], got {self.min_overlap_frac!r}")
        positive(self.min_overlap_px, "min_overlap_px", allow_zero=True)
        positive(self.max_angle_diff_deg, "max_angle_diff_deg")
        positive(self.agree_px, "agree_px")
        for name in ("max_grey_diff", "max_near_grey_diff"):
            value = getattr(self, name)
            if not (value >= 0):  # inf allowed: disables the check
                raise ValueError(f"{name} must be non-negative, got {value!r}")
        if not (0.0 <= self.opposite_weight <= 1.0):
            raise ValueError(f"opposite_weight must be in [0, 1], got {self.opposite_weight!r}")
        if not (0.0 < self.rel_peak <= 1.0):
            raise ValueError(f"rel_peak must be in (0, 1], got {self.rel_peak!r}")
        positive(self.self_weight, "self_weight", allow_zero=True)
        positive(self.smooth_px, "smooth_px")
        positive(self.min_peak_sep_px, "min_peak_sep_px")
        positive(self.sigma_v_px, "sigma_v_px")
        su, sv = (float(x) for x in self.region_sigma_px)
        if not (math.isfinite(su) and math.isfinite(sv) and su > 0 and sv > 0):
            raise ValueError(
                f"region_sigma_px must be two positive numbers, got {self.region_sigma_px!r}"
            )
        object.__setattr__(self, "region_sigma_px", (su, sv))

    def splat(self) -> Splat:
        """How a candidate is spread into its segment's histogram (1 px bins)."""
        sig_bins = self.smooth_px / BIN_PX
        return Splat(
            opposite_weight=float(self.opposite_weight),
            sigma_bins=float(sig_bins),
            radius=max(1, math.ceil(3.0 * sig_bins)),
            bin_px=BIN_PX,
            norm=math.sqrt(2.0 * math.pi) * sig_bins,
        )

    def peak_rule(self, n_bins: int, n_left: int) -> PeakRule:
        """The decision's parameters for histograms of ``n_bins`` bins and ``n_left`` segments."""
        return PeakRule(
            bin_px=BIN_PX,
            half=math.ceil(self.min_peak_sep_px / BIN_PX),
            rel_peak=float(self.rel_peak),
            span=n_bins * BIN_PX + 4.0 * self.agree_px,
            agree_px=float(self.agree_px),
            unique_right=bool(self.unique_right),
            n_left=n_left,
        )


def _check_inputs(
    left: object, right: object, rig: object
) -> tuple[ImageSegments, ImageSegments, StereoRig]:
    """``(left, right, rig)`` checked to be two ``ImageSegments`` and a ``StereoRig``.

    Raises:
        ValueError: naming ``left``, ``right`` or ``rig``.
    """
    if not isinstance(left, ImageSegments):
        raise ValueError(f"left must be an ImageSegments, got {type(left).__name__}")
    if not isinstance(right, ImageSegments):
        raise ValueError(f"right must be an ImageSegments, got {type(right).__name__}")
    if not isinstance(rig, StereoRig):
        raise ValueError(f"rig must be a StereoRig, got {type(rig).__name__}")
    return left, right, rig


def _near(segments: ImageSegments) -> tuple[FloatArray, FloatArray]:
    """The "near" grey levels left and right of the segments (``ImageSegments`` fills them)."""
    left, right = segments.grey_left_near, segments.grey_right_near
    assert left is not None and right is not None  # set by ImageSegments.__post_init__
    return left, right


def _columns(segments: ImageSegments) -> SegmentColumns:
    """The arrays of ``segments`` that the candidate grid reads."""
    near_left, near_right = _near(segments)
    return SegmentColumns(
        endpoints=segments.endpoints,
        angle=segments.angle_rad,
        polarity=segments.polarity,
        grey_far_left=segments.grey_left,
        grey_far_right=segments.grey_right,
        grey_near_left=near_left,
        grey_near_right=near_right,
        u_center=segments.u_center,
        slope=segments.slope,
        v_center=segments.v_center,
    )


def _candidates(
    left: ImageSegments, right: ImageSegments, rig: StereoRig, options: MatchOptions
) -> Candidates:
    """The (left, right) pairs that pass the matching constraints, by the compiled loop
    :func:`modeling.stereo._kernels.match.candidate_grid` (equal to
    :func:`candidates_reference`)."""
    o = options
    constraints = Constraints(
        min_overlap_px=o.min_overlap_px,
        min_overlap_frac=o.min_overlap_frac,
        max_angle_rad=math.radians(o.max_angle_diff_deg),
        allow_opposite=o.allow_opposite,
        max_grey_diff=o.max_grey_diff,
        max_near_grey_diff=o.max_near_grey_diff,
        min_disparity_px=max(rig.min_disparity_px - o.agree_px, 1e-3),
        max_disparity_px=rig.max_disparity_px + o.agree_px,
    )
    return candidate_grid(_columns(left), _columns(right), constraints)


def candidates_reference(
    left: ImageSegments, right: ImageSegments, rig: StereoRig, options: MatchOptions
) -> Candidates:
    """The (left, right) pairs that pass the matching constraints (section 3.1; the module
    docstring), sorted by left, then right index (``k`` rows, possibly zero): the readable
    reference of the compiled candidate grid, which the matching runs.

    Every constraint is evaluated on the whole (nL, nR) grid of pairs, and the pairs are gathered
    at the end.
    """
    o = options
    v0L, v1L = left.endpoints[:, 0, 1], left.endpoints[:, 1, 1]
    v0R, v1R = right.endpoints[:, 0, 1], right.endpoints[:, 1, 1]
    n_right = v0R.shape[0]
    rows = np.empty((v0L.shape[0], n_right, 2))  # first and last row of the overlap, px
    lo = np.maximum(v0L[:, None], v0R, out=rows[..., 0])
    hi = np.minimum(v1L[:, None], v1R, out=rows[..., 1])
    # epipolar: the row ranges overlap enough
    ov = hi - lo
    ok = ov >= np.maximum(
        o.min_overlap_px, o.min_overlap_frac * np.minimum((v1L - v0L)[:, None], v1R - v0R)
    )
    # direction: similar angles, the same polarity or (allow_opposite) the opposite one
    ok &= np.abs(left.angle_rad[:, None] - right.angle_rad) <= math.radians(o.max_angle_diff_deg)
    opposite = left.polarity[:, None] != right.polarity
    if not o.allow_opposite:
        ok &= ~opposite
    # photometric agreement of the four side samples: far left, far right, near left, near right
    far_l = np.abs(left.grey_left[:, None] - right.grey_left) <= o.max_grey_diff
    far_r = np.abs(left.grey_right[:, None] - right.grey_right) <= o.max_grey_diff
    (near_left_l, near_right_l), (near_left_r, near_right_r) = _near(left), _near(right)
    near_l = np.abs(near_left_l[:, None] - near_left_r) <= o.max_near_grey_diff
    near_r = np.abs(near_right_l[:, None] - near_right_r) <= o.max_near_grey_diff
    ok &= np.where(opposite, (far_l & near_l) | (far_r & near_r), (far_l | far_r) & near_l & near_r)
    # disparity along the pair: d(v) = u_left(v) - u_right(v) = (a_l - a_r) + (s_l - s_r) v, with
    # u(v) = a + s v the fitted lines; in the rig's range (widened by agree_px) at both ends
    a_l = left.u_center - left.slope * left.v_center
    a_r = right.u_center - right.slope * right.v_center
    d_a = a_l[:, None] - a_r
    d_s = left.slope[:, None] - right.slope
    disp = d_a[..., None] + d_s[..., None] * rows
    d_lo, d_hi = disp[..., 0], disp[..., 1]
    dmin = max(rig.min_disparity_px - o.agree_px, 1e-3)
    dmax = rig.max_disparity_px + o.agree_px
    ok &= (np.minimum(d_lo, d_hi) >= dmin) & (np.maximum(d_lo, d_hi) <= dmax)
    flat = np.flatnonzero(ok)  # row-major: sorted by left, then right index
    li, rj = np.divmod(flat, n_right)
    return Candidates(
        li=li,
        rj=rj,
        rows=rows.reshape(-1, 2)[flat],
        overlap=ov.ravel()[flat],
        disparity=disp.reshape(-1, 2)[flat],
        opposite=opposite.ravel()[flat],
    )


def match_candidates(
    left: ImageSegments,
    right: ImageSegments,
    rig: StereoRig,
    options: MatchOptions | None = None,
    **overrides: Any,
) -> MatchCandidates:
    """The candidate pairs ``match_segments`` decides among (constraints only, no histogram).

    Args:
        left: Segments of the left (reference) image.
        right: Segments of the right image.
        rig: The stereo rig (disparity range).
        options: The options (defaults: ``MatchOptions()``); only the constraints and
            ``agree_px`` (it widens the disparity range) matter here.
        **overrides: Fields of ``MatchOptions`` to replace.

    Returns:
        Every pair passing the epipolar, direction, photometric and disparity-range constraints.

    Raises:
        ValueError: ``left``/``right`` are not ``ImageSegments``, ``rig`` is not a ``StereoRig``,
            or an option is unknown or out of range.
    """
    left, right, rig = _check_inputs(left, right, rig)
    opts = with_overrides(options, MatchOptions, overrides)
    cand = _candidates(left, right, rig, opts)
    return MatchCandidates(
        left_index=cand.li,
        right_index=cand.rj,
        rows_px=cand.rows,
        disparity_px=cand.disparity,
        opposite_polarity=cand.opposite,
        overlap_px=cand.overlap,
    )


def match_segments(
    left: ImageSegments,
    right: ImageSegments,
    rig: StereoRig,
    options: MatchOptions | None = None,
    **overrides: Any,
) -> StereoMatches:
    """Match left and right segments of a rectified pair (section 3.1, Eq. 1 of section 3.3).

    The paper's steps: the candidates (epipolar overlap, direction, photometry, disparity range),
    the local disparity histograms of the regions and the decision by their prominent peaks with
    Eq. 1 (:mod:`modeling.stereo.disparity_histograms`; the decision runs as a compiled loop equal
    to ``decide_matches_reference``), then the kept pairs' endpoints and variances.

    Args:
        left: Segments of the left (reference) image.
        right: Segments of the right image.
        rig: The stereo rig (disparity range).
        options: The options (defaults: ``MatchOptions()``).
        **overrides: Fields of ``MatchOptions`` to replace, e.g. ``rel_peak=0.6``.

    Returns:
        The kept pairs with their probabilities; empty if nothing matches.

    Raises:
        ValueError: ``left``/``right`` are not ``ImageSegments``, ``rig`` is not a ``StereoRig``,
            or an option is unknown or out of range.
    """
    left, right, rig = _check_inputs(left, right, rig)
    opts = with_overrides(options, MatchOptions, overrides)
    cand = _candidates(left, right, rig, opts)
    n_cand = int(cand.li.size)
    if n_cand == 0:
        return StereoMatches.empty()
    inputs = histogram_inputs(cand, left.slope, opts.splat())
    ends = left.endpoints[inputs.rows]
    mid = 0.5 * (ends[:, 0] + ends[:, 1])
    hist = region_histograms(inputs, mid, opts.region_sigma_px, opts.self_weight)
    kept = decide(hist, cand, inputs, opts.peak_rule(inputs.n_bins, len(left)))
    if kept.sel.size == 0:
        return StereoMatches.empty(n_cand)
    return _stereo_matches(kept, cand, left, right, opts.sigma_v_px, n_cand)


def _stereo_matches(
    kept: Decision,
    cand: Candidates,
    left: ImageSegments,
    right: ImageSegments,
    sigma_v_px: float,
    n_candidates: int,
) -> StereoMatches:
    """The kept candidates as ``StereoMatches``: the overlap's ends on the left fitted line, the
    disparities there and their variances (the images are independent: ``var d = var u_left +
    var u_right``, section 3.2)."""
    sel = kept.sel
    lsel, rsel = cand.li[sel], cand.rj[sel]
    v_ends = cand.rows[sel]
    uvar_l = left.u_var_at(lsel[:, None], v_ends)
    left_endpoints = np.empty((sel.size, 2, 2))
    left_endpoints[..., 0] = left.u_at(lsel[:, None], v_ends)
    left_endpoints[..., 1] = v_ends
    disp = cand.disparity[sel]
    return StereoMatches._trusted(
        n_candidates,
        left_index=lsel,
        right_index=rsel,
        probability=kept.probability,
        left_endpoints=left_endpoints,
        disparity_px=disp,
        disparity_var=uvar_l + right.u_var_at(rsel[:, None], v_ends),
        u_left_var=uvar_l,
        v_var=np.full(disp.shape, sigma_v_px**2),
        peak_disparity_px=kept.peak_disparity,
        peak_height=kept.peak_height,
        opposite_polarity=cand.opposite[sel],
    )
