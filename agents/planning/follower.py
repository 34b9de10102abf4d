"""Driving a route: pure pursuit for the body, and where the head points meanwhile.

:class:`PathFollower` turns a route (a polyline of waypoints) into normalised ``(forward, turn)``
commands by pure pursuit. :class:`RouteDriver` adds the head for the model-based agents: it points
the head at the route a little ahead (so the edges of what lies round the next corner are seen
before the body turns into it), or at a point to look at, turning the body towards it when the
head cannot reach it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from agents.base import ControlLimits
from modeling.geometry import wrap_angle
from modeling.types import FloatArray

__all__ = ["PathFollower", "RouteDriver", "pan_towards"]


@dataclass(frozen=True, slots=True, kw_only=True)
class PathFollower:
    """Pure-pursuit follower turning a route into normalised (forward, turn) commands.

    Attributes:
        max_speed_mps: Speed that a forward command of 1 gives, m/s.
        max_turn_rate_rps: Turn rate that a turn command of 1 gives, rad/s.
        dt_s: Duration of one control step, seconds.
        lookahead_m: Pure-pursuit look-ahead distance, metres.
        goal_tolerance_m: Distance at which the route's end counts as reached, metres.
        shortcut_m: Pursue from the last part of the route that passes within this much of the
            robot (0: always from the nearest part). A re-planned route can start
            with a short step back (to the free cell nearest to a robot standing in a margin or
            in a doorway) and then pass the robot again; pursuing from the nearest part would
            turn the robot round on the spot for that step, and a fresh plan a few steps later
            can turn it back. No obstacle fits between two parts of a route this close.
    """

    max_speed_mps: float
    max_turn_rate_rps: float
    dt_s: float
    lookahead_m: float = 0.4
    goal_tolerance_m: float = 0.1
    shortcut_m: float = 0.0

    def command(self, pose: ArrayLike, waypoints: ArrayLike) -> tuple[float, float]:
        """Forward and turn commands in [-1, 1] moving ``pose`` (x, y, heading) along the route."""
        x, y, heading = np.asarray(pose, dtype=np.float64).reshape(3)
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        here = np.array([x, y])
        if len(pts) == 0 or np.linalg.norm(pts[-1] - here) < self.goal_tolerance_m:
            return 0.0, 0.0
        target = self._lookahead_point(here, pts)
        delta = target - here
        bearing = wrap_angle(math.atan2(delta[1], delta[0]) - heading)
        turn = float(np.clip(bearing / (self.max_turn_rate_rps * self.dt_s), -1.0, 1.0))
        distance = float(np.linalg.norm(pts[-1] - here))
        # Slow down to turn on the spot when facing away; stop exactly at the goal.
        alignment = max(0.0, math.cos(bearing)) ** 2
        forward = min(1.0, distance / (self.max_speed_mps * self.dt_s)) * alignment
        if abs(bearing) > math.radians(60):
            forward = 0.0
        return float(forward), turn

    def point_ahead(self, here: ArrayLike, waypoints: ArrayLike, distance_m: float) -> FloatArray:
        """(2,) the point ``distance_m`` along the route ahead of the robot at ``here``."""
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        xy = np.asarray(here, dtype=np.float64).reshape(2)
        if len(pts) == 0:
            return xy
        return self._lookahead_point(xy, pts, distance_m)

    def _lookahead_point(
        self, here: FloatArray, pts: FloatArray, lookahead_m: float | None = None
    ) -> FloatArray:
        end: FloatArray = pts[-1]
        if len(pts) == 1:
            return end
        seg_a, seg_b = pts[:-1], pts[1:]
        d = seg_b - seg_a
        length2 = np.maximum((d * d).sum(axis=1), 1e-12)
        t = np.clip(((here - seg_a) * d).sum(axis=1) / length2, 0.0, 1.0)
        closest = seg_a + t[:, None] * d
        dist = np.linalg.norm(closest - here, axis=1)
        near = np.flatnonzero(dist <= self.shortcut_m)
        k = int(near[-1]) if near.size else int(np.argmin(dist))
        # Walk forward along the polyline by the look-ahead distance from the closest point.
        remaining = self.lookahead_m if lookahead_m is None else lookahead_m
        point: FloatArray = closest[k]
        for i in range(k, len(seg_b)):
            step = float(np.linalg.norm(seg_b[i] - point))
            if step >= remaining:
                ahead: FloatArray = point + (seg_b[i] - point) * (remaining / max(step, 1e-12))
                return ahead
            remaining -= step
            point = seg_b[i]
        return end


def pan_towards(
    target: FloatArray, here: FloatArray, heading_rad: float, pan_limit_rad: float
) -> tuple[float, float]:
    """``(bearing, pan)``: the bearing of ``target`` from the body at ``here`` (radians, wrapped)
    and the pan command that points the head at it, as a fraction of the pan limit (clipped).

    Args:
        target: (2,) the point to look at, world metres.
        here: (2,) the robot, world metres.
        heading_rad: Heading of the body, radians.
        pan_limit_rad: Pan of the head at a pan command of 1, radians.
    """
    need = wrap_angle(math.atan2(*(target - here)[::-1]) - heading_rad)
    return need, float(np.clip(need, -pan_limit_rad, pan_limit_rad)) / pan_limit_rad


@dataclass(frozen=True, slots=True, kw_only=True)
class RouteDriver:
    """Body and head commands along a route.

    Attributes:
        pursuit: The body's pure-pursuit follower.
        limits: Action scales and field of view of the robot.
        gaze_ahead_m: While following, the head points at the route this far ahead (0: straight
            ahead).
    """

    pursuit: PathFollower
    limits: ControlLimits
    gaze_ahead_m: float = 0.0

    def follow(
        self, pose: tuple[float, float, float, float], waypoints: FloatArray, *, gaze: bool
    ) -> tuple[float, float, float]:
        """``(forward, turn, pan)`` following ``waypoints`` (n, 2) from ``pose`` (x, y, heading,
        pan); the head looks ``gaze_ahead_m`` ahead along the route when ``gaze``, else straight
        ahead."""
        x, y, heading, _ = pose
        forward, turn = self.pursuit.command((x, y, heading), waypoints)
        pan = 0.0
        if gaze and self.gaze_ahead_m > 0:
            # Look where the robot will be: at the route ``gaze_ahead_m`` ahead. Straight on,
            # that is straight ahead; before a turn the head turns into it first, so the vertical
            # edges of what lies round the corner (the two corners of a narrow box face, which
            # make it an obstacle) are seen before the body turns into it.
            here = np.array([x, y])
            ahead = self.pursuit.point_ahead(here, waypoints, self.gaze_ahead_m)
            _, pan = pan_towards(ahead, here, heading, self.limits.pan_limit_rad)
        return forward, turn, pan

    def look(
        self,
        pose: tuple[float, float, float, float],
        waypoints: FloatArray,
        target: FloatArray,
    ) -> tuple[float, float, float]:
        """``(forward, turn, pan)`` pointing the head at ``target`` (2,) while following
        ``waypoints`` at half speed; beyond the reach of the head, the body turns towards it,
        standing."""
        x, y, heading, _ = pose
        lim = self.limits
        forward, turn = self.pursuit.command((x, y, heading), waypoints)
        need, pan = pan_towards(target, np.array([x, y]), heading, lim.pan_limit_rad)
        if abs(need) > lim.pan_limit_rad + 0.5 * lim.fov_rad - 0.1:
            forward = 0.0
            turn = float(np.clip(need / (lim.max_turn_rate_rad_s * lim.dt_s), -1.0, 1.0))
        else:
            forward *= 0.5
        return forward, turn, pan

    def sees(self, point: FloatArray, pose: tuple[float, float, float, float]) -> bool:
        """Whether ``point`` (2,) lies in the field of view (less a 0.1 rad margin) of the head at
        ``pose`` (x, y, heading, pan)."""
        x, y, heading, pan = pose
        rel = point - np.array([x, y])
        off = abs(wrap_angle(math.atan2(rel[1], rel[0]) - (heading + pan)))
        return off < 0.5 * self.limits.fov_rad - 0.1
