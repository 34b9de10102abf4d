"""The truth perception: the true visible outlines of the scene, the upper bound of perception.

``perception="truth"`` (issue 43) renders nothing. Its floor observation holds what a perfect
sensor on the head would give the model stages: the parts of the true outlines that the head
sees, with no error, no spread and no ambiguity (issue 16's experiment added these outlines to
the surrogate's views). Each view (:func:`true_floor_observation`):

1. Every side of every rendered part (:class:`~stereo_nav_env.sim.scenes.BoxPart`: walls, boxes,
   table and chair legs, tops and seats, shelf boards) whose height range meets the band between
   ``min_height_m`` and the robot's height, and whose outer face turns to the head, is sampled
   every ``step_m`` or less (:class:`SceneSides`).
2. A sample is seen where it lies in both images' columns and the rig's depth range
   (:func:`~stereo_nav_env.perception.surrogate.visibility.in_both_images`) and some height of
   its side within the band and the image's rows is hidden by no part: the surrogate's
   visibility sweep (:func:`~stereo_nav_env.perception.surrogate.visibility.seen_heights`,
   which takes the parts' heights into account: a low box hides the bottom of a wall, not its
   top).
3. Each run of seen samples along a side gives one floor segment on the side, from half a
   sample step before its first sample to half a step after its last (clipped to the side),
   with the heights seen as its ``height_m`` and the covariance
   :func:`~modeling.observation.negligible_covariance` (a zero one is refused:
   :data:`~modeling.observation.NEGLIGIBLE_STD_M`, 1 micrometre).

The same model stages follow (:func:`modeling.model.build.build_model`). Nothing is drawn from
the generator: the model of a view is a function of the scene and the head pose. Like the
surrogate's sweep, the visibility assumes a level head (``tilt_rad`` 0, the default).

Frames and units: world metres, floor plane x-y, z up; camera depth ``Z`` along the optical
axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from modeling.observation import FloorObservation, FloorSegment, negligible_covariance
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import FloatArray, IntArray
from modeling.validation import number
from stereo_nav_env.perception.base import ComparableModel, Perception, PerceptionName, Stopwatch
from stereo_nav_env.perception.surrogate.visibility import (
    SceneEdges,
    camera_xz,
    in_both_images,
    seen_heights,
)
from stereo_nav_env.sim.scenes import Scene

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = ["SceneSides", "TruthPerception", "true_floor_observation"]

STEP_M = 0.02
"""The longest step between the samples of a side, metres."""


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class SceneSides:
    """The footprint sides of a scene's rendered parts, one row each (world frame, metres).

    Attributes:
        start: (S, 2) first corner of each side (the part's counter-clockwise order).
        end: (S, 2) its second corner.
        normal: (S, 2) outward unit normal.
        part: (S,) its part, an index into the parts of
            :class:`~stereo_nav_env.perception.surrogate.visibility.SceneEdges` (obstacles in
            order, their parts in order).
        z_min: (S,) bottom of its part, metres. ``z_max``: (S,) top.
    """

    start: FloatArray
    end: FloatArray
    normal: FloatArray
    part: IntArray
    z_min: FloatArray
    z_max: FloatArray

    @classmethod
    def of(cls, scene: Scene) -> SceneSides:
        """The sides of every part of ``scene``'s obstacles."""
        start, end, part, z_min, z_max = [], [], [], [], []
        p = 0
        for ob in scene.obstacles:
            for bp in ob.parts:
                fp = np.asarray(bp.footprint, dtype=np.float64)
                start.append(fp)
                end.append(np.roll(fp, -1, axis=0))
                part.append(np.full(fp.shape[0], p))
                z_min.append(np.full(fp.shape[0], bp.z_min_m))
                z_max.append(np.full(fp.shape[0], bp.z_max_m))
                p += 1
        if not start:
            empty = np.zeros((0, 2))
            return cls(
                start=empty,
                end=empty,
                normal=empty,
                part=np.zeros(0, np.int64),
                z_min=np.zeros(0),
                z_max=np.zeros(0),
            )
        a, b = np.concatenate(start), np.concatenate(end)
        side = b - a
        normal = np.stack([side[:, 1], -side[:, 0]], axis=1)  # outward: counter-clockwise parts
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        return cls(
            start=a,
            end=b,
            normal=normal,
            part=np.concatenate(part).astype(np.int64),
            z_min=np.concatenate(z_min),
            z_max=np.concatenate(z_max),
        )


def true_floor_observation(
    edges: SceneEdges,
    sides: SceneSides,
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    min_height_m: float = 0.05,
    max_height_m: float,
    step_m: float = STEP_M,
) -> FloorObservation:
    """The true visible outlines from ``head_pose`` as a floor observation (the module doc).

    Args:
        edges: The scene's parts (:meth:`SceneEdges.of`: what hides).
        sides: The scene's sides (:meth:`SceneSides.of` of the same scene).
        rig: The stereo rig whose view is taken.
        head_pose: Pose of the left optical centre (level).
        min_height_m: Lowest height that is an obstacle, metres.
        max_height_m: Highest (the robot's height), metres.
        step_m: Longest step between the samples of a side, metres.

    Returns:
        One :class:`~modeling.observation.FloorSegment` per seen run of a side (``source``: the
        side's index in ``sides``), no ambiguous segment; viewpoint ``(x, y, heading)`` of the
        head, the rig's field of view and range.

    Raises:
        ValueError: A height band that is empty or a ``step_m`` that is not positive.
    """
    low_band = number(min_height_m, "min_height_m", low=0.0, strict=False)
    high_band = number(max_height_m, "max_height_m", low=low_band)
    step = number(step_m, "step_m", low=0.0)
    head_xy = np.array([head_pose.x_m, head_pose.y_m])
    mid = 0.5 * (sides.start + sides.end)
    facing = np.einsum("si,si->s", sides.normal, head_xy - mid) > 0.0
    in_band = (sides.z_min < high_band) & (sides.z_max > low_band)
    chosen = np.flatnonzero(facing & in_band)
    a, b = sides.start[chosen], sides.end[chosen]
    length = np.hypot(*(b - a).T)
    count = np.maximum(np.ceil(length / step), 1.0).astype(np.int64)
    side_of = np.repeat(np.arange(chosen.size), count)  # one row per sample
    first = np.cumsum(count) - count
    index = np.arange(side_of.size) - first[side_of]  # the sample's index along its side
    t = (index + 0.5) / count[side_of]
    points = a[side_of] + t[:, None] * (b - a)[side_of]
    X, Z = camera_xz(points, head_pose)
    ok = in_both_images(X, Z, rig, 0.0)
    f, cy, Hh = rig.focal_px, rig.principal_point_px[1], head_pose.height_m
    Zs = np.where(ok, Z, 1.0)
    # the heights inside the image's rows at this depth (v = cy + f (Hh - z) / Z)
    z_img_low = Hh - (rig.height_px - 0.5 - cy) * Zs / f
    z_img_high = Hh + (cy + 0.5) * Zs / f
    rows = chosen[side_of]
    low = np.maximum.reduce([sides.z_min[rows], np.full(rows.size, low_band), z_img_low])
    high = np.minimum.reduce([sides.z_max[rows], np.full(rows.size, high_band), z_img_high])
    look = np.flatnonzero(ok & (high > low))
    seen_low, seen_high = seen_heights(
        edges, head_pose, points[look], sides.part[rows[look]], low[look], high[look]
    )
    seen = np.zeros(side_of.size, dtype=bool)
    seen[look] = seen_high > seen_low
    # the seen heights of each seen sample (+-inf elsewhere: no part in a run's extremes)
    bottom, top = np.full(side_of.size, np.inf), np.full(side_of.size, -np.inf)
    bottom[look] = np.where(seen[look], seen_low, np.inf)
    top[look] = np.where(seen[look], seen_high, -np.inf)
    segments = _runs(sides, chosen, side_of, index, count, seen, bottom, top)
    return FloorObservation(
        segments=segments,
        viewpoint=np.array([head_pose.x_m, head_pose.y_m, head_pose.heading_rad]),
        fov_rad=rig.hfov_rad,
        max_range_m=rig.max_depth_m,
    )


def _runs(
    sides: SceneSides,
    chosen: IntArray,
    side_of: IntArray,
    index: IntArray,
    count: IntArray,
    seen: np.ndarray,
    bottom: FloatArray,
    top: FloatArray,
) -> tuple[FloorSegment, ...]:
    """One segment per run of seen samples (``seen``, in side order) along each side: from half
    a step before its first sample to half a step after its last, with the lowest and highest
    seen heights of the run (``bottom``, ``top``: +-inf where a sample is not seen, so that a
    reduction from one run's start to the next's takes the run's own)."""
    new_side = np.r_[True, side_of[1:] != side_of[:-1]]
    starts = np.flatnonzero(seen & (new_side | ~np.r_[False, seen[:-1]]))
    last_of_side = np.r_[side_of[1:] != side_of[:-1], True]
    stops = np.flatnonzero(seen & (last_of_side | ~np.r_[seen[1:], False]))
    if starts.size == 0:
        return ()
    k = side_of[starts]
    side = chosen[k]
    a, b = sides.start[side], sides.end[side]
    t0 = index[starts] / count[k]
    t1 = (index[stops] + 1.0) / count[k]
    ends = np.stack([a + t0[:, None] * (b - a), a + t1[:, None] * (b - a)], axis=1)
    # the lowest and highest seen heights of each run (runs are contiguous rows)
    heights = np.stack(
        [np.minimum.reduceat(bottom, starts), np.maximum.reduceat(top, starts)], axis=1
    )
    cov = np.broadcast_to(negligible_covariance(), (side.size, 2, 2, 2))
    return FloorSegment.stack(ends, cov, heights, side.astype(np.int64))


class TruthPerception(Perception):
    """``perception="truth"``: the true visible outlines, no spread, no ambiguity, then the same
    model stages (module doc). Renders nothing; the scene's parts and sides are made once per
    scene. Laps ``triangulation`` (the outlines) and ``modeling``."""

    name = PerceptionName.TRUTH

    def __init__(self, config: EnvConfig) -> None:
        super().__init__(config)
        self._scene: tuple[Scene, SceneEdges, SceneSides] | None = None

    def perceive(
        self, scene: Scene, head_pose: HeadPose, rng: np.random.Generator, watch: Stopwatch
    ) -> ComparableModel:
        """The model of the true visible outlines (:meth:`Perception.perceive`; ``rng`` is not
        drawn from)."""
        if self._scene is None or self._scene[0] is not scene:
            self._scene = (scene, SceneEdges.of(scene), SceneSides.of(scene))
        _, edges, sides = self._scene
        settings = self.model_settings()
        floor = true_floor_observation(
            edges,
            sides,
            self.config.rig,
            head_pose,
            max_height_m=settings["robot_height_m"],
        )
        watch.lap("triangulation")
        return self.model_of(floor, watch)
