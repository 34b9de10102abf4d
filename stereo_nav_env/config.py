"""Configuration of the stereo-nav environments: frozen, slotted, keyword-only dataclasses.

``gym.make("StereoNav-v0", **kwargs)`` maps every keyword argument onto one field of
:class:`EnvConfig`, :class:`ObservationConfig` or :class:`RewardConfig` (field names are unique
across the three, so flat keywords suffice); ``observation=`` and ``rewards=`` also take a whole
sub-configuration (an instance or a dict). An unknown keyword or an invalid value is a
``ValueError`` that names it. Values that follow from others (the stereo rig, the world's physical
parameters, the raster's cell size) are properties, never stored defaults.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from modeling.rig import StereoRig
from stereo_nav_env.scenes import FAMILIES, available_maps
from stereo_nav_env.world import WorldConfig

__all__ = [
    "OBSERVATION_MODES",
    "REGION_FEATURES",
    "EnvConfig",
    "ObservationConfig",
    "RewardConfig",
]

OBSERVATION_MODES = ("model", "images", "both")

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
"""Names of the F columns of ``obs["critical_regions"]`` (see :mod:`stereo_nav_env.observation`)."""


# ----------------------------------------------------------------------------------- validators
def _number(owner: object, name: str, *, low: float | None = None, strict: bool = True) -> float:
    value = getattr(owner, name)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if low is not None and (value <= low if strict else value < low):
        relation = ">" if strict else ">="
        raise ValueError(f"{name} must be {relation} {low}, got {value!r}")
    return float(value)


def _integer(owner: object, name: str, low: int) -> int:
    value = getattr(owner, name)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return value


def _boolean(owner: object, name: str) -> bool:
    value = getattr(owner, name)
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return value


# ------------------------------------------------------------------------------------ configs
@dataclass(frozen=True, slots=True, kw_only=True)
class ObservationConfig:
    """What the observation holds and how big it is.

    Attributes:
        observation_mode: ``"model"`` (situations, critical regions, raster, goal, head pan),
            ``"images"`` (the rectified pair, goal, head pan) or ``"both"``.
        num_situations: K, the most probable situations observed (the rest are left out).
        num_regions: R, critical regions kept per situation (the nearest to the robot).
        raster_size_px: Side of the square egocentric raster, pixels (>= 36, SB3's CNN minimum).
        raster_half_extent_m: The raster covers this far from the robot's centre in each
            direction, metres.
        feature_range_m: Bound of the positions and lengths in ``critical_regions``, metres
            (larger values are clipped).
    """

    observation_mode: str = "model"
    num_situations: int = 8
    num_regions: int = 8
    raster_size_px: int = 64
    raster_half_extent_m: float = 5.0
    feature_range_m: float = 10.0

    def __post_init__(self) -> None:
        if self.observation_mode not in OBSERVATION_MODES:
            raise ValueError(
                f"observation_mode must be one of {list(OBSERVATION_MODES)}, "
                f"got {self.observation_mode!r}"
            )
        _integer(self, "num_situations", 1)
        _integer(self, "num_regions", 1)
        _integer(self, "raster_size_px", 36)
        _number(self, "raster_half_extent_m", low=0.0)
        _number(self, "feature_range_m", low=0.0)

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
        return self.observation_mode in ("model", "both")

    @property
    def has_images(self) -> bool:
        """Whether the rectified pair is observed."""
        return self.observation_mode in ("images", "both")


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
            _number(self, name, low=0.0, strict=False)
        _number(self, "geodesic_cell_m", low=0.0)


@dataclass(frozen=True, slots=True, kw_only=True)
class EnvConfig:
    """Configuration of :class:`~stereo_nav_env.env.StereoNavEnv`.

    Attributes:
        scenario: A bundled map name (``"default"``, ``"two_gaps"``), a path to a ``.json`` map, a
            generator family (``"room"``, ``"corridor"``, ``"cluttered"``, ``"office"``: a new scene
            from the env's generator at every reset) or ``"random"`` (a random family too).
        robot_width_m: Robot diameter, metres.
        robot_height_m: Robot height, metres; floor segments are kept up to this height.
        head_height_m: Height of the optical centres, metres.
        width_px: Image width, pixels.
        height_px: Image height, pixels.
        focal_px: Focal length, pixels.
        baseline_m: Stereo baseline, metres.
        pixel_noise_std: Standard deviation of the Gaussian noise added to every pixel, grey
            levels (rounded to whole grey levels, the same value on its three channels; 0 =
            none), drawn from ``np_random``.
        max_speed_m_s: Forward speed at ``action[0] = 1``, m/s (backwards at -1).
        max_turn_rate_rad_s: Turn rate at ``action[1] = 1``, rad/s (counter-clockwise).
        max_pan_rate_rad_s: Largest head pan rate, rad/s.
        pan_limit_rad: Head pan at ``action[2] = +-1``, radians (left positive).
        dt_s: Seconds per step.
        goal_radius_m: The episode succeeds when the robot's centre is this close to the goal.
        terminate_on_collision: Whether a collision ends the episode.
        eps: Classification tolerance of the model (passable if ``p > 1 - eps``, impassable if
            ``p < eps``), in (0, 0.5).
        model_max_situations: Most situations the model enumerates (``info["model"]``).
        close_faces: Whether a face's bottom edge joining two vertical edges closes the "gap"
            between them (:mod:`modeling.faces`, an addition to the paper's pipeline).
        diagnostics: Whether ``info["diagnostics"]`` compares the model with ground truth.
        observation: What the observation holds (:class:`ObservationConfig`).
        rewards: Reward weights (:class:`RewardConfig`).
    """

    scenario: str = "default"
    robot_width_m: float = 0.5
    robot_height_m: float = 1.0
    head_height_m: float = 0.8
    width_px: int = 320
    height_px: int = 240
    focal_px: float = 260.0
    baseline_m: float = 0.12
    pixel_noise_std: float = 2.0
    max_speed_m_s: float = 0.5
    max_turn_rate_rad_s: float = math.pi / 2
    max_pan_rate_rad_s: float = math.pi / 2
    pan_limit_rad: float = math.pi / 2
    dt_s: float = 0.1
    goal_radius_m: float = 0.3
    terminate_on_collision: bool = True
    eps: float = 0.05
    model_max_situations: int = 64
    close_faces: bool = True
    diagnostics: bool = True
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
        _number(self, "pixel_noise_std", low=0.0, strict=False)
        _number(self, "goal_radius_m", low=0.0)
        eps = _number(self, "eps", low=0.0)
        if eps >= 0.5:
            raise ValueError(f"eps must be in (0, 0.5), got {self.eps!r}")
        _integer(self, "width_px", 16)
        _integer(self, "height_px", 16)
        _integer(self, "model_max_situations", 1)
        _boolean(self, "terminate_on_collision")
        _boolean(self, "close_faces")
        _boolean(self, "diagnostics")
        if not isinstance(self.observation, ObservationConfig):
            raise ValueError(
                f"observation must be an ObservationConfig, got {type(self.observation).__name__}"
            )
        if not isinstance(self.rewards, RewardConfig):
            raise ValueError(f"rewards must be a RewardConfig, got {type(self.rewards).__name__}")
        _ = self.rig, self.world_config  # validate the derived configurations (errors name fields)

    # ------------------------------------------------------------------ derived
    @property
    def rig(self) -> StereoRig:
        """The stereo rig these settings describe."""
        return StereoRig(
            focal_px=self.focal_px,
            baseline_m=self.baseline_m,
            width_px=self.width_px,
            height_px=self.height_px,
        )

    @property
    def world_config(self) -> WorldConfig:
        """The world's robot and physics parameters."""
        return WorldConfig(
            robot_width_m=self.robot_width_m,
            robot_height_m=self.robot_height_m,
            head_height_m=self.head_height_m,
            max_speed_m_s=self.max_speed_m_s,
            max_turn_rate_rad_s=self.max_turn_rate_rad_s,
            max_pan_rate_rad_s=self.max_pan_rate_rad_s,
            pan_limit_rad=self.pan_limit_rad,
            dt_s=self.dt_s,
        )

    @property
    def robot_radius_m(self) -> float:
        """Radius of the robot disc, metres."""
        return self.robot_width_m / 2.0

    @property
    def is_generated(self) -> bool:
        """Whether every reset generates a new scene (a family or ``"random"``)."""
        return self.scenario in (*FAMILIES, "random")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """A configuration from flat keyword arguments (``gym.make`` passes them here).

        Each key is a field of :class:`EnvConfig`, :class:`ObservationConfig` or
        :class:`RewardConfig`; ``observation`` and ``rewards`` may also be given whole, as an
        instance or a dict of its fields (flat keys then override them).

        Raises:
            ValueError: An unknown key (named), or an invalid value (its field named).
        """
        subs: dict[str, type] = {"observation": ObservationConfig, "rewards": RewardConfig}
        top_names = {f.name for f in dataclasses.fields(cls)} - set(subs)
        sub_names = {key: {f.name for f in dataclasses.fields(c)} for key, c in subs.items()}
        top: dict[str, Any] = {}
        nested: dict[str, dict[str, Any]] = {key: {} for key in subs}
        unknown: list[str] = []
        for key, value in kwargs.items():
            if key in subs:
                if isinstance(value, subs[key]):
                    base = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
                elif isinstance(value, dict):
                    bad = sorted(set(value) - sub_names[key])
                    if bad:
                        raise ValueError(f"unknown {key} option(s) {bad}")
                    base = dict(value)
                else:
                    kind, got = subs[key].__name__, type(value).__name__
                    raise ValueError(f"{key} must be a {kind} or a dict, got {got}")
                nested[key] = {**base, **nested[key]}
            elif key in top_names:
                top[key] = value
            else:
                owner = next((s for s, names in sub_names.items() if key in names), None)
                if owner is None:
                    unknown.append(key)
                else:
                    nested[owner][key] = value
        if unknown:
            known = sorted(top_names | set(subs) | set().union(*sub_names.values()))
            raise ValueError(f"unknown StereoNav option(s) {sorted(unknown)}; known: {known}")
        try:
            made = {key: subs[key](**values) for key, values in nested.items()}
        except TypeError as exc:  # pragma: no cover - keys are checked above
            raise ValueError(str(exc)) from exc
        return cls(**top, **made)
