"""End-to-end helpers: from a stereo pair to a floor observation and to an environment model.

``stereo_to_floor`` chains segment extraction (``modeling.segments``), matching
(``modeling.matching``), triangulation (``modeling.triangulation``) and, unless
``close_faces=False``, the floor segments of plain faces (``modeling.faces``);
``model_from_stereo`` continues with ``modeling.model.build_model``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.faces import close_faces as close_faces_of
from modeling.matching import match_segments
from modeling.observation import FloorObservation
from modeling.rig import HeadPose, StereoRig
from modeling.segments import extract_segment_pair, extract_segments
from modeling.triangulation import TriangulationOptions, triangulate_to_floor
from modeling.validation import keyword_options, positive

if TYPE_CHECKING:  # pragma: no cover
    from modeling.model import EnvironmentModel

__all__ = ["model_from_stereo", "stereo_to_floor", "to_gray"]


def _keyword_options(fn: Callable[..., Any]) -> frozenset[str]:
    """The names of ``fn``'s keyword-only parameters (its options)."""
    return frozenset(keyword_options(fn))


# The options of each stage, read from its signature (the one place they are listed).
_EXTRACT_KEYS = _keyword_options(extract_segments)
_MATCH_KEYS = _keyword_options(match_segments)
_TRIANGULATE_KEYS = frozenset(f.name for f in dataclasses.fields(TriangulationOptions))


def to_gray(image: NDArray[np.uint8], name: str = "image") -> NDArray[np.uint8]:
    """A uint8 (H, W) grey image from a uint8 (H, W) or RGB (H, W, 3) image.

    Raises:
        ValueError: naming ``name``, for another dtype or shape.
    """
    if not isinstance(image, np.ndarray):
        raise ValueError(f"{name} must be a numpy array, got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {image.dtype}")
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 3:
        return np.asarray(cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY), np.uint8)
    raise ValueError(f"{name} must have shape (H, W) or (H, W, 3), got {image.shape}")


def split_stereo_kwargs(
    kw: dict[str, Any],
) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Split keyword options into those of extraction, matching and triangulation.

    Raises:
        ValueError: for an unknown key.
    """
    unknown = sorted(set(kw) - _EXTRACT_KEYS - _MATCH_KEYS - _TRIANGULATE_KEYS)
    if unknown:
        raise ValueError(f"unknown stereo option(s) {unknown}")
    ext = {k: v for k, v in kw.items() if k in _EXTRACT_KEYS}
    mat = {k: v for k, v in kw.items() if k in _MATCH_KEYS}
    tri = {k: v for k, v in kw.items() if k in _TRIANGULATE_KEYS}
    return ext, mat, tri


def stereo_to_floor(
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    close_faces: bool = True,
    on_stage: Callable[[str], None] | None = None,
    **kw: Any,
) -> FloorObservation:
    """Floor observation of a rectified stereo pair: extract -> match -> triangulate (-> faces).

    Args:
        left: Left image, uint8 (H, W) grey or (H, W, 3) RGB, the rig's size.
        right: Right image, same size and kind.
        rig: The stereo rig.
        head_pose: Pose of the left optical centre.
        close_faces: Add the floor segments of plain faces (:func:`modeling.faces.close_faces`,
            as the env does by default); ``False``: the paper's pipeline alone.
        on_stage: Called with ``"segments"``, ``"matching"`` and ``"triangulation"`` (faces
            included) as each stage ends, e.g. to time them.
        **kw: Options of ``extract_segments`` (e.g. ``sigma_px``), ``match_segments`` (e.g.
            ``rel_peak``) and ``triangulate_to_floor`` (``min_height_m``, ``max_height_m``).

    Returns:
        The ``FloorObservation``.

    Raises:
        ValueError: images of the wrong dtype/shape (naming ``left`` or ``right``), images whose
            size differs from the rig's, or unknown options.
    """
    gl = to_gray(left, "left")
    gr = to_gray(right, "right")
    if not isinstance(rig, StereoRig):
        raise ValueError(f"rig must be a StereoRig, got {type(rig).__name__}")
    want = (rig.height_px, rig.width_px)
    if gl.shape != want:
        raise ValueError(f"left must be {want[0]}x{want[1]} pixels (the rig's), got {gl.shape}")
    if gr.shape != want:
        raise ValueError(f"right must be {want[0]}x{want[1]} pixels (the rig's), got {gr.shape}")
    ext, mat, tri = split_stereo_kwargs(kw)
    if not isinstance(close_faces, bool):
        raise ValueError(f"close_faces must be a bool, got {close_faces!r}")
    stage_done = on_stage if on_stage is not None else _no_op
    segs_l, segs_r = extract_segment_pair(gl, gr, **ext)
    stage_done("segments")
    matches = match_segments(segs_l, segs_r, rig, **mat)
    stage_done("matching")
    floor = triangulate_to_floor(matches, rig, head_pose, **tri)
    if close_faces:
        floor = close_faces_of(segs_l, floor, max_height_m=tri.get("max_height_m", 1.0))
    stage_done("triangulation")
    return floor


def _no_op(_: str) -> None:
    pass


# ---------------------------------------------------------------------------------------------
# model_from_stereo: stereo_to_floor(...) -> build_model(...)
# ---------------------------------------------------------------------------------------------
def _model_keys() -> frozenset[str]:
    """The keyword-only options of :func:`~modeling.model.build_model`."""
    from modeling.model import build_model

    return _keyword_options(build_model)


def model_from_stereo(
    left_rgb: NDArray[np.uint8],
    right_rgb: NDArray[np.uint8],
    rig: StereoRig,
    head_pose: HeadPose,
    robot_width_m: float,
    **kw: Any,
) -> EnvironmentModel:
    """The environment model of a rectified stereo pair: :func:`stereo_to_floor`, then
    :func:`~modeling.model.build_model`.

    Args:
        left_rgb: Left image, uint8 (H, W, 3) RGB or (H, W) grey, the rig's size.
        right_rgb: Right image, same size and kind.
        rig: The stereo rig.
        head_pose: Pose of the left optical centre, world frame.
        robot_width_m: Robot width (diameter), metres, > 0.
        **kw: Options of the stereo stages (those of :func:`stereo_to_floor`, e.g. ``sigma_px``,
            ``rel_peak``, ``min_height_m``, ``close_faces``) and of ``build_model`` (``eps``,
            ``max_situations``, ``min_isolated_length_m``, ``outline_buffer_m``), each passed to
            its own stage.

    Returns:
        The :class:`~modeling.model.EnvironmentModel` (world frame, metres).

    Raises:
        ValueError: an unknown option (all of them are named), or any bad input of the stages
            (naming it).
    """
    positive(robot_width_m, "robot_width_m")  # fail before the stereo work
    model_keys = _model_keys()
    stereo_keys = _EXTRACT_KEYS | _MATCH_KEYS | _TRIANGULATE_KEYS | {"close_faces"}
    unknown = sorted(set(kw) - model_keys - stereo_keys)
    if unknown:
        raise ValueError(
            f"unknown option(s) {unknown} of model_from_stereo; stereo options are "
            f"{sorted(stereo_keys)}, model options are {sorted(model_keys)}"
        )
    model_kw = {k: v for k, v in kw.items() if k in model_keys}
    stereo_kw = {k: v for k, v in kw.items() if k in stereo_keys}
    from modeling.model import build_model  # the stereo stages alone do not need it

    observation = stereo_to_floor(left_rgb, right_rgb, rig, head_pose, **stereo_kw)
    return build_model(observation, robot_width_m, **model_kw)
