"""The expected-cost planner (Miura and Shirai, ICRA-92, as the paper's section 5 proposes).

:class:`PlannerCore` keeps the robot's map (:mod:`agents.planning.gridmap`: occupancy fused from
the successive models, bump marks, remembered critical regions called *gates*) and plans on the cost
grid of :mod:`agents.planning.costmap`. The three policies (:class:`~agents.planning.config.Policy`)
differ only in how they treat a gate whose passability ``p`` is undecided (``eps < p < 1 - eps``):

* ``greedy`` plans in the most probable situation and takes every undecided gate as passable;
* ``cautious`` plans in the most probable situation and takes every undecided gate as impassable
  (if that leaves no route at all it falls back to the greedy plan rather than stop);
* ``planner`` minimises the expected cost over the (at most ``max_situations``) most probable
  situations of the model.

The planner, in each situation ``s`` (its obstacles, the remembered gates and the critical regions
only ``s`` has): a gate edge from entry ``a`` to exit ``b`` costs (:func:`expected_gate_weight`)

    w(a -> b) = L_ab + (1 - p) * max(0, C_fail + V_alt(a) - L_ab - V_open(b))

(with probability ``p`` the robot passes; otherwise it finds the region impassable at ``a`` and
takes the best alternative from there); ``V_open`` is the cost-to-go with the undecided gates
open, ``V_alt`` without the gate (first with every undecided gate closed; then, for the few gates
on near-best routes, with only that gate removed and the others at their expected weights).
Dijkstra on these weights gives the expected cost-to-go ``V_s`` and the situation's best
contingent route. Every situation's route is a candidate; each candidate is scored in every
situation (where it meets an obstacle of that situation the robot detours from there,
``cost so far + V_s(there)``) and the candidate of least probability-weighted cost is followed
(unless the route kept from the last plan is within a margin: hysteresis). Before committing, the
planner weighs looking at or approaching the undecided gates (:mod:`agents.planning.looking`).
"""

from __future__ import annotations

import enum
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig, Policy
from agents.planning.costmap import CostGrid, path_from
from agents.planning.gridmap import (
    Gate,
    GateHistory,
    GridSpec,
    OccupancyMap,
    observed_segments,
    rasterize_lines,
    rasterize_obstacles,
    top_situations,
)
from agents.planning.looking import LookKind, best_information
from modeling.model.records import EnvironmentModel, Situation
from modeling.types import FloatArray

__all__ = ["Decision", "Mode", "PlannerCore", "SituationPlan", "expected_gate_weight"]


class Mode(str, enum.Enum):
    """What a :class:`Decision` asks the robot to do."""

    FOLLOW = "follow"
    LOOK = "look"
    APPROACH = "approach"
    NONE = "none"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class Decision:
    """The outcome of one planning cycle.

    Attributes:
        mode: Follow the route, look at ``look_at`` (while following), approach, or nothing.
        waypoints: (n, 2) route to follow, world metres (robot first).
        look_at: (2,) point to pan the head to (``Mode.LOOK``), else ``None``.
        gate: Index (in the gate history) of the region looked at or approached, else ``None``.
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
class SituationPlan:
    """One situation's graph and cost-to-go fields.

    Attributes:
        grid: The cost grid of the situation (its obstacles, the map, its gates).
        weights: ``{(u, v): metres}`` of the gate edges (expected weights for the planner).
        value: (n_cells,) cost-to-go to ``target`` on ``weights``, metres.
        pred: (n_cells,) next cell towards ``target`` (-1: none).
        start: Cell of the robot.
        target: Cell of the goal.
        open_value: (n_cells,) cost-to-go with the undecided gates open (``V_open``), metres.
    """

    grid: CostGrid
    weights: dict[tuple[int, int], float]
    value: FloatArray
    pred: NDArray[np.int64]
    start: int
    target: int
    open_value: FloatArray | None = None


def expected_gate_weight(
    length_m: float, p: float, fail_cost_m: float, alt_m: float, beyond_m: float
) -> float:
    """The expected cost of a gate edge ``a -> b``: the planner's cost of an undecided region.

    ``w = L + (1 - p) * max(0, C_fail + V_alt(a) - L - V_open(b))``: with probability ``p`` the
    robot passes (``L``); otherwise it finds the region impassable at ``a``, pays ``C_fail`` and
    takes the best alternative from there, ``V_alt(a)``, instead of going on from ``b``.

    Args:
        length_m: ``L``, the edge's length, metres.
        p: Probability that the region is passable.
        fail_cost_m: ``C_fail``, cost of finding it impassable at its entry, metres.
        alt_m: ``V_alt(a)``, the best alternative's cost-to-go from the entry, metres.
        beyond_m: ``V_open(b)``, the cost-to-go from the exit, metres.
    """
    detour = fail_cost_m + alt_m - length_m - beyond_m
    return length_m + (1.0 - p) * max(0.0, detour)


class PlannerCore:
    """Memory and planning, without an environment (unit-testable).

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
        self.occupancy = OccupancyMap(self.spec, fused_range_m=self.config.fused_range_m)
        self.gates = GateHistory()
        self.looks_at: dict[int, int] = {}
        self.model: EnvironmentModel | None = None
        self.last_plans: list[SituationPlan] = []
        self._prev_nodes: list[int] = []

    @property
    def width_m(self) -> float:
        """Robot width, metres."""
        return self.limits.robot_width_m

    # ------------------------------------------------------------------ occupancy map
    def observe(
        self, model: EnvironmentModel | None, step: int, fused: EnvironmentModel | None = None
    ) -> None:
        """Fuse the model of the latest observation (and the nearby obstacles of ``fused``, the
        env's memory model, when given) into the occupancy map."""
        self.model = model
        if model is None:
            return
        self.occupancy.update(model, max_situations=self.config.max_situations, fused=fused)
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
        self.occupancy.add_bump(front, direction, length, step)
        return self.gates.mark_failed(np.array([x, y]), r + 0.35, step)

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
        occ = self.occupancy.occupied()
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
            walls=self.occupancy.bumps >= 0,
        )

    def _plan_situation(
        self,
        situation: Situation | None,
        pose_xy: FloatArray,
        rule: Callable[[float, bool], float],
    ) -> SituationPlan | None:
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
        value, pred = grid.to_target(open_w, target)
        plan = SituationPlan(
            grid=grid, weights=open_w, value=value, pred=pred, start=start, target=target
        )
        if len(closed_w) == len(open_w):
            plan.open_value = value
            return plan
        # Expected gate weights: length + (1 - p) (C_fail + V_alt(entry) - length - V_open(exit)),
        # V_alt the best alternative without the gate. First with every undecided gate closed
        # (pessimistic), then, for the few gates on near-best routes, without that gate only
        # (the others at their expected weights).
        closed_value, _ = grid.to_target(closed_w, target)
        cap = self.config.unreachable_cost_m
        undecided = [e for e in grid.gate_edges if eps < p_of[e.gate] < 1.0 - eps]

        def weights(fallback: dict[int, FloatArray]) -> dict[tuple[int, int], float]:
            w = dict(closed_w)
            for e in undecided:
                p = p_of[e.gate]
                alt_value = fallback.get(e.gate, closed_value)
                for u, v in ((e.a, e.b), (e.b, e.a)):
                    alt = min(float(alt_value[u]), cap + float(value[u]))
                    w[(u, v)] = expected_gate_weight(
                        e.length_m, p, self.config.fail_cost_m, alt, float(value[v])
                    )
            return w

        exp_w = weights({})
        from_start, _ = grid.from_source(open_w, start)
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
            fallback[e.gate], _ = grid.to_target(without, target)
        if fallback:
            exp_w = weights(fallback)
        exp_value, exp_pred = grid.to_target(exp_w, target)
        return SituationPlan(
            grid=grid,
            weights=exp_w,
            value=exp_value,
            pred=exp_pred,
            start=start,
            target=target,
            open_value=value,
        )

    # ------------------------------------------------------------------ routes
    def _route_nodes(self, plan: SituationPlan) -> list[int]:
        if not math.isfinite(float(plan.value[plan.start])):
            return []
        return path_from(plan.pred, plan.start)

    def _waypoints(self, plan: SituationPlan, nodes: list[int], pose_xy: FloatArray) -> FloatArray:
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

    def _route_gates(self, plan: SituationPlan, nodes: list[int]) -> tuple[int, ...]:
        by_pair = {(e.a, e.b): e.gate for e in plan.grid.gate_edges}
        by_pair.update({(e.b, e.a): e.gate for e in plan.grid.gate_edges})
        return tuple(by_pair[(u, v)] for u, v in itertools.pairwise(nodes) if (u, v) in by_pair)

    def _route_cost(self, plan: SituationPlan, nodes: list[int]) -> float:
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

    def relax(self, before_step: int) -> None:
        """The map leaves no route at all although the goal is reachable, so it holds a false
        obstacle (a bump mark across a gap, a phantom seen once, a gate a bump beside it
        closed): forget what was seen and the bump marks before ``before_step``, re-open the
        gates those bumps closed, and drop the kept route. The recent bumps stay (what the
        robot is touching now is real), and so do the gates they closed."""
        self.occupancy.forget(before_step)
        self.gates.reopen(before_step)
        self.forget_route()

    def _repaired(self, plan: SituationPlan, nodes: list[int]) -> list[int]:
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
        probs = np.array([1.0 if (sit := sits[k]) is None else sit.probability for k, _ in valid])
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
            margin = max(cfg.keep_route_m, cfg.keep_route_share * scores[best_k])
            if kept_score <= scores[best_k] + margin:
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
            decision = self._with_information(pose, valid[0][1], decision, p_of)
        return decision

    def _with_information(
        self,
        pose: tuple[float, float, float, float],
        plan: SituationPlan,
        decision: Decision,
        p_of: list[float],
    ) -> Decision:
        """``decision``, turned into a look or an approach where one is worthwhile
        (:func:`agents.planning.looking.best_information`)."""
        choice, gains = best_information(
            pose,
            plan,
            self.gates.gates,
            p_of,
            route_gates=decision.route_gates,
            looks_at=self.looks_at,
            width_m=self.width_m,
            limits=self.limits,
            config=self.config,
        )
        if choice is None:
            return Decision(
                mode=decision.mode,
                waypoints=decision.waypoints,
                route_gates=decision.route_gates,
                expected_cost_m=decision.expected_cost_m,
                candidates=decision.candidates,
                gains=gains,
            )
        if choice.kind is LookKind.LOOK:
            return Decision(
                mode=Mode.LOOK,
                waypoints=decision.waypoints,
                look_at=self.gates.gates[choice.gate].midpoint.copy(),
                gate=choice.gate,
                route_gates=decision.route_gates,
                expected_cost_m=decision.expected_cost_m - choice.gain_m,
                candidates=decision.candidates,
                gains=gains,
            )
        assert choice.waypoints is not None
        return Decision(
            mode=Mode.APPROACH,
            waypoints=choice.waypoints,
            gate=choice.gate,
            route_gates=(),
            expected_cost_m=decision.expected_cost_m - choice.gain_m,
            candidates=decision.candidates,
            gains=gains,
        )
