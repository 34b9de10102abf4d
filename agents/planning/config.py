"""The parameters of the model-based agents (``greedy``, ``cautious``, ``planner``).

One frozen :class:`NavigatorConfig` holds the parameters of all parts of such an agent: the map
and the planner (:mod:`agents.planning.planner`), the looking rule (:mod:`agents.planning.looking`),
the recovery from bumps and stalls (:mod:`agents.planning.recovery`) and the route follower
(:mod:`agents.planning.follower`). :class:`Policy` names how an agent treats a critical region whose
passability is undecided.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from modeling.validation import integer, number, positive

__all__ = ["NavigatorConfig", "Policy"]


class Policy(str, enum.Enum):
    """How undecided critical regions are treated."""

    GREEDY = "greedy"
    CAUTIOUS = "cautious"
    PLANNER = "planner"


@dataclass(frozen=True, slots=True, kw_only=True)
class NavigatorConfig:
    """Parameters of the model-based agents.

    Attributes:
        policy: ``greedy``, ``cautious`` or ``planner``.
        resolution_m: Grid cell size, metres.
        eps: Undecided means ``eps < p < 1 - eps`` (the model's classification tolerance).
        max_situations: Situations weighed by the planner (most probable first).
        obstacle_range_m: Obstacles of the current model farther than this are not planned on.
        hard_m: Clearance below which a cell is blocked, metres.
        soft_m: Clearance below which a cell costs more, metres.
        replan_every: Steps between re-plans (sooner after a bump or at the end of a route).
        fail_cost_m: Cost of finding a region impassable at its entry (backing off), metres.
        unreachable_cost_m: Stand-in for an infinite detour, metres.
        max_relevant_gates: Gates on near-best routes whose detour is computed without them alone.
        relevant_margin_m: A route within this of the best one is near-best, metres.
        look_cost_m: Fixed cost of a look, metres of travel.
        look_range_m: Regions farther than this are not looked at.
        min_gain_m: A look must save at least this much, metres.
        min_approach_gain_m: An approach (a change of route) must save at least this much, metres.
        keep_route_m: Hysteresis: a re-plan keeps the previous route (repaired where it is now
            blocked) unless the new best one is cheaper by more than this or by
            ``keep_route_share`` of its cost, whichever is more, so that the robot does not swing
            between two ways round (0 and 0: the cheapest route at every re-plan, ties kept).
        keep_route_share: See ``keep_route_m``.
        max_looks_per_gate: Looks at one gate at most.
        stall_steps: Back off after this many steps with less than 0.15 m of movement.
        forget_steps: When the robot has come no nearer to the goal (by 0.3 m) for this many
            steps, it forgets what it saw and its older bumps (a false obstacle may trap it).
        keep_bumps_steps: Bumps younger than this survive such forgetting.
        progress_reset_m: A re-plan whose route's expected cost exceeds the last plan's by more
            than this (a way found blocked, a detour begun) restarts that watch, so that a
            detour leading away from the goal is not taken for lost progress and the blockage
            is not forgotten half-way round it (0: never; ``docs/evaluation.md``, "Why the
            planner stalls", has the figures).
        backoff_steps: Steps of moving away after a bump (reversing, or forwards after a bump
            while reversing).
        bump_mark_m: Length of the face marked by a bump whose contact normal was measured.
        bump_guess_m: Length of the mark across the motion when the normal is unknown.
        relax_keep_steps: When the occupancy map leaves no route to the goal at all, bumps older
            than this and what was seen are forgotten, and the gates those bumps closed are
            open again (the map must hold a false obstacle; ``PlannerCore.relax``).
        shortcut_m: The follower joins a later part of the route passing this close to the robot
            (a route that first steps back to a cell behind the robot and then passes it again).
        gaze_ahead_m: The planner, when not looking at a gate, points its head at the route
            this far ahead (0: straight ahead). Greedy and cautious always look straight ahead.
        fused_range_m: Obstacles of the env's fused memory model (``info["memory_model"]``,
            its most probable situation) within this distance of the head are added to the
            map with every observation (0, the default: the views' models alone; nothing
            either when the env keeps no memory). Off by default: on the suite it cut
            collisions but closed narrow passages (``docs/evaluation.md`` has the figures).
    """

    policy: Policy = Policy.PLANNER
    resolution_m: float = 0.1
    eps: float = 0.05
    max_situations: int = 3
    obstacle_range_m: float = 3.0
    hard_m: float = 0.26
    soft_m: float = 0.5
    replan_every: int = 5
    fail_cost_m: float = 2.0
    unreachable_cost_m: float = 40.0
    max_relevant_gates: int = 6
    relevant_margin_m: float = 6.0
    look_cost_m: float = 0.15
    look_range_m: float = 6.0
    min_gain_m: float = 0.05
    min_approach_gain_m: float = 0.5
    keep_route_m: float = 0.5
    keep_route_share: float = 0.1
    max_looks_per_gate: int = 2
    stall_steps: int = 40
    forget_steps: int = 100
    keep_bumps_steps: int = 200
    progress_reset_m: float = 2.0
    backoff_steps: int = 4
    bump_mark_m: float = 0.8
    bump_guess_m: float = 1.0
    relax_keep_steps: int = 30
    shortcut_m: float = 0.15
    gaze_ahead_m: float = 1.0
    fused_range_m: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "policy", Policy(self.policy))
        for name in ("resolution_m", "soft_m", "fail_cost_m", "look_range_m"):
            positive(getattr(self, name), name)
        number(self.eps, "eps", low=0.0, high=0.5)
        integer(self.max_situations, "max_situations", low=1)
        integer(self.replan_every, "replan_every", low=1)
        positive(self.fused_range_m, "fused_range_m", allow_zero=True)
        positive(self.progress_reset_m, "progress_reset_m", allow_zero=True)
        positive(self.keep_route_m, "keep_route_m", allow_zero=True)
        number(self.keep_route_share, "keep_route_share", low=0.0, high=1.0, strict=False)
