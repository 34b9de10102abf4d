"""End-to-end helpers: from a stereo pair to a floor observation and to an environment model.

``stereo_to_floor`` chains segment extraction (``modeling.segments``), matching
(``modeling.matching``), triangulation (``modeling.triangulation``) and, unless
``close_faces=False``, the floor segments of plain faces (``modeling.faces``) and, with
``ground_lines=True``, those of the lowest near-horizontal lines (``modeling.ground_lines``);
``model_from_stereo`` continues with ``modeling.model.build_model``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.faces import FaceOptions
from modeling.faces import close_faces as close_faces_of
from modeling.ground_lines import GroundLineOptions, add_ground_lines
from modeling.matching import MatchOptions, match_segments
from modeling.observation import FloorObservation
from modeling.rig import HeadPose, StereoRig
from modeling.segments import SegmentOptions, extract_segment_pair
from modeling.triangulation import TriangulationOptions, triangulate_to_floor
from modeling.validation import instance, positive, with_overrides

if TYPE_CHECKING:  # pragma: no cover
    from modeling.model import EnvironmentModel

__all__ = ["STEREO_STAGES", "model_from_stereo", "route_options", "stereo_to_floor", "to_gray"]


# Each stage's options dataclass, by stage name. A flat keyword goes to every stage that has a
# field of its name (``max_height_m`` bounds both the triangulation's band and the faces' tops).
STEREO_STAGES: dict[str, type[Any]] = {
    "segments": SegmentOptions,
    "matching": MatchOptions,
    "triangulation": TriangulationOptions,
    "faces": FaceOptions,
    "ground_lines": GroundLineOptions,
}


def _fields(cls: type[Any]) -> frozenset[str]:
    return frozenset(f.name for f in dataclasses.fields(cls))


def route_options(kw: Mapping[str, Any], stages: Mapping[str, type[Any]]) -> dict[str, Any]:
    """One options instance per stage from flat keywords (each key to every stage naming it).

    Raises:
        ValueError: A key no stage has (every unknown key named, with the known ones), or a bad
            value (the dataclass names it).
    """
    known = frozenset().union(*(_fields(cls) for cls in stages.values()))
    unknown = sorted(set(kw) - known)
    if unknown:
        raise ValueError(f"unknown option(s) {unknown}; known: {sorted(known)}")
    return {
        name: with_overrides(None, cls, {k: v for k, v in kw.items() if k in _fields(cls)})
        for name, cls in stages.items()
    }


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


def stereo_to_floor(
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    close_faces: bool = True,
    ground_lines: bool = False,
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
        ground_lines: Add the floor segments of the lowest near-horizontal lines
            (:func:`modeling.ground_lines.add_ground_lines`; off by default).
        on_stage: Called with ``"segments"``, ``"matching"`` and ``"triangulation"`` (faces
            included) as each stage ends, e.g. to time them.
        **kw: Fields of the stage options (:data:`STEREO_STAGES`): ``SegmentOptions`` (e.g.
            ``bias_sigma_px``), ``MatchOptions`` (e.g. ``rel_peak``), ``TriangulationOptions``
            (``min_height_m``, ``max_height_m``), ``FaceOptions`` and ``GroundLineOptions``.

    Returns:
        The ``FloorObservation``.

    Raises:
        ValueError: images of the wrong dtype/shape (naming ``left`` or ``right``), images whose
            size differs from the rig's, or unknown options.
    """
    gl = to_gray(left, "left")
    gr = to_gray(right, "right")
    instance(rig, StereoRig, "rig")
    want = (rig.height_px, rig.width_px)
    if gl.shape != want:
        raise ValueError(f"left must be {want[0]}x{want[1]} pixels (the rig's), got {gl.shape}")
    if gr.shape != want:
        raise ValueError(f"right must be {want[0]}x{want[1]} pixels (the rig's), got {gr.shape}")
    opts = route_options(kw, STEREO_STAGES)
    if not isinstance(close_faces, bool):
        raise ValueError(f"close_faces must be a bool, got {close_faces!r}")
    if not isinstance(ground_lines, bool):
        raise ValueError(f"ground_lines must be a bool, got {ground_lines!r}")
    stage_done = on_stage if on_stage is not None else _no_op
    segs_l, segs_r = extract_segment_pair(gl, gr, opts["segments"], rig=rig)
    stage_done("segments")
    matches = match_segments(segs_l, segs_r, rig, opts["matching"])
    stage_done("matching")
    floor = triangulate_to_floor(matches, rig, head_pose, opts["triangulation"])
    if close_faces:
        floor = close_faces_of(segs_l, floor, opts["faces"])
    if ground_lines:
        floor = add_ground_lines(segs_l, floor, rig, head_pose, opts["ground_lines"])
    stage_done("triangulation")
    return floor


def _no_op(_: str) -> None:
    pass


# ---------------------------------------------------------------------------------------------
# model_from_stereo: stereo_to_floor(...) -> build_model(...)
# ---------------------------------------------------------------------------------------------
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
        **kw: Options of the stereo stages (those of :func:`stereo_to_floor`, e.g.
            ``rel_peak``, ``min_height_m``, ``close_faces``) and fields of
            :class:`~modeling.model.ModelOptions` (``eps``, ``max_situations``,
            ``min_isolated_3d_length_m``, ``outline_buffer_m``), each passed to its own stage.

    Returns:
        The :class:`~modeling.model.EnvironmentModel` (world frame, metres).

    Raises:
        ValueError: an unknown option (all of them are named), or any bad input of the stages
            (naming it).
    """
    from modeling.model import ModelOptions, build_model  # the stereo stages do not need it

    positive(robot_width_m, "robot_width_m")  # fail before the stereo work
    model_keys = _fields(ModelOptions)
    known = model_keys.union(
        {"close_faces", "ground_lines"}, *(_fields(c) for c in STEREO_STAGES.values())
    )
    unknown = sorted(set(kw) - known)
    if unknown:
        raise ValueError(
            f"unknown option(s) {unknown} of model_from_stereo; known: {sorted(known)}"
        )
    model_options = with_overrides(
        None, ModelOptions, {k: v for k, v in kw.items() if k in model_keys}
    )
    stereo_kw = {k: v for k, v in kw.items() if k not in model_keys}
    observation = stereo_to_floor(left_rgb, right_rgb, rig, head_pose, **stereo_kw)
    return build_model(observation, robot_width_m, model_options)
