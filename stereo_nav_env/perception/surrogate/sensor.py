"""The surrogate perception: the environment model from the true scene and the stereo error model.

``perception="surrogate"`` (:class:`~stereo_nav_env.config.EnvConfig`) renders nothing. From the
true scene as seen from the head it builds what segment stereo would have found, and hands it to
the *same* modeling code as the stereo pipeline (:func:`modeling.stereo.pipeline.stereo_to_floor`'s
stages after the segment extraction, then :func:`modeling.model.build.build_model`):

1. The edges the pipeline could see (:mod:`stereo_nav_env.perception.surrogate.visibility`): the
   vertical edges of the rendered parts in the field of view and range, facing the head, not
   occluded (the sweep over the parts' footprints with their heights), each with its seen run of
   rows and whether it is an outline (one of the two sides meeting there faces the head) or a crease
   (both do); and the image lines of the floor sides of the parts, for the faces.
2. Which images segment each edge: both, the left only, the right only or neither, drawn with
   the probabilities of its class (:data:`EDGE_CLASSES`: its obstacle's kind, outline or
   crease) and depth bin, measured on the stereo pipeline (:class:`SurrogateRates`,
   ``data/surrogate_rates.json``, written by ``scripts/measure_surrogate.py``). A crease of a
   leg, a few pixels from its outlines between faces of one dark colour, is seldom imaged; a
   chair's thin legs less often than a table's.
3. The photometry (:mod:`stereo_nav_env.perception.surrogate.photometry`): the grey levels the
   renderer draws beside each edge in each image (the near and far samples the matcher compares),
   row by row, and the pieces the extraction cuts an edge into: the runs of one polarity with
   contrast, each stopping the measured ``end_loss_px`` short of its ends (the stereo's line support
   does).
4. Idealised image segments of both images (:class:`~modeling.stereo.segments.ImageSegments`), one
   per piece of an edge the image segments, with the least-squares error model of
   :mod:`modeling.stereo.segments`: a fit of ``n`` rows with per-point variance ``sigma_px^2`` and
   the common bias ``bias_sigma_px^2`` (``SegmentOptions``). The segments' columns are drawn from
   that model (the fitted line's offset ``N(0, s^2 / n)``, slope ``N(0, s^2 / S_vv)``, bias
   ``N(0, bias^2)``), scaled by the measured ``error_scale`` (the stereo's actual error over its
   stated one). A false match beyond the matcher's own moves the right segment by a disparity
   error drawn from the measured ones (its rate by depth bin). Each segment carries the grey
   levels of step 3, so which edges the matcher can take for one another is what the stereo's
   photometric test decides: identical legs in front of the same background, two wall corners
   between the same faces.
5. :func:`modeling.stereo.matching.match_segments` on those segments: the matcher's own candidates
   (epipolar overlap, direction, photometry, disparity range) and its local disparity
   histograms decide. A repeated edge (a bookshelf front) gets its candidates at the other
   repeated edges' disparities, with the probabilities of the histogram's peaks (Eq. 1); an edge
   alone is certain; an edge the right image does not segment may take a look-alike's partner.
6. :func:`modeling.stereo.triangulation.triangulate_to_floor` (the covariances: the depth standard
   deviation grows as ``Z^2 / (f b) sigma_d``; the height band),
   :func:`modeling.stereo.faces.close_faces` (with the floor lines of step 1 as the image's
   near-horizontal lines), and :func:`modeling.model.build.build_model`.
7. With ``ground_lines=True``, the stereo's ground-line cue (:mod:`modeling.stereo.ground_lines`)
   before the model: the left-image lines where the faces the head sees meet the floor
   (:func:`stereo_nav_env.perception.surrogate.floor.visible_ground_lines`: every floor side
   facing the head, cut where a part hides the floor or the image ends, whether or not its
   vertical edges are seen), each end moved by the lines' pixel error
   ``N(0, end_sigma_px^2)`` in both directions, those near-horizontal and long enough as the
   extraction sorts them (``SegmentOptions.min_angle_deg``, ``min_length_px``), then
   :func:`modeling.stereo.ground_lines.line_ground_segments`: the lowest-line rule, the range and
   the covariance ``J diag(end_sigma_px^2) J^T`` of the stereo's own ground lines. (The stereo
   also reads top edges and shelf boards, which the lowest-line rule mostly drops; the surrogate
   has only the floor contacts.)

Every random draw comes from the generator passed in (the env's ``np_random``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from modeling.model.build import build_model
from modeling.stereo.faces import FaceOptions
from modeling.stereo.faces import close_faces as close_faces_of
from modeling.stereo.ground_lines import GroundLineOptions, add_line_ground_segments
from modeling.stereo.matching import match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments, SegmentOptions
from modeling.stereo.triangulation import triangulate_to_floor
from modeling.types import FloatArray, IntArray
from stereo_nav_env.perception.base import ComparableModel, Perception, PerceptionName, Stopwatch
from stereo_nav_env.perception.surrogate._kernels.segments import (
    Detection,
    FalseMatchDraws,
    FalseMatchRates,
    FoundEdges,
    PieceSampling,
    SeenEdges,
    image_fits_loop,
    piece_fits,
    segment_pieces_loop,
)
from stereo_nav_env.perception.surrogate.floor import visible_floor_lines, visible_ground_lines
from stereo_nav_env.perception.surrogate.photometry import ROWS, image_pieces, surface_arrays
from stereo_nav_env.perception.surrogate.rates import SurrogateRates, default_rates, edge_classes
from stereo_nav_env.perception.surrogate.visibility import SceneEdges, visible_edges
from stereo_nav_env.sim.scenes import Scene

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = [
    "SurrogatePerception",
    "perceive_surrogate",
    "piece_fits",
    "piece_fits_reference",
    "surrogate_ground_lines",
    "surrogate_segments",
    "surrogate_segments_reference",
]


_SEGMENT_OPTIONS = SegmentOptions()
"""The extraction's default options (frozen: made once, not every step)."""
_FACE_RANGE_M = FaceOptions().max_range_m
"""How far :func:`modeling.stereo.faces.close_faces` closes faces by default, metres."""
_GROUND_OPTIONS = GroundLineOptions()
"""The ground lines' default options, those of the stereo's (frozen: made once)."""


PieceFits = tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray, FloatArray, FloatArray
]
"""The fitted lines of :func:`piece_fits`: ``(endpoints, u_center, v_center, slope, point_var,
n_points, s_vv, bias_var)`` as :class:`~modeling.stereo.segments.ImageSegments` holds them."""


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
    in two compiled loops (:mod:`stereo_nav_env.perception.surrogate._kernels.segments`): the
    detection outcomes and the pieces of the edges found, then each image's fitted lines."""
    opts = _SEGMENT_OPTIONS if options is None else options
    vis = visible_edges(edges, head, rig, trim_px=opts.trim_px, min_length_px=opts.min_length_px)
    pick = rng.random(len(vis))
    (cx, cy), c, s = rig.principal_point_px, math.cos(head.heading_rad), math.sin(head.heading_rad)
    found, outcome, left_corners, *pieces = segment_pieces_loop(
        pick,
        SeenEdges(vis.corner, vis.crease, vis.u, vis.Z, vis.v_top, vis.v_bottom),
        Detection(edges.corner_kind, rates._inner_bins, rates._detection_table),
        np.array([rig.focal_px, cx, cy, rig.fb, rig.baseline_m]),
        np.array([head.x_m, head.y_m, c, s, head.height_m]),
        PieceSampling(
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
        ),
        surface_arrays(edges),
    )
    n = found.size
    false_pick = rng.random(n)
    wrong_index = rng.integers(len(rates.false_error_px), size=n)
    sign_pick = rng.random(n)
    u, Z = vis.u[found], vis.Z[found]
    found_edges = FoundEdges(u, Z, outcome)
    false_draws = FalseMatchDraws(false_pick, wrong_index, sign_pick)
    false_rates = FalseMatchRates(rates._inner_bins, rates._false_rate, rates._false_error)
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
        image = pieces[k]
        draw = rng.standard_normal((3, image.edge.size))
        *fit, contrast = image_fits_loop(
            image, draw, found_edges, false_draws, false_rates, scalars, k == 1
        )
        out.append(_image_segments(rig, fit, image.polarity, contrast, image.greys, lines))
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


def surrogate_ground_lines(
    edges: SceneEdges,
    rig: StereoRig,
    head: HeadPose,
    rng: np.random.Generator,
    options: SegmentOptions | None = None,
    ground_options: GroundLineOptions | None = None,
) -> FloatArray:
    """The near-horizontal lines the stereo's extraction would find where the faces ``head``
    sees meet the floor, (k, 2, 2) px in the left image, with their pixel error drawn from
    ``rng`` (step 7 of the module docstring)."""
    opts = _SEGMENT_OPTIONS if options is None else options
    gopts = _GROUND_OPTIONS if ground_options is None else ground_options
    lines = visible_ground_lines(edges, head, rig, max_range_m=gopts.ground_range_m)
    lines = lines + rng.normal(scale=gopts.end_sigma_px, size=lines.shape)
    d = lines[:, 1] - lines[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    flat = np.abs(d[:, 1]) < opts.sin_min_angle * length
    out: FloatArray = lines[flat & (length >= opts.min_length_px)]
    return out


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
    ground_lines: bool = False,
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
        close_faces: Close the "gaps" that are plain faces
            (:func:`modeling.stereo.faces.close_faces`).
        ground_lines: Add the floor segments of the lowest near-horizontal lines, as the
            stereo's ``ground_lines`` does (step 7 of the module docstring; draws from ``rng``
            after every other draw, so the rest of the view is the same with it off).
        rates: The stereo's measured rates (default: :func:`default_rates`).
        stopwatch: If given, its laps ``segments``, ``matching``, ``triangulation`` and
            ``modeling`` are added to, as :func:`~stereo_nav_env.perception.stereo.perceive` does.

    Returns:
        The :class:`~stereo_nav_env.perception.stereo.ComparableModel`.
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
    if ground_lines:
        floor = add_line_ground_segments(
            surrogate_ground_lines(edges, rig, head_pose, rng),
            floor,
            rig,
            head_pose,
            _GROUND_OPTIONS,
        )
    watch.lap("triangulation")
    model = ComparableModel.of(
        build_model(floor, robot_width_m, eps=eps, max_situations=max_situations)
    )
    watch.lap("modeling")
    return model


class SurrogatePerception(Perception):
    """``perception="surrogate"``: the floor observation from the true scene and the stereo's
    error model, then the same model stages (module doc). Renders nothing; the scene's edges are
    made once per scene."""

    name = PerceptionName.SURROGATE

    def __init__(self, config: EnvConfig) -> None:
        super().__init__(config)
        self._edges: tuple[Scene, SceneEdges] | None = None

    def perceive(
        self, scene: Scene, head_pose: HeadPose, rng: np.random.Generator, watch: Stopwatch
    ) -> ComparableModel:
        """The surrogate's model of the view (:meth:`Perception.perceive`)."""
        if self._edges is None or self._edges[0] is not scene:
            self._edges = (scene, SceneEdges.of(scene))
        return perceive_surrogate(
            self._edges[1],
            self.config.rig,
            head_pose,
            rng,
            stopwatch=watch,
            ground_lines=self.config.ground_lines,
            **self.model_settings(),
        )
