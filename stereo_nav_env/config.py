"""Configuration of the stereo-nav environments: frozen, slotted, keyword-only dataclasses.

:class:`EnvConfig` nests one sub-configuration per concern, and every value has one home:

* ``world``: :class:`WorldConfig` (robot size, dynamics, step length),
* ``camera``: :class:`CameraConfig` (image size, focal length, baseline, pixel noise),
* ``observation``: :class:`ObservationConfig` (what the observation holds and how big it is),
* ``rewards``: :class:`RewardConfig` (the reward weights),
* and on :class:`EnvConfig` itself the scenario, the episode's end and the model's settings.

The *episode rules* (what ends an episode and what it pays) are named presets in :data:`RULES`:
``"v0"`` (the dataclass defaults: a collision ends the episode and costs 10) and ``"v1"``
(collisions do not end an episode, 0.1 per contact step; Habitat PointNav's convention).
``EnvConfig.from_kwargs(rules="v1", ...)`` starts from a preset (the registered ``-v1`` ids pass
it); :meth:`EnvConfig.rules_dict` returns the rules in force as a plain dict, for every result
to record.

``gym.make("StereoNav-v0", **kwargs)`` takes flat keywords: each names a field anywhere in that
tree (the names are unique across it), or a whole sub-configuration (``world=``, ``camera=``,
``observation=``, ``rewards=``: an instance or a dict of its fields, which flat keywords
override). An unknown keyword or an invalid value is a ``ValueError`` that names it. Values that
follow from others (the stereo rig, the robot's radius, the raster's cell size) are properties,
never stored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from modeling.stereo.rig import StereoRig
from modeling.validation import boolean, from_flat, integer, number
from stereo_nav_env.perception.base import PerceptionName
from stereo_nav_env.sim.scenes import DEFAULT_ROBOT_WIDTH_M, FAMILIES, available_maps

__all__ = [
    "OBSERVATION_MODES",
    "REGION_FEATURES",
    "RULES",
    "RULE_FIELDS",
    "CameraConfig",
    "EnvConfig",
    "ObservationConfig",
    "ObservationMode",
    "PerceptionName",
    "RewardConfig",
    "WorldConfig",
]


class ObservationMode(str, Enum):
    """What the observation holds: the model of the latest view, the rectified pair, both, the
    model fused over the episode's views (``memory``), the latest view's and the fused one, or
    ``policy``: the latest view's model with what a learned policy needs beside it (the floor
    never seen, the contact, the previous action, a normalised goal; ``StereoNav-v1``'s)."""

    MODEL = "model"
    IMAGES = "images"
    BOTH = "both"
    MEMORY = "memory"
    MODEL_MEMORY = "model_memory"
    POLICY = "policy"


OBSERVATION_MODES = tuple(mode.value for mode in ObservationMode)
"""The values of :class:`ObservationMode` (``"model"``, ``"images"``, ``"both"``, ``"memory"``,
``"model_memory"``, ``"policy"``)."""

REGION_FEATURES = (
    "valid",
    "x_m",
    "y_m",
    "width_mean_m",
    "width_std_m",
    "p_passable",
    "doubt",
    "distance_m",
    "bearing_rad",
    "axis_x",
    "axis_y",
    "radius_m",
)
"""Names of the F columns of ``obs["critical_regions"]`` (see
:mod:`stereo_nav_env.observation.packing`)."""


RULES: dict[str, dict[str, Any]] = {
    "v0": {
        "terminate_on_collision": True,
        "goal_radius_m": 0.3,
        "goal_reward": 10.0,
        "collision_penalty": 10.0,
        "time_penalty": 0.01,
        "progress_weight": 1.0,
        "stuck_steps": 0,
        "stuck_progress_m": 0.5,
    },
    "v1": {
        "terminate_on_collision": False,
        "goal_radius_m": 0.3,
        "goal_reward": 10.0,
        "collision_penalty": 0.1,
        "time_penalty": 0.01,
        "progress_weight": 1.0,
        "stuck_steps": 0,
        "stuck_progress_m": 0.5,
    },
}
"""The episode-rule presets by name: flat :class:`EnvConfig` keywords (``"v0"`` equals the
dataclass defaults; ``"v1"``: collisions do not end an episode and cost 0.1 a contact step)."""

RULE_FIELDS = tuple(RULES["v0"])
"""The fields that make up the episode rules (:meth:`EnvConfig.rules_dict`)."""

_REWARD_RULES = ("goal_reward", "collision_penalty", "time_penalty", "progress_weight")


def _instance(value: object, name: str, cls: type) -> None:
    if not isinstance(value, cls):
        raise ValueError(f"{name} must be a {cls.__name__}, got {type(value).__name__}")


# ------------------------------------------------------------------------------------ configs
@dataclass(frozen=True, slots=True, kw_only=True)
class WorldConfig:
    """Physical parameters of the robot and the simulation.

    Attributes:
        robot_width_m: Diameter of the disc robot, metres.
        robot_height_m: Height of the robot, metres (what it cannot pass under).
        head_height_m: Height of the stereo head's optical centres above the floor, metres.
        max_speed_m_s: Largest forward speed magnitude, m/s (commands are clipped to it).
        max_turn_rate_rad_s: Largest body turn rate magnitude, rad/s.
        max_pan_rate_rad_s: Largest head pan rate, rad/s.
        pan_limit_rad: The pan stays within ``[-pan_limit_rad, pan_limit_rad]`` of the body heading.
        dt_s: Duration of one :meth:`World.step`, seconds.
        substeps: Physics substeps per step.
    """

    robot_width_m: float = DEFAULT_ROBOT_WIDTH_M
    robot_height_m: float = 1.0
    head_height_m: float = 0.8
    max_speed_m_s: float = 0.5
    max_turn_rate_rad_s: float = math.pi / 2
    max_pan_rate_rad_s: float = math.pi / 2
    pan_limit_rad: float = math.pi / 2
    dt_s: float = 0.1
    substeps: int = 10

    def __post_init__(self) -> None:
        for name in (
            "robot_width_m",
            "robot_height_m",
            "head_height_m",
            "max_speed_m_s",
            "max_turn_rate_rad_s",
            "max_pan_rate_rad_s",
            "dt_s",
        ):
            number(getattr(self, name), name, low=0.0)
        number(self.pan_limit_rad, "pan_limit_rad", low=0.0, high=math.pi, strict=False)
        integer(self.substeps, "substeps", low=1)
        if self.head_height_m > self.robot_height_m:
            raise ValueError(
                f"head_height_m ({self.head_height_m}) must not exceed robot_height_m "
                f"({self.robot_height_m})"
            )
        if self.max_speed_m_s * self.dt_s / self.substeps > self.robot_width_m / 10:
            raise ValueError(
                "substeps too few: max_speed_m_s * dt_s / substeps must be <= robot_width_m / 10 "
                "so the robot cannot tunnel"
            )

    @property
    def robot_radius_m(self) -> float:
        """Radius of the robot disc, metres."""
        return self.robot_width_m / 2.0


@dataclass(frozen=True, slots=True, kw_only=True)
class CameraConfig:
    """The stereo camera: a rectified horizontal pair, and the noise of its pixels.

    Attributes:
        width_px: Image width, pixels (>= 16).
        height_px: Image height, pixels (>= 16).
        focal_px: Focal length, pixels.
        baseline_m: Stereo baseline, metres.
        pixel_noise_std: Standard deviation of the Gaussian noise added to every pixel, grey
            levels (rounded to whole grey levels, the same value on its three channels; 0 =
            none), drawn from the env's ``np_random``.
        tilt_rad: Pitch of the head's optical axis below the horizon, radians (positive: looking
            down), in (-pi/2, pi/2) (``modeling.stereo.rig.HeadPose.tilt_rad``).
    """

    width_px: int = 320
    height_px: int = 240
    focal_px: float = 260.0
    baseline_m: float = 0.12
    pixel_noise_std: float = 2.0
    tilt_rad: float = 0.0

    def __post_init__(self) -> None:
        integer(self.width_px, "width_px", low=16)
        number(self.tilt_rad, "tilt_rad", low=-0.5 * math.pi, high=0.5 * math.pi)
        integer(self.height_px, "height_px", low=16)
        number(self.pixel_noise_std, "pixel_noise_std", low=0.0, strict=False)
        _ = self.rig  # the rig checks focal_px and baseline_m (its errors name them)

    @property
    def rig(self) -> StereoRig:
        """The stereo rig these settings describe."""
        return StereoRig(
            focal_px=self.focal_px,
            baseline_m=self.baseline_m,
            width_px=self.width_px,
            height_px=self.height_px,
        )


@dataclass(frozen=True, slots=True, kw_only=True)
class ObservationConfig:
    """What the observation holds and how big it is.

    Attributes:
        observation_mode: :class:`ObservationMode` (or its value): ``"model"`` (situations,
            critical regions, raster, goal, head pan), ``"images"`` (the rectified pair, goal,
            head pan), ``"both"`` (the two), ``"memory"`` (the fused model's situations,
            critical regions and raster with its unknown channel, goal, head pan) or
            ``"model_memory"`` (the model's keys and the fused model's) or ``"policy"`` (a
            five-channel raster that separates seen-free, occupied, critical, occluded and
            never-seen floor, the situations and regions scaled to [-1, 1], the goal as distance
            over ``goal_range_m`` with its bearing's cos and sin, the head pan, a contact flag
            and the previous action: :func:`stereo_nav_env.observation.packing.pack_policy`).
        num_situations: K, the most probable situations observed (the rest are left out).
        num_regions: R, critical regions kept per situation (the nearest to the robot).
        raster_size_px: Side of the square egocentric raster, pixels (>= 36, SB3's CNN minimum).
        raster_half_extent_m: The raster covers this far from the robot's centre in each
            direction, metres.
        feature_range_m: Bound of the positions and lengths in ``critical_regions``, metres
            (larger values are clipped).
        goal_range_m: In mode ``"policy"`` the goal's distance is observed over this range,
            metres (clipped to 1).
    """

    observation_mode: ObservationMode = ObservationMode.MODEL
    num_situations: int = 8
    num_regions: int = 8
    raster_size_px: int = 64
    raster_half_extent_m: float = 5.0
    feature_range_m: float = 10.0
    goal_range_m: float = 15.0

    def __post_init__(self) -> None:
        try:
            mode = ObservationMode(self.observation_mode)
        except ValueError:
            raise ValueError(
                f"observation_mode must be one of {list(OBSERVATION_MODES)}, "
                f"got {self.observation_mode!r}"
            ) from None
        object.__setattr__(self, "observation_mode", mode)
        integer(self.num_situations, "num_situations", low=1)
        integer(self.num_regions, "num_regions", low=1)
        integer(self.raster_size_px, "raster_size_px", low=36)
        number(self.raster_half_extent_m, "raster_half_extent_m", low=0.0)
        number(self.feature_range_m, "feature_range_m", low=0.0)
        number(self.goal_range_m, "goal_range_m", low=0.0)

    @property
    def num_features(self) -> int:
        """F, the features per critical region (``len(REGION_FEATURES)``)."""
        return len(REGION_FEATURES)

    @property
    def raster_cell_m(self) -> float:
        """Side of one raster pixel, metres."""
        return 2.0 * self.raster_half_extent_m / self.raster_size_px

    @property
    def has_model(self) -> bool:
        """Whether the model fields (situations, regions, raster) are observed."""
        return self.observation_mode in (
            ObservationMode.MODEL,
            ObservationMode.BOTH,
            ObservationMode.MODEL_MEMORY,
        )

    @property
    def has_images(self) -> bool:
        """Whether the rectified pair is observed."""
        return self.observation_mode in (ObservationMode.IMAGES, ObservationMode.BOTH)

    @property
    def has_policy(self) -> bool:
        """Whether the observation is the learned policy's (mode ``"policy"``)."""
        return self.observation_mode is ObservationMode.POLICY

    @property
    def has_memory(self) -> bool:
        """Whether the fused model's fields (``memory_*``) are observed."""
        return self.observation_mode in (ObservationMode.MEMORY, ObservationMode.MODEL_MEMORY)


@dataclass(frozen=True, slots=True, kw_only=True)
class RewardConfig:
    """Weights of the named reward components (see :mod:`stereo_nav_env.rewards`).

    Attributes:
        goal_reward: Added in the step that reaches the goal.
        collision_penalty: Subtracted in a step with a collision.
        time_penalty: Subtracted in every step.
        progress_weight: Times the decrease of the geodesic distance to the goal (metres) in the
            step.
        geodesic_cell_m: Cell size of the grid on which the geodesic distance is computed, metres.
    """

    goal_reward: float = 10.0
    collision_penalty: float = 10.0
    time_penalty: float = 0.01
    progress_weight: float = 1.0
    geodesic_cell_m: float = 0.05

    def __post_init__(self) -> None:
        for name in ("goal_reward", "collision_penalty", "time_penalty", "progress_weight"):
            number(getattr(self, name), name, low=0.0, strict=False)
        number(self.geodesic_cell_m, "geodesic_cell_m", low=0.0)


@dataclass(frozen=True, slots=True, kw_only=True)
class EnvConfig:
    """Configuration of :class:`~stereo_nav_env.env.StereoNavEnv`.

    Attributes:
        scenario: A bundled map name (``"default"``, ``"two_gaps"``), a path to a ``.json`` map, a
            generator family (``"room"``, ``"corridor"``, ``"cluttered"``, ``"office"``: a new scene
            from the env's generator at every reset) or ``"random"`` (a random family too).
        goal_radius_m: The episode succeeds when the robot's centre is this close to the goal.
        terminate_on_collision: Whether a collision ends the episode.
        stuck_steps: Truncate the episode once this many steps in a row have not brought the
            robot ``stuck_progress_m`` closer (geodesically) to the goal than where it last did
            (0: never; :class:`~stereo_nav_env.rewards.StuckTimer`).
        stuck_progress_m: The progress that resets the stuck count, metres.
        eps: Classification tolerance of the model (passable if ``p > 1 - eps``, impassable if
            ``p < eps``), in (0, 0.5).
        model_max_situations: Most situations the model enumerates (``info["model"]``).
        close_faces: Whether a face's bottom edge joining two vertical edges closes the "gap"
            between them (:mod:`modeling.stereo.faces`, an addition to the paper's pipeline).
        ground_lines: Whether the image's lowest near-horizontal lines enter as floor segments
            where they meet the floor (:mod:`modeling.stereo.ground_lines`, an addition to the
            paper's pipeline; off by default; perceptions ``stereo`` and ``stereo_means``, and
            ``surrogate``, which imitates those lines from the true scene).
        surface_detail: Whether the faces of walls, boxes and bookshelves carry surface detail
            (:mod:`stereo_nav_env.sim.scenes.surface`: panel seams, door frames, cabinet
            fronts, book spines, drawn per scene from its seed; issue 42), which the stereo
            sees as vertical edges on faces and the surrogate imitates. ``False`` (the default
            for now): plain, flat-shaded faces, the world of every figure before issue 42, kept
            for comparison; the scene, the rendering and every observation are then those of
            the plain world exactly. A map's own listed detail is used when on, dropped when off.
        perception: :class:`~stereo_nav_env.perception.base.PerceptionName` (or its value):
            ``"stereo"`` (render the pair and run the stereo pipeline), ``"surrogate"`` (render
            nothing: the floor observation from the true scene and the stereo's error model and
            measured rates, :mod:`stereo_nav_env.perception.surrogate`), ``"stereo_means"`` (the
            stereo's floor observation taken at face value: no spread, each ambiguous segment
            its most probable candidate, one situation), ``"dense"`` (the rendered pair through
            OpenCV's semi-global matching into an occupancy evidence grid whose blobs' outlines
            are the floor observation, :mod:`stereo_nav_env.perception.dense`) or ``"truth"``
            (render nothing: the true visible outlines with no spread,
            :mod:`stereo_nav_env.perception.truth`). The last three are issue 43's ablation. A
            perception that renders nothing (``surrogate``, ``truth``) needs an observation
            without images; ``ground_lines`` needs one with near-horizontal image lines
            (``stereo``, ``stereo_means``, ``surrogate``: ``PerceptionName.has_ground_lines``).
        memory: Whether every view is fused into the episode's memory and its model built
            (``info["memory_model"]``, the ``memory_*`` diagnostics; the ``"memory"`` and
            ``"model_memory"`` observation modes need it). ``None`` (the default): on exactly when
            the observation holds the memory, so the env pays for what it returns; ``True``: on
            for a caller that reads ``info["memory_model"]``; ``False``: off
            (``info["memory_model"]`` is ``None``). Resolved to a bool on construction.
        diagnostics: Whether ``info["diagnostics"]`` compares the model with ground truth.
        info_models: Whether ``info`` carries the model objects (``"model"``,
            ``"memory_model"``). ``False`` for a training loop that pickles ``info`` across
            processes and reads no model there (each is about 25 KiB): the keys are left out and
            the models stay readable in the env's process as ``env.unwrapped.model`` and
            ``env.unwrapped.memory_model`` (:func:`agents.base.model_of` falls back to them).
        world: The robot and its physics (:class:`WorldConfig`).
        camera: The stereo camera and its pixel noise (:class:`CameraConfig`).
        observation: What the observation holds (:class:`ObservationConfig`).
        rewards: Reward weights (:class:`RewardConfig`).
    """

    scenario: str = "default"
    goal_radius_m: float = 0.3
    terminate_on_collision: bool = True
    stuck_steps: int = 0
    stuck_progress_m: float = 0.5
    eps: float = 0.05
    model_max_situations: int = 64
    close_faces: bool = True
    ground_lines: bool = False
    surface_detail: bool = False
    perception: PerceptionName = PerceptionName.STEREO
    memory: bool | None = None
    diagnostics: bool = True
    info_models: bool = True
    world: WorldConfig = field(default_factory=WorldConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    observation: ObservationConfig = field(default_factory=ObservationConfig)
    rewards: RewardConfig = field(default_factory=RewardConfig)

    def __post_init__(self) -> None:
        known = (*available_maps(), *FAMILIES, "random")
        if not isinstance(self.scenario, str) or not (
            self.scenario in known or self.scenario.endswith(".json")
        ):
            raise ValueError(
                f"scenario must be one of {list(known)} or a .json path, got {self.scenario!r}"
            )
        number(self.goal_radius_m, "goal_radius_m", low=0.0)
        number(self.eps, "eps", low=0.0, high=0.5)
        integer(self.model_max_situations, "model_max_situations", low=1)
        boolean(self.terminate_on_collision, "terminate_on_collision")
        integer(self.stuck_steps, "stuck_steps", low=0)
        number(self.stuck_progress_m, "stuck_progress_m", low=0.0)
        boolean(self.close_faces, "close_faces")
        boolean(self.ground_lines, "ground_lines")
        boolean(self.surface_detail, "surface_detail")
        boolean(self.diagnostics, "diagnostics")
        boolean(self.info_models, "info_models")
        try:
            perception = PerceptionName(self.perception)
        except ValueError:
            raise ValueError(
                f"perception must be one of {[p.value for p in PerceptionName]}, "
                f"got {self.perception!r}"
            ) from None
        object.__setattr__(self, "perception", perception)
        _instance(self.world, "world", WorldConfig)
        _instance(self.camera, "camera", CameraConfig)
        _instance(self.observation, "observation", ObservationConfig)
        _instance(self.rewards, "rewards", RewardConfig)
        if self.memory is None:  # on exactly when the observation holds it
            object.__setattr__(self, "memory", self.observation.has_memory)
        boolean(self.memory, "memory")
        if self.observation.has_memory and not self.memory:
            raise ValueError(
                f"observation_mode {self.observation.observation_mode.value!r} observes the "
                "memory: memory must be True"
            )
        if not perception.has_ground_lines and self.ground_lines:
            with_lines = [p.value for p in PerceptionName if p.has_ground_lines]
            raise ValueError(
                f"ground_lines needs a perception among {with_lines}: "
                f"perception={perception.value!r} has no near-horizontal image lines"
            )
        if not perception.renders_images and self.observation.has_images:
            raise ValueError(
                f"perception={perception.value!r} renders no images: observation_mode must not "
                f"hold them, got {self.observation.observation_mode.value!r}"
            )

    # ------------------------------------------------------------------ derived
    @property
    def rig(self) -> StereoRig:
        """The stereo rig of the camera (``camera.rig``)."""
        return self.camera.rig

    @property
    def blind_range_m(self) -> float:
        """The head does not see the floor nearer than this to its optical centre, metres: the
        image's lower edge meets the floor there (``head_height_m / tan(half vertical field of
        view + tilt)``; 1.73 m with the defaults; ``inf`` when the lower edge looks above the
        horizon)."""
        camera = self.camera
        below = math.atan((camera.height_px / 2.0) / camera.focal_px) + camera.tilt_rad
        if below <= 0.0:
            return math.inf
        if below >= 0.5 * math.pi:
            return 0.0
        return self.world.head_height_m / math.tan(below)

    @property
    def is_generated(self) -> bool:
        """Whether every reset generates a new scene (a family or ``"random"``)."""
        return self.scenario in (*FAMILIES, "random")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """A configuration from flat keyword arguments (``gym.make`` passes them here).

        Each key is a field of :class:`EnvConfig` or of one of its sub-configurations
        (``world``, ``camera``, ``observation``, ``rewards``), or the name of a sub-configuration
        given whole, as an instance or a dict of its fields (flat keys then override them). The
        key ``rules`` names a preset of :data:`RULES` (default ``"v0"``) whose values stand
        where the other keys do not set them (a whole ``rewards`` keeps its own weights).

        Raises:
            ValueError: An unknown key (named), or an invalid value (its field named).
        """
        given = dict(kwargs)
        rules = given.pop("rules", "v0")
        if not isinstance(rules, str) or rules not in RULES:
            raise ValueError(f"rules must be one of {list(RULES)}, got {rules!r}")
        preset = {
            key: value
            for key, value in RULES[rules].items()
            if key not in given and not (key in _REWARD_RULES and "rewards" in given)
        }
        return from_flat(cls, {**preset, **given}, what="StereoNav")

    def rules_dict(self) -> dict[str, Any]:
        """The episode rules in force as a plain, JSON-friendly dict.

        Returns:
            ``{"preset": name, **values}``: the values of :data:`RULE_FIELDS` (the reward weights
            read from ``rewards``) and the name of the :data:`RULES` preset they equal
            (``"custom"`` when none).
        """
        values: dict[str, Any] = {
            key: getattr(self.rewards if key in _REWARD_RULES else self, key) for key in RULE_FIELDS
        }
        preset = next(
            (name for name, rule in RULES.items() if rule == values),
            "custom",
        )
        return {"preset": preset, **values}
