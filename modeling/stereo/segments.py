"""Straight line segments of one rectified grey image, with uncertainty (sections 3.1-3.2).

Detection uses OpenCV's Line Segment Detector (LSD) on a half-resolution pyramid level (fast, and
robust to pixel noise; LSD returns (N, 4) in OpenCV 5, (N, 1, 4) in OpenCV 4, or None: the lines
are always reshaped to (N, 4)). Every detected segment is then *re-localised at full resolution*:
in each image row it crosses, the sub-pixel column of its edge is found as the parabolic peak of
the horizontal intensity gradient (central difference, of the segment's own contrast sign) near
the LSD line, and the horizontal position ``u = u_c + slope * (v - v_c)`` is fitted to those edge
points by least squares, as in section 3.2 of Miura (ICRA-94). The row-by-row search is a
compiled loop (``modeling.stereo._kernels.edge``, Numba; a block of ``2 B + 1`` pixels around the
LSD line serves the gradient, the peak search and the grey levels on both sides) whose readable
NumPy formulation is :func:`modeling.stereo.edge_points.edge_sums_reference`; the fit of each
segment's line from its sums is compiled too (``segment_fits``), its reference
:func:`least_squares_lines_reference`.

Uncertainty model (section 3.2, "quantization error"). Each edge point's column is taken as
``u_i ~ N(a + b v_i, s^2)`` independently, where ``s^2`` is the residual variance of the fit, but at
least ``sigma_px^2``: the nominal per-point sigma of the rig, ``StereoRig.sigma_px``, its one
source (the rig is passed to :func:`extract_segments` / :func:`extract_segment_pair`; with few
points, or a perfectly clean edge, the residual says too little). On a clean edge the floor is
what holds, so the endpoint standard deviations grow in proportion to ``sigma_px``. Least squares
then gives the variance of the fitted column at any row ``v``::

    var_u(v) = s^2 * (1 / n + (v - v_c)^2 / S_vv) + bias_sigma_px^2

The last term is the part of the localisation error that does *not* average out along the segment
because it is the same in every row: the quantisation of the edge's sub-pixel position by the
imaging (a rendered edge is anti-aliased with a few samples per pixel, so its position moves in
steps: 4x multisampling gives steps of 1/4 px, a uniform error of standard deviation
``0.25 / sqrt(12) = 0.072`` px), and for a real camera the residual rectification error (typically
0.1 px). The default ``bias_sigma_px = 0.1`` covers both; it was checked against ground truth on the
project's rendered scenes (``scripts/bench_stereo.py``: vertical obstacle edges, robust standard
deviation of the column error 0.10 px, of the disparity error 0.12 px). Use ``1 / sqrt(12)``
(0.29 px) for an imager *without* anti-aliasing, whose edges snap to whole pixels.

Near-horizontal segments are **not fitted**: the epipolar lines of a rectified pair are image rows,
so a segment's disparity is undefined (or badly conditioned) when it runs along a row. Segments
whose angle to the image rows is below ``min_angle_deg`` are kept aside, as detected, in
``ImageSegments.horizontal``: unmatched, they still say where the top or bottom edge of a surface
joins two vertical edges (``modeling.stereo.faces``).

For the matcher's photometric checks, each segment also carries the mean grey level on both sides
of its edge points at two distances: ``side_px`` (3 px, "far") and ``near_px`` (1.5 px, "near",
linearly interpolated along the row).

Image frame: pixels, u right, v down, (0, 0) the centre of the top-left pixel.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.stereo._kernels.edge import (
    EdgeSearch,
    EdgeSums,
    FitLimits,
    LinesToFit,
    SegmentFits,
    edge_sums,
    segment_fits,
)
from modeling.stereo.rig import StereoRig
from modeling.types import FloatArray, IntArray
from modeling.validation import instance, positive, with_overrides
from modeling.worker import worker

__all__ = [
    "ImageSegments",
    "SegmentOptions",
    "extract_segment_pair",
    "extract_segments",
    "least_squares_lines_reference",
]

_DEFAULT_SIGMA_PX = StereoRig().sigma_px  # of the default rig


# one detector per thread and scale: an OpenCV LSD object keeps working buffers between calls
_LSD_LOCAL = threading.local()

_MAX_SEARCH_PX = 4
_MAX_SIDE_PX = 4


def _lsd(scale: float) -> cv2.LineSegmentDetector:
    cache: dict[float, cv2.LineSegmentDetector] = _LSD_LOCAL.__dict__.setdefault("by_scale", {})
    det = cache.get(scale)
    if det is None:
        det = cv2.createLineSegmentDetector(cv2.LSD_REFINE_NONE, scale)
        cache[scale] = det
    return det


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


_FIELDS: tuple[tuple[str, type], ...] = (
    ("u_center", np.float64),
    ("v_center", np.float64),
    ("slope", np.float64),
    ("point_var", np.float64),
    ("n_points", np.int64),
    ("s_vv", np.float64),
    ("bias_var", np.float64),
    ("polarity", np.int8),
    ("contrast", np.float64),
    ("grey_left", np.float64),
    ("grey_right", np.float64),
    ("grey_left_near", np.float64),
    ("grey_right_near", np.float64),
)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ImageSegments:
    """Line segments of one image and the least-squares fit of their horizontal position.

    All arrays have one row per segment (``n`` segments, possibly zero). Pixels, image frame. The
    arrays are read-only.

    Attributes:
        endpoints: (n, 2, 2) ``[[u0, v0], [u1, v1]]`` px, ordered top to bottom (``v0 <= v1``);
            the fitted line evaluated at the first and last row with edge points.
        u_center: (n,) fitted column at ``v_center``, px.
        v_center: (n,) mean row of the edge points, px.
        slope: (n,) ``du/dv`` of the fitted line (0 for a vertical segment).
        point_var: (n,) per-edge-point variance of the column, px^2 (residual, at least
            ``sigma_px^2``).
        n_points: (n,) number of edge points in the fit.
        s_vv: (n,) ``sum (v_i - v_center)^2`` of the edge points, px^2.
        bias_var: (n,) correlated (non-averaging) variance of the column, px^2.
        polarity: (n,) ``+1`` where the image is brighter on the right of the segment (intensity
            increases with u), ``-1`` where it is darker on the right.
        contrast: (n,) mean absolute horizontal gradient at the edge points, grey levels per px.
        grey_left: (n,) mean intensity ``side_px`` columns left of the edge points, grey levels.
        grey_right: (n,) mean intensity ``side_px`` columns right of the edge points.
        grey_left_near: (n,) mean intensity ``near_px`` left of the edge points (interpolated);
            ``grey_left`` if not given.
        grey_right_near: (n,) mean intensity ``near_px`` right of the edge points; ``grey_right``
            if not given.
        image_shape: ``(height_px, width_px)`` of the image.
        horizontal: (k, 2, 2) ``[[u0, v0], [u1, v1]]`` px of the image's near-horizontal lines
            (LSD's, at least ``min_length_px`` long, at less than ``min_angle_deg`` to the rows),
            not fitted and not matched (their disparity is undefined), left end first; they
            tell where the top or bottom edge of a surface joins two vertical edges
            (:func:`modeling.stereo.faces.close_faces`). Empty if not given.
    """

    endpoints: FloatArray
    u_center: FloatArray
    v_center: FloatArray
    slope: FloatArray
    point_var: FloatArray
    n_points: IntArray
    s_vv: FloatArray
    bias_var: FloatArray
    polarity: NDArray[np.int8]
    contrast: FloatArray
    grey_left: FloatArray
    grey_right: FloatArray
    grey_left_near: FloatArray | None = None
    grey_right_near: FloatArray | None = None
    image_shape: tuple[int, int] = field(default=(0, 0))
    horizontal: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))

    def __post_init__(self) -> None:
        # C-contiguous (a copy only of a strided view): the compiled loops that read these
        # arrays then see one layout, and Numba compiles them once
        ends = np.ascontiguousarray(self.endpoints, dtype=np.float64)
        if ends.ndim != 3 or ends.shape[1:] != (2, 2):
            raise ValueError(f"endpoints must have shape (n, 2, 2), got {ends.shape}")
        n = ends.shape[0]
        object.__setattr__(self, "endpoints", _readonly(ends))
        if self.grey_left_near is None:
            object.__setattr__(self, "grey_left_near", self.grey_left)
        if self.grey_right_near is None:
            object.__setattr__(self, "grey_right_near", self.grey_right)
        for name, dtype in _FIELDS:
            arr: np.ndarray = np.ascontiguousarray(getattr(self, name), dtype=dtype)
            if arr.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
            object.__setattr__(self, name, _readonly(arr))
        if ends.size and np.any(ends[:, 0, 1] > ends[:, 1, 1]):
            raise ValueError("endpoints must be ordered top to bottom (v0 <= v1)")
        hor = np.ascontiguousarray(self.horizontal, dtype=np.float64)
        if hor.ndim != 3 or hor.shape[1:] != (2, 2):
            raise ValueError(f"horizontal must have shape (k, 2, 2), got {hor.shape}")
        object.__setattr__(self, "horizontal", _readonly(hor))
        shape = tuple(int(s) for s in self.image_shape)
        if len(shape) != 2:
            raise ValueError(f"image_shape must be (height, width), got {self.image_shape!r}")
        object.__setattr__(self, "image_shape", shape)

    @classmethod
    def trusted(cls, image_shape: tuple[int, int], **arrays: np.ndarray) -> ImageSegments:
        """Built from arrays a producer has made with the shapes, dtypes and C-contiguous
        layout ``__post_init__`` would give them (``extract_segments``; the env's surrogate
        perception): skips its conversions and checks (they would cost a tenth of the
        extraction). Every field but ``horizontal`` (default: none) must be given."""
        obj = object.__new__(cls)
        arrays.setdefault("horizontal", np.zeros((0, 2, 2)))
        for name, arr in arrays.items():
            object.__setattr__(obj, name, _readonly(arr))
        object.__setattr__(obj, "image_shape", image_shape)
        return obj

    def __len__(self) -> int:
        return int(self.endpoints.shape[0])

    @classmethod
    def empty(
        cls, image_shape: tuple[int, int] = (0, 0), *, horizontal: FloatArray | None = None
    ) -> ImageSegments:
        """No segments (and the given near-horizontal lines, if any)."""
        arrays: dict[str, Any] = {name: np.zeros(0, dtype=dtype) for name, dtype in _FIELDS}
        hor = np.zeros((0, 2, 2)) if horizontal is None else horizontal
        return cls(endpoints=np.zeros((0, 2, 2)), image_shape=image_shape, horizontal=hor, **arrays)

    @property
    def length(self) -> FloatArray:
        """(n,) length of each segment, px."""
        length: FloatArray = np.linalg.norm(self.endpoints[:, 1] - self.endpoints[:, 0], axis=-1)
        return length

    @property
    def angle_rad(self) -> FloatArray:
        """(n,) angle of each segment from the image vertical, radians, ``atan(du/dv)``."""
        return np.arctan(self.slope)

    def u_at(self, index: IntArray, v: FloatArray) -> FloatArray:
        """Fitted column of segments ``index`` at rows ``v`` (same broadcastable shapes), px."""
        return self.u_center[index] + self.slope[index] * (v - self.v_center[index])

    def u_var_at(self, index: IntArray, v: FloatArray) -> FloatArray:
        """Variance of the fitted column of segments ``index`` at rows ``v``, px^2."""
        dv = v - self.v_center[index]
        return (
            self.point_var[index] * (1.0 / self.n_points[index] + dv * dv / self.s_vv[index])
            + self.bias_var[index]
        )


def _check_gray(gray: object, name: str) -> NDArray[np.uint8]:
    if not isinstance(gray, np.ndarray):
        raise ValueError(f"{name} must be a numpy array, got {type(gray).__name__}")
    if gray.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {gray.dtype}")
    if gray.ndim != 2:
        raise ValueError(f"{name} must have shape (H, W), got {gray.shape}")
    if gray.shape[0] < 8 or gray.shape[1] < 8:
        raise ValueError(f"{name} must be at least 8x8 pixels, got {gray.shape}")
    return np.ascontiguousarray(gray)


@dataclass(frozen=True, slots=True, kw_only=True)
class SegmentOptions:
    """The options of :func:`extract_segments` and :func:`extract_segment_pair` (sections 3.1-3.2).

    Attributes:
        bias_sigma_px: Standard deviation of the column error common to all edge points of a
            segment (sub-pixel quantisation of the edge by the imaging, rectification), px; added
            to the fitted variance. See the module docstring for the default.
        min_length_px: Segments shorter than this (after fitting) are dropped, px.
        min_angle_deg: Segments at less than this angle to the image rows are dropped (their
            disparity is ill-defined along the epipolar lines), degrees, in [0, 90).
        min_gradient: Smallest horizontal gradient (grey levels per px, central difference) that
            counts as an edge point.
        lsd_scale: Scale at which LSD detects segments, in (0, 1] (0.5: half resolution, faster
            and less sensitive to noise; positions are re-fitted at full resolution).
        search_px: Half-width of the per-row search window around the LSD line, px (1 to 4).
        trim_px: Rows this close to a detected endpoint are not used (corners blur them), px.
        side_px: Distance from the edge at which the "far" grey level of each side is sampled,
            px (1 to 4).
        near_px: Distance from the edge at which the "near" grey level of each side is sampled
            (linear interpolation along the row), px (0.5 to 3).

    Raises:
        ValueError: naming the option that is out of range.
    """

    bias_sigma_px: float = 0.1
    min_length_px: float = 12.0
    min_angle_deg: float = 25.0
    min_gradient: float = 5.0
    lsd_scale: float = 0.5
    search_px: int = 3
    trim_px: int = 2
    side_px: int = 3
    near_px: float = 1.5

    def __post_init__(self) -> None:
        for name in ("min_length_px", "lsd_scale"):
            positive(getattr(self, name), name)
        positive(self.bias_sigma_px, "bias_sigma_px", allow_zero=True)
        positive(self.min_gradient, "min_gradient", allow_zero=True)
        if not (0.0 <= self.min_angle_deg < 90.0):
            raise ValueError(f"min_angle_deg must be in [0, 90), got {self.min_angle_deg!r}")
        if self.lsd_scale > 1.0:
            raise ValueError(f"lsd_scale must be in (0, 1], got {self.lsd_scale!r}")
        search_px, trim_px, side_px = self.search_px, self.trim_px, self.side_px
        if int(search_px) != search_px or not (1 <= search_px <= _MAX_SEARCH_PX):
            raise ValueError(
                f"search_px must be an integer in [1, {_MAX_SEARCH_PX}], got {search_px!r}"
            )
        if int(trim_px) != trim_px or trim_px < 0:
            raise ValueError(f"trim_px must be a non-negative integer, got {trim_px!r}")
        if int(side_px) != side_px or not (1 <= side_px <= _MAX_SIDE_PX):
            raise ValueError(f"side_px must be an integer in [1, {_MAX_SIDE_PX}], got {side_px!r}")
        if not (0.5 <= self.near_px <= _MAX_SIDE_PX - 1):
            raise ValueError(f"near_px must be in [0.5, {_MAX_SIDE_PX - 1}], got {self.near_px!r}")

    @property
    def sin_min_angle(self) -> float:
        """``sin(min_angle_deg)``: a line rising by less than this of its length is horizontal."""
        return math.sin(math.radians(self.min_angle_deg))


def extract_segments(
    gray: NDArray[np.uint8],
    options: SegmentOptions | None = None,
    *,
    rig: StereoRig | None = None,
    **overrides: Any,
) -> ImageSegments:
    """Straight segments of a grey image, each with a least-squares horizontal position.

    Args:
        gray: (H, W) uint8 image (rectified), at least 8x8 pixels.
        options: The options (defaults: ``SegmentOptions()``).
        rig: The rig that took the image: its ``sigma_px`` is the per-point sigma's floor
            (default: ``StereoRig()``).
        **overrides: Fields of ``SegmentOptions`` to replace, e.g. ``min_length_px=10.0``.

    Returns:
        The segments; empty when none is found (blank image, pure noise).

    Raises:
        ValueError: ``gray`` is not a 2-D uint8 array of at least 8x8 pixels, or an option is
            unknown or out of range.
    """
    img = _check_gray(gray, "gray")
    opts = with_overrides(options, SegmentOptions, overrides)
    return _fit([img], [_detect(img, opts.lsd_scale)], opts, _sigma_px(rig))[0]


def extract_segment_pair(
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    options: SegmentOptions | None = None,
    *,
    rig: StereoRig | None = None,
    **overrides: Any,
) -> tuple[ImageSegments, ImageSegments]:
    """The segments of both images of a rectified pair: ``extract_segments`` of each, faster.

    The two line detections run at once (OpenCV releases the interpreter lock; one worker thread
    per process), and the edge points of both images are re-localised and fitted in one pass.
    The result is identical to ``(extract_segments(left, options), extract_segments(right,
    options))``.

    Args:
        left: (H, W) uint8 left image.
        right: (H, W) uint8 right image, the same shape.
        options: The options (defaults: ``SegmentOptions()``).
        rig: The rig that took the pair (its ``sigma_px``; default ``StereoRig()``).
        **overrides: Fields of ``SegmentOptions`` to replace.

    Returns:
        ``(left_segments, right_segments)``.

    Raises:
        ValueError: An image is not a 2-D uint8 array of at least 8x8 pixels, the shapes differ,
            or an option is unknown or out of range.
    """
    img_l = _check_gray(left, "left")
    img_r = _check_gray(right, "right")
    if img_l.shape != img_r.shape:
        raise ValueError(
            f"left and right must have the same shape, got {img_l.shape}, {img_r.shape}"
        )
    opts = with_overrides(options, SegmentOptions, overrides)
    job = worker().submit(_detect, img_r, opts.lsd_scale)
    lines_l = _detect(img_l, opts.lsd_scale)
    lines_r = job.result()
    segs_l, segs_r = _fit([img_l, img_r], [lines_l, lines_r], opts, _sigma_px(rig))
    return segs_l, segs_r


def _sigma_px(rig: StereoRig | None) -> float:
    """The per-point sigma's floor: ``rig.sigma_px`` (of ``StereoRig()`` when ``rig`` is None)."""
    if rig is None:
        return _DEFAULT_SIGMA_PX
    instance(rig, StereoRig, "rig")
    return float(rig.sigma_px)


# ------------------------------------------------------------------ detection and fitting
def _detect(img: NDArray[np.uint8], lsd_scale: float) -> FloatArray:
    """LSD lines of ``img``, (N, 4) float64 ``x0, y0, x1, y1`` full-resolution px, N >= 0."""
    if lsd_scale == 0.5:
        # one pyramid level (cv2.pyrDown: 5x5 Gaussian, every other pixel) and LSD at scale 1 on
        # it: about 0.15 ms faster per image than LSD's own Gaussian resampling at 0.5, with as
        # many segments and the same accuracy on the benchmark (positions are re-fitted anyway)
        raw = _lsd(1.0).detect(cv2.pyrDown(img))[0]
        to_full = 2.0
    else:
        raw = _lsd(float(lsd_scale)).detect(img)[0]
        to_full = 1.0
    if raw is None:
        return np.zeros((0, 4))
    # OpenCV 4 returns (N, 1, 4), OpenCV 5 (N, 4): always flatten to (N, 4)
    return np.asarray(raw, dtype=np.float64).reshape(-1, 4) * to_full


def _lines_to_fit(
    detected: list[FloatArray], height: int, opts: SegmentOptions
) -> tuple[list[FloatArray], LinesToFit]:
    """The detected lines of each image sorted into the near-horizontal ones (per image, (h, 2, 2)
    px, left end first, as detected) and the lines to fit (top end first, at least
    ``min_length_px`` long, steep enough, crossing three rows or more after the trim at both
    ends), with the rows each one crosses."""
    n_img = len(detected)
    lines = np.concatenate(detected)  # a copy: reordered in place below
    image_of = np.repeat(np.arange(n_img), [len(d) for d in detected])
    swap = lines[:, 1] > lines[:, 3]  # top end first
    lines[swap] = lines[swap][:, [2, 3, 0, 1]]
    x0, y0, x1, y1 = lines.T
    dv = y1 - y0
    length = np.hypot(x1 - x0, dv)
    sin_min = opts.sin_min_angle
    is_hor = (length >= opts.min_length_px) & (dv < sin_min * length)
    hor = lines[is_hor].reshape(-1, 2, 2)
    flip = hor[:, 0, 0] > hor[:, 1, 0]  # left end first
    hor[flip] = hor[flip, ::-1]
    hor_of = image_of[is_hor]
    horizontal = [hor[hor_of == k] for k in range(n_img)]
    r0 = np.maximum(np.ceil(y0).astype(np.int64) + opts.trim_px, 1)
    r1 = np.minimum(np.floor(y1).astype(np.int64) - opts.trim_px, height - 2)
    keep = np.flatnonzero(
        (length >= opts.min_length_px) & (dv > 0) & (dv >= sin_min * length) & (r1 >= r0 + 2)
    )
    return horizontal, LinesToFit(
        image_of=image_of[keep],
        x0=x0[keep],
        y0=y0[keep],
        inv_slope=(x1[keep] - x0[keep]) / dv[keep],  # du/dv of the detected line
        r0=r0[keep],
        r1=r1[keep],
    )


def _fit(
    images: list[NDArray[np.uint8]],
    detected: list[FloatArray],
    opts: SegmentOptions,
    sigma_px: float,
) -> list[ImageSegments]:
    """Re-localise and fit the LSD lines of each image (same shapes), all in one pass;
    ``sigma_px`` (the rig's) is the floor of the per-point sigma.

    The images are stacked vertically for the compiled loops; every quantity is computed in each
    image's own rows (pixels past its sides replicate its edge columns), so the result for one
    image does not depend on the others.
    """
    H, W = images[0].shape
    shape = (H, W)
    n_img = len(images)
    if sum(len(d) for d in detected) == 0:
        return [ImageSegments.empty(shape) for _ in images]
    horizontal, lines = _lines_to_fit(detected, H, opts)
    if lines.x0.size == 0:
        return [ImageSegments.empty(shape, horizontal=h) for h in horizontal]
    # edge points, one per row, summed per segment
    # (``modeling.stereo.edge_points.edge_sums_reference`` is the NumPy formulation); the pixel
    # block around the LSD line covers the search window, the peak's neighbours and the side samples
    search = EdgeSearch(
        height=H,
        search_px=int(opts.search_px),
        side_px=int(opts.side_px),
        near_px=float(opts.near_px),
        half_block=opts.search_px + max(opts.side_px, math.ceil(opts.near_px) + 1),
        min_gradient=float(opts.min_gradient),
    )
    stack = np.concatenate(images) if n_img > 1 else np.ascontiguousarray(images[0])
    edges = edge_sums(stack, lines, search)
    limits = FitLimits(
        sigma_px=sigma_px,
        min_length_px=float(opts.min_length_px),
        sin_min=opts.sin_min_angle,
    )
    fit = _fields_of_fit(segment_fits(edges, lines, limits))
    sel = np.flatnonzero(fit.pop("ok"))
    out = []
    for k in range(n_img):
        mine = sel[lines.image_of[sel] == k]
        if mine.size == 0:
            out.append(ImageSegments.empty(shape, horizontal=horizontal[k]))
            continue
        out.append(
            ImageSegments.trusted(
                shape,
                bias_var=np.full(mine.size, float(opts.bias_sigma_px) ** 2),
                polarity=edges.polarity[mine],
                horizontal=horizontal[k],
                **{name: values[mine] for name, values in fit.items()},
            )
        )
    return out


def _fields_of_fit(fits: SegmentFits) -> dict[str, np.ndarray]:
    """The compiled fit's rows (``modeling.stereo._kernels.edge.N_FIT``) by ``ImageSegments`` field,
    as :func:`least_squares_lines_reference` returns them."""
    f = fits.fit
    return {
        "ok": fits.ok,
        "endpoints": f[:4].T.reshape(-1, 2, 2),
        "u_center": f[4],
        "v_center": f[5],
        "slope": f[6],
        "point_var": f[7],
        "n_points": f[8].astype(np.int64),
        "s_vv": f[9],
        "contrast": f[10],
        "grey_left": f[11],
        "grey_right": f[12],
        "grey_left_near": f[13],
        "grey_right_near": f[14],
    }


def least_squares_lines_reference(
    edges: EdgeSums, lines: LinesToFit, limits: FitLimits
) -> dict[str, np.ndarray]:
    """The least-squares line ``u = u_c + slope (v - v_c)`` of each line's edge points from their
    sums (section 3.2), with its variances and mean grey levels: the readable reference of the
    compiled :func:`modeling.stereo._kernels.edge.segment_fits` that the fit runs (the same
    ``limits``: the per-point sigma's floor, the rig's ``sigma_px``, and the kept segments').

    Returns:
        The ``ImageSegments`` fields ``endpoints`` (m, 2, 2), ``u_center``, ``v_center``,
        ``slope``, ``point_var``, ``n_points``, ``s_vv``, ``contrast``, ``grey_left``,
        ``grey_right``, ``grey_left_near``, ``grey_right_near`` (m,) each, and ``ok`` (m,):
        whether the segment is kept (at least 3 edge points spread over rows, at least
        ``min_length_px`` long and steep enough).
    """
    S = edges.sums  # columns as ``modeling.stereo._kernels.edge.N_SUMS`` says
    n = S[:, 0]
    safe_n = np.maximum(n, 1.0)
    mv = S[:, 1] / safe_n
    mu = S[:, 2] / safe_n
    svv = S[:, 3] - n * mv * mv
    suv = S[:, 4] - n * mv * mu
    suu = S[:, 5] - n * mu * mu
    ok = (n >= 3) & (svv > 1e-9)
    b = suv / np.where(ok, svv, 1.0)  # slope relative to the detected line
    rss = np.maximum(suu - b * suv, 0.0)
    slope = lines.inv_slope + b
    vc = lines.r0 + mv  # mean row of the edge points
    uc = lines.x0 + lines.inv_slope * (vc - lines.y0) + mu  # the fitted column there
    grey = S[:, 6:] / safe_n[:, None]  # contrast, grey far left, far right, near left, near right
    # the ends: the first and last row with edge points
    v0 = edges.first_row.astype(np.float64)
    v1 = edges.last_row.astype(np.float64)
    u0 = uc + slope * (v0 - vc)
    u1 = uc + slope * (v1 - vc)
    seg_len = np.hypot(u1 - u0, v1 - v0)
    ok &= (v1 > v0) & (seg_len >= limits.min_length_px) & ((v1 - v0) >= limits.sin_min * seg_len)
    return {
        "ok": ok,
        "endpoints": np.stack([u0, v0, u1, v1], axis=1).reshape(-1, 2, 2),
        "u_center": uc,
        "v_center": vc,
        "slope": slope,
        "point_var": np.maximum(rss / np.maximum(n - 2.0, 1.0), limits.sigma_px**2),
        "n_points": n.astype(np.int64),
        "s_vv": svv,
        "contrast": grey[:, 0],
        "grey_left": grey[:, 1],
        "grey_right": grey[:, 2],
        "grey_left_near": grey[:, 3],
        "grey_right_near": grey[:, 4],
    }
