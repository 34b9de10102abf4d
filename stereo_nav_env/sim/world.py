"""The 2D physical world: a disc robot among static obstacle footprints, simulated with pymunk.

The only module that imports pymunk. Frames and units: world metres, floor plane x-y, headings in
radians counter-clockwise from +x, time in seconds.

The robot is a dynamic disc whose velocity and angular velocity are set from the commanded forward
speed and turn rate at every physics substep (kinematic-like control), so pymunk's contact solver
stops it at obstacles and lets it slide along them instead of passing through. Substeps are short
enough (``max_speed_m_s * dt_s / substeps`` is a few millimetres) that it cannot tunnel through
thin walls. A stereo head sits on the robot's centre; its pan angle relative to the body moves
towards a target at a limited rate and within limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk
import shapely
from shapely.geometry import Polygon

from modeling.stereo.rig import HeadPose
from stereo_nav_env.config import WorldConfig
from stereo_nav_env.sim.scenes import Scene

__all__ = ["Contact", "RobotState", "StepResult", "World"]

_ROBOT = 1
_OBSTACLE = 2
_ROBOT_CATEGORY = 0b1
"""The robot shape's filter category (the nearest-obstacle query leaves it out)."""
_NOT_ROBOT = pymunk.ShapeFilter(mask=pymunk.ShapeFilter.ALL_MASKS() ^ _ROBOT_CATEGORY)
"""The query filter of every shape but the robot's."""
_CLEAR_MARGIN_M = 0.05
"""Slack of :meth:`World.untouched_substeps` (a contact counts from 1 mm apart)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class RobotState:
    """Where the robot is.

    Attributes:
        x_m: World x of the robot's centre, metres.
        y_m: World y, metres.
        heading_rad: Body heading, radians counter-clockwise from +x, wrapped to (-pi, pi].
        pan_rad: Head pan relative to the body, radians (positive: to the left).
    """

    x_m: float
    y_m: float
    heading_rad: float
    pan_rad: float

    @property
    def gaze_rad(self) -> float:
        """World direction of the head's optical axes, radians, wrapped to (-pi, pi]."""
        return _wrap(self.heading_rad + self.pan_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class Contact:
    """Where the robot touched an obstacle (from pymunk's contact point set).

    Attributes:
        point_xy: The contact point on the obstacle's surface, world frame, metres.
        normal_xy: Unit normal of the obstacle's surface there, pointing out of the obstacle
            (towards the robot's centre), world frame.
    """

    point_xy: tuple[float, float]
    normal_xy: tuple[float, float]


@dataclass(frozen=True, slots=True, kw_only=True)
class StepResult:
    """What happened during one :meth:`World.step`.

    Attributes:
        collided: Whether the robot touched an obstacle in any substep.
        distance_m: Path length its centre travelled, metres.
        contacts: The contacts of the last substep with a contact (empty when ``collided`` is
            false), one per touched shape, those within 1 cm of an earlier one left out.
    """

    collided: bool
    distance_m: float
    contacts: tuple[Contact, ...] = ()


def _wrap(angle: float) -> float:
    """``angle`` (radians) wrapped to (-pi, pi] by the exact ``math.remainder``: the physics' own
    wrap of the body's unbounded pymunk angle (``modeling.geometry.wrap_angle``'s
    ``(a + pi) % 2pi - pi`` rounds and maps to [-pi, pi), so it would change the poses' last bits
    and with them every observation of a rollout)."""
    wrapped = math.remainder(angle, 2 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


def _clip(value: float, limit: float) -> float:
    """``value`` (finite) clipped to ``[-limit, limit]``: ``np.clip``'s value, to the sign of
    a zero, in plain Python (the physics clips several times a step)."""
    return min(max(value, -limit), limit)


def _convex_pieces(footprint: np.ndarray) -> list[list[tuple[float, float]]]:
    poly = Polygon(footprint)
    if poly.equals(poly.convex_hull):
        return [[(float(x), float(y)) for x, y in footprint]]
    tris = shapely.constrained_delaunay_triangles(poly)
    return [
        [(float(x), float(y)) for x, y in np.asarray(t.exterior.coords)[:3]] for t in tris.geoms
    ]


class World:
    """A pymunk space holding the scene's obstacles and the robot.

    Args:
        scene: The scene (its footprints become static polygons).
        config: Robot and simulation parameters.
    """

    query_every_substep: bool = False
    """Query the contacts after every substep: the plain loop, the reference that
    :meth:`step`'s skipping of the queries is tested against (same results)."""

    def __init__(self, scene: Scene, config: WorldConfig | None = None) -> None:
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {type(scene).__name__}")
        self.config = WorldConfig() if config is None else config
        if not isinstance(self.config, WorldConfig):
            raise ValueError(f"config must be a WorldConfig, got {type(config).__name__}")
        self.scene = scene
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        self.space.iterations = 20
        self.space.collision_slop = 1e-4
        self.space.collision_bias = 0.0  # resolve overlap fully in each substep
        self.space.damping = 1.0
        static = self.space.static_body
        shapes = []
        for ob in scene.obstacles:
            for piece in _convex_pieces(ob.footprint):
                shape = pymunk.Poly(static, piece)
                shape.friction = 0.0
                shape.elasticity = 0.0
                shape.collision_type = _OBSTACLE
                shapes.append(shape)
        self.space.add(*shapes)
        self.body = pymunk.Body(10.0, float("inf"))  # replaced and added to the space by reset()
        self.shape = pymunk.Circle(self.body, self.config.robot_radius_m)
        self._pan = 0.0
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(
        self, pose: tuple[float, float, float] | None = None, pan_rad: float = 0.0
    ) -> RobotState:
        """Put the robot at ``pose`` ``(x, y, heading)`` (default: the scene's start), at rest."""
        x, y, heading = self.scene.start if pose is None else pose
        for name, value in (("pose", (x, y, heading)), ("pan_rad", (pan_rad,))):
            if not all(math.isfinite(float(v)) for v in value):
                raise ValueError(f"{name} must be finite, got {value!r}")
        # a fresh body: cached contacts of the old one would push it with warm-started impulses
        if self.body in self.space.bodies:
            self.space.remove(self.body, self.shape)
        self.body = pymunk.Body(10.0, float("inf"))
        self.body.position = (float(x), float(y))
        self.body.angle = float(heading)
        self.shape = pymunk.Circle(self.body, self.config.robot_radius_m)
        self.shape.friction = 0.0
        self.shape.elasticity = 0.0
        self.shape.collision_type = _ROBOT
        # its own category, so that untouched_substeps' query can leave it out (it collides
        # with the obstacles: their masks take every category)
        self.shape.filter = pymunk.ShapeFilter(categories=_ROBOT_CATEGORY)
        self.space.add(self.body, self.shape)
        limit = self.config.pan_limit_rad
        self._pan = float(np.clip(pan_rad, -limit, limit))
        return self.state

    @property
    def state(self) -> RobotState:
        """The robot's pose and head pan now."""
        x, y = self.body.position
        return RobotState(
            x_m=float(x), y_m=float(y), heading_rad=_wrap(self.body.angle), pan_rad=self._pan
        )

    @property
    def pan_rad(self) -> float:
        """Head pan relative to the body, radians."""
        return self._pan

    def head_pose(self, baseline_m: float, *, tilt_rad: float = 0.0) -> HeadPose:
        """Pose of the LEFT optical centre of a head of ``baseline_m`` centred on the robot.

        The left camera is ``baseline_m / 2`` to the left of the robot's centre, across the gaze
        direction, at ``head_height_m``, its optical axis ``tilt_rad`` below the horizon
        (``CameraConfig.tilt_rad``; validated by ``HeadPose``).
        """
        if not (math.isfinite(baseline_m) and baseline_m > 0):
            raise ValueError(f"baseline_m must be a positive finite number, got {baseline_m!r}")
        s = self.state
        gaze = s.gaze_rad
        half = baseline_m / 2.0
        return HeadPose(
            x_m=s.x_m - half * math.sin(gaze),
            y_m=s.y_m + half * math.cos(gaze),
            heading_rad=gaze,
            height_m=self.config.head_height_m,
            tilt_rad=tilt_rad,
        )

    def in_collision(self) -> bool:
        """Whether the robot's disc overlaps or touches an obstacle now."""
        return bool(self.contacts())

    def contacts(self) -> tuple[Contact, ...]:
        """The robot's contacts with obstacles now (overlap or within 1 mm), one per touched
        shape (its deepest point), those within 1 cm of an earlier one left out."""
        out: list[Contact] = []
        for info in self.space.shape_query(self.shape):
            contact_set = info.contact_point_set  # made anew by pymunk on every access
            points = contact_set.points
            if not points:
                continue
            deepest = min(points, key=lambda p: p.distance)
            if deepest.distance > 1e-3:
                continue
            # pymunk's normal points from the robot (shape a) into the obstacle (shape b)
            n = contact_set.normal
            point = (float(deepest.point_b.x), float(deepest.point_b.y))
            if any(math.dist(point, c.point_xy) < 0.01 for c in out):
                continue
            out.append(Contact(point_xy=point, normal_xy=(-float(n.x), -float(n.y))))
        return tuple(out)

    def _latest_contacts(self, positions: list[pymunk.Vec2d]) -> tuple[Contact, ...]:
        """The contacts at the latest of ``positions`` (the last: the robot's now) with any, as
        querying after every substep keeps them (they depend on the position alone: the
        obstacles are static); ``()`` if none. The body is put back where it is."""
        now = self.body.position
        try:
            for i, position in enumerate(reversed(positions)):
                if i:
                    self.body.position = position
                found = self.contacts()
                if found:
                    return found
            return ()
        finally:
            if len(positions) > 1:
                self.body.position = now

    def untouched_substeps(self, substep_m: float, substeps: int) -> int:
        """How many of the next ``substeps`` moves of at most ``substep_m`` each surely make no
        contact: those that keep the disc more than a 5 cm margin from every obstacle (the
        nearest one found by one query). :meth:`step` queries contacts after the others only;
        a test holds its results equal to querying after every substep."""
        r = self.config.robot_radius_m
        reach = r + substeps * substep_m + _CLEAR_MARGIN_M
        nearest = self.space.point_query_nearest(self.body.position, reach, _NOT_ROBOT)
        if nearest is None:
            return substeps
        clearance = nearest.distance - r - _CLEAR_MARGIN_M  # free travel before any contact
        if clearance <= 0:
            return 0
        return substeps if substep_m <= 0 else min(substeps, math.floor(clearance / substep_m))

    # ------------------------------------------------------------------ dynamics
    def step(
        self, forward_speed_m_s: float, turn_rate_rad_s: float, pan_target_rad: float
    ) -> StepResult:
        """Advance by ``config.dt_s``.

        Args:
            forward_speed_m_s: Commanded speed along the heading, m/s (clipped to the maximum).
            turn_rate_rad_s: Commanded turn rate, rad/s (clipped).
            pan_target_rad: Head pan the head moves towards (clipped to the pan limits).

        Returns:
            Whether it collided (and where), and how far it moved.
        """
        cfg = self.config
        values = (forward_speed_m_s, turn_rate_rad_s, pan_target_rad)
        for name, value in zip(
            ("forward_speed_m_s", "turn_rate_rad_s", "pan_target_rad"), values, strict=True
        ):
            if not math.isfinite(float(value)):
                raise ValueError(f"{name} must be finite, got {value!r}")
        v = _clip(float(forward_speed_m_s), cfg.max_speed_m_s)
        w = _clip(float(turn_rate_rad_s), cfg.max_turn_rate_rad_s)
        target = _clip(float(pan_target_rad), cfg.pan_limit_rad)
        h = cfg.dt_s / cfg.substeps
        contacts: tuple[Contact, ...] = ()
        distance = 0.0
        reference = self.query_every_substep
        # without contact the disc moves |v| h a substep (no solver push): the substeps that
        # cannot reach an obstacle need no contact query (most of the physics' time)
        untouched = 0 if reference else self.untouched_substeps(abs(v) * h, cfg.substeps)
        after: list[pymunk.Vec2d] = []  # the positions after the substeps that may touch
        for k in range(cfg.substeps):
            before = self.body.position
            angle = self.body.angle
            self.body.velocity = (v * math.cos(angle), v * math.sin(angle))
            self.body.angular_velocity = w
            self.space.step(h)
            distance += float((self.body.position - before).length)
            if reference:
                contacts = self.contacts() or contacts
            elif k >= untouched:
                after.append(self.body.position)
        if not reference:
            contacts = self._latest_contacts(after)
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0
        max_pan = cfg.max_pan_rate_rad_s * cfg.dt_s
        self._pan += _clip(target - self._pan, max_pan)
        return StepResult(collided=bool(contacts), distance_m=distance, contacts=contacts)
