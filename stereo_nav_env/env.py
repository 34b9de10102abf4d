"""The Gymnasium environment: a thin orchestrator of scene, world and stereo renderer.

This first version (issue 2) has a small observation and a simple reward; the full observation of
ARCHITECTURE.md (situations, critical regions, raster) and the modeling pipeline come later.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from modeling.rig import HeadPose, StereoRig
from stereo_nav_env.render import StereoRenderer
from stereo_nav_env.scenes import FAMILIES, Scene, available_maps, load_scenario
from stereo_nav_env.world import World, WorldConfig

__all__ = ["EnvConfig", "StereoNavEnv"]

GOAL_RANGE_M = 100.0  # bound of the goal observation (metres); scenes are far smaller


@dataclass(frozen=True, slots=True, kw_only=True)
class EnvConfig:
    """Configuration of :class:`StereoNavEnv`; ``gym.make`` keyword arguments map onto it.

    Attributes:
        scenario: A bundled map name (``"default"``, ``"two_gaps"``), a path to a ``.json`` map, a
            generator family (``"room"``, ``"corridor"``, ``"cluttered"``, ``"office"``: a new scene
            from the env's generator at every reset) or ``"random"`` (a random family too).
        robot_width_m: Robot diameter, metres.
        width_px: Image width, pixels.
        height_px: Image height, pixels.
        focal_px: Focal length, pixels.
        baseline_m: Stereo baseline, metres.
        head_height_m: Height of the optical centres, metres.
        pixel_noise_std: Standard deviation of Gaussian noise added to each pixel value by
            ``render_stereo()`` (grey levels, 0 = none), drawn from the env's ``np_random``.
        max_speed_m_s: Forward speed at action[0] = 1, m/s.
        max_turn_rate_rad_s: Turn rate at action[1] = 1, rad/s.
        max_pan_rate_rad_s: Largest head pan rate, rad/s.
        pan_limit_rad: Head pan at action[2] = +-1, radians.
        dt_s: Seconds per step.
        goal_radius_m: The episode succeeds when the robot's centre is this close to the goal.
        collision_penalty: Reward subtracted in a step with a collision.
        goal_reward: Reward added on reaching the goal.
        time_penalty: Reward subtracted every step.
    """

    scenario: str = "default"
    robot_width_m: float = 0.5
    width_px: int = 320
    height_px: int = 240
    focal_px: float = 260.0
    baseline_m: float = 0.12
    head_height_m: float = 0.8
    pixel_noise_std: float = 0.0
    max_speed_m_s: float = 0.5
    max_turn_rate_rad_s: float = math.pi / 2
    max_pan_rate_rad_s: float = math.pi / 2
    pan_limit_rad: float = math.pi / 2
    dt_s: float = 0.1
    goal_radius_m: float = 0.3
    collision_penalty: float = 1.0
    goal_reward: float = 10.0
    time_penalty: float = 0.01

    def __post_init__(self) -> None:
        known = (*available_maps(), *FAMILIES, "random")
        if not isinstance(self.scenario, str) or not (
            self.scenario in known or self.scenario.endswith(".json")
        ):
            raise ValueError(
                f"scenario must be one of {list(known)} or a .json path, got {self.scenario!r}"
            )
        for name in ("pixel_noise_std", "collision_penalty", "goal_reward", "time_penalty"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
        if not (isinstance(self.goal_radius_m, int | float) and self.goal_radius_m > 0):
            raise ValueError(f"goal_radius_m must be positive, got {self.goal_radius_m!r}")
        _ = self.rig, self.world_config  # validate the derived configurations

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
            head_height_m=self.head_height_m,
            max_speed_m_s=self.max_speed_m_s,
            max_turn_rate_rad_s=self.max_turn_rate_rad_s,
            max_pan_rate_rad_s=self.max_pan_rate_rad_s,
            pan_limit_rad=self.pan_limit_rad,
            dt_s=self.dt_s,
        )

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """A config from keyword arguments; an unknown key is a ``ValueError`` naming it."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ValueError(f"unknown StereoNav option(s) {unknown}; known: {sorted(names)}")
        return cls(**kwargs)


class StereoNavEnv(gym.Env[dict[str, NDArray[np.float32]], NDArray[np.float32]]):
    """Navigate a disc robot to a goal while looking at the world through a stereo head.

    ## Description
    A robot (a disc, 0.5 m wide, 1 m tall) moves on the floor of an indoor scene (walls with
    doorways, tables and chairs on legs, bookshelves with repeated vertical edges, boxes) simulated
    with pymunk, and sees it through a rectified stereo pair rendered with pyrender from a head on
    its centre that pans relative to the body. Gaps between obstacles close to the robot width make
    passability uncertain. The perception follows Miura (ICRA-94).

    ## Action Space
    ``Box(-1, 1, (3,), float32)``:

    | index | meaning                | scale                          |
    |-------|------------------------|--------------------------------|
    | 0     | forward speed          | x ``max_speed_m_s`` (0.5 m/s)  |
    | 1     | turn rate (CCW > 0)    | x ``max_turn_rate_rad_s``      |
    | 2     | head pan target        | x ``pan_limit_rad`` (90 deg)   |

    The pan moves towards its target at most ``max_pan_rate_rad_s`` (90 deg/s).

    ## Observation Space
    ``Dict`` (provisional; replaced by the model-based observation in a later issue):

    | key        | shape | dtype   | meaning                                                     |
    |------------|-------|---------|-------------------------------------------------------------|
    | goal       | (2,)  | float32 | goal in the robot frame: (forward, left), metres            |
    | head_pan   | (1,)  | float32 | head pan relative to the body / ``pan_limit_rad``, in [-1, 1] |

    ## Rewards
    Named components in ``info["reward_components"]``, summed: ``progress`` (decrease of the
    distance to the goal, metres), ``collision`` (``-collision_penalty`` in a step with a contact),
    ``goal`` (``goal_reward`` on arrival), ``time`` (``-time_penalty`` each step).

    ## Starting State
    The scene's start pose, head pan 0. Maps are fixed; generator families draw a new scene from
    the env's seeded generator at every reset.

    ## Episode End
    Terminated when the robot's centre is within ``goal_radius_m`` of the goal
    (``info["is_success"]``). Truncated by the ``TimeLimit`` wrapper (500 steps for
    ``StereoNav-v0``).

    ## Arguments
    ``render_mode`` (``None`` or ``"rgb_array"``: ``render()`` returns the left and right images
    side by side, (H, 2W, 3) uint8) and the fields of :class:`EnvConfig` as keyword arguments.

    ## Version History
    * v0: first version (issue 2): scene, world, stereo rendering; provisional observation.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.config = EnvConfig.from_kwargs(**kwargs)
        self.rig: StereoRig = self.config.rig
        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self.observation_space = spaces.Dict(
            {
                "goal": spaces.Box(-GOAL_RANGE_M, GOAL_RANGE_M, shape=(2,), dtype=np.float32),
                "head_pan": spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32),
            }
        )
        self._fixed_scene: Scene | None = None
        if self.config.scenario not in (*FAMILIES, "random"):
            self._fixed_scene = load_scenario(self.config.scenario)
        self.scene: Scene | None = None
        self.world: World | None = None
        self._renderer: StereoRenderer | None = None

    # ------------------------------------------------------------------ ground truth / views
    def _require_world(self) -> World:
        if self.world is None:
            raise RuntimeError("call reset() before using the environment")
        return self.world

    @property
    def head_pose(self) -> HeadPose:
        """Pose of the LEFT optical centre now."""
        return self._require_world().head_pose(self.rig.baseline_m)

    def ground_truth_footprints(self) -> list[NDArray[np.float64]]:
        """True obstacle outlines, each (k, 2) world metres."""
        self._require_world()
        assert self.scene is not None
        return self.scene.footprints()

    def _get_renderer(self) -> StereoRenderer:
        assert self.scene is not None
        if self._renderer is None:
            self._renderer = StereoRenderer(self.rig, self.scene)
        elif self._renderer.scene is not self.scene:
            self._renderer.set_scene(self.scene)
        return self._renderer

    def render_stereo(self) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
        """The rectified pair from the current head pose: uint8 (H, W, 3) each.

        Gaussian pixel noise of ``pixel_noise_std`` grey levels is added (from ``np_random``).
        """
        left, right = self._get_renderer().render_stereo(self.head_pose)
        sigma = self.config.pixel_noise_std
        if sigma > 0:
            left, right = (
                np.clip(np.rint(img + self.np_random.normal(0.0, sigma, img.shape)), 0, 255).astype(
                    np.uint8
                )
                for img in (left, right)
            )
        return left, right

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: the stereo pair side by side, (H, 2W, 3) uint8."""
        if self.render_mode != "rgb_array":
            return None
        left, right = self.render_stereo()
        return np.concatenate([left, right], axis=1)

    # ------------------------------------------------------------------ gym API
    def _goal_distance(self) -> float:
        assert self.scene is not None
        s = self._require_world().state
        return math.hypot(self.scene.goal[0] - s.x_m, self.scene.goal[1] - s.y_m)

    def _obs(self) -> dict[str, NDArray[np.float32]]:
        assert self.scene is not None
        s = self._require_world().state
        dx, dy = self.scene.goal[0] - s.x_m, self.scene.goal[1] - s.y_m
        c, si = math.cos(s.heading_rad), math.sin(s.heading_rad)
        goal = np.clip([c * dx + si * dy, -si * dx + c * dy], -GOAL_RANGE_M, GOAL_RANGE_M).astype(
            np.float32
        )
        limit = self.config.pan_limit_rad
        pan = s.pan_rad / limit if limit > 0 else 0.0
        return {"goal": goal, "head_pan": np.array([np.clip(pan, -1, 1)], dtype=np.float32)}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, Any]]:
        """Start an episode; a generated scenario draws its scene from ``np_random``."""
        super().reset(seed=seed)
        if self._fixed_scene is not None:
            scene = self._fixed_scene
        else:
            scene_seed = int(self.np_random.integers(2**31 - 1))
            scene = load_scenario(
                self.config.scenario, scene_seed, robot_width_m=self.config.robot_width_m
            )
        self.scene = scene
        self.world = World(scene, self.config.world_config)
        info = {
            "is_success": False,
            "scene": scene.name,
            "distance_to_goal_m": self._goal_distance(),
        }
        return self._obs(), info

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[dict[str, NDArray[np.float32]], float, bool, bool, dict[str, Any]]:
        """Move, turn and pan by ``action`` (see Action Space) for ``dt_s`` seconds."""
        world = self._require_world()
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise ValueError(f"action must be 3 finite numbers, got {action!r}")
        a = np.clip(a, -1.0, 1.0)
        cfg = self.config
        before = self._goal_distance()
        result = world.step(
            a[0] * cfg.max_speed_m_s, a[1] * cfg.max_turn_rate_rad_s, a[2] * cfg.pan_limit_rad
        )
        after = self._goal_distance()
        success = after <= cfg.goal_radius_m
        components = {
            "progress": before - after,
            "collision": -cfg.collision_penalty if result.collided else 0.0,
            "goal": cfg.goal_reward if success else 0.0,
            "time": -cfg.time_penalty,
        }
        info = {
            "is_success": success,
            "collision": result.collided,
            "reward_components": components,
            "distance_to_goal_m": after,
        }
        return self._obs(), float(sum(components.values())), success, False, info

    def close(self) -> None:
        """Release the renderer's OpenGL context (idempotent)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close()
