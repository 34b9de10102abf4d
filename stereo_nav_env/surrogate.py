"""The surrogate perception: the environment model from the true scene and the stereo error model.

``perception="surrogate"`` (:class:`~stereo_nav_env.config.EnvConfig`) renders nothing. From the
true scene as seen from the head it builds what segment stereo would have found, and hands it to
the *same* modeling code as the stereo pipeline (:func:`modeling.pipeline.stereo_to_floor`'s
stages after the segment extraction, then :func:`modeling.model.build_model`):

1. The edges the pipeline could see (:mod:`.surrogate_visibility`): the vertical edges of the
   rendered parts in the field of view and range, facing the head, not occluded (the sweep over
   the parts' footprints with their heights), each with its seen run of rows and whether it is
   an outline (one of the two sides meeting there faces the head) or a crease (both do); and the
   image lines of the floor sides of the parts, for the faces.
2. Which images segment each edge: both, the left only, the right only or neither, drawn with
   the probabilities of its class (:data:`EDGE_CLASSES`: its obstacle's kind, outline or
   crease) and depth bin, measured on the stereo pipeline (:class:`SurrogateRates`,
   ``data/surrogate_rates.json``, written by ``scripts/measure_surrogate.py``). A crease of a
   leg, a few pixels from its outlines between faces of one dark colour, is seldom imaged; a
   chair's thin legs less often than a table's.
3. The photometry (:mod:`.surrogate_photometry`): the grey levels the renderer draws beside
   each edge in each image (the near and far samples the matcher compares), row by row, and
   the pieces the extraction cuts an edge into: the runs of one polarity with contrast, each
   stopping the measured ``end_loss_px`` short of its ends (the stereo's line support does).
4. Idealised image segments of both images (:class:`~modeling.segments.ImageSegments`), one per
   piece of an edge the image segments, with the least-squares error model of
   :mod:`modeling.segments`: a fit of ``n`` rows with per-point variance ``sigma_px^2`` and the
   common bias ``bias_sigma_px^2`` (``SegmentOptions``). The segments' columns are drawn from
   that model (the fitted line's offset ``N(0, s^2 / n)``, slope ``N(0, s^2 / S_vv)``, bias
   ``N(0, bias^2)``), scaled by the measured ``error_scale`` (the stereo's actual error over its
   stated one). A false match beyond the matcher's own moves the right segment by a disparity
   error drawn from the measured ones (its rate by depth bin). Each segment carries the grey
   levels of step 3, so which edges the matcher can take for one another is what the stereo's
   photometric test decides: identical legs in front of the same background, two wall corners
   between the same faces.
5. :func:`modeling.matching.match_segments` on those segments: the matcher's own candidates
   (epipolar overlap, direction, photometry, disparity range) and its local disparity
   histograms decide. A repeated edge (a bookshelf front) gets its candidates at the other
   repeated edges' disparities, with the probabilities of the histogram's peaks (Eq. 1); an edge
   alone is certain; an edge the right image does not segment may take a look-alike's partner.
6. :func:`modeling.triangulation.triangulate_to_floor` (the covariances: the depth standard
   deviation grows as ``Z^2 / (f b) sigma_d``; the height band), :func:`modeling.faces.close_faces`
   (with the floor lines of step 1 as the image's near-horizontal lines), and
   :func:`modeling.model.build_model`.

Every random draw comes from the generator passed in (the env's ``np_random``).
"""

from __future__ import annotations

import functools
import importlib.resources
import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.faces import FaceOptions
from modeling.faces import close_faces as close_faces_of
from modeling.matching import match_segments
from modeling.model import build_model
from modeling.rig import HeadPose, StereoRig
from modeling.segments import ImageSegments, SegmentOptions
from modeling.triangulation import triangulate_to_floor
from stereo_nav_env._surrogate_loops import image_fits_loop, piece_fits, segment_pieces_loop
from stereo_nav_env.perception import ComparableModel, Stopwatch
from stereo_nav_env.scenes import ObstacleKind
from stereo_nav_env.surrogate_floor import visible_floor_lines
from stereo_nav_env.surrogate_photometry import ROWS, image_pieces, surface_arrays
from stereo_nav_env.surrogate_visibility import SceneEdges, VisibleEdges, visible_edges

__all__ = [
    "EDGE_CLASSES",
    "RATES_FILE",
    "SurrogateRates",
    "default_rates",
    "edge_classes",
    "perceive_surrogate",
    "piece_fits",
    "piece_fits_reference",
    "surrogate_segments",
    "surrogate_segments_reference",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

RATES_FILE = "surrogate_rates.json"
"""The measured rates, in ``stereo_nav_env/data`` (written by ``scripts/measure_surrogate.py``)."""


_SEGMENT_OPTIONS = SegmentOptions()
"""The extraction's default options (frozen: made once, not every step)."""
_FACE_RANGE_M = FaceOptions().max_range_m
"""How far :func:`modeling.faces.close_faces` closes faces by default, metres."""

EDGE_CLASSES = tuple(f"{kind.value}{crease}" for kind in ObstacleKind for crease in ("", "_crease"))
"""The classes of edge the detection rates are kept for: an obstacle kind's outlines (one of the
two sides meeting there faces the head: the edge stands against what lies behind it) and its
creases (``_crease``: both sides face the head; the edge is only the shading step between two
faces). The kind stands for its parts' size and colour: a chair's thin dark legs are found far
less often than a table's."""


@dataclass(frozen=True, slots=True, kw_only=True)
class SurrogateRates:
    """How the stereo pipeline departs from the ideal, measured against the ground truth.

    Attributes:
        depth_bins_m: (k + 1,) edges of the depth bins, metres, increasing.
        detection: For each of :data:`EDGE_CLASSES`, (k, 3): per depth bin, the probabilities
            that the segment extraction images a seen edge of that class (one with contrast in
            both images) in both images, in the left one only and in the right one only (the
            rest: in neither).
        false_match_rate: (k,) probability that an edge imaged in both images is matched at a
            wrong disparity (more than 1 px off) beyond the matcher's own false matches, per
            depth bin.
        false_error_px: The absolute disparity errors of the measured false matches, px (> 1);
            a false match draws one of them, with a random sign.
        error_scale: The stereo's actual column errors over the error model's standard
            deviation (1: the model is exact), > 0.
        end_loss_px: Rows by which the stereo's segments stop short of each end of the seen
            run of their edge (the median), px, >= 0.
    """

    depth_bins_m: tuple[float, ...]
    detection: dict[str, tuple[tuple[float, float, float], ...]]
    false_match_rate: tuple[float, ...]
    false_error_px: tuple[float, ...]
    error_scale: float
    end_loss_px: float
    _detection_table: FloatArray = field(init=False, repr=False, compare=False)
    _inner_bins: FloatArray = field(init=False, repr=False, compare=False)
    _false_rate: FloatArray = field(init=False, repr=False, compare=False)
    _false_error: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        bins = np.asarray(self.depth_bins_m, dtype=np.float64)
        k = bins.size - 1
        if k < 1 or not np.all(np.diff(bins) > 0) or not np.all(np.isfinite(bins)):
            raise ValueError(f"depth_bins_m must increase, got {self.depth_bins_m!r}")
        if not isinstance(self.detection, dict) or set(self.detection) != set(EDGE_CLASSES):
            raise ValueError(f"detection must map each of {EDGE_CLASSES} to its rates")
        detection = {}
        for name in EDGE_CLASSES:
            arr = np.asarray(self.detection[name], dtype=np.float64)
            if (
                arr.shape != (k, 3)
                or not np.all((arr >= 0) & (arr <= 1))
                or not np.all(arr.sum(axis=1) <= 1 + 1e-9)
            ):
                raise ValueError(
                    f"detection[{name!r}] must be {k} rows of 3 probabilities summing to at "
                    f"most 1, got {self.detection[name]!r}"
                )
            detection[name] = tuple((a, b, c) for a, b, c in arr.tolist())
        object.__setattr__(self, "detection", detection)
        table = np.array([detection[name] for name in EDGE_CLASSES])  # (classes, k, 3)
        table.setflags(write=False)
        object.__setattr__(self, "_detection_table", table)
        arr = np.asarray(self.false_match_rate, dtype=np.float64)
        if arr.shape != (k,) or not np.all((arr >= 0) & (arr <= 1)):
            raise ValueError(f"false_match_rate must be {k} probabilities, got {arr.tolist()!r}")
        object.__setattr__(self, "false_match_rate", tuple(arr.tolist()))
        errors = np.asarray(self.false_error_px, dtype=np.float64)
        if errors.ndim != 1 or errors.size == 0 or not np.all(np.isfinite(errors) & (errors > 0)):
            raise ValueError(f"false_error_px must be positive numbers, got {errors.tolist()!r}")
        object.__setattr__(self, "false_error_px", tuple(errors.tolist()))
        if not (math.isfinite(self.error_scale) and self.error_scale > 0):
            raise ValueError(f"error_scale must be positive, got {self.error_scale!r}")
        object.__setattr__(self, "depth_bins_m", tuple(bins.tolist()))
        # the arrays the surrogate reads every step, made once
        for name, value in (
            ("_inner_bins", bins[1:-1]),  # a depth's bin: how many of these it reaches
            ("_false_rate", np.array(self.false_match_rate)),
            ("_false_error", np.array(self.false_error_px)),
        ):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "error_scale", float(self.error_scale))
        if not (math.isfinite(self.end_loss_px) and self.end_loss_px >= 0):
            raise ValueError(f"end_loss_px must be >= 0, got {self.end_loss_px!r}")
        object.__setattr__(self, "end_loss_px", float(self.end_loss_px))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SurrogateRates:
        """The rates of a dict with (at least) the attribute names as keys."""
        return cls(**{name: data[name] for name in cls.__dataclass_fields__ if name[0] != "_"})

    def depth_bin(self, depth_m: FloatArray) -> IntArray:
        """(n,) the bin of each of the depths ``depth_m`` (n,) metres, clipped to the bins (one
        search over the inner bin edges: a depth below the first bin is in it, one past the
        last in the last)."""
        out: IntArray = np.searchsorted(self._inner_bins, depth_m, side="right")
        return out

    def false_rate_at(self, depth_m: FloatArray) -> FloatArray:
        """(n,) the false-match rate at depths ``depth_m`` (n,) metres (clipped to the bins)."""
        out: FloatArray = self._false_rate[self.depth_bin(depth_m)]
        return out

    def false_errors(self, index: IntArray) -> FloatArray:
        """The measured false-match errors ``false_error_px[index]``, px (a new array)."""
        out: FloatArray = self._false_error[index]
        return out

    def detection_at(self, edge_class: IntArray, depth_m: FloatArray) -> FloatArray:
        """(n, 3) detection probabilities (both images, left only, right only) of ``n`` edges
        of classes ``edge_class`` (indices into :data:`EDGE_CLASSES`) at depths ``depth_m``
        (clipped to the bins)."""
        out: FloatArray = self._detection_table[edge_class, self.depth_bin(depth_m)]
        return out


def edge_classes(edges: SceneEdges, vis: VisibleEdges) -> IntArray:
    """(n,) the class of each seen edge, an index into :data:`EDGE_CLASSES`."""
    out: IntArray = 2 * edges.corner_kind[vis.corner] + vis.crease.astype(np.int64)
    return out


@functools.cache
def default_rates() -> SurrogateRates:
    """The rates in the package's ``data/surrogate_rates.json``."""
    text = importlib.resources.files("stereo_nav_env").joinpath("data", RATES_FILE).read_text()
    return SurrogateRates.from_dict(json.loads(text))


PieceFits = tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray, FloatArray, FloatArray
]
"""The fitted lines of :func:`piece_fits`: ``(endpoints, u_center, v_center, slope, point_var,
n_points, s_vv, bias_var)`` as :class:`~modeling.segments.ImageSegments` holds them."""


def piece_fits_reference(
    top: FloatArray,
    bottom: FloatArray,
    centre: FloatArray,
    draw: FloatArray,
    point_var_px2: float,
    bias_var_px2: float,
) -> PieceFits:
    """The least-squares fits of pieces spanning rows ``top`` to ``bottom`` (m,) of edges at
    columns ``centre`` (m,), with the errors ``draw`` (3, m: the offset's, the slope's and the
    bias's standard-normal draws, already scaled): a fit of ``n`` rows with per-point variance
    ``point_var_px2`` has offset ``N(0, s^2 / n)`` and slope ``N(0, s^2 / S_vv)``, plus the
    common bias ``N(0, bias_var_px2)``."""
    m = top.shape[0]
    n_rows = np.floor(bottom - top) + 1.0
    s_vv = n_rows * (n_rows * n_rows - 1.0) / 12.0
    point_var = np.full(m, point_var_px2)
    bias_var = np.full(m, bias_var_px2)
    offset = draw[0] * np.sqrt(point_var / n_rows) + draw[2] * np.sqrt(bias_var)
    slope = draw[1] * np.sqrt(point_var / s_vv)
    v_c = 0.5 * (top + bottom)
    u_c = centre + offset
    ends_v = np.stack([top, bottom], axis=1)
    ends = np.stack([u_c[:, None] + slope[:, None] * (ends_v - v_c[:, None]), ends_v], -1)
    return ends, u_c, v_c, slope, point_var, n_rows.astype(np.int64), s_vv, bias_var


def surrogate_segments_reference(
    edges: SceneEdges,
    rig: StereoRig,
    head: HeadPose,
    rng: np.random.Generator,
    rates: SurrogateRates,
    options: SegmentOptions | None = None,
) -> tuple[ImageSegments, ImageSegments]:
    """The idealised left and right image segments of what ``head`` sees (steps 1-4 of the
    module docstring), drawing from ``rng``; the left ones carry the floor lines as their
    near-horizontal lines. In NumPy, the one to read (:func:`surrogate_segments` makes the same,
    bit for bit, with the same draws, in compiled loops)."""
    opts = _SEGMENT_OPTIONS if options is None else options
    vis = visible_edges(edges, head, rig, trim_px=opts.trim_px, min_length_px=opts.min_length_px)
    # which images segment each seen edge: both, the left only, the right only, neither
    # (the outcome: how many of the cumulative probabilities the draw reaches; 3: neither)
    p = np.cumsum(rates.detection_at(edge_classes(edges, vis), vis.Z), axis=1)
    outcome = (rng.random(len(vis))[:, None] >= p).sum(axis=1)
    found = np.flatnonzero(outcome < 3)
    outcome = outcome[found]
    in_image = np.stack([outcome != 2, outcome != 1])  # (2, n): left, right
    n = found.size
    Z, u = vis.Z[found], vis.u[found]
    v0, v1 = vis.v_top[found], vis.v_bottom[found]
    pieces_of = image_pieces(edges, head, rig, u, Z, v0, v1, opts, end_loss_px=rates.end_loss_px)
    false = (outcome == 0) & (rng.random(n) < rates.false_rate_at(Z))
    wrong = rates.false_errors(rng.integers(len(rates.false_error_px), size=n))
    wrong *= np.where(rng.random(n) < 0.5, -1.0, 1.0)
    centre = np.stack([u, u - rig.fb / Z + np.where(false, wrong, 0.0)])  # (2, n)
    floor_lines = visible_floor_lines(
        edges, head, rig, vis.corner[found[in_image[0]]], max_range_m=_FACE_RANGE_M
    )
    d = floor_lines[:, 1] - floor_lines[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    flat = np.abs(d[:, 1]) < opts.sin_min_angle * length
    horizontal = floor_lines[flat & (length >= opts.min_length_px)]

    def image(k: int, lines: FloatArray) -> ImageSegments:
        """The segments of image ``k`` (0 left, 1 right): the pieces of the edges it images."""
        pieces = pieces_of[k]
        r = np.flatnonzero(in_image[k, pieces.edge])
        # the fitted line's errors: offset, slope, common bias
        draw = rng.standard_normal((3, r.size)) * rates.error_scale
        fit = piece_fits_reference(
            pieces.v_top[r],
            pieces.v_bottom[r],
            centre[k, pieces.edge[r]],
            draw,
            rig.sigma_px**2,
            opts.bias_sigma_px**2,
        )
        g = np.ascontiguousarray(pieces.greys[:, r])  # rows C-contiguous
        contrast = np.abs(g[3] - g[2]) / (2.0 * opts.near_px)
        return _image_segments(rig, list(fit), pieces.polarity[r], contrast, g, lines)

    return image(0, horizontal), image(1, np.zeros((0, 2, 2)))


def surrogate_segments(
    edges: SceneEdges,
    rig: StereoRig,
    head: HeadPose,
    rng: np.random.Generator,
    rates: SurrogateRates,
    options: SegmentOptions | None = None,
) -> tuple[ImageSegments, ImageSegments]:
    """:func:`surrogate_segments_reference`, the same draws from ``rng`` in the same order and
    the same segments bit for bit (a test holds them equal), with the work between the draws
    in two compiled loops (:mod:`._surrogate_loops`): the detection outcomes and the pieces of
    the edges found, then each image's fitted lines."""
    opts = _SEGMENT_OPTIONS if options is None else options
    vis = visible_edges(edges, head, rig, trim_px=opts.trim_px, min_length_px=opts.min_length_px)
    pick = rng.random(len(vis))
    (cx, cy), c, s = rig.principal_point_px, math.cos(head.heading_rad), math.sin(head.heading_rad)
    found, outcome, left_corners, *pieces = segment_pieces_loop(
        pick,
        vis.corner,
        vis.crease,
        vis.u,
        vis.Z,
        vis.v_top,
        vis.v_bottom,
        edges.corner_kind,
        rates._inner_bins,
        rates._detection_table,
        np.array([rig.focal_px, cx, cy, rig.fb, rig.baseline_m]),
        np.array([head.x_m, head.y_m, c, s, head.height_m]),
        np.array(
            [
                -float(opts.side_px),
                float(opts.side_px),
                -opts.near_px,
                opts.near_px,
                2.0 * opts.min_gradient,
                opts.min_length_px,
                rates.end_loss_px,
            ]
        ),
        ROWS,
        surface_arrays(edges),
    )
    n = found.size
    false_pick = rng.random(n)
    wrong_index = rng.integers(len(rates.false_error_px), size=n)
    sign_pick = rng.random(n)
    u, Z = vis.u[found], vis.Z[found]
    floor_lines = visible_floor_lines(edges, head, rig, left_corners, max_range_m=_FACE_RANGE_M)
    d = floor_lines[:, 1] - floor_lines[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    flat = np.abs(d[:, 1]) < opts.sin_min_angle * length
    scalars = np.array(
        [rates.error_scale, rig.fb, rig.sigma_px**2, opts.bias_sigma_px**2, 2.0 * opts.near_px]
    )
    out = []
    for k, lines in enumerate(
        (floor_lines[flat & (length >= opts.min_length_px)], np.zeros((0, 2, 2)))
    ):
        edge, top, bottom, greys, polarity = pieces[k]
        draw = rng.standard_normal((3, edge.size))
        *fit, contrast = image_fits_loop(
            edge,
            top,
            bottom,
            greys,
            draw,
            u,
            Z,
            outcome,
            false_pick,
            wrong_index,
            sign_pick,
            rates._inner_bins,
            rates._false_rate,
            rates._false_error,
            scalars,
            k == 1,
        )
        out.append(_image_segments(rig, fit, polarity, contrast, greys, lines))
    return out[0], out[1]


def _image_segments(
    rig: StereoRig,
    fit: list[Any],
    polarity: NDArray[np.int8],
    contrast: FloatArray,
    greys: FloatArray,
    lines: FloatArray,
) -> ImageSegments:
    """The :class:`ImageSegments` of one image's fitted pieces (``piece_fits``' arrays), every
    array with the dtype and layout ImageSegments keeps (a test checks)."""
    return ImageSegments.trusted(
        (int(rig.height_px), int(rig.width_px)),
        endpoints=fit[0],
        u_center=fit[1],
        v_center=fit[2],
        slope=fit[3],
        point_var=fit[4],
        n_points=fit[5],
        s_vv=fit[6],
        bias_var=fit[7],
        polarity=polarity,
        contrast=contrast,
        grey_left=greys[0],
        grey_right=greys[1],
        grey_left_near=greys[2],
        grey_right_near=greys[3],
        horizontal=lines,
    )


def perceive_surrogate(
    edges: SceneEdges,
    rig: StereoRig,
    head_pose: HeadPose,
    rng: np.random.Generator,
    *,
    robot_width_m: float,
    robot_height_m: float,
    eps: float,
    max_situations: int,
    close_faces: bool = True,
    rates: SurrogateRates | None = None,
    stopwatch: Stopwatch | None = None,
) -> ComparableModel:
    """The environment model of the surrogate perception (the module docstring).

    Args:
        edges: The true scene's edges (:meth:`SceneEdges.of`).
        rig: The stereo rig whose view is imitated.
        head_pose: Pose of the left optical centre, world frame.
        rng: The source of every random draw (the env's ``np_random``).
        robot_width_m: Robot diameter, metres (gap classification).
        robot_height_m: Floor segments are kept between 0.05 m and this height, metres.
        eps: Classification tolerance in (0, 0.5).
        max_situations: Most situations enumerated.
        close_faces: Close the "gaps" that are plain faces (:func:`modeling.faces.close_faces`).
        rates: The stereo's measured rates (default: :func:`default_rates`).
        stopwatch: If given, its laps ``segments``, ``matching``, ``triangulation`` and
            ``modeling`` are added to, as :func:`~stereo_nav_env.perception.perceive` does.

    Returns:
        The :class:`~stereo_nav_env.perception.ComparableModel`.
    """
    watch = stopwatch if stopwatch is not None else Stopwatch()
    left, right = surrogate_segments(
        edges, rig, head_pose, rng, default_rates() if rates is None else rates
    )
    watch.lap("segments")
    matches = match_segments(left, right, rig)
    watch.lap("matching")
    floor = triangulate_to_floor(matches, rig, head_pose, max_height_m=robot_height_m)
    if close_faces:
        floor = close_faces_of(left, floor, max_height_m=robot_height_m)
    watch.lap("triangulation")
    model = ComparableModel.of(
        build_model(floor, robot_width_m, eps=eps, max_situations=max_situations)
    )
    watch.lap("modeling")
    return model
