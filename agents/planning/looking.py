"""Where to look: the value of looking at, or approaching, an undecided gate before committing.

For each undecided gate that would shorten the trip if passable (the nearest four within reach),
the planner weighs (the decision maths is :mod:`agents.planning.decision`):

* *looking* at it now: panning the head (and, beyond the pan limit, turning) so it comes into
  view, which measures its width again with the std predicted from the stereo error model
  (``std * (d_now / d_seen)^2``); value = ``min(C_via(p), C_alt) - E_m[min(C_via(p'), C_alt)]``
  minus the cost of the look (:func:`look_cost_m`: a fixed cost plus the time the pan takes);
* *approaching* it: driving to a point on its near side, closer than any view so far.

A worthwhile look comes first (cheap, made while moving); otherwise a worthwhile approach; otherwise
the robot follows its route (:func:`best_information`). So it decides where to look as well as
where to move.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.costmap import CostGrid, GateEdge
from agents.planning.decision import (
    GateCosts,
    calibrated_mean,
    expected_after_measurement,
    predicted_std,
    value_of_information,
)
from agents.planning.gridmap import Gate
from modeling.geometry import wrap_angle
from modeling.types import FloatArray

if TYPE_CHECKING:
    from agents.planning.planner import SituationPlan

__all__ = ["InformationChoice", "LookKind", "best_information", "line_of_sight", "look_cost_m"]


class LookKind(str, enum.Enum):
    """How the robot learns more about a gate."""

    LOOK = "look"
    APPROACH = "approach"


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class InformationChoice:
    """The most worthwhile look or approach of a planning cycle.

    Attributes:
        kind: Look at the gate or approach it.
        gate: Index of the gate in the gate history.
        gain_m: Expected saving net of the option's cost, metres.
        waypoints: (n, 2) route to the approach point, world metres (robot first); ``None`` for
            a look.
    """

    kind: LookKind
    gate: int
    gain_m: float
    waypoints: FloatArray | None = None


def line_of_sight(grid: CostGrid, a: FloatArray, b: FloatArray, skip_m: float) -> bool:
    """No obstacle of ``grid`` between ``a`` and ``b`` (2,) (ignoring the last ``skip_m`` before
    ``b``), world metres."""
    length = float(np.hypot(*(b - a)))
    if length <= skip_m:
        return True
    t = np.arange(0.0, length - skip_m, 0.5 * grid.spec.resolution_m) / length
    pts = a + (b - a) * t[:, None]
    pts = pts[grid.spec.inside(pts)]
    idx = grid.spec.index_of(pts)
    return not bool((grid.clearance_m.reshape(-1)[idx] < 0.05).any())


def look_cost_m(
    need_rad: float, pan_rad: float, limits: ControlLimits, config: NavigatorConfig
) -> float:
    """The cost of a look, metres of travel: a fixed cost, plus the time of the pan (at half
    speed) and of the body's turn beyond the pan limit (standing).

    Args:
        need_rad: Bearing of the gate from the body, radians (wrapped).
        pan_rad: Pan of the head now, radians.
        limits: Action scales of the robot.
        config: Navigator parameters (``look_cost_m``).
    """
    pan_target = float(np.clip(need_rad, -limits.pan_limit_rad, limits.pan_limit_rad))
    turn = max(0.0, abs(need_rad) - limits.pan_limit_rad)
    return (
        config.look_cost_m
        + 0.5 * limits.max_speed_m_s * abs(pan_target - pan_rad) / limits.max_pan_rate_rad_s
        + limits.max_speed_m_s * turn / limits.max_turn_rate_rad_s
    )


def _candidates(
    plan: SituationPlan,
    gates: list[Gate],
    p_of: list[float],
    here: FloatArray,
    config: NavigatorConfig,
) -> list[GateEdge]:
    """The gate edges of remembered, undecided gates within reach, nearest first."""
    candidates: list[GateEdge] = []
    for e in plan.grid.gate_edges:
        if e.gate >= len(gates):
            continue  # a region of this situation only: not remembered, not looked at
        g = gates[e.gate]
        if g.failed or not (config.eps < p_of[e.gate] < 1.0 - config.eps):
            continue
        if float(np.hypot(*(g.midpoint - here))) > config.look_range_m + 2.0:
            continue
        candidates.append(e)
    candidates.sort(key=lambda e: float(np.hypot(*(e.mid_xy - here))))
    return candidates


def best_information(
    pose: tuple[float, float, float, float],
    plan: SituationPlan,
    gates: list[Gate],
    p_of: list[float],
    *,
    route_gates: tuple[int, ...],
    looks_at: dict[int, int],
    width_m: float,
    limits: ControlLimits,
    config: NavigatorConfig,
) -> tuple[InformationChoice | None, dict[tuple[str, int], float]]:
    """Weigh looking at / approaching each undecided gate that could shorten the trip.

    Args:
        pose: ``(x_m, y_m, heading_rad, pan_rad)`` of the robot, world frame.
        plan: The most probable situation's plan.
        gates: The remembered gates (``p_of`` gives their effective passability).
        p_of: Effective passability of each remembered gate.
        route_gates: Gates the chosen route crosses (approached anyway).
        looks_at: Looks made so far at each gate.
        width_m: Robot width, metres.
        limits: Action scales of the robot.
        config: Navigator parameters.

    Returns:
        The worthwhile look (first) or approach of greatest gain, or ``None``; and the gain of
        every option weighed, ``{("look" | "approach", gate): metres}``.
    """
    x, y, heading, pan = pose
    here = np.array([x, y])
    cap = config.unreachable_cost_m
    from_robot, from_pred = plan.grid.from_source(plan.weights, plan.start)
    look_gain, approach_gain = config.min_gain_m, config.min_approach_gain_m
    look: InformationChoice | None = None
    approach: InformationChoice | None = None
    gains: dict[tuple[str, int], float] = {}
    for e in _candidates(plan, gates, p_of, here, config)[:4]:
        g = gates[e.gate]
        entry, exit_ = (e.a, e.b) if from_robot[e.a] <= from_robot[e.b] else (e.b, e.a)
        if not math.isfinite(float(from_robot[entry])):
            continue
        without = {k: w for k, w in plan.weights.items() if k not in ((e.a, e.b), (e.b, e.a))}
        v_minus, _ = plan.grid.to_target(without, plan.target)
        costs = GateCosts(
            to_entry_m=float(from_robot[entry]),
            cross_m=e.length_m,
            beyond_m=float(plan.value[exit_]),
            fail_m=config.fail_cost_m,
            alt_from_entry_m=min(float(v_minus[entry]), cap),
            alt_m=min(float(v_minus[plan.start]), cap),
        )
        if costs.via(1.0) >= costs.alt_m:
            continue  # even if passable it would not help
        # the width's normal, calibrated to the gate's exact passability (the route's p)
        std = g.width_std_m
        mean = calibrated_mean(g.p_passable, std, width_m)
        ref = min(g.seen_distance_m, g.viewed_distance_m)
        dist = float(np.hypot(*(g.midpoint - here)))
        # Look from here.
        need = wrap_angle(math.atan2(*(g.midpoint - here)[::-1]) - heading)
        if (
            dist <= config.look_range_m
            and dist < 0.9 * ref
            and looks_at.get(e.gate, 0) < config.max_looks_per_gate
            and line_of_sight(plan.grid, here, g.midpoint, 0.35)
        ):
            sigma = predicted_std(std, g.seen_distance_m, dist)
            gain = value_of_information(mean, std, sigma, width_m, costs) - look_cost_m(
                need, pan, limits, config
            )
            gains[("look", e.gate)] = gain
            if gain > look_gain:
                look_gain = gain
                look = InformationChoice(kind=LookKind.LOOK, gate=e.gate, gain_m=gain)
        # Approach: a point on the entry side, closer than any view so far.
        if e.gate in route_gates:
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
            fail_m=config.fail_cost_m,
            alt_from_entry_m=costs.alt_from_entry_m,
            alt_m=min(float(v_minus[p_cell]), cap),
        )
        after = float(from_robot[p_cell]) + expected_after_measurement(
            mean, std, sigma, width_m, from_p.commit
        )
        gain = float(costs.commit(g.p_passable)) - after
        gains[("approach", e.gate)] = gain
        if gain > approach_gain:
            approach_gain = gain
            route = _route_to(plan, from_pred, int(p_cell), here)
            approach = InformationChoice(
                kind=LookKind.APPROACH, gate=e.gate, gain_m=gain, waypoints=route
            )
    return (look if look is not None else approach), gains


def _route_to(
    plan: SituationPlan, pred: NDArray[np.int64], cell: int, here: FloatArray
) -> FloatArray:
    """(n, 2) the shortest route from the robot at ``here`` to ``cell``, world metres."""
    nodes = [cell]
    while nodes[-1] != plan.start and pred[nodes[-1]] >= 0:
        nodes.append(int(pred[nodes[-1]]))
    nodes.reverse()
    return np.vstack([here[None], plan.grid.spec.xy_of(np.asarray(nodes))])
