"""Pure perception and modeling core after Miura, ICRA-94.

Segment-based stereo with uncertainty, floor projection, obstacles and free spaces, critical
regions, occlusion and the enumeration of possible situations. Depends on numpy, scipy, shapely,
networkx and (for segment extraction only) OpenCV and Numba; never on gymnasium, pymunk, pyrender
or torch.

The package, by concept (docs/architecture.md):

* :mod:`modeling.stereo`: from a rectified image pair to a floor observation (paper section 3);
* :mod:`modeling.observation`: :class:`FloorObservation`, the one seam between stereo and model
  (and :func:`face_value`, an observation with its uncertainty dropped);
* :mod:`modeling.model`: from a floor observation to obstacles, critical regions, occlusion and
  situations (sections 2 and 4);
* :mod:`modeling.memory`: the fusion of observations across views (section 6);
* :mod:`modeling.pipeline`: ``model_from_stereo``, the only place stereo and model meet;
* shared helpers: :mod:`modeling.types` (array aliases), :mod:`modeling.validation` (input
  checks that raise ``ValueError`` naming the field), :mod:`modeling.geometry` (angles, frames),
  :mod:`modeling.jit` (Numba on first call), :mod:`modeling.worker` (one worker thread) and
  :mod:`modeling.plotting` (matplotlib figures of a model, imported lazily).

Public names are imported lazily so that ``import modeling`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS: dict[str, str] = {
    "StereoRig": "modeling.stereo.rig",
    "HeadPose": "modeling.stereo.rig",
    "FloorSegment": "modeling.observation",
    "AmbiguousSegment": "modeling.observation",
    "FloorObservation": "modeling.observation",
    "face_value": "modeling.observation",
    "ImageSegments": "modeling.stereo.segments",
    "extract_segments": "modeling.stereo.segments",
    "extract_segment_pair": "modeling.stereo.segments",
    "SegmentOptions": "modeling.stereo.segments",
    "MatchOptions": "modeling.stereo.matching",
    "TriangulationOptions": "modeling.stereo.triangulation",
    "FaceOptions": "modeling.stereo.faces",
    "ModelOptions": "modeling.model.build",
    "StereoMatches": "modeling.stereo.matching",
    "match_segments": "modeling.stereo.matching",
    "triangulate_to_floor": "modeling.stereo.triangulation",
    "close_faces": "modeling.stereo.faces",
    "gap_passable_probability": "modeling.model.gaps",
    "Relation": "modeling.model.gaps",
    "classify_gap": "modeling.model.gaps",
    "build_model": "modeling.model.build",
    "EnvironmentModel": "modeling.model.records",
    "Situation": "modeling.model.records",
    "Obstacle": "modeling.model.records",
    "CriticalRegion": "modeling.model.records",
    "Passage": "modeling.model.records",
    "model_from_stereo": "modeling.pipeline",
    "MemoryOptions": "modeling.memory.options",
    "ModelMemory": "modeling.memory.fusion",
    "fuse": "modeling.memory.fusion",
    "add_contact": "modeling.memory.fusion",
    "build_memory_model": "modeling.memory.fusion",
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
    "face_value",
    "fuse",
    "gap_passable_probability",
    "match_segments",
    "model_from_stereo",
    "triangulate_to_floor",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from modeling.memory.fusion import ModelMemory, add_contact, build_memory_model, fuse
    from modeling.memory.options import MemoryOptions
    from modeling.model.build import ModelOptions, build_model
    from modeling.model.gaps import Relation, classify_gap, gap_passable_probability
    from modeling.model.records import (
        CriticalRegion,
        EnvironmentModel,
        Obstacle,
        Passage,
        Situation,
    )
    from modeling.observation import (
        AmbiguousSegment,
        FloorObservation,
        FloorSegment,
        face_value,
    )
    from modeling.pipeline import model_from_stereo
    from modeling.stereo.faces import FaceOptions, close_faces
    from modeling.stereo.matching import MatchOptions, StereoMatches, match_segments
    from modeling.stereo.rig import HeadPose, StereoRig
    from modeling.stereo.segments import (
        ImageSegments,
        SegmentOptions,
        extract_segment_pair,
        extract_segments,
    )
    from modeling.stereo.triangulation import TriangulationOptions, triangulate_to_floor


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'modeling' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
