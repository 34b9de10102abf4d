"""Perception: what the robot makes of one view, behind one interface.

:class:`~stereo_nav_env.perception.base.Perception` is the protocol the environment holds: given
the scene and the head pose, it returns the :class:`~modeling.model.records.EnvironmentModel` of
the view. Implementations, named by :class:`~stereo_nav_env.perception.base.PerceptionName`:
``stereo`` (:mod:`.stereo`: render the pair, add pixel noise, run the paper's pipeline) and
``surrogate`` (:mod:`.surrogate`: the floor observation from the true scene and the stereo's
measured error model, rendering nothing).

May import: :mod:`modeling`, :mod:`stereo_nav_env.sim` (the scene) and
:mod:`stereo_nav_env.rendering` (the renderer and its shading). Never the environment, the
observation packing or the rewards.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stereo_nav_env.perception.base import Perception, PerceptionName
from stereo_nav_env.perception.stereo import StereoPerception
from stereo_nav_env.perception.surrogate.sensor import SurrogatePerception

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = ["PERCEPTIONS", "Perception", "PerceptionName", "make_perception"]

PERCEPTIONS: dict[PerceptionName, type[Perception]] = {
    PerceptionName.STEREO: StereoPerception,
    PerceptionName.SURROGATE: SurrogatePerception,
}
"""The implementation of each perception name."""


def make_perception(config: EnvConfig) -> Perception:
    """The :class:`Perception` that ``config.perception`` names, for that configuration."""
    return PERCEPTIONS[PerceptionName(config.perception)](config)
