"""The surrogate perception: the environment model from the true scene and the stereo error model.

``perception="surrogate"`` (:class:`~stereo_nav_env.config.EnvConfig`) renders nothing. From the
true scene as seen from the head it builds what segment stereo would have found, and hands it to
the *same* modeling code as the stereo pipeline (:func:`modeling.pipeline.stereo_to_floor`'s
stages after the segment extraction, then :func:`modeling.model.build_model`):

1. The edges the pipeline could see (:mod:`.surrogate_visibility`): the vertical edges of the
   rendered parts in the field of view and range, facing the head, not occluded (the sweep over
   the parts' footprints with their heights), each with its seen run of rows; and the image lines
   of the floor sides of the parts, for the faces.
2. Missed edges: each is dropped with the miss rate of its depth bin and its kind (a wall's or
   a box's corner, or furniture's), measured on the stereo pipeline (:class:`SurrogateRates`,
   ``data/surrogate_rates.json``, written by ``scripts/measure_surrogate.py``). A few found
   edges get a stray second candidate (the stereo's ambiguity beyond the repeated edges).
3. Idealised image segments of both images (:class:`~modeling.segments.ImageSegments`), one per
   seen edge, with the least-squares error model of :mod:`modeling.segments`: a fit of ``n`` rows
   with per-point variance ``sigma_px^2`` and the common bias ``bias_sigma_px^2``
   (``SegmentOptions``). The segments' columns are drawn from that model (the fitted line's
   offset ``N(0, s^2 / n)``, slope ``N(0, s^2 / S_vv)``, bias ``N(0, bias^2)``), scaled by the
   measured ``error_scale`` (the stereo's actual error over its stated one). A false match moves
   the right segment by a disparity error drawn from the measured ones (its rate by depth bin).
   Each segment carries grey levels of its look-alike group only: the edges of one group
   (the same corner of a shelf's sides and dividers, of a table's legs) can match each other, no
   others can.
4. :func:`modeling.matching.match_segments` on those segments: the matcher's own candidates
   (epipolar overlap, disparity range) and its local disparity histograms decide. A repeated edge
   (a bookshelf front) gets its candidates at the other repeated edges' disparities, with the
   probabilities of the histogram's peaks (Eq. 1); an edge alone is certain.
5. :func:`modeling.triangulation.triangulate_to_floor` (the covariances: the depth standard
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
from dataclasses import dataclass
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
from stereo_nav_env.perception import ComparableModel, Stopwatch
from stereo_nav_env.surrogate_visibility import SceneEdges, visible_edges, visible_floor_lines

__all__ = [
    "RATES_FILE",
    "SurrogateRates",
    "default_rates",
    "perceive_surrogate",
    "surrogate_segments",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

RATES_FILE = "surrogate_rates.json"
"""The measured rates, in ``stereo_nav_env/data`` (written by ``scripts/measure_surrogate.py``)."""
_GROUP_GREY = 50.0
"""Grey-level step between look-alike groups: above the matcher's photometric tolerances."""


@dataclass(frozen=True, slots=True, kw_only=True)
class SurrogateRates:
    """How the stereo pipeline departs from the ideal, measured against the ground truth.

    Attributes:
        depth_bins_m: (k + 1,) edges of the depth bins, metres, increasing.
        miss_rate_plain: (k,) probability that a seen corner of a wall or a box is not found
            (imaged by no matched segment), per depth bin.
        miss_rate_furniture: (k,) the same for the edges of furniture (legs, shelf sides and
            dividers: thin, close together, often merged or missed).
        false_match_rate: (k,) probability that a found edge is matched at a wrong disparity
            (more than 1 px off), per depth bin.
        false_error_px: The absolute disparity errors of the measured false matches, px (> 1);
            a false match draws one of them, with a random sign.
        stray_rate: (k,) probability that a found edge also gets a stray candidate (the
            stereo's ambiguity beyond the repeated edges the surrogate knows), per depth bin.
        stray_offset_px: The disparity offsets of the stray candidates, px; one is drawn, with a
            random sign.
        error_scale: The stereo's actual column errors over the error model's standard
            deviation (1: the model is exact), > 0.
    """

    depth_bins_m: tuple[float, ...]
    miss_rate_plain: tuple[float, ...]
    miss_rate_furniture: tuple[float, ...]
    false_match_rate: tuple[float, ...]
    false_error_px: tuple[float, ...]
    stray_rate: tuple[float, ...]
    stray_offset_px: tuple[float, ...]
    error_scale: float

    def __post_init__(self) -> None:
        bins = np.asarray(self.depth_bins_m, dtype=np.float64)
        k = bins.size - 1
        if k < 1 or not np.all(np.diff(bins) > 0) or not np.all(np.isfinite(bins)):
            raise ValueError(f"depth_bins_m must increase, got {self.depth_bins_m!r}")
        for name in ("miss_rate_plain", "miss_rate_furniture", "false_match_rate", "stray_rate"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.shape != (k,) or not np.all((arr >= 0) & (arr <= 1)):
                raise ValueError(f"{name} must be {k} probabilities, got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(arr.tolist()))
        for name in ("false_error_px", "stray_offset_px"):
            errors = np.asarray(getattr(self, name), dtype=np.float64)
            if (
                errors.ndim != 1
                or errors.size == 0
                or not np.all(np.isfinite(errors) & (errors > 0))
            ):
                raise ValueError(f"{name} must be positive numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(errors.tolist()))
        if not (math.isfinite(self.error_scale) and self.error_scale > 0):
            raise ValueError(f"error_scale must be positive, got {self.error_scale!r}")
        object.__setattr__(self, "depth_bins_m", tuple(bins.tolist()))
        object.__setattr__(self, "error_scale", float(self.error_scale))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SurrogateRates:
        """The rates of a dict with (at least) the attribute names as keys."""
        return cls(**{name: data[name] for name in cls.__dataclass_fields__})

    def at_depth(self, rates: tuple[float, ...], depth_m: FloatArray) -> FloatArray:
        """``rates`` (one per bin) at depths ``depth_m`` (n,) metres (clipped to the bins)."""
        k = np.searchsorted(np.asarray(self.depth_bins_m), depth_m, side="right") - 1
        out: FloatArray = np.asarray(rates)[np.clip(k, 0, len(rates) - 1)]
        return out


@functools.cache
def default_rates() -> SurrogateRates:
    """The rates in the package's ``data/surrogate_rates.json``."""
    text = importlib.resources.files("stereo_nav_env").joinpath("data", RATES_FILE).read_text()
    return SurrogateRates.from_dict(json.loads(text))


def surrogate_segments(
    edges: SceneEdges,
    rig: StereoRig,
    head: HeadPose,
    rng: np.random.Generator,
    rates: SurrogateRates,
    options: SegmentOptions | None = None,
) -> tuple[ImageSegments, ImageSegments]:
    """The idealised left and right image segments of what ``head`` sees (steps 1-3 of the
    module docstring), drawing from ``rng``; the left ones carry the floor lines as their
    near-horizontal lines."""
    opts = SegmentOptions() if options is None else options
    vis = visible_edges(edges, head, rig, trim_px=opts.trim_px, min_length_px=opts.min_length_px)
    miss = np.where(
        edges.corner_plain[vis.corner],
        rates.at_depth(rates.miss_rate_plain, vis.Z),
        rates.at_depth(rates.miss_rate_furniture, vis.Z),
    )
    found = np.flatnonzero(rng.random(len(vis)) >= miss)
    n = found.size
    Z, u = vis.Z[found], vis.u[found]
    v0, v1 = vis.v_top[found], vis.v_bottom[found]
    group = vis.group[found]
    rows = np.floor(v1 - v0) + 1.0
    s_vv = rows * (rows * rows - 1.0) / 12.0
    point_var = np.full(n, rig.sigma_px**2)
    bias_var = np.full(n, opts.bias_sigma_px**2)
    # the fitted line's errors, left and right image: offset, slope, common bias
    draw = rng.standard_normal((2, 3, n)) * rates.error_scale
    offset = draw[:, 0] * np.sqrt(point_var / rows) + draw[:, 2] * np.sqrt(bias_var)
    slope = draw[:, 1] * np.sqrt(point_var / s_vv)
    false = rng.random(n) < rates.at_depth(rates.false_match_rate, Z)
    wrong = np.asarray(rates.false_error_px)[rng.integers(len(rates.false_error_px), size=n)]
    wrong *= np.where(rng.random(n) < 0.5, -1.0, 1.0)
    u_right = u - rig.fb / Z + np.where(false, wrong, 0.0)
    # stray candidates: a second right segment of the edge's look-alike group
    stray = np.flatnonzero(rng.random(n) < rates.at_depth(rates.stray_rate, Z))
    shift = np.asarray(rates.stray_offset_px)[rng.integers(len(rates.stray_offset_px), size=n)]
    shift *= np.where(rng.random(n) < 0.5, -1.0, 1.0)
    v_c = 0.5 * (v0 + v1)
    ends_v = np.stack([v0, v1], axis=1)
    grey = group.astype(np.float64) * _GROUP_GREY
    polarity = np.where(group % 2 == 0, 1, -1).astype(np.int8)
    faces = FaceOptions()
    floor_lines = visible_floor_lines(
        edges, head, rig, vis.corner[found], max_range_m=faces.max_range_m
    )
    d = floor_lines[:, 1] - floor_lines[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    flat = np.abs(d[:, 1]) < opts.sin_min_angle * length
    horizontal = floor_lines[flat & (length >= opts.min_length_px)]

    def image(centre: FloatArray, k: int, extra: IntArray, lines: FloatArray) -> ImageSegments:
        """The segments of image ``k`` (0 left, 1 right): one per found edge, then the strays
        ``extra`` (rows of the found edges, moved by their ``shift``)."""
        r = np.concatenate([np.arange(n), extra])
        u_c = centre[r] + offset[k, r]
        u_c[n:] += shift[extra]
        slope_k = slope[k, r]
        ends = np.stack(
            [u_c[:, None] + slope_k[:, None] * (ends_v[r] - v_c[r, None]), ends_v[r]], -1
        )
        return ImageSegments(
            endpoints=ends,
            u_center=u_c,
            v_center=v_c[r],
            slope=slope_k,
            point_var=point_var[r],
            n_points=rows[r].astype(np.int64),
            s_vv=s_vv[r],
            bias_var=bias_var[r],
            polarity=polarity[r],
            contrast=np.full(r.size, 30.0),
            grey_left=grey[r],
            grey_right=grey[r] + 0.5 * _GROUP_GREY,
            image_shape=(rig.height_px, rig.width_px),
            horizontal=lines,
        )

    none = np.zeros(0, dtype=np.int64)
    return image(u, 0, none, horizontal), image(u_right, 1, stray, np.zeros((0, 2, 2)))


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
