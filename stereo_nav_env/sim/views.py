"""Head poses to measure perception on: the start of seeded scenes and views of bookshelf fronts.

:func:`scene_views` yields, for seeded scenes of the standard families, the view from each
scene's start pose and, where the scene has a bookshelf, a view of its front from 1.6 to 3.2 m
(the repeated vertical edges that make stereo matching ambiguous). The stereo's accuracy
(:mod:`agents.evaluation.stereo_accuracy`) and the surrogate's calibration
(:mod:`stereo_nav_env.perception.surrogate.calibration`) measure on them.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from modeling.stereo.rig import HeadPose
from stereo_nav_env.config import WorldConfig
from stereo_nav_env.sim.scenes import STANDARD_FAMILIES, ObstacleKind, Scene, generate_scene

__all__ = ["STANDARD_FAMILIES", "SceneView", "scene_views"]

HEAD_HEIGHT_M = WorldConfig().head_height_m
"""Height of the left optical centre above the floor in every view, metres (the robot's)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class SceneView:
    """One view to measure: a scene, the head pose, its family, whether it faces a bookshelf."""

    scene: Scene
    pose: HeadPose
    family: str
    bookshelf_view: bool


def scene_views(n_scenes: int, seed: int = 0) -> Iterator[SceneView]:
    """The views of ``n_scenes`` seeded scenes, cycling :data:`STANDARD_FAMILIES`.

    Each scene gives the view from its start pose and, if it has a bookshelf, a view of the
    bookshelf's front from 1.6 to 3.2 m (up to 20 tries to find a free spot).
    """
    rng = np.random.default_rng(seed)
    for i in range(n_scenes):
        family = STANDARD_FAMILIES[i % len(STANDARD_FAMILIES)]
        scene = generate_scene(seed + i, family=family)
        x, y, h = scene.start
        pose = HeadPose(x_m=x, y_m=y, heading_rad=h, height_m=HEAD_HEIGHT_M)
        yield SceneView(scene=scene, pose=pose, family=family, bookshelf_view=False)
        shelves = [o for o in scene.obstacles if o.kind is ObstacleKind.BOOKSHELF]
        for _ in range(20):
            if not shelves:
                break
            ob = shelves[int(rng.integers(len(shelves)))]
            fp = ob.footprint
            a, b = fp[0], fp[1]
            e = b - a
            normal = np.array([e[1], -e[0]]) / np.linalg.norm(e)  # outward, front side
            dist = rng.uniform(1.6, 3.2)
            lateral = rng.uniform(-0.3, 0.3) * np.linalg.norm(e)
            p = (a + b) / 2 + normal * dist + lateral * e / np.linalg.norm(e)
            if not scene.is_free(p, 0.5, 0.0):
                continue
            heading = math.atan2(-normal[1], -normal[0]) + rng.uniform(-0.25, 0.25)
            pose = HeadPose(x_m=p[0], y_m=p[1], heading_rad=heading, height_m=HEAD_HEIGHT_M)
            yield SceneView(scene=scene, pose=pose, family=family, bookshelf_view=True)
            break
