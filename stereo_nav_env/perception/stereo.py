"""The stereo perception: render the pair, add pixel noise, run the paper's pipeline.

Each view: the scene is rendered from the head (:mod:`stereo_nav_env.rendering.renderer`), Gaussian
pixel noise of ``pixel_noise_std`` grey levels is drawn from the env's ``np_random``
(:mod:`stereo_nav_env.perception.noise`), and the modeling pipeline of ``modeling`` (Miura,
ICRA-94) runs on the noisy grey images: :func:`modeling.stereo.pipeline.stereo_to_floor`
(segments in both images, matching, floor segments with uncertainty, plain faces, optional
ground lines), each stage timed through its ``on_stage`` callback, then
:func:`modeling.model.build.build_model` (obstacles, critical regions, occlusion, situations).

:class:`StereoMeansPerception` (``perception="stereo_means"``, issue 43's ablation) is the same
with the floor observation taken at face value before the model stages
(:func:`modeling.observation.face_value`: endpoints at their means with a negligible covariance,
each ambiguous segment its most probable candidate): one situation, no undecided gap. The dense
perception (:mod:`stereo_nav_env.perception.dense`) renders the same noisy pair through
:meth:`StereoPerception.noisy_grey_pair`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

from modeling.model.build import build_model
from modeling.observation import face_value
from modeling.stereo.pipeline import stereo_to_floor, to_gray
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import UInt8Image
from modeling.worker import worker
from stereo_nav_env.perception.base import (
    ComparableModel,
    Perception,
    PerceptionName,
    StereoPair,
    Stopwatch,
)
from stereo_nav_env.perception.noise import (
    add_pixel_noise,
    draw_noise_levels,
    noise_of_levels,
    noisy_grey,
)
from stereo_nav_env.sim.scenes import Scene

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = ["StereoMeansPerception", "StereoPerception", "perceive"]


def perceive(
    left: UInt8Image,
    right: UInt8Image,
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    robot_width_m: float,
    robot_height_m: float,
    eps: float,
    max_situations: int,
    close_faces: bool = True,
    ground_lines: bool = False,
    at_face_value: bool = False,
    stopwatch: Stopwatch | None = None,
) -> ComparableModel:
    """The environment model of one rectified pair (the whole modeling pipeline).

    Args:
        left: Left image, uint8 (H, W) grey or (H, W, 3) RGB of the rig's size.
        right: Right image, the same.
        rig: The stereo rig that took the pair.
        head_pose: Pose of the left optical centre, world frame.
        robot_width_m: Robot diameter, metres (gap classification).
        robot_height_m: Floor segments are kept between 0.05 m and this height, metres.
        eps: Classification tolerance in (0, 0.5).
        max_situations: Most situations enumerated.
        close_faces: Close the "gaps" that are plain faces
            (:func:`modeling.stereo.faces.close_faces`).
        ground_lines: Add the floor segments of the lowest near-horizontal lines
            (:func:`modeling.stereo.ground_lines.add_ground_lines`).
        at_face_value: Take the floor observation at face value before the model stages
            (:func:`modeling.observation.face_value`: no spread, no ambiguity).
        stopwatch: If given, its laps ``segments``, ``matching``, ``triangulation`` and
            ``modeling`` are added to (its clock must have been lapped just before the call).

    Returns:
        The :class:`ComparableModel`.
    """
    watch = stopwatch if stopwatch is not None else Stopwatch()
    floor = stereo_to_floor(
        left,
        right,
        rig,
        head_pose,
        close_faces=close_faces,
        ground_lines=ground_lines,
        on_stage=watch.lap,
        max_height_m=robot_height_m,
    )
    if at_face_value:
        floor = face_value(floor)
    model = build_model(floor, robot_width_m, eps=eps, max_situations=max_situations)
    out = ComparableModel.of(model)
    watch.lap("modeling")
    return out


class StereoPerception(Perception):
    """``perception="stereo"``: the rendered pair through the whole pipeline (module doc).

    The clean pair and the noise's uniform draws are kept; the noisy RGB pair (the same noise on
    every channel) is made only when asked for (:meth:`stereo_pair`: the images observation,
    ``env.render_stereo()``, ``env.render()``), since the pipeline needs only the noisy grey
    images.
    """

    name = PerceptionName.STEREO
    at_face_value: ClassVar[bool] = False
    """Whether the floor observation is taken at face value before the model stages."""

    def __init__(self, config: EnvConfig) -> None:
        super().__init__(config)
        self._clean_pair: StereoPair | None = None
        self._noise_levels: NDArray[np.uint16] | None = None
        self._pair: StereoPair | None = None

    def perceive(
        self, scene: Scene, head_pose: HeadPose, rng: np.random.Generator, watch: Stopwatch
    ) -> ComparableModel:
        """Render, add noise, run the pipeline (:meth:`Perception.perceive`)."""
        left, right = self.noisy_grey_pair(scene, head_pose, rng, watch)
        return self.model_of_pair(left, right, head_pose, watch)

    def noisy_grey_pair(
        self, scene: Scene, head_pose: HeadPose, rng: np.random.Generator, watch: Stopwatch
    ) -> tuple[UInt8Image, UInt8Image]:
        """The rendered pair from ``head_pose`` with its pixel noise drawn from ``rng``, as grey
        uint8 (H, W) images (laps ``render`` and ``noise``; the RGB pair is kept for
        :meth:`stereo_pair`)."""
        cfg = self.config
        rig = cfg.rig
        sigma = cfg.camera.pixel_noise_std
        # the pixel noise is drawn in the worker thread while the pair renders (the generator
        # releases the interpreter lock; nothing else draws from rng meanwhile, so the draws are
        # those of drawing it here, before the render): about 0.4 ms a step
        draw = None
        if sigma > 0:
            draw = worker().submit(draw_noise_levels, rng, rig.height_px, rig.width_px)
        self._clean_pair = self.renderer(scene).render_stereo(head_pose)
        levels = None if draw is None else draw.result()
        watch.lap("render")
        self._noise_levels, self._pair = levels, None
        if levels is None:
            grey = [to_gray(image) for image in self._clean_pair]
        else:
            grey = [
                noisy_grey(image, lv, sigma)
                for image, lv in zip(self._clean_pair, levels, strict=True)
            ]
        watch.lap("noise")
        return grey[0], grey[1]

    def model_of_pair(
        self, left: UInt8Image, right: UInt8Image, head_pose: HeadPose, watch: Stopwatch
    ) -> ComparableModel:
        """The model of the noisy grey pair: the paper's pipeline (:func:`perceive`)."""
        cfg = self.config
        return perceive(
            left,
            right,
            cfg.rig,
            head_pose,
            ground_lines=cfg.ground_lines,
            at_face_value=self.at_face_value,
            stopwatch=watch,
            **self.model_settings(),
        )

    def stereo_pair(self) -> StereoPair | None:
        """The latest pair with its pixel noise (made on first use, then kept)."""
        if self._clean_pair is None:
            return None
        if self._pair is None:
            left, right = self._clean_pair
            if self._noise_levels is not None:
                noise = noise_of_levels(self._noise_levels, self.config.camera.pixel_noise_std)
                left = add_pixel_noise(left, noise[0])
                right = add_pixel_noise(right, noise[1])
            self._pair = (left, right)
        return self._pair


class StereoMeansPerception(StereoPerception):
    """``perception="stereo_means"``: the same rendered pair and segment stereo as
    :class:`StereoPerception`, the floor observation taken at face value before the model stages
    (:func:`modeling.observation.face_value`): every endpoint at its mean with a negligible
    covariance (:data:`modeling.observation.NEGLIGIBLE_STD_M`, 1 micrometre: a zero one is
    refused), every ambiguous segment its most probable candidate (or nothing, where "no
    obstacle here" is more probable). One situation, of probability 1; every gap passable or
    impassable."""

    name = PerceptionName.STEREO_MEANS
    at_face_value = True
