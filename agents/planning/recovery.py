"""Recovery from bumps, stalls and lost progress: the model-based agents' reflexes.

Plain walls, box faces and table tops are invisible to the segment stereo, so the robot bumps into
them. A bump marks the map (the agent passes it to the planner) and the robot backs off for a few
steps. Bumped again while backing off, it estimates the contact normals from the motion each
contact blocked (for a sliding contact, a guess of the side) and moves along their mean, away from
everything it touched lately. No movement for a while counts as a bump (forwards); no progress
towards the goal for longer tells the agent to forget what it saw and its older bumps (a false
obstacle may trap it). That watch restarts when a re-plan finds the way much longer than the last
plan did (:meth:`Recovery.route_cost`): the detour round a blockage just found leads away from the
goal at first, and forgetting half-way round it sent the robot back to the way it had found
blocked.

Bumped again while already moving along the contact normals, the robot is wedged (in a slot between
two obstacles, say, whose faces the normals estimated from blocked motion, alternating, do not
point out of): it retraces its own trail, the places it passed on its way in, which were free, back
for up to ``_RETRACE_M`` (then it re-plans from there).

:class:`Recovery` owns this state; each step the agent calls :meth:`Recovery.update` (what
happened), :meth:`Recovery.escape_command` (the back-off's command, if one is under way) and
:meth:`Recovery.commanded` (the forward command finally sent), and after each re-plan
:meth:`Recovery.route_cost`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from modeling.geometry import wrap_angle
from modeling.types import FloatArray

__all__ = ["Bump", "Recovery", "RecoveryEvents"]

_TRAIL_STEP_M = 0.1
"""The trail keeps a position each time the robot has moved this far from the last one, metres."""

_TRAIL_POINTS = 40
"""The trail keeps this many positions at most (the latest)."""

_RETRACE_M = 1.0
"""A wedged robot retraces this much of its trail at most, metres."""

_RETRACE_STEPS = 30
"""A retrace ends after this many steps, or after ``_RETRACE_BLOCKED`` steps with a contact."""

_RETRACE_BLOCKED = 4
"""Contacts that blocked a retrace's motion before it gives up (and the agent re-plans)."""


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Bump:
    """A collision of this step, for the map.

    Attributes:
        backwards: Whether the robot was reversing.
        normal: (2,) unit contact normal (from the obstacle towards the robot), or ``None`` when
            no blocked motion measured it.
    """

    backwards: bool
    normal: FloatArray | None


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class RecoveryEvents:
    """What :meth:`Recovery.update` noticed this step (the agent acts on them in this order).

    Attributes:
        bump: This step's collision, to mark on the map, or ``None``.
        lost: No progress towards the goal for ``forget_steps``: forget what was seen, the older
            bumps and the kept route.
        stalled: No movement for ``stall_steps``: mark a bump ahead (a back-off has started).
    """

    bump: Bump | None = None
    lost: bool = False
    stalled: bool = False

    @property
    def replan(self) -> bool:
        """Whether any of them calls for a fresh plan."""
        return self.bump is not None or self.lost or self.stalled


class Recovery:
    """The back-off state machine, the contact normals, and the stall and progress watches.

    Args:
        config: Navigator parameters (``backoff_steps``, ``stall_steps``, ``forget_steps``).
        limits: Action scales of the robot.
        pose: ``(x_m, y_m, heading_rad)`` of the robot at the start of the episode.
        goal_distance_m: Its distance from the goal then, metres.
    """

    def __init__(
        self,
        config: NavigatorConfig,
        limits: ControlLimits,
        pose: tuple[float, float, float],
        goal_distance_m: float,
    ) -> None:
        x, y, heading = pose
        self.config = config
        self.limits = limits
        # The back-off: steps left, direction (1 forwards, -1 backwards), reversals, the heading
        # to move along (``None``: straight), and the step of its last command.
        self._escape = 0
        self._escape_dir = -1.0
        self._escape_flips = 0
        self._escape_heading: float | None = None
        self._escape_last = -10
        # The contacts: the last command and pose (to measure what was blocked), the normals
        # of the recent contacts, and the number of side guesses.
        self._last_forward = 0.0
        self._last_pose = (x, y, heading)
        self._contacts: list[tuple[int, FloatArray]] = []
        self._slides = 0
        # The watches: where the robot last moved, and how near to the goal it came, and when.
        self._anchor = np.array([x, y])
        self._anchor_step = 0
        self._closest = goal_distance_m
        self._closest_step = 0
        self._route_cost = math.inf
        # The trail of places passed (oldest first), the points of it being retraced (next
        # first), contacts met while retracing, and bumps met during the current back-off.
        self._trail: deque[tuple[int, FloatArray]] = deque(
            [(0, np.array([x, y]))], maxlen=_TRAIL_POINTS
        )
        self._trouble_step = 0
        self._retrace: list[FloatArray] = []
        self._retrace_blocked = 0
        self._escape_bumps = 0

    def route_cost(self, cost_m: float, step: int, goal_distance_m: float) -> None:
        """Take in the expected cost of the route just planned: a rise of more than
        ``progress_reset_m`` over the last one (a way found blocked, a detour begun) restarts the
        progress watch from ``goal_distance_m``, so that a detour away from the goal is not taken
        for lost progress (and what blocked the way is not forgotten)."""
        reset = self.config.progress_reset_m
        if reset > 0.0 and math.isfinite(cost_m):
            if math.isfinite(self._route_cost) and cost_m > self._route_cost + reset:
                self._closest, self._closest_step = goal_distance_m, step
            self._route_cost = cost_m

    @property
    def escaping(self) -> bool:
        """Whether a back-off is under way."""
        return self._escape > 0

    def update(
        self,
        pose: tuple[float, float, float],
        step: int,
        *,
        collided: bool,
        goal_distance_m: float,
    ) -> RecoveryEvents:
        """Take in this step's pose ``(x_m, y_m, heading_rad)``, collision flag and distance to
        the goal; start or redirect a back-off where they call for one."""
        x, y, heading = pose
        here = np.array([x, y])
        if not self._retrace and float(np.hypot(*(here - self._trail[-1][1]))) > _TRAIL_STEP_M:
            self._trail.append((step, here))
        bump = self._collided(here, heading, step) if collided else None
        lost = False
        if goal_distance_m < self._closest - 0.3:
            self._closest, self._closest_step = goal_distance_m, step
        elif step - self._closest_step > self.config.forget_steps:
            self._closest, self._closest_step = goal_distance_m, step
            lost = True
        stalled = False
        if float(np.hypot(*(here - self._anchor))) > 0.15:
            self._anchor, self._anchor_step = here, step
        elif step - self._anchor_step > self.config.stall_steps:
            self._anchor, self._anchor_step = here, step
            self._escape, self._escape_dir, self._escape_flips = self.config.backoff_steps, -1.0, 0
            self._escape_heading = None
            self._retrace, self._escape_bumps = [], 0
            stalled = True
        self._last_pose = (x, y, heading)
        return RecoveryEvents(bump=bump, lost=lost, stalled=stalled)

    def escape_command(self, heading: float, step: int) -> tuple[float, float] | None:
        """``(forward, turn)`` of the back-off at ``step``, or ``None`` when none is under way."""
        if self._escape <= 0:
            return None
        self._escape -= 1
        self._escape_last = step
        if self._retrace:
            return self._retrace_command(heading)
        if self._escape_heading is None:
            return 0.6 * self._escape_dir, 0.0
        forward, turn = self._drive_along(self._escape_heading, heading)
        if self._escape == 0:
            self._escape_heading = None
        return forward, turn

    def commanded(self, forward: float) -> None:
        """Record the forward command sent this step (a bump next step measures what it lost)."""
        self._last_forward = forward

    def _collided(self, here: FloatArray, heading: float, step: int) -> Bump:
        """A collision at ``step``: note its contact, and start or redirect the back-off."""
        cfg = self.config
        backwards = self._last_forward < 0
        normal = self._note_contact(here, heading, step)
        if self._retrace:
            # Touching while retracing the way in (a graze, or the contact it is leaving): keep
            # going back, unless it keeps meeting contacts.
            self._retrace_blocked += int(normal is not None)
            if self._retrace_blocked >= _RETRACE_BLOCKED:
                self._retrace, self._escape = [], 0
            return Bump(backwards=backwards, normal=normal)
        escaping = self._escape > 0 or step - self._escape_last <= 1
        if escaping and self._escape_bumps >= 1 and self._start_retrace(here):
            return Bump(backwards=backwards, normal=normal)
        self._escape_bumps = self._escape_bumps + 1 if escaping else 0
        if not escaping:
            self._trouble_step = step
        away = self._away_from_contacts(step)
        self._escape_heading = None
        if self._escape > 0 and away is not None:
            # Bumped while backing off: move along the mean contact normal (away from
            # everything touched lately), after turning the nearer end of the body that way.
            lim = self.limits
            err = abs(wrap_angle(away - heading))
            err = min(err, math.pi - err)
            turn_steps = math.ceil(err / (lim.max_turn_rate_rad_s * lim.dt_s))
            self._escape = cfg.backoff_steps + turn_steps
            self._escape_heading = away
        elif self._escape > 0 or step - self._escape_last <= 1:
            # Bumped while escaping (or by its last step, as when a back-off meets what is
            # behind just as it ends; taken as a fresh bump, that would back off forwards
            # and bounce between the two for ever): the other way, twice at most, then
            # re-plan from here.
            self._escape_dir = -self._escape_dir
            self._escape_flips += 1
            self._escape = cfg.backoff_steps if self._escape_flips <= 2 else 0
        else:
            self._escape = cfg.backoff_steps
            self._escape_dir = 1.0 if backwards else -1.0
            self._escape_flips = 0
        return Bump(backwards=backwards, normal=normal)

    def _start_retrace(self, here: FloatArray) -> bool:
        """Start retracing the trail back from ``here``: the places passed before the bump that
        started this trouble (not the shuffles since), up to ``_RETRACE_M`` of them; whether
        there was a trail to retrace."""
        points: list[FloatArray] = []
        length, last = 0.0, here
        for k, p in reversed(self._trail):
            d = float(np.hypot(*(p - last)))
            if k >= self._trouble_step or (d < 1.5 * _TRAIL_STEP_M and not points):
                continue  # shuffles since the bump, or where the robot is now
            length += d
            if length > _RETRACE_M:
                break
            points.append(p)
            last = p
        if not points:
            return False
        self._retrace, self._retrace_blocked = points, 0
        self._escape, self._escape_heading, self._escape_bumps = _RETRACE_STEPS, None, 0
        return True

    def _retrace_command(self, heading: float) -> tuple[float, float]:
        """``(forward, turn)`` towards the next point of the trail being retraced."""
        here = self._last_pose[:2]
        while self._retrace and math.dist(here, self._retrace[0]) < 0.5 * _TRAIL_STEP_M:
            self._retrace.pop(0)
        if not self._retrace:
            self._escape = 0
            return 0.0, 0.0
        d = self._retrace[0] - np.array(here)
        forward, turn = self._drive_along(math.atan2(float(d[1]), float(d[0])), heading)
        reach = abs(forward) * self.limits.max_speed_m_s * self.limits.dt_s
        if reach > 0.0:  # no farther than the point: circling it would never reach it
            forward *= min(1.0, float(np.hypot(*d)) / reach)
        if self._escape == 0:
            self._retrace = []
        return forward, turn

    def _note_contact(self, here: FloatArray, heading: float, step: int) -> FloatArray | None:
        """Estimate the contact normal of this step's collision from the motion it blocked.

        The commanded displacement of the last step (``forward`` along the chord of the arc
        turned then) less the displacement that happened is the part the obstacle stopped: the
        contact is frictionless, so that part lies along the normal, and the normal points the
        other way. That holds for a sliding contact too (only a little is blocked, but along the
        normal). When nothing measurable was blocked (the disc only just touched), only a guess
        of the side is kept for the escape, and no normal is returned.

        Returns:
            The unit normal (from the obstacle towards the robot), or ``None``.
        """
        lim = self.limits
        x0, y0, h0 = self._last_pose
        chord = h0 + 0.5 * wrap_angle(heading - h0)
        meant = (
            self._last_forward
            * lim.max_speed_m_s
            * lim.dt_s
            * np.array([math.cos(chord), math.sin(chord)])
        )
        blocked = meant - (here - np.array([x0, y0]))
        size = float(np.hypot(*blocked))
        if size > max(1e-3, 0.05 * float(np.hypot(*meant))):
            normal: FloatArray = -blocked / size
            self._contacts.append((step, normal))
            return normal
        if self._last_forward != 0.0:
            # Only touching something beside the path: it lies to one side of the motion. Guess
            # a side, alternating; a wrong guess bumps into it and measures the normal.
            self._slides += 1
            motion = h0 + (0.0 if self._last_forward > 0 else math.pi)
            side = motion + (math.pi / 2 if self._slides % 2 else -math.pi / 2)
            self._contacts.append((step, 0.5 * np.array([math.cos(side), math.sin(side)])))
        return None

    def _away_from_contacts(self, step: int, window: int = 12) -> float | None:
        """Heading away from the contacts of the last ``window`` steps (their mean normal)."""
        self._contacts = [(k, n) for k, n in self._contacts if step - k <= window]
        if not self._contacts:
            return None
        mean = np.sum([n for _, n in self._contacts], axis=0)
        if float(np.hypot(*mean)) < 0.3 * len(self._contacts):
            # Touching on opposite sides (wedged front and back): try sideways, a quarter turn
            # from the latest normal; a contact there adds its normal and points the way out.
            latest = self._contacts[-1][1]
            return math.atan2(latest[0], -latest[1])
        return math.atan2(mean[1], mean[0])

    def _drive_along(self, direction: float, heading: float) -> tuple[float, float]:
        """(forward, turn) moving the robot along ``direction``, forwards or backwards.

        The end of the robot facing ``direction`` more leads; the body turns to line it up and
        drives only as far as it is lined up (turning in place first when it is across).
        """
        lim = self.limits
        err = wrap_angle(direction - heading)
        sign = 1.0
        if abs(err) > math.pi / 2:  # reverse: line the tail up with the direction
            sign, err = -1.0, wrap_angle(err - math.pi)
        turn = float(np.clip(err / (lim.max_turn_rate_rad_s * lim.dt_s), -1.0, 1.0))
        forward = sign * 0.6 * max(math.cos(err), 0.0) ** 2
        return forward, turn
