"""Perception: what the robot makes of one view, behind one interface.

:class:`~stereo_nav_env.perception.base.Perception` is the protocol the environment holds: given
the scene and the head pose, it returns the :class:`~modeling.model.records.EnvironmentModel` of
the view. Implementations, named by :class:`~stereo_nav_env.perception.base.PerceptionName`:

* ``stereo`` (:mod:`.stereo`: render the pair, add pixel noise, run the paper's pipeline);
* ``surrogate`` (:mod:`.surrogate`: the floor observation from the true scene and the stereo's
  measured error model, rendering nothing);
* issue 43's ablation of the paper's model: ``stereo_means`` (:mod:`.stereo` too: the same
  segments taken at face value, no spread, no ambiguity), ``dense`` (:mod:`.dense`: OpenCV's
  semi-global matching into an occupancy evidence grid, its blobs' outlines as the floor
  observation) and ``truth`` (:mod:`.truth`: the true visible outlines, rendering nothing).

Beside them: :mod:`.base` (the interface, the names, content-equal models, the stopwatch) and
:mod:`.noise` (the rendered pair's pixel noise).

May import: :mod:`modeling`, :mod:`stereo_nav_env.sim` (the scene) and
:mod:`stereo_nav_env.rendering` (the renderer and its shading). Never the environment, the
observation packing or the rewards.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stereo_nav_env.perception.base import Perception, PerceptionName
from stereo_nav_env.perception.dense import DensePerception
from stereo_nav_env.perception.stereo import StereoMeansPerception, StereoPerception
from stereo_nav_env.perception.surrogate.sensor import SurrogatePerception
from stereo_nav_env.perception.truth import TruthPerception

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = ["PERCEPTIONS", "Perception", "PerceptionName", "make_perception"]

PERCEPTIONS: dict[PerceptionName, type[Perception]] = {
    PerceptionName.STEREO: StereoPerception,
    PerceptionName.SURROGATE: SurrogatePerception,
    PerceptionName.STEREO_MEANS: StereoMeansPerception,
    PerceptionName.DENSE: DensePerception,
    PerceptionName.TRUTH: TruthPerception,
}
"""The implementation of each perception name."""


def make_perception(config: EnvConfig) -> Perception:
    """The :class:`Perception` that ``config.perception`` names, for that configuration."""
    return PERCEPTIONS[PerceptionName(config.perception)](config)
