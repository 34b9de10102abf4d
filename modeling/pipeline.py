"""From a rectified stereo pair to an environment model: the stereo stages, then the model stages.

:func:`model_from_stereo` chains :func:`modeling.stereo.pipeline.stereo_to_floor` (image pair to
:class:`~modeling.observation.FloorObservation`) and :func:`modeling.model.build.build_model`
(floor observation to situations). It is the only place where :mod:`modeling.stereo` and
:mod:`modeling.model` meet.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from modeling.model.build import ModelOptions, build_model
from modeling.model.records import EnvironmentModel
from modeling.stereo.pipeline import STEREO_STAGES, stereo_to_floor
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.validation import field_names, positive, reject_unknown, with_overrides

__all__ = ["model_from_stereo"]


def model_from_stereo(
    left_rgb: NDArray[np.uint8],
    right_rgb: NDArray[np.uint8],
    rig: StereoRig,
    head_pose: HeadPose,
    robot_width_m: float,
    **kw: Any,
) -> EnvironmentModel:
    """The environment model of a rectified stereo pair: :func:`stereo_to_floor`, then
    :func:`~modeling.model.build.build_model`.

    Args:
        left_rgb: Left image, uint8 (H, W, 3) RGB or (H, W) grey, the rig's size.
        right_rgb: Right image, same size and kind.
        rig: The stereo rig.
        head_pose: Pose of the left optical centre, world frame.
        robot_width_m: Robot width (diameter), metres, > 0.
        **kw: Options of the stereo stages (those of :func:`stereo_to_floor`, e.g.
            ``rel_peak``, ``min_height_m``, ``close_faces``) and fields of
            :class:`~modeling.model.build.ModelOptions` (``eps``, ``max_situations``,
            ``min_isolated_3d_length_m``, ``outline_buffer_m``), each passed to its own stage.

    Returns:
        The :class:`~modeling.model.build.EnvironmentModel` (world frame, metres).

    Raises:
        ValueError: an unknown option (all of them are named, with the closest known one of each,
            :func:`~modeling.validation.reject_unknown`), or any bad input of the stages
            (naming it).
    """
    positive(robot_width_m, "robot_width_m")  # fail before the stereo work
    model_keys = frozenset(field_names(ModelOptions))
    known = model_keys.union(
        {"close_faces", "ground_lines"}, *(field_names(c) for c in STEREO_STAGES.values())
    )
    reject_unknown(kw, known, "model_from_stereo")
    model_options = with_overrides(
        None, ModelOptions, {k: v for k, v in kw.items() if k in model_keys}
    )
    stereo_kw = {k: v for k, v in kw.items() if k not in model_keys}
    observation = stereo_to_floor(left_rgb, right_rgb, rig, head_pose, **stereo_kw)
    return build_model(observation, robot_width_m, model_options)
