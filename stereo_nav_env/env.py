"""The Gymnasium environments ``StereoNav`` and ``StereoNavDiscrete``: a thin orchestrator.

Each step: the physics advances and the head pans (:mod:`stereo_nav_env.sim.world`), the
perception turns the view into an environment model (:mod:`stereo_nav_env.perception`: the stereo
renders the pair with pixel noise from ``np_random`` and runs the modeling pipeline, the surrogate
imitates it, issue 43's ``stereo_means``, ``dense`` and ``truth`` ablate it), with ``memory`` on
the view and any contact are fused into the episode's memory and its model is built
(:mod:`stereo_nav_env.fusion`, :mod:`modeling.memory`), the observation is packed
(:mod:`stereo_nav_env.observation`), the reward is computed (:mod:`stereo_nav_env.rewards`,
:mod:`stereo_nav_env.sim.geodesic`) and the models are compared with the truth
(:mod:`stereo_nav_env.diagnostics`). ``render()`` draws with
:mod:`stereo_nav_env.rendering.viewer`. Configuration: :mod:`stereo_nav_env.config`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, cast

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from modeling.memory.fusion import ModelMemory
from modeling.model.build import ModelCache
from modeling.model.records import EnvironmentModel
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import UInt8Image
from stereo_nav_env.actions import DISCRETE_ACTIONS, continuous_command, discrete_command
from stereo_nav_env.config import EnvConfig
from stereo_nav_env.diagnostics import GroundTruth, memory_diagnostics, model_diagnostics
from stereo_nav_env.fusion import fuse_view, memory_model_of, memory_options
from stereo_nav_env.observation.packing import (
    goal_features,
    observation_space,
    pack_memory,
    pack_model,
    pack_policy,
    pan_fraction,
)
from stereo_nav_env.observation.seen import SeenFloor
from stereo_nav_env.perception import Perception, make_perception
from stereo_nav_env.perception.base import ComparableModel, StereoPair, Stopwatch
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.rendering.viewer import MapView, draw_background, draw_frame, model_caption
from stereo_nav_env.rewards import StuckTimer, reward_components
from stereo_nav_env.sim.geodesic import GeodesicField
from stereo_nav_env.sim.scenes import Scene, load_scenario
from stereo_nav_env.sim.world import Contact, World

__all__ = ["StereoNavDiscreteEnv", "StereoNavEnv"]

Obs = dict[str, NDArray[Any]]

STAGES = tuple(
    "physics noise render segments matching triangulation modeling fusion memory_model packing "
    "rewards diagnostics".split()
)
"""Names of the stages timed in ``env.last_timings_ms``."""


class StereoNavEnv(gym.Env[Obs, NDArray[np.float32]]):
    """Drive a disc robot to a goal, seeing the world only through an uncertain stereo head.

    ## Description
    A robot (a disc 0.5 m wide and 1 m tall) moves on the floor of an indoor scene (walls with
    doorways, tables and chairs on legs, bookshelves whose repeated vertical edges make stereo
    matching ambiguous, boxes), simulated with pymunk. A stereo head on its centre pans relative
    to the body; every step a rectified pair is rendered (pyrender, headless) with Gaussian pixel
    noise (``pixel_noise_std``, 2 grey levels by default, drawn from ``np_random``), and the
    modeling pipeline of Miura (ICRA-94) turns it into an environment model: floor segments with
    uncertain endpoints, obstacles, critical regions (gaps whose passability for the robot's width
    is undecided, each with ``p_passable``), the occluded area, and the possible situations of the
    world (one per combination of ambiguous matches) with their probabilities. One addition to
    the paper's pipeline (``close_faces``, on by default): a plain face's bottom edge joining the
    lower ends of two vertical edges closes the "gap" between them (:mod:`modeling.stereo.faces`).
    Gaps close to the robot's width make passability genuinely uncertain, and looking again from
    elsewhere resolves it. With ``memory`` on (when the observation holds the memory, or asked
    for), every view is also fused into the episode's memory
    (:class:`~modeling.memory.fusion.ModelMemory`, paper section 6), whose model is
    ``info["memory_model"]``.

    ## Action Space
    ``StereoNav-v0``: ``Box(-1, 1, (3,), float32)``; every action moves and looks:

    | index | meaning                              | scale                                  |
    |-------|--------------------------------------|----------------------------------------|
    | 0     | forward speed (negative: backwards)  | x ``max_speed_m_s`` (0.5 m/s)          |
    | 1     | turn rate (counter-clockwise > 0)    | x ``max_turn_rate_rad_s`` (90 deg/s)   |
    | 2     | head pan target, relative to the body (left > 0) | x ``pan_limit_rad`` (90 deg) |

    The head moves towards its target at most ``max_pan_rate_rad_s`` (90 deg/s, 9 deg a step).
    Values outside [-1, 1] are clipped to it; an action that is not 3 finite numbers (NaN,
    infinity, another shape) is a ``ValueError``.

    ``StereoNavDiscrete-v0``: ``Discrete(11)`` macro actions, each one step of
    ``(forward, turn, pan target)`` in the same units
    (:data:`~stereo_nav_env.actions.DISCRETE_ACTIONS`):

    | index | name              | forward | turn | pan  |
    |-------|-------------------|---------|------|------|
    | 0     | forward           | 1       | 0    | 0    |
    | 1     | forward_left      | 1       | 0.5  | 0    |
    | 2     | forward_right     | 1       | -0.5 | 0    |
    | 3     | turn_left         | 0       | 1    | 0    |
    | 4     | turn_right        | 0       | -1   | 0    |
    | 5     | stop_look_left    | 0       | 0    | 0.5  |
    | 6     | stop_look_centre  | 0       | 0    | 0    |
    | 7     | stop_look_right   | 0       | 0    | -0.5 |
    | 8     | slow_look_left    | 0.5     | 0    | 0.5  |
    | 9     | slow_look_right   | 0.5     | 0    | -0.5 |
    | 10    | back_up           | -0.5    | 0    | 0    |

    An index that is not an integer in [0, 11) is a ``ValueError``.

    ## Observation Space
    ``Dict`` (K = ``num_situations`` = 8, R = ``num_regions`` = 8, F = 12, S = ``raster_size_px``
    = 64; robot frame: origin at the robot's centre, +x forward, +y left, metres):

    | key                | shape        | dtype   | range       | meaning                       |
    |--------------------|--------------|---------|-------------|-------------------------------|
    | `situation_probs`  | (K,)         | float32 | [0, 1]      | probabilities of the K most   |
    |                    |              |         |             | probable situations,          |
    |                    |              |         |             | descending (0: none)          |
    | `critical_regions` | (K * R * F,) | float32 | per column, | row-major (K, R, F): each     |
    |                    |              |         | see below   | situation's critical regions, |
    |                    |              |         |             | nearest first                 |
    | `raster`           | (S, S, 3)    | uint8   | [0, 255]    | egocentric top-down raster,   |
    |                    |              |         |             | forward up: expected          |
    |                    |              |         |             | occupancy; doubt 4p(1-p) of   |
    |                    |              |         |             | the critical regions;         |
    |                    |              |         |             | unobserved (255 occluded, 128 |
    |                    |              |         |             | outside the field of view)    |
    | `goal`             | (4,)         | float32 | x, y in     | goal in the robot frame:      |
    |                    |              |         | [-100, 100] | x_m, y_m, distance_m,         |
    |                    |              |         | m; d [0,    | bearing_rad (``GOAL_RANGE_M`` |
    |                    |              |         | 200]; [-pi, | = 100 m clips the lengths)    |
    |                    |              |         | pi] rad     |                               |
    | `head_pan`         | (1,)         | float32 | [-1, 1]     | head pan relative to the body |
    |                    |              |         |             | divided by ``pan_limit_rad``  |
    | `left`, `right`    | (H, W, 3)    | uint8   | [0, 255]    | the noisy rectified pair      |
    |                    |              |         |             | (``observation_mode``         |
    |                    |              |         |             | ``"images"`` or ``"both"``)   |

    The ``memory_*`` keys: ``memory_situation_probs`` and ``memory_critical_regions`` are those
    of the fused model (robot frame of now), ``memory_raster`` (S, S, 4) has the `raster`
    channels of the fused model, then unknown (255 where the floor was never seen).

    The F region columns: valid, x_m, y_m (centre of the narrowest undecided relation),
    width_mean_m, width_std_m, p_passable, doubt (4p(1-p)), distance_m, bearing_rad, axis_x, axis_y
    (unit vector across the gap), radius_m (extent of the region); padding rows are all 0. Their
    ranges (L = ``feature_range_m``, 10 m; larger values clipped): valid, p_passable, doubt in
    [0, 1]; x_m, y_m in [-L, L]; width_mean_m, width_std_m, radius_m in [0, L]; distance_m in
    [0, 2L]; bearing_rad in [-pi, pi]; axis_x, axis_y in [-1, 1]. With
    ``observation_mode="images"`` only ``left``, ``right``, ``goal`` and ``head_pan`` are present.
    The modes: ``"model"`` (v0's default: the latest view's model keys, ``goal``, ``head_pan``),
    ``"images"``, ``"both"`` (model keys and images), ``"memory"`` (the three ``memory_*`` keys
    instead of the model keys), ``"model_memory"`` (the model keys and the ``memory_*`` keys) and
    ``"policy"`` (v1's default): `raster` (S, S, 5) with seen free (this view), occupied,
    critical, occluded and never seen (the blind band, floor within ``blind_range_m`` of the
    head, included) apart; `situation_probs`; `critical_regions` over their bounds, in [-1, 1];
    `goal` (3,): distance over ``goal_range_m`` (15 m, clipped to 1), cos and sin of the
    bearing; `head_pan`; `contact` (1,) in {0, 1}; `prev_action` (3,) in [-1, 1].
    Details: :mod:`stereo_nav_env.observation.packing`, :mod:`stereo_nav_env.observation.raster`.

    ## Rewards
    The sum of the named components in ``info["reward_components"]`` (weights in
    :class:`~stereo_nav_env.config.RewardConfig`): ``goal`` (+10 on reaching the goal),
    ``collision`` (-10 in a step with a contact under the v0 rules, -0.1 under v1), ``time``
    (-0.01 every step), ``progress`` (1 x the decrease of the geodesic distance to the goal
    through the true free space, metres). The rules in force: ``config.rules_dict()``.

    ## Starting State
    The scene's start pose, head pan 0, at rest. Maps are fixed; generator families draw a new scene
    from ``np_random`` at every reset. The first observation is computed from the start pose.

    ## Episode End
    Terminated when the robot's centre is within ``goal_radius_m`` (0.3 m) of the goal
    (``info["is_success"]``), or, under the v0 rules, when it touches an obstacle
    (``info["collision"]``; ``terminate_on_collision``, False under v1: the robot stops at the
    obstacle and may recover). Truncated by the ``TimeLimit`` wrapper after
    ``max_episode_steps`` (500 steps, 50 s), and when stuck: ``stuck_steps`` steps (0 = never,
    the default) without ``stuck_progress_m`` of geodesic progress.

    ## Info
    ``model`` (:class:`~modeling.model.records.EnvironmentModel` of the latest pair, compared by
    content), ``memory_model`` (with ``memory`` on: the fused model of every view of the episode
    so far, and its contacts: :func:`modeling.memory.fusion.build_memory_model` of
    ``env.unwrapped.memory``, compared by content; else ``None``), ``diagnostics`` (floats
    comparing them with the truth: ``nees_mean``, ``coverage_95``, ``passability_brier``,
    ``p_true_candidate`` and their counts, and the same of the fused model as ``memory_<name>``; a
    figure with nothing to measure in the view is left out; see :mod:`stereo_nav_env.diagnostics`;
    empty with ``diagnostics=False``), ``reward_components`` (after a step), ``is_success``,
    ``collision``, ``scene`` (its name), ``distance_to_goal_m`` (straight) and
    ``geodesic_distance_m``.

    ## Arguments
    ``gym.make("StereoNav-v0", render_mode=None, **kwargs)``: ``render_mode`` is ``None`` or
    ``"rgb_array"`` (``render()``: a 480 x 960 RGB frame, the true world from above with the model
    and the left image; :mod:`stereo_nav_env.rendering.viewer`). Every other keyword is a field of
    :class:`~stereo_nav_env.config.EnvConfig` or of one of its sub-configurations (world, camera,
    observation, rewards), given flat (``robot_width_m=0.6``) or whole (``world=``: an instance
    or a dict); an unknown or invalid one is a ``ValueError`` naming it. The configuration is
    ``env.unwrapped.config``, its stereo rig ``env.unwrapped.rig``. ``perception="surrogate"``
    renders nothing: the floor observation comes from the true scene, the stereo's error model
    and its measured rates (:mod:`stereo_nav_env.perception.surrogate.sensor`), then the same
    modeling, packing, rewards and diagnostics; the observation must then hold no images. So does
    ``perception="truth"`` (the true visible outlines, no spread); ``"stereo_means"`` (the
    stereo's segments at face value, one situation) and ``"dense"`` (OpenCV's semi-global
    matching into an occupancy grid) render the same pair as the stereo (issue 43).
    ``surface_detail=True`` gives the faces of walls, boxes and bookshelves vertical structure
    (panel seams, door frames, cabinet fronts, book spines; drawn per scene from its seed,
    :mod:`stereo_nav_env.sim.scenes.surface`), which the stereo sees and the surrogate imitates;
    off by default (plain, flat-shaded faces: the world, the rendering and every observation are
    then those of the versions before it, bit for bit).

    ## Version History
    * v0: the model-based observation (situations, critical regions, raster), move-and-look
      actions, named rewards with geodesic progress, diagnostics against ground truth (issue 5).
      A first v0 of issue 2 observed only the goal and the head pan. Issue 16 added the fused
      model (``info["memory_model"]``, the ``"memory"`` and ``"model_memory"`` observation modes,
      the ``memory_*`` diagnostics); the default mode's spaces are unchanged.
    * v1: the episode rules of issue 18 (``rules="v1"``, :data:`~stereo_nav_env.config.RULES`):
      collisions do not end an episode and cost 0.1 per contact step; optional truncation when
      stuck; the ``"policy"`` observation by default. Actions as v0.
    * Both versions, issue 40: ``memory`` defaults to ``None``, on exactly when the observation
      holds the memory (``"memory"``, ``"model_memory"``); it was on in every v0 env before,
      fusing every view into a memory no default consumer read. Pass ``memory=True`` for
      ``info["memory_model"]`` and the ``memory_*`` diagnostics. Observations, rewards and the
      model are unchanged.
    * Both versions, issue 42: ``surface_detail`` (off by default) gives faces seams, door
      frames, fronts and book spines; with it off, every observation is as before, bit for bit.
      It stays off: on the dev split it took the planner's success from 0.75 to 0.50 (seed
      4242) and 0.94 to 0.62 (seed 90317), time-outs from 5 to 14 of 32 (docs/evaluation.md).
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
        self.action_space = self._make_action_space()
        self.observation_space = cast(
            spaces.Space[Obs], observation_space(self.config.observation, self.rig)
        )
        self._fixed_scene: Scene | None = self._map_scene()
        self.scene: Scene | None = None
        self.world: World | None = None
        self.model: EnvironmentModel | None = None
        self.memory: ModelMemory | None = None
        """The episode's fused memory of every view so far (world frame)."""
        self.memory_model: EnvironmentModel | None = None
        """The model of :attr:`memory` (``info["memory_model"]``)."""
        self.memory_options = memory_options(self.config)
        """How views and contacts are fused (:class:`~modeling.memory.fusion.MemoryOptions`)."""
        self._memory_cache = ModelCache()
        """The last memory model's intermediate results (the next is often made of the same
        remembered segments: :class:`~modeling.model.build.ModelCache`)."""
        self.perception: Perception = make_perception(self.config)
        """What turns each view into a model (``config.perception``; it owns the renderer)."""
        self.last_timings_ms: dict[str, float] = {}
        self._geodesic: GeodesicField | None = None
        self._truth: GroundTruth | None = None
        self._truth_scene: Scene | None = None
        self._view: tuple[MapView, UInt8Image] | None = None
        self._steps = 0
        self._return = 0.0
        self._stuck = StuckTimer(window_steps=0, progress_m=1.0, reference_m=math.inf)
        self._seen: SeenFloor | None = None  # the floor seen in the episode ("policy" mode)
        self._last = (np.zeros(3, np.float32), False)  # the last command and contact

    # ------------------------------------------------------------------ actions
    def _make_action_space(self) -> spaces.Space[Any]:
        return spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)

    def _command(self, action: Any) -> NDArray[np.float64]:
        """The normalised ``(forward, turn, pan)`` command of ``action`` (validated, clipped)."""
        return continuous_command(action)

    # ------------------------------------------------------------------ ground truth / views
    def _require_world(self) -> World:
        if self.world is None:
            raise RuntimeError("call reset() before using the environment")
        return self.world

    @property
    def head_pose(self) -> HeadPose:
        """Pose of the LEFT optical centre now."""
        tilt = self.config.camera.tilt_rad
        return self._require_world().head_pose(self.rig.baseline_m, tilt_rad=tilt)

    @property
    def robot_pose(self) -> tuple[float, float, float]:
        """``(x_m, y_m, heading_rad)`` of the robot's centre now, world frame."""
        s = self._require_world().state
        return (s.x_m, s.y_m, s.heading_rad)

    def ground_truth_footprints(self) -> list[NDArray[np.float64]]:
        """True obstacle outlines, each (k, 2) world metres."""
        self._require_world()
        assert self.scene is not None
        return self.scene.footprints()

    def render_stereo(self) -> StereoPair:
        """The noisy rectified pair of the latest observation: copies, uint8 (H, W, 3) each."""
        self._require_world()
        pair = self.perception.stereo_pair()
        if pair is None:
            raise RuntimeError(
                f"perception={self.config.perception.value!r} renders no stereo pair"
            )
        left, right = pair
        return left.copy(), right.copy()

    def stereo_renderer(self) -> StereoRenderer:
        """The renderer of the current scene (made on first use, kept across resets): for tools
        that render poses of their own, e.g. a benchmark timing the pair alone."""
        self._require_world()
        assert self.scene is not None
        return self.perception.renderer(self.scene)

    # ------------------------------------------------------------------ one observation
    def _observe(self, watch: Stopwatch, contacts: tuple[Contact, ...] = ()) -> Obs:
        """Perceive (:attr:`perception`), fuse the view and ``contacts`` into the memory
        (:meth:`_remember`), pack the observation."""
        cfg, world, pose = self.config, self._require_world(), self.robot_pose
        assert self.scene is not None
        self.model = self.perception.perceive(self.scene, self.head_pose, self.np_random, watch)
        self._remember(contacts, watch)
        near, ocfg = cfg.blind_range_m, cfg.observation
        pan = np.array([pan_fraction(world.pan_rad, cfg.world.pan_limit_rad)], np.float32)
        if self._seen is not None:  # mode "policy": its own goal field, first as in every mode
            self._seen.mark(self.model, near)
            unseen = self._seen.never_seen(pose, ocfg)
            packed = pack_policy(self.model, unseen, self.scene.goal, pose, ocfg, near, self._last)
            obs: Obs = {"goal": packed["goal"], "head_pan": pan, **packed}
        else:
            obs = {"goal": goal_features(self.scene.goal, pose), "head_pan": pan}
        if ocfg.has_model:
            obs.update(pack_model(self.model, pose, ocfg, near_m=near))
        if ocfg.has_memory:
            assert self.memory is not None and self.memory_model is not None
            obs.update(pack_memory(self.memory_model, self.memory.seen, pose, ocfg, near_m=near))
        if cfg.observation.has_images:
            obs["left"], obs["right"] = self.render_stereo()
        watch.lap("packing")
        return obs

    def _remember(self, contacts: tuple[Contact, ...], watch: Stopwatch) -> None:
        """With ``config.memory``: fuse the latest view (``self.model``) and ``contacts`` into
        ``self.memory`` (lap ``fusion``), then build ``self.memory_model`` (``memory_model``)."""
        if not self.config.memory:
            return
        assert self.model is not None and self.memory is not None
        self.memory = fuse_view(self.memory, self.model, contacts, self.config, self.memory_options)
        watch.lap("fusion")
        self.memory_model = ComparableModel.of(
            memory_model_of(self.memory, self.config, cache=self._memory_cache)
        )
        watch.lap("memory_model")

    def _info(self, watch: Stopwatch, *, geodesic_m: float) -> dict[str, Any]:
        """The info dict of the current state (``geodesic_m``: its distance to the goal)."""
        assert self.scene is not None and self.model is not None
        pose = self.robot_pose
        diagnostics: dict[str, float] = {}
        if self.config.diagnostics:
            assert self._truth is not None
            diagnostics = model_diagnostics(self.model, self._truth)
            if self.memory is not None and self.memory_model is not None:
                fused = (self.memory_model, self.memory, self.memory_options.gate_chi2)
                diagnostics |= memory_diagnostics(*fused, self.model, self._truth)
        watch.lap("diagnostics")
        models = (
            {"model": self.model, "memory_model": self.memory_model}
            if self.config.info_models
            else {}
        )
        return {
            **models,
            "diagnostics": diagnostics,
            "is_success": False,
            "collision": False,
            "scene": self.scene.name,
            "distance_to_goal_m": math.hypot(
                self.scene.goal[0] - pose[0], self.scene.goal[1] - pose[1]
            ),
            "geodesic_distance_m": geodesic_m,
        }

    # ------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Obs, dict[str, Any]]:
        """Start an episode; a generated scenario draws its scene from ``np_random``."""
        super().reset(seed=seed)
        watch = Stopwatch()
        cfg = self.config
        if self._fixed_scene is not None:
            scene = self._fixed_scene
        else:
            scene = self._load_scene(int(self.np_random.integers(2**31 - 1)))
        self.scene = scene
        self.world = World(scene, cfg.world)
        if self._truth_scene is not scene:
            self._geodesic = GeodesicField.build(
                scene, cfg.world.robot_radius_m, cfg.rewards.geodesic_cell_m
            )
            self._truth = (
                GroundTruth.of(
                    scene, cfg.world.robot_width_m, max_height_m=cfg.world.robot_height_m
                )
                if cfg.diagnostics
                else None
            )
            self._truth_scene = scene
            self._view = None
        self._steps = 0
        self._return = 0.0
        self.memory = ModelMemory.empty()  # the first view is fused into an empty memory
        self._seen, self._last = None, (np.zeros(3, np.float32), False)
        if cfg.observation.has_policy:  # the floor seen, on cells half the raster's
            self._seen = SeenFloor(scene.bounds, cfg.observation.raster_cell_m / 2)
        watch.lap("physics")
        obs = self._observe(watch)
        assert self._geodesic is not None
        geodesic_m = self._geodesic(self.robot_pose[:2])
        self._stuck = StuckTimer(
            window_steps=cfg.stuck_steps, progress_m=cfg.stuck_progress_m, reference_m=geodesic_m
        )
        info = self._info(watch, geodesic_m=geodesic_m)
        self.last_timings_ms = watch.laps
        return obs, info

    def step(self, action: Any) -> tuple[Obs, float, bool, bool, dict[str, Any]]:
        """Move, turn and pan by ``action`` (see Action Space) for ``dt_s`` seconds, then look."""
        command = self._command(action)
        world = self._require_world()
        assert self._geodesic is not None and self.scene is not None
        watch = Stopwatch()
        cfg = self.config
        before = self._geodesic(self.robot_pose[:2])
        result = world.step(
            command[0] * cfg.world.max_speed_m_s,
            command[1] * cfg.world.max_turn_rate_rad_s,
            command[2] * cfg.world.pan_limit_rad,
        )
        watch.lap("physics")
        self._last = (command.astype(np.float32), bool(result.collided))  # clipped already
        obs = self._observe(watch, result.contacts)
        pose = self.robot_pose
        after = self._geodesic(pose[:2])
        reached = math.hypot(self.scene.goal[0] - pose[0], self.scene.goal[1] - pose[1]) <= (
            cfg.goal_radius_m
        )
        components = reward_components(
            cfg.rewards,
            geodesic_before_m=before,
            geodesic_after_m=after,
            collided=result.collided,
            reached_goal=reached,
        )
        reward = float(sum(components.values()))
        watch.lap("rewards")
        info = self._info(watch, geodesic_m=after)
        info.update(is_success=reached, collision=result.collided, reward_components=components)
        terminated = bool(reached or (result.collided and cfg.terminate_on_collision))
        truncated = self._stuck.update(after) and not terminated
        self._steps += 1
        self._return += reward
        self.last_timings_ms = watch.laps
        return obs, reward, terminated, truncated, info

    def render(self) -> UInt8Image | None:  # type: ignore[override]  # gymnasium 1.2.2: a TypeVar
        """``rgb_array``: a 480 x 960 RGB frame (world from above, model overlay, left image)."""
        if self.render_mode != "rgb_array":
            return None
        self._require_world()
        assert self.scene is not None
        if self._view is None:
            view = MapView.of(self.scene)
            self._view = (view, draw_background(self.scene, view, self.config.world.robot_width_m))
        view, background = self._view
        headline = f"{self.scene.name}  step {self._steps}  return {self._return:+.2f}"
        state = self._require_world().state
        return draw_frame(
            background,
            view,
            scene=self.scene,
            model=self.model,
            robot_pose=self.robot_pose,
            gaze_rad=state.gaze_rad,
            robot_radius_m=self.config.world.robot_radius_m,
            goal_radius_m=self.config.goal_radius_m,
            left_image=None if (pair := self.perception.stereo_pair()) is None else pair[0],
            caption=model_caption(headline, self.model),
        )

    def set_scenario(self, scenario: str) -> None:
        """Draw the next resets' scenes from ``scenario`` (a map or family; a curriculum's next
        stage): the spaces stay, the episode under way goes on. ``ValueError`` for a bad name."""
        self.config = dataclasses.replace(self.config, scenario=scenario)
        self._fixed_scene = self._map_scene()

    def _map_scene(self) -> Scene | None:
        """The configured map's scene, loaded once for every reset; ``None`` for a family (each
        reset draws its own)."""
        return None if self.config.is_generated else self._load_scene()

    def _load_scene(self, seed: int = 0) -> Scene:
        """The configured scenario's scene (a family's drawn from ``seed``), for the configured
        robot width and surface detail."""
        cfg = self.config
        return load_scenario(
            cfg.scenario,
            seed,
            robot_width_m=cfg.world.robot_width_m,
            surface_detail=cfg.surface_detail,
        )

    def close(self) -> None:
        """Release the renderer's OpenGL context (idempotent; rendering again makes a new one)."""
        self.perception.close()
        super().close()  # type: ignore[no-untyped-call]  # gymnasium 1.2.2

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_view"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)


class StereoNavDiscreteEnv(StereoNavEnv):
    """``StereoNavDiscrete-v0``: :class:`StereoNavEnv` with ``Discrete(11)`` move-and-look macros.

    Everything but the action space is the same; see :class:`StereoNavEnv` (Action Space) and
    :data:`stereo_nav_env.actions.DISCRETE_ACTIONS`.
    """

    def _make_action_space(self) -> spaces.Space[Any]:
        return spaces.Discrete(len(DISCRETE_ACTIONS))

    def _command(self, action: Any) -> NDArray[np.float64]:
        return discrete_command(action)
