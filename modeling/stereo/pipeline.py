"""End-to-end helpers: from a stereo pair to a floor observation and to an environment model.

``stereo_to_floor`` chains segment extraction (``modeling.stereo.segments``), matching
(``modeling.stereo.matching``), triangulation (``modeling.stereo.triangulation``) and, unless
``close_faces=False``, the floor segments of plain faces (``modeling.stereo.faces``) and, with
``ground_lines=True``, those of the lowest near-horizontal lines (``modeling.stereo.ground_lines``);
:func:`modeling.pipeline.model_from_stereo` continues with the model stages.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.observation import FloorObservation
from modeling.stereo.faces import FaceOptions
from modeling.stereo.faces import close_faces as close_faces_of
from modeling.stereo.ground_lines import GroundLineOptions, add_ground_lines
from modeling.stereo.matching import MatchOptions, match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import SegmentOptions, extract_segment_pair
from modeling.stereo.triangulation import TriangulationOptions, triangulate_to_floor
from modeling.validation import field_names, instance, reject_unknown, with_overrides

__all__ = ["STEREO_STAGES", "route_options", "stereo_to_floor", "to_gray"]


# Each stage's options dataclass, by stage name. A flat keyword goes to every stage that has a
# field of its name (``max_height_m`` bounds both the triangulation's band and the faces' tops).
STEREO_STAGES: dict[str, type[Any]] = {
    "segments": SegmentOptions,
    "matching": MatchOptions,
    "triangulation": TriangulationOptions,
    "faces": FaceOptions,
    "ground_lines": GroundLineOptions,
}


def route_options(kw: Mapping[str, Any], stages: Mapping[str, type[Any]]) -> dict[str, Any]:
    """One options instance per stage from flat keywords (each key to every stage naming it).

    Raises:
        ValueError: A key no stage has (every unknown key named, with the closest known one and
            all the known ones, :func:`~modeling.validation.reject_unknown`), or a bad
            value (the dataclass names it).
    """
    reject_unknown(kw, frozenset().union(*(field_names(cls) for cls in stages.values())))
    return {
        name: with_overrides(None, cls, {k: v for k, v in kw.items() if k in field_names(cls)})
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
        close_faces: Add the floor segments of plain faces
            (:func:`modeling.stereo.faces.close_faces`,
            as the env does by default); ``False``: the paper's pipeline alone.
        ground_lines: Add the floor segments of the lowest near-horizontal lines
            (:func:`modeling.stereo.ground_lines.add_ground_lines`; off by default).
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
