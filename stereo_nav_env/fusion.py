"""The env's episode memory (issue 16): how each view and each contact is fused.

:func:`memory_options` derives the :class:`~modeling.memory.fusion.MemoryOptions` from the env's
configuration; :func:`fuse_view` folds one single-view model and the step's contacts into the
memory; :func:`memory_model_of` builds the fused :class:`~modeling.model.records.EnvironmentModel`.
Frames: world, metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from modeling.memory.fusion import ModelMemory, add_contact, build_memory_model, fuse
from modeling.memory.options import MemoryOptions
from modeling.model.build import ModelCache
from modeling.model.records import EnvironmentModel
from modeling.stereo.segments import SegmentOptions
from stereo_nav_env.config import EnvConfig
from stereo_nav_env.sim.world import Contact

__all__ = ["fuse_view", "memory_model_of", "memory_options"]


def memory_options(config: EnvConfig) -> MemoryOptions:
    """How the env fuses views (:class:`~modeling.memory.fusion.MemoryOptions`): the defaults, with
    the level head's vertical limit, so that the memory does not count as seen what lies below the
    image's lower edge (a point of height ``h`` nearer than ``(head_height_m - h) /
    tan(half_vfov_rad)``: the floor within 1.73 m with the defaults), and judges a segment in view
    or not at its own height; and with the segment stereo's angle limit
    (``SegmentOptions.min_angle_deg``), so that a segment imaged along the rows, which the stereo
    cannot match, does not fade where its floor is seen free."""
    camera = config.camera
    return MemoryOptions(
        head_height_m=config.world.head_height_m,
        half_vfov_rad=math.atan((camera.height_px / 2.0) / camera.focal_px),
        min_image_angle_deg=SegmentOptions().min_angle_deg,
    )


def fuse_view(
    memory: ModelMemory,
    model: EnvironmentModel,
    contacts: Sequence[Contact],
    config: EnvConfig,
    options: MemoryOptions,
) -> ModelMemory:
    """``memory`` with the floor observation of ``model`` fused in, then each contact (a bump as
    high as the robot) added."""
    memory = fuse(memory, model.observation, options)
    for contact in contacts:
        memory = add_contact(
            memory,
            contact.point_xy,
            contact.normal_xy,
            height_m=config.world.robot_height_m,
            options=options,
        )
    return memory


def memory_model_of(
    memory: ModelMemory, config: EnvConfig, *, cache: ModelCache | None = None
) -> EnvironmentModel:
    """The fused model of ``memory`` for the env's robot width, ``eps`` and situation limit
    (``cache``: the last call's intermediate results, :class:`~modeling.model.build.ModelCache`;
    the same model with or without it)."""
    return build_memory_model(
        memory,
        config.world.robot_width_m,
        eps=config.eps,
        max_situations=config.model_max_situations,
        cache=cache,
    )
