"""Pure perception and modeling core after Miura, ICRA-94.

Segment-based stereo with uncertainty, floor projection, obstacles and free spaces, critical
regions, occlusion and the enumeration of possible situations. Depends on numpy, scipy, shapely,
networkx and (for segment extraction only) OpenCV and Numba; never on gymnasium, pymunk, pyrender
or torch.

Public names are imported lazily so that ``import modeling`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS: dict[str, str] = {
    "StereoRig": "modeling.rig",
    "HeadPose": "modeling.rig",
    "FloorSegment": "modeling.observation",
    "AmbiguousSegment": "modeling.observation",
    "FloorObservation": "modeling.observation",
    "ImageSegments": "modeling.segments",
    "extract_segments": "modeling.segments",
    "extract_segment_pair": "modeling.segments",
    "SegmentOptions": "modeling.segments",
    "MatchOptions": "modeling.matching",
    "TriangulationOptions": "modeling.triangulation",
    "FaceOptions": "modeling.faces",
    "ModelOptions": "modeling.model",
    "StereoMatches": "modeling.matching",
    "match_segments": "modeling.matching",
    "triangulate_to_floor": "modeling.triangulation",
    "close_faces": "modeling.faces",
    "gap_passable_probability": "modeling.gaps",
    "Relation": "modeling.gaps",
    "classify_gap": "modeling.gaps",
    "build_model": "modeling.model",
    "EnvironmentModel": "modeling.records",
    "Situation": "modeling.records",
    "Obstacle": "modeling.records",
    "CriticalRegion": "modeling.records",
    "Passage": "modeling.records",
    "model_from_stereo": "modeling.pipeline",
    "MemoryOptions": "modeling.memory",
    "ModelMemory": "modeling.memory",
    "fuse": "modeling.memory",
    "add_contact": "modeling.memory",
    "build_memory_model": "modeling.memory",
}

__all__ = [
    "AmbiguousSegment",
    "CriticalRegion",
    "EnvironmentModel",
    "FaceOptions",
    "FloorObservation",
    "FloorSegment",
    "HeadPose",
    "ImageSegments",
    "MatchOptions",
    "MemoryOptions",
    "ModelMemory",
    "ModelOptions",
    "Obstacle",
    "Passage",
    "Relation",
    "SegmentOptions",
    "Situation",
    "StereoMatches",
    "StereoRig",
    "TriangulationOptions",
    "add_contact",
    "build_memory_model",
    "build_model",
    "classify_gap",
    "close_faces",
    "extract_segment_pair",
    "extract_segments",
    "fuse",
    "gap_passable_probability",
    "match_segments",
    "model_from_stereo",
    "triangulate_to_floor",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from modeling.faces import FaceOptions, close_faces
    from modeling.gaps import Relation, classify_gap, gap_passable_probability
    from modeling.matching import MatchOptions, StereoMatches, match_segments
    from modeling.memory import (
        MemoryOptions,
        ModelMemory,
        add_contact,
        build_memory_model,
        fuse,
    )
    from modeling.model import ModelOptions, build_model
    from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
    from modeling.pipeline import model_from_stereo
    from modeling.records import CriticalRegion, EnvironmentModel, Obstacle, Passage, Situation
    from modeling.rig import HeadPose, StereoRig
    from modeling.segments import (
        ImageSegments,
        SegmentOptions,
        extract_segment_pair,
        extract_segments,
    )
    from modeling.triangulation import TriangulationOptions, triangulate_to_floor


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'modeling' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
