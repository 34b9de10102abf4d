"""Model-based scripted agents: ``greedy``, ``cautious`` and the expected-cost ``planner``.

All three keep the same memory (:mod:`agents.gridmap`: occupancy fused from the successive models,
bump marks, remembered critical regions called *gates*), plan on the same cost grid
(:mod:`agents.costmap`) and drive with the same pure-pursuit follower and recovery; they differ in
how they treat a critical region whose passability is undecided (``eps < p < 1 - eps``):

* ``greedy`` plans in the most probable situation and takes every undecided region as passable;
* ``cautious`` plans in the most probable situation and takes every undecided region as
  impassable (if that leaves no route at all it falls back to the greedy plan rather than stop);
* ``planner`` (Miura and Shirai, ICRA-92, as the paper's section 5 proposes) minimises the
  expected cost over the (at most ``max_situations``) most probable situations of the model.

The planner, in each situation ``s`` (its obstacles, the remembered gates and the critical regions
only ``s`` has): a gate edge from entry ``a`` to exit ``b`` costs

    w(a -> b) = L_ab + (1 - p) * max(0, C_fail + V_alt(a) - L_ab - V_open(b))

(with probability ``p`` the robot passes; otherwise it finds the region impassable at ``a`` and
takes the best alternative from there); ``V_open`` is the cost-to-go with the undecided gates
open, ``V_alt`` without the gate (first with every undecided gate closed; then, for the few gates
on near-best routes, with only that gate removed and the others at their expected weights).
Dijkstra on these weights gives the expected cost-to-go ``V_s`` and the situation's best
contingent route. Every situation's route is a candidate; each candidate is scored in every
situation (where it meets an obstacle of that situation the robot detours from there,
``cost so far + V_s(there)``) and the candidate of least probability-weighted cost is followed
(unless the route kept from the last plan is within a margin: hysteresis).

Then, before committing, for each undecided gate that would shorten the trip if passable, the
planner weighs (:mod:`agents.decision`):

* *looking* at it now: panning the head (and, beyond the pan limit, turning) so it comes into
  view, which measures its width again with the std predicted from the stereo error model
  (``std * (d_now / d_seen)^2``); value = ``min(C_via(p), C_alt) - E_m[min(C_via(p'), C_alt)]``
  minus the cost of the look (a fixed cost plus the time the pan takes);
* *approaching* it: driving to a point on its near side, closer than any view so far.

A worthwhile look comes first (cheap, made while moving); otherwise a worthwhile approach; otherwise
the robot follows its route. So it decides where to look as well as where to move.

Every agent re-plans every few steps, at once after a bump and when a look is done. A bump marks
the map (plain walls, box faces and table tops are invisible to the segment stereo) and closes a
gate being crossed; the robot then backs off. Bumped again while backing off, it estimates the
contact normals from the motion each contact blocked (for a sliding contact, a guess of the side)
and moves along their mean, away from everything it touched lately. No movement for a while
counts as a bump; no progress towards the goal for longer makes the robot forget what it saw and
its older bumps (a false obstacle may trap it).
"""

from __future__ import annotations

import enum
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse.csgraph import dijkstra

from agents.base import (
    Agent,
    ControlLimits,
    control_limits,
    goal_xy,
    model_of,
    robot_pose,
    room_bounds,
)
from agents.costmap import CostGrid, GateEdge, cost_to_go, path_from
from agents.decision import (
    GateCosts,
    expected_after_measurement,
    p_wider,
    predicted_std,
    value_of_information,
)
from agents.gridmap import (
    Gate,
    GateMemory,
    GridSpec,
    OccupancyMemory,
    observed_segments,
    rasterize_lines,
    rasterize_obstacles,
    top_situations,
)
from agents.routes import PathFollower
from modeling.model import EnvironmentModel, Situation

__all__ = ["Decision", "Mode", "ModelBasedAgent", "NavigatorConfig", "PlannerCore", "Policy"]

FloatArray = NDArray[np.float64]


class Policy(str, enum.Enum):
    """How undecided critical regions are treated."""

    GREEDY = "greedy"
    CAUTIOUS = "cautious"
    PLANNER = "planner"


class Mode(str, enum.Enum):
    """What a :class:`Decision` asks the robot to do."""

    FOLLOW = "follow"
    LOOK = "look"
    APPROACH = "approach"
    NONE = "none"


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
        max_looks_per_gate: Looks at one gate at most.
        stall_steps: Back off after this many steps with less than 0.15 m of movement.
        forget_steps: When the robot has come no nearer to the goal (by 0.3 m) for this many
            steps, it forgets what it saw and its older bumps (a false obstacle may trap it).
        keep_bumps_steps: Bumps younger than this survive such forgetting.
        backoff_steps: Steps of moving away after a bump (reversing, or forwards after a bump
            while reversing).
        bump_mark_m: Length of the face marked by a bump whose contact normal was measured.
        bump_guess_m: Length of the mark across the motion when the normal is unknown.
        relax_keep_steps: When the memory leaves no route to the goal at all, bumps older than
            this and what was seen are forgotten (the memory must hold a false obstacle).
        shortcut_m: The follower joins a later part of the route passing this close to the robot
            (a route that first steps back to a cell behind the robot and then passes it again).
        gaze_ahead_m: The planner, when not looking at a gate, points its head at the route
            this far ahead (0: straight ahead). Greedy and cautious always look straight ahead.
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
    max_looks_per_gate: int = 2
    stall_steps: int = 40
    forget_steps: int = 100
    keep_bumps_steps: int = 200
    backoff_steps: int = 4
    bump_mark_m: float = 0.8
    bump_guess_m: float = 1.0
    relax_keep_steps: int = 30
    shortcut_m: float = 0.15
    gaze_ahead_m: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "policy", Policy(self.policy))
        for name in ("resolution_m", "soft_m", "fail_cost_m", "look_range_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        if not 0 < self.eps < 0.5:
            raise ValueError(f"eps must be in (0, 0.5), got {self.eps!r}")
        if self.max_situations < 1 or self.replan_every < 1:
            raise ValueError("max_situations and replan_every must be >= 1")


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Decision:
    """The outcome of one planning cycle.

    Attributes:
        mode: Follow the route, look at ``look_at`` (while following), approach, or nothing.
        waypoints: (n, 2) route to follow, world metres (robot first).
        look_at: (2,) point to pan the head to (``Mode.LOOK``), else ``None``.
        gate: Index (in the gate memory) of the region looked at or approached, else ``None``.
        route_gates: Gate indices crossed by the route, in order.
        expected_cost_m: Expected cost of the chosen route, metres.
        candidates: ``{situation index: expected cost}`` of the candidate routes (planner).
        gains: ``{("look" | "approach", gate): saving in metres}`` of the options weighed.
    """

    mode: Mode
    waypoints: FloatArray
    look_at: FloatArray | None = None
    gate: int | None = None
    route_gates: tuple[int, ...] = ()
    expected_cost_m: float = math.inf
    candidates: dict[int, float] = field(default_factory=dict)
    gains: dict[tuple[str, int], float] = field(default_factory=dict)


@dataclass(slots=True)
class _Plan:
    """One situation's graph and fields."""

    grid: CostGrid
    weights: dict[tuple[int, int], float]
    value: FloatArray
    pred: NDArray[np.int64]
    start: int
    target: int
    open_value: FloatArray | None = None


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class PlannerCore:
    """Memory, planning and the looking rule, without an environment (unit-testable).

    Args:
        bounds: ``(xmin, ymin, xmax, ymax)`` of the floor (its border is taken as walls).
        goal: (2,) goal, world metres.
        limits: Action scales and robot size.
        config: Navigator parameters.
    """

    def __init__(
        self,
        bounds: tuple[float, float, float, float],
        goal: NDArray[np.floating],
        limits: ControlLimits,
        config: NavigatorConfig | None = None,
    ) -> None:
        self.config = config or NavigatorConfig()
        self.limits = limits
        self.goal = np.asarray(goal, dtype=np.float64).reshape(2)
        self.spec = GridSpec.from_bounds(bounds, self.config.resolution_m)
        self.memory = OccupancyMemory(self.spec)
        self.gates = GateMemory()
        self.looks_at: dict[int, int] = {}
        self.model: EnvironmentModel | None = None
        self.last_plans: list[_Plan] = []
        self._prev_nodes: list[int] = []

    @property
    def width_m(self) -> float:
        """Robot width, metres."""
        return self.limits.robot_width_m

    # ------------------------------------------------------------------ memory
    def observe(self, model: EnvironmentModel | None, step: int) -> None:
        """Fuse the model of the latest observation into the memory."""
        self.model = model
        if model is None:
            return
        self.memory.update(model, max_situations=self.config.max_situations)
        self.gates.update(model, step)

    def bump(
        self,
        pose: tuple[float, float, float, float],
        backwards: bool,
        step: int = 0,
        normal: FloatArray | None = None,
    ) -> list[int]:
        """Record a collision at ``pose`` (at ``step``) while moving forwards (or backwards).

        With a measured contact ``normal`` (unit, from the obstacle towards the robot) the mark is
        a piece of the touched face: through the contact point, across the normal,
        ``bump_mark_m`` long. Without one it is a guess: across the motion, in front of the body,
        ``bump_guess_m`` long. The guess is what a mark across the heading was always: right for
        a head-on contact, but for a contact at an angle or one beside the path it lies across
        the free space next to the face, where it can close a doorway or the gap the robot was
        sliding through (so the measured face is preferred whenever the motion gives one).

        Returns:
            Indices of the gates closed by it (those within reach of the robot).
        """
        x, y, heading, _ = pose
        r = 0.5 * self.width_m
        if normal is not None:
            direction = math.atan2(-float(normal[1]), -float(normal[0]))
            length = self.config.bump_mark_m
        else:
            direction = heading + (math.pi if backwards else 0.0)
            length = self.config.bump_guess_m
        front = np.array([x, y]) + (r + 0.05) * np.array([math.cos(direction), math.sin(direction)])
        self.memory.add_bump(front, direction, length, step)
        return self.gates.mark_failed(np.array([x, y]), r + 0.35)

    # ------------------------------------------------------------------ gate treatment
    def _effective_p(self, p: float, failed: bool) -> float:
        eps = self.config.eps
        if failed:
            return 0.0
        policy = self.config.policy
        if policy is Policy.GREEDY:
            return 1.0 if p > eps else 0.0
        if policy is Policy.CAUTIOUS:
            return 1.0 if p >= 1.0 - eps else 0.0
        return 1.0 if p >= 1.0 - eps else (0.0 if p <= eps else p)

    def _occupied(self, situation: Situation | None, pose_xy: FloatArray) -> NDArray[np.bool_]:
        occ = self.memory.occupied()
        if situation is not None:
            occ = occ | rasterize_obstacles(
                self.spec,
                situation,
                viewpoint_xy=pose_xy,
                max_range_m=self.config.obstacle_range_m,
            )
        if self.model is not None:
            occ = occ | rasterize_lines(
                self.spec,
                observed_segments(self.model),
                viewpoint_xy=pose_xy,
                max_range_m=self.config.obstacle_range_m,
            )
        return occ

    def _situation_gates(
        self, situation: Situation | None, rule: Callable[[float, bool], float]
    ) -> tuple[list[Gate], list[float]]:
        """The remembered gates, plus the critical regions only ``situation`` has (temporary)."""
        gates = list(self.gates.gates)
        p_of = [rule(g.p_passable, g.failed) for g in gates]
        if situation is None or self.model is None:
            return gates, p_of
        vp = np.asarray(self.model.observation.viewpoint[:2], dtype=np.float64)
        for reg in situation.critical_regions:
            ends = np.asarray(reg.narrowest, dtype=np.float64).reshape(2, 2)
            dist = float(np.hypot(*(ends.mean(axis=0) - vp)))
            if dist > self.gates.max_range_m or self.gates.match(ends) is not None:
                continue
            gates.append(
                Gate(
                    ends=ends,
                    width_mean_m=float(reg.width_mean_m),
                    width_std_m=float(reg.width_std_m),
                    p_passable=float(reg.p_passable),
                    polygon=np.asarray(reg.polygon, dtype=np.float64),
                    seen_distance_m=dist,
                    viewed_distance_m=dist,
                )
            )
            p_of.append(rule(float(reg.p_passable), False))
        return gates, p_of

    def _grid(
        self, situation: Situation | None, pose_xy: FloatArray, gates: list[Gate]
    ) -> CostGrid:
        return CostGrid(
            self.spec,
            self._occupied(situation, pose_xy),
            gates,
            hard_m=self.config.hard_m,
            soft_m=self.config.soft_m,
            free_xy=self.goal[None],
        )

    def _plan_situation(
        self,
        situation: Situation | None,
        pose_xy: FloatArray,
        rule: Callable[[float, bool], float],
    ) -> _Plan | None:
        gates, p_of = self._situation_gates(situation, rule)
        grid = self._grid(situation, pose_xy, gates)
        start = grid.nearest_free(pose_xy, 1.0)
        target = grid.nearest_free(self.goal, 0.5)
        if start is None or target is None:
            return None
        eps = self.config.eps
        open_w: dict[tuple[int, int], float] = {}
        closed_w: dict[tuple[int, int], float] = {}
        for e in grid.gate_edges:
            p = p_of[e.gate]
            if p <= 0.0:
                continue
            for u, v in ((e.a, e.b), (e.b, e.a)):
                open_w[(u, v)] = e.length_m
                if p >= 1.0 - eps:
                    closed_w[(u, v)] = e.length_m
        value, pred = cost_to_go(grid.matrix(open_w), target)
        plan = _Plan(grid=grid, weights=open_w, value=value, pred=pred, start=start, target=target)
        if len(closed_w) == len(open_w):
            plan.open_value = value
            return plan
        # Expected gate weights: length + (1 - p) (C_fail + V_alt(entry) - length - V_open(exit)),
        # V_alt the best alternative without the gate. First with every undecided gate closed
        # (pessimistic), then, for the few gates on near-best routes, without that gate only
        # (the others at their expected weights).
        closed_value, _ = cost_to_go(grid.matrix(closed_w), target)
        cap = self.config.unreachable_cost_m
        undecided = [e for e in grid.gate_edges if eps < p_of[e.gate] < 1.0 - eps]

        def weights(fallback: dict[int, FloatArray]) -> dict[tuple[int, int], float]:
            w = dict(closed_w)
            for e in undecided:
                p = p_of[e.gate]
                alt_value = fallback.get(e.gate, closed_value)
                for u, v in ((e.a, e.b), (e.b, e.a)):
                    alt = min(float(alt_value[u]), cap + float(value[u]))
                    detour = self.config.fail_cost_m + alt - e.length_m - float(value[v])
                    w[(u, v)] = e.length_m + (1.0 - p) * max(0.0, detour)
            return w

        exp_w = weights({})
        from_start = dijkstra(grid.matrix(open_w), directed=True, indices=start)
        best = float(value[start])
        via = sorted(
            (
                min(
                    from_start[e.a] + e.length_m + value[e.b],
                    from_start[e.b] + e.length_m + value[e.a],
                ),
                k,
            )
            for k, e in enumerate(undecided)
        )
        fallback: dict[int, FloatArray] = {}
        for cost, k in via[: self.config.max_relevant_gates]:
            if not cost <= best + self.config.relevant_margin_m:
                break
            e = undecided[k]
            without = {key: w for key, w in exp_w.items() if key not in ((e.a, e.b), (e.b, e.a))}
            fallback[e.gate], _ = cost_to_go(grid.matrix(without), target)
        if fallback:
            exp_w = weights(fallback)
        exp_value, exp_pred = cost_to_go(grid.matrix(exp_w), target)
        return _Plan(
            grid=grid,
            weights=exp_w,
            value=exp_value,
            pred=exp_pred,
            start=start,
            target=target,
            open_value=value,
        )

    # ------------------------------------------------------------------ routes
    def _route_nodes(self, plan: _Plan) -> list[int]:
        if not math.isfinite(float(plan.value[plan.start])):
            return []
        return path_from(plan.pred, plan.start)

    def _waypoints(self, plan: _Plan, nodes: list[int], pose_xy: FloatArray) -> FloatArray:
        spec = plan.grid.spec
        pts: list[FloatArray] = [pose_xy]
        mids = {(e.a, e.b): e.mid_xy for e in plan.grid.gate_edges}
        mids.update({(e.b, e.a): e.mid_xy for e in plan.grid.gate_edges})
        xy = spec.xy_of(np.asarray(nodes, dtype=np.int64))
        for k, node in enumerate(nodes):
            if k and (nodes[k - 1], node) in mids:
                pts.append(mids[(nodes[k - 1], node)])
            pts.append(xy[k])
        if np.hypot(*(pts[-1] - self.goal)) > 1e-9:
            pts.append(self.goal)
        return np.asarray(pts)

    def _route_gates(self, plan: _Plan, nodes: list[int]) -> tuple[int, ...]:
        by_pair = {(e.a, e.b): e.gate for e in plan.grid.gate_edges}
        by_pair.update({(e.b, e.a): e.gate for e in plan.grid.gate_edges})
        return tuple(by_pair[(u, v)] for u, v in itertools.pairwise(nodes) if (u, v) in by_pair)

    def _route_cost(self, plan: _Plan, nodes: list[int]) -> float:
        """Cost of following ``nodes`` in ``plan``'s situation, detouring where it is blocked.

        The first hop, from ``plan.start`` to ``nodes[0]``, may be a short straight jump (a route
        kept from an earlier plan).
        """
        if not nodes:
            return math.inf
        acc = 0.0
        if nodes[0] != plan.start:
            a, b = plan.grid.spec.xy_of(np.array([plan.start, nodes[0]]))
            jump = float(np.hypot(*(b - a)))
            if jump > 0.35 or plan.grid.blocked.reshape(-1)[nodes[0]]:
                return float(plan.value[plan.start])
            acc = jump * float(plan.grid.cost.reshape(-1)[nodes[0]])
        for u, v in itertools.pairwise(nodes):
            w = plan.grid.edge_weight(u, v, plan.weights)
            if not math.isfinite(w):
                return acc + float(plan.value[u])
            acc += w
        return acc

    def _kept_route(self, here: FloatArray) -> list[int]:
        """The rest of the previous route from the node nearest to the robot (empty if none)."""
        if not self._prev_nodes:
            return []
        xy = self.spec.xy_of(np.asarray(self._prev_nodes))
        d = np.hypot(*(xy - here).T)
        k = int(np.argmin(d))
        if d[k] > 0.35 or len(self._prev_nodes) - k < 2:
            return []
        return self._prev_nodes[k:]

    def forget_route(self) -> None:
        """Drop the route kept for hysteresis."""
        self._prev_nodes = []

    def _repaired(self, plan: _Plan, nodes: list[int]) -> list[int]:
        """``nodes`` up to its first move blocked in ``plan``, then ``plan``'s route from there."""
        if not nodes:
            return []
        for k, (u, v) in enumerate(itertools.pairwise(nodes)):
            if not math.isfinite(plan.grid.edge_weight(u, v, plan.weights)):
                if not math.isfinite(float(plan.value[u])):
                    return []
                return nodes[:k] + path_from(plan.pred, u)
        return nodes

    # ------------------------------------------------------------------ decide
    def plan(self, pose: tuple[float, float, float, float]) -> Decision:
        """Choose the route, and for the planner whether to look or approach first."""
        x, y, _, _ = pose
        here = np.array([x, y])
        cfg = self.config
        if self.model is not None and self.model.situations:
            if cfg.policy is Policy.PLANNER:
                sits: list[Situation | None] = list(top_situations(self.model, cfg.max_situations))
            else:
                sits = [self.model.situations[0]]
        else:
            sits = [None]
        p_of = [self._effective_p(g.p_passable, g.failed) for g in self.gates.gates]
        plans = [self._plan_situation(s, here, self._effective_p) for s in sits]
        if cfg.policy is Policy.CAUTIOUS and (
            plans[0] is None or not math.isfinite(float(plans[0].value[plans[0].start]))
        ):

            def relaxed(p: float, failed: bool) -> float:
                return 0.0 if failed else (1.0 if p > cfg.eps else 0.0)

            plans = [self._plan_situation(s, here, relaxed) for s in sits]
        valid = [
            (k, pl)
            for k, pl in enumerate(plans)
            if pl is not None and math.isfinite(float(pl.value[pl.start]))
        ]
        self.last_plans = [pl for _, pl in valid]
        if not valid:
            self._prev_nodes = []
            return Decision(mode=Mode.NONE, waypoints=np.array([here, self.goal]))
        probs = np.array([sits[k].probability if sits[k] is not None else 1.0 for k, _ in valid])
        probs = probs / probs.sum()
        routes = {k: self._route_nodes(pl) for k, pl in valid}
        scores: dict[int, float] = {}
        for k, _ in valid:
            if len(valid) == 1:
                scores[k] = float(valid[0][1].value[valid[0][1].start])
            else:
                scores[k] = float(
                    sum(
                        p * self._route_cost(pl, routes[k])
                        for p, (_, pl) in zip(probs, valid, strict=True)
                    )
                )
        best_k = min(scores, key=scores.__getitem__)
        best_plan = dict(valid)[best_k]
        nodes = routes[best_k]
        # Hysteresis: keep the previous route (repaired from where it is now blocked) unless the
        # new one is clearly cheaper, so that the robot does not swing between two ways round.
        kept = self._repaired(best_plan, self._kept_route(here))
        if kept:
            kept_score = float(
                sum(p * self._route_cost(pl, kept) for p, (_, pl) in zip(probs, valid, strict=True))
            )
            if kept_score <= scores[best_k] + max(0.5, 0.1 * scores[best_k]):
                nodes = [best_plan.start, *kept] if kept[0] != best_plan.start else kept
                scores[-1] = kept_score
                best_k = -1
        self._prev_nodes = list(nodes)
        waypoints = self._waypoints(best_plan, nodes, here)
        route_gates = self._route_gates(best_plan, nodes)
        decision = Decision(
            mode=Mode.FOLLOW,
            waypoints=waypoints,
            route_gates=route_gates,
            expected_cost_m=scores[best_k],
            candidates=scores,
        )
        if cfg.policy is Policy.PLANNER:
            decision = self._information(pose, valid[0][1], decision, p_of)
        return decision

    def _line_of_sight(self, grid: CostGrid, a: FloatArray, b: FloatArray, skip_m: float) -> bool:
        """No obstacle between ``a`` and ``b`` (ignoring the last ``skip_m`` before ``b``)."""
        length = float(np.hypot(*(b - a)))
        if length <= skip_m:
            return True
        t = np.arange(0.0, length - skip_m, 0.5 * grid.spec.resolution_m) / length
        pts = a + (b - a) * t[:, None]
        pts = pts[grid.spec.inside(pts)]
        idx = grid.spec.index_of(pts)
        return not bool((grid.clearance_m.reshape(-1)[idx] < 0.05).any())

    def _information(
        self,
        pose: tuple[float, float, float, float],
        plan: _Plan,
        decision: Decision,
        p_of: list[float],
    ) -> Decision:
        """Weigh looking at / approaching each undecided gate that could shorten the trip."""
        cfg = self.config
        lim = self.limits
        x, y, heading, pan = pose
        here = np.array([x, y])
        width = self.width_m
        gates = self.gates.gates
        cap = cfg.unreachable_cost_m
        m = plan.grid.matrix(plan.weights)
        from_robot, from_pred = dijkstra(
            m, directed=True, indices=plan.start, return_predecessors=True
        )
        target = plan.target
        candidates: list[GateEdge] = []
        for e in plan.grid.gate_edges:
            if e.gate >= len(gates):
                continue  # a region of this situation only: not remembered, not looked at
            g = gates[e.gate]
            if g.failed or not (cfg.eps < p_of[e.gate] < 1.0 - cfg.eps):
                continue
            if float(np.hypot(*(g.midpoint - here))) > cfg.look_range_m + 2.0:
                continue
            candidates.append(e)
        candidates.sort(key=lambda e: float(np.hypot(*(e.mid_xy - here))))
        # The best look and the best approach; a worthwhile look goes first (it is cheap and can
        # be made while moving; the approach, if still worth it, is decided after it).
        look_gain, approach_gain = cfg.min_gain_m, cfg.min_approach_gain_m
        look: tuple[str, int, Any] | None = None
        approach: tuple[str, int, Any] | None = None
        gains: dict[tuple[str, int], float] = {}
        for e in candidates[:4]:
            g = gates[e.gate]
            entry, exit_ = (e.a, e.b) if from_robot[e.a] <= from_robot[e.b] else (e.b, e.a)
            if not math.isfinite(float(from_robot[entry])):
                continue
            without = {k: w for k, w in plan.weights.items() if k not in ((e.a, e.b), (e.b, e.a))}
            v_minus, _ = cost_to_go(plan.grid.matrix(without), target)
            costs = GateCosts(
                to_entry_m=float(from_robot[entry]),
                cross_m=e.length_m,
                beyond_m=float(plan.value[exit_]),
                fail_m=cfg.fail_cost_m,
                alt_from_entry_m=min(float(v_minus[entry]), cap),
                alt_m=min(float(v_minus[plan.start]), cap),
            )
            if costs.via(1.0) >= costs.alt_m:
                continue  # even if passable it would not help
            mean, std = g.width_mean_m, g.width_std_m
            ref = min(g.seen_distance_m, g.viewed_distance_m)
            dist = float(np.hypot(*(g.midpoint - here)))
            # Look from here.
            bearing = math.atan2(*(g.midpoint - here)[::-1])
            need = _wrap(bearing - heading)
            if (
                dist <= cfg.look_range_m
                and dist < 0.9 * ref
                and self.looks_at.get(e.gate, 0) < cfg.max_looks_per_gate
                and self._line_of_sight(plan.grid, here, g.midpoint, 0.35)
            ):
                pan_target = float(np.clip(need, -lim.pan_limit_rad, lim.pan_limit_rad))
                turn = max(0.0, abs(need) - lim.pan_limit_rad)
                cost = (
                    cfg.look_cost_m
                    + 0.5 * lim.max_speed_m_s * abs(pan_target - pan) / lim.max_pan_rate_rad_s
                    + lim.max_speed_m_s * turn / lim.max_turn_rate_rad_s
                )
                sigma = predicted_std(std, g.seen_distance_m, dist)
                gain = value_of_information(mean, std, sigma, width, costs) - cost
                gains[("look", e.gate)] = gain
                if gain > look_gain:
                    look_gain, look = gain, ("look", e.gate, None)
            # Approach: a point on the entry side, closer than any view so far.
            if e.gate in decision.route_gates:
                continue  # the route approaches it anyway
            side = plan.grid.spec.xy_of(np.array([entry]))[0] - g.midpoint
            side = side / max(float(np.hypot(*side)), 1e-9)
            d_app = max(1.0, 0.5 * min(dist, ref))
            if d_app >= 0.8 * ref:
                continue
            p_xy = g.midpoint + d_app * side
            p_cell = plan.grid.nearest_free(p_xy, 0.3)
            if p_cell is None or not math.isfinite(float(from_robot[p_cell])):
                continue
            sigma = predicted_std(std, g.seen_distance_m, d_app)
            entry_xy = plan.grid.spec.xy_of(np.array([entry]))[0]
            from_p = GateCosts(
                to_entry_m=float(np.hypot(*(entry_xy - p_xy))),
                cross_m=e.length_m,
                beyond_m=float(plan.value[exit_]),
                fail_m=cfg.fail_cost_m,
                alt_from_entry_m=costs.alt_from_entry_m,
                alt_m=min(float(v_minus[p_cell]), cap),
            )
            after = float(from_robot[p_cell]) + expected_after_measurement(
                mean, std, sigma, width, from_p.commit
            )
            gain = float(costs.commit(p_wider(mean, std, width))) - after
            gains[("approach", e.gate)] = gain
            if gain > approach_gain:
                approach_gain, approach = gain, ("approach", e.gate, p_cell)
        best, best_gain = (look, look_gain) if look is not None else (approach, approach_gain)
        if best is None:
            return Decision(
                mode=decision.mode,
                waypoints=decision.waypoints,
                route_gates=decision.route_gates,
                expected_cost_m=decision.expected_cost_m,
                candidates=decision.candidates,
                gains=gains,
            )
        kind, gate, cell = best
        if kind == "look":
            return Decision(
                mode=Mode.LOOK,
                waypoints=decision.waypoints,
                look_at=gates[gate].midpoint.copy(),
                gate=gate,
                route_gates=decision.route_gates,
                expected_cost_m=decision.expected_cost_m - best_gain,
                candidates=decision.candidates,
                gains=gains,
            )
        nodes = [int(cell)]
        while nodes[-1] != plan.start and from_pred[nodes[-1]] >= 0:
            nodes.append(int(from_pred[nodes[-1]]))
        nodes.reverse()
        pts = np.vstack([here[None], plan.grid.spec.xy_of(np.asarray(nodes))])
        return Decision(
            mode=Mode.APPROACH,
            waypoints=pts,
            gate=gate,
            route_gates=(),
            expected_cost_m=decision.expected_cost_m - best_gain,
            candidates=decision.candidates,
            gains=gains,
        )


class ModelBasedAgent(Agent):
    """``greedy``, ``cautious`` or ``planner``: memory + cost grid + follower + recovery.

    Args:
        policy: Which of the three.
        config: Further parameters (its ``policy`` is replaced by ``policy``).
    """

    def __init__(self, policy: Policy | str, config: NavigatorConfig | None = None) -> None:
        super().__init__()
        base = config or NavigatorConfig()
        kw = {f: getattr(base, f) for f in base.__dataclass_fields__}
        kw["policy"] = Policy(policy)
        self.config = NavigatorConfig(**kw)
        self.name = self.config.policy.value
        self.core: PlannerCore | None = None
        self._follower: PathFollower | None = None
        self._start_episode((0.0, 0.0, 0.0), math.inf)

    def _start_episode(self, pose: tuple[float, float, float], goal_distance_m: float) -> None:
        """The per-episode state (decision, escape, stall and progress anchors, contacts), fresh,
        for a robot at ``pose`` (x, y, heading) ``goal_distance_m`` from its goal."""
        x, y, heading = pose
        self.decision: Decision | None = None
        self._since_plan = 0
        self._escape = 0
        self._escape_dir = -1.0
        self._escape_flips = 0
        self._anchor = np.array([x, y])
        self._anchor_step = 0
        self._closest = goal_distance_m
        self._closest_step = 0
        self._look_steps = 0
        self._last_forward = 0.0
        self._last_pose = (x, y, heading)
        self._contacts: list[tuple[int, FloatArray]] = []
        self._escape_heading: float | None = None
        self._slides = 0
        self._escape_last = -10

    def _reset(self, seed: int | None) -> None:
        limits = control_limits(self.env)
        self.core = PlannerCore(room_bounds(self.env), goal_xy(self.env), limits, self.config)
        self._follower = PathFollower(
            max_speed_mps=limits.max_speed_m_s,
            max_turn_rate_rps=limits.max_turn_rate_rad_s,
            dt_s=limits.dt_s,
            lookahead_m=0.35,
            shortcut_m=self.config.shortcut_m,
        )
        x, y, heading, _ = robot_pose(self.env)
        self._start_episode(
            (x, y, heading), float(np.hypot(*(np.array([x, y]) - goal_xy(self.env))))
        )

    def _act(self, obs: Any, info: dict[str, Any]) -> NDArray[np.floating]:
        assert self.core is not None and self._follower is not None
        cfg = self.config
        core = self.core
        pose = robot_pose(self.env)
        x, y, heading, _ = pose
        here = np.array([x, y])
        core.observe(model_of(self.env, info), self.steps)
        replan = self.decision is None or self._since_plan >= cfg.replan_every
        if info.get("collision", False):
            backwards = self._last_forward < 0
            normal = self._note_contact(here, heading)
            core.bump(pose, backwards=backwards, step=self.steps, normal=normal)
            replan = True
            away = self._away_from_contacts()
            self._escape_heading = None
            if self._escape > 0 and away is not None:
                # Bumped while backing off: move along the mean contact normal (away from
                # everything touched lately), after turning the nearer end of the body that way.
                lim = core.limits
                err = abs(_wrap(away - heading))
                err = min(err, math.pi - err)
                turn_steps = math.ceil(err / (lim.max_turn_rate_rad_s * lim.dt_s))
                self._escape = cfg.backoff_steps + turn_steps
                self._escape_heading = away
            elif self._escape > 0 or self.steps - self._escape_last <= 1:
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
        to_goal = float(np.hypot(*(here - core.goal)))
        if to_goal < self._closest - 0.3:
            self._closest, self._closest_step = to_goal, self.steps
        elif self.steps - self._closest_step > cfg.forget_steps:
            core.memory.forget(self.steps - cfg.keep_bumps_steps)
            core.forget_route()
            self._closest, self._closest_step = to_goal, self.steps
            replan = True
        if float(np.hypot(*(here - self._anchor))) > 0.15:
            self._anchor, self._anchor_step = here, self.steps
        elif self.steps - self._anchor_step > cfg.stall_steps:
            self._anchor, self._anchor_step = here, self.steps
            core.bump(pose, backwards=False, step=self.steps)
            self._escape, self._escape_dir, self._escape_flips = cfg.backoff_steps, -1.0, 0
            self._escape_heading = None
            replan = True
        self._last_pose = (x, y, heading)
        if self._escape > 0:
            self._escape -= 1
            self._escape_last = self.steps
            self.decision = None
            if self._escape_heading is None:
                self._last_forward = 0.6 * self._escape_dir
                return np.array([self._last_forward, 0.0, 0.0])
            forward, turn = self._drive_along(self._escape_heading, heading)
            if self._escape == 0:
                self._escape_heading = None
            self._last_forward = forward
            return np.array([forward, turn, 0.0])
        if self.decision is not None and self.decision.mode is Mode.LOOK:
            replan = replan or self._look_done(pose)
        if replan:
            self.decision = core.plan(pose)
            if self.decision.mode is Mode.NONE:
                # No route at all: the goal is reachable, so the memory holds a false obstacle
                # (a bump mark across a gap, a phantom seen once). Keep only the recent bumps
                # (what the robot is touching now is real) and plan again, rather than drive
                # straight at the goal into what it already knows is there.
                core.memory.forget(self.steps - cfg.relax_keep_steps)
                core.forget_route()
                self.decision = core.plan(pose)
            self._since_plan = 0
            if self.decision.mode is Mode.LOOK and self.decision.gate is not None:
                core.looks_at[self.decision.gate] = core.looks_at.get(self.decision.gate, 0) + 1
                self._look_steps = 0
        self._since_plan += 1
        d = self.decision
        assert d is not None
        forward, turn = self._follower.command((x, y, heading), d.waypoints)
        pan_cmd = 0.0
        if cfg.policy is Policy.PLANNER and cfg.gaze_ahead_m > 0 and d.mode is not Mode.LOOK:
            # Look where the robot will be: at the route ``gaze_ahead_m`` ahead. Straight on,
            # that is straight ahead; before a turn the head turns into it first, so the vertical
            # edges of what lies round the corner (the two corners of a narrow box face, which
            # make it an obstacle) are seen before the body turns into it.
            ahead = self._follower.point_ahead(here, d.waypoints, cfg.gaze_ahead_m)
            _, pan_cmd = self._pan_towards(ahead, here, heading)
        if d.mode is Mode.LOOK and d.look_at is not None:
            lim = core.limits
            need, pan_cmd = self._pan_towards(d.look_at, here, heading)
            if abs(need) > lim.pan_limit_rad + 0.5 * lim.fov_rad - 0.1:
                # Out of reach of the head: turn the body towards it, standing.
                forward = 0.0
                turn = float(np.clip(need / (lim.max_turn_rate_rad_s * lim.dt_s), -1.0, 1.0))
            else:
                forward *= 0.5
            self._look_steps += 1
        self._last_forward = forward
        return np.array([forward, turn, pan_cmd])

    def _pan_towards(
        self, target: FloatArray, here: FloatArray, heading: float
    ) -> tuple[float, float]:
        """``(bearing, pan)``: the bearing of ``target`` from the body (radians, wrapped) and the
        pan command that points the head at it, as a fraction of the pan limit (clipped)."""
        assert self.core is not None
        limit = self.core.limits.pan_limit_rad
        need = _wrap(math.atan2(*(target - here)[::-1]) - heading)
        return need, float(np.clip(need, -limit, limit)) / limit

    def _note_contact(self, here: FloatArray, heading: float) -> FloatArray | None:
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
        assert self.core is not None
        lim = self.core.limits
        x0, y0, h0 = self._last_pose
        chord = h0 + 0.5 * _wrap(heading - h0)
        meant = (
            self._last_forward
            * lim.max_speed_m_s
            * lim.dt_s
            * np.array([math.cos(chord), math.sin(chord)])
        )
        blocked = meant - (here - np.array([x0, y0]))
        size = float(np.hypot(*blocked))
        if size > max(1e-3, 0.05 * float(np.hypot(*meant))):
            normal = -blocked / size
            self._contacts.append((self.steps, normal))
            return normal
        if self._last_forward != 0.0:
            # Only touching something beside the path: it lies to one side of the motion. Guess
            # a side, alternating; a wrong guess bumps into it and measures the normal.
            self._slides += 1
            motion = h0 + (0.0 if self._last_forward > 0 else math.pi)
            side = motion + (math.pi / 2 if self._slides % 2 else -math.pi / 2)
            self._contacts.append((self.steps, 0.5 * np.array([math.cos(side), math.sin(side)])))
        return None

    def _away_from_contacts(self, window: int = 12) -> float | None:
        """Heading away from the contacts of the last ``window`` steps (their mean normal)."""
        self._contacts = [(k, n) for k, n in self._contacts if self.steps - k <= window]
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
        assert self.core is not None
        lim = self.core.limits
        err = _wrap(direction - heading)
        sign = 1.0
        if abs(err) > math.pi / 2:  # reverse: line the tail up with the direction
            sign, err = -1.0, _wrap(err - math.pi)
        turn = float(np.clip(err / (lim.max_turn_rate_rad_s * lim.dt_s), -1.0, 1.0))
        forward = sign * 0.6 * max(math.cos(err), 0.0) ** 2
        return forward, turn

    def _look_done(self, pose: tuple[float, float, float, float]) -> bool:
        """The looked-at point has been in the field of view for a step (or the look timed out)."""
        d = self.decision
        assert d is not None and d.look_at is not None and self.core is not None
        x, y, heading, pan = pose
        lim = self.core.limits
        rel = d.look_at - np.array([x, y])
        off = abs(_wrap(math.atan2(rel[1], rel[0]) - (heading + pan)))
        in_view = off < 0.5 * lim.fov_rad - 0.1
        if in_view and d.gate is not None and d.gate < len(self.core.gates.gates):
            g = self.core.gates.gates[d.gate]
            g.viewed_distance_m = min(g.viewed_distance_m, float(np.hypot(*rel)))
        return in_view or self._look_steps > 15
