"""The perception interface: what the environment asks of a perception, and what it gets back.

The environment holds one :class:`Perception` (made by
:func:`stereo_nav_env.perception.make_perception` from ``EnvConfig.perception``, a
:class:`PerceptionName`) and never branches on which one it is. Every step it calls
:meth:`Perception.perceive` with the scene, the head pose and its ``np_random``, and gets the
environment model of the view as a :class:`ComparableModel`: an
:class:`~modeling.model.records.EnvironmentModel` whose ``==`` compares content (arrays,
geometries, nested dataclasses) instead of identity, so that two rollouts with one seed give
equal ``info`` dictionaries (Gymnasium's determinism check compares them with ``==``).
:class:`Stopwatch` times the stages of a step.
"""

from __future__ import annotations

import abc
import dataclasses
import math
import time
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from numpy.typing import NDArray

from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import FloorObservation
from modeling.stereo.rig import HeadPose
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import Scene

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = [
    "ComparableModel",
    "Perception",
    "PerceptionName",
    "StereoPair",
    "Stopwatch",
    "structurally_equal",
]

StereoPair = tuple[NDArray[np.uint8], NDArray[np.uint8]]
"""A rectified pair: left and right uint8 (H, W, 3) RGB images."""


class PerceptionName(str, Enum):
    """The perceptions of ``EnvConfig.perception`` (``gym.make(..., perception=...)``)."""

    STEREO = "stereo"
    """Render the pair, add pixel noise, run the paper's stereo pipeline and model stages."""
    SURROGATE = "surrogate"
    """Render nothing: the floor observation from the true scene and the stereo's measured error
    model, then the same model stages (issue 17)."""
    STEREO_MEANS = "stereo_means"
    """The rendered pair and segment stereo of ``stereo``, the floor observation taken at face
    value before the model stages: no spread, each ambiguous segment its most probable
    candidate, one situation (issue 43)."""
    DENSE = "dense"
    """The rendered pair through OpenCV's semi-global matching into an occupancy evidence grid,
    its blobs' outlines as the floor observation, then the same model stages (issue 43)."""
    TRUTH = "truth"
    """Render nothing: the true visible outlines of the scene as the floor observation, with no
    spread and no ambiguity, then the same model stages (issue 43)."""

    @property
    def renders_images(self) -> bool:
        """Whether this perception renders the stereo pair (the ``"images"`` and ``"both"``
        observations, ``env.render_stereo()`` and the image-line cues need it)."""
        return self in (PerceptionName.STEREO, PerceptionName.STEREO_MEANS, PerceptionName.DENSE)

    @property
    def has_image_lines(self) -> bool:
        """Whether this perception extracts image segments from the rendered pair (and with them
        the near-horizontal image lines)."""
        return self in (PerceptionName.STEREO, PerceptionName.STEREO_MEANS)

    @property
    def has_ground_lines(self) -> bool:
        """Whether ``ground_lines`` (the lowest near-horizontal image lines as floor segments,
        :mod:`modeling.stereo.ground_lines`) applies: the perceptions that extract image lines,
        and the surrogate, which imitates those lines from the true scene."""
        return self.has_image_lines or self is PerceptionName.SURROGATE


def structurally_equal(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` hold the same content (deep; NaN equals NaN).

    Compares dataclass fields, numpy arrays (shape, dtype, values), shapely geometries (their WKB),
    dicts, lists and tuples recursively, floats with NaN equal to NaN, anything else with ``==``.
    """
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if dataclasses.is_dataclass(a):
        return all(
            structurally_equal(getattr(a, f.name), getattr(b, f.name))
            for f in dataclasses.fields(a)
        )
    if isinstance(a, np.ndarray):
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype == object:
            return all(structurally_equal(x, y) for x, y in zip(a.flat, b.flat, strict=True))
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    if isinstance(a, shapely.Geometry):
        return bool(shapely.to_wkb(a) == shapely.to_wkb(b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(structurally_equal(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(structurally_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return bool(a == b)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ComparableModel(EnvironmentModel):
    """An :class:`~modeling.model.records.EnvironmentModel` compared by content (see the module
    doc)."""

    @classmethod
    def of(cls, model: EnvironmentModel) -> ComparableModel:
        """The same model (fields shared, not copied) with content equality."""
        return cls(**{f.name: getattr(model, f.name) for f in dataclasses.fields(model)})

    def __eq__(self, other: object) -> bool:
        return isinstance(other, EnvironmentModel) and structurally_equal(
            {f.name: getattr(self, f.name) for f in dataclasses.fields(self)},
            {f.name: getattr(other, f.name) for f in dataclasses.fields(other)},
        )

    __hash__ = None  # type: ignore[assignment]


class Stopwatch:
    """Wall-clock laps in milliseconds: ``lap(name)`` adds the time since the previous lap."""

    def __init__(self) -> None:
        self.laps: dict[str, float] = {}
        self._t = time.perf_counter()

    def lap(self, name: str) -> None:
        """Add the time since the last lap (or creation) to ``laps[name]``, milliseconds."""
        now = time.perf_counter()
        self.laps[name] = self.laps.get(name, 0.0) + (now - self._t) * 1e3
        self._t = now


class Perception(abc.ABC):
    """One way of turning the robot's view into an environment model.

    Subclasses implement :meth:`perceive`; those that render (``name.renders_images``) return
    their latest pair from :meth:`stereo_pair`. The renderer of the scene (for the
    pair, or for tools that render poses of their own) is made on first use, kept across resets
    and released by :meth:`close`; it does not travel through a pickle (an OpenGL context cannot).

    Args:
        config: The environment's configuration (rig, robot size, model settings, noise).
    """

    name: ClassVar[PerceptionName]

    def __init__(self, config: EnvConfig) -> None:
        self.config = config
        self._renderer: StereoRenderer | None = None

    @abc.abstractmethod
    def perceive(
        self, scene: Scene, head_pose: HeadPose, rng: np.random.Generator, watch: Stopwatch
    ) -> ComparableModel:
        """The model of the view from ``head_pose`` in ``scene``.

        Args:
            scene: The true scene (the surrogate reads it; the stereo renders it).
            head_pose: Pose of the left optical centre, world frame.
            rng: The env's ``np_random``, the only source of randomness.
            watch: Its laps (``render``, ``noise``, ``segments``, ``matching``,
                ``triangulation``, ``modeling``) are added to.
        """

    def stereo_pair(self) -> StereoPair | None:
        """The noisy rectified pair of the latest view, or ``None`` if this perception renders
        none (or has not perceived yet)."""
        return None

    def model_settings(self) -> dict[str, Any]:
        """The keywords of the model stages, the same for every perception."""
        cfg = self.config
        return {
            "robot_width_m": cfg.world.robot_width_m,
            "robot_height_m": cfg.world.robot_height_m,
            "eps": cfg.eps,
            "max_situations": cfg.model_max_situations,
            "close_faces": cfg.close_faces,
        }

    def model_of(self, floor: FloorObservation, watch: Stopwatch) -> ComparableModel:
        """The model stages on ``floor`` with :meth:`model_settings` (lap ``modeling``)."""
        settings = self.model_settings()
        model = build_model(
            floor,
            settings["robot_width_m"],
            eps=settings["eps"],
            max_situations=settings["max_situations"],
        )
        out = ComparableModel.of(model)
        watch.lap("modeling")
        return out

    def renderer(self, scene: Scene) -> StereoRenderer:
        """The renderer of ``scene`` (made on first use, its scene swapped when it changes)."""
        if self._renderer is None:
            self._renderer = StereoRenderer(self.config.rig, scene)
        elif self._renderer.scene is not scene:
            self._renderer.set_scene(scene)
        return self._renderer

    def close(self) -> None:
        """Release the renderer's OpenGL context (idempotent)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # made again on first use
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
