"""The expected-cost planner on synthetic environment models (no rendering).

Walls are rows of floor segments with gaps; the model is built by ``modeling.build_model`` from
those segments, exactly as it would be from stereo.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.decision import (
    GateCosts,
    calibrated_mean,
    expected_after_measurement,
    p_wider,
    predicted_std,
    value_of_information,
)
from agents.planning.planner import Mode, PlannerCore, expected_gate_weight
from stereo_nav_env.config import EnvConfig
from tests.agents.synthetic import model_of, wall_segments


def _core(policy: str, bounds, goal, **kw) -> PlannerCore:
    """A planner core that maps everything the synthetic observations hold (8 m range)."""
    kw.setdefault("obstacle_range_m", 8.0)
    core = PlannerCore(
        bounds,
        np.asarray(goal, float),
        ControlLimits.from_config(EnvConfig()),
        NavigatorConfig(policy=policy, **kw),
    )
    core.occupancy.insert_range_m = 8.0
    return core


def _crossing_y(waypoints: np.ndarray, x_m: float) -> float:
    """y where the route crosses the wall at ``x_m``."""
    return float(waypoints[np.argmin(np.abs(waypoints[:, 0] - x_m)), 1])


@pytest.fixture(scope="module")
def two_gaps():
    """A wall at x = 3 m with a narrow gap at y = 2 m (0.45 m) and a wider one at y = 4 m (0.6 m).

    The robot, at (1, 2.6), is nearer the narrow gap; both are undecided for a 0.5 m robot.
    """
    segs = wall_segments(3.0, [(0.1, 1.775), (2.225, 3.7), (4.3, 5.9)], 0.06)
    return model_of(segs, (1.0, 2.6, 0.0))


def test_the_model_has_two_undecided_gaps(two_gaps) -> None:
    regions = sorted(two_gaps.most_probable.critical_regions, key=lambda r: r.width_mean_m)
    assert [round(r.width_mean_m, 2) for r in regions] == [0.46, 0.61]
    assert 0.05 < regions[0].p_passable < 0.5 < regions[1].p_passable < 0.95


def test_planner_prefers_the_wider_gap(two_gaps) -> None:
    pose = (1.0, 2.6, 0.0, 0.0)
    planner = _core("planner", (0, 0, 6, 6), (5.0, 3.0))
    planner.observe(two_gaps, 0)
    decision = planner.plan(pose)
    assert decision.mode is Mode.FOLLOW
    assert _crossing_y(decision.waypoints, 3.0) == pytest.approx(4.0, abs=0.1)
    # Ignoring p (undecided = passable), the nearer narrow gap is shorter: greedy takes it.
    greedy = _core("greedy", (0, 0, 6, 6), (5.0, 3.0))
    greedy.observe(two_gaps, 0)
    assert _crossing_y(greedy.plan(pose).waypoints, 3.0) == pytest.approx(2.0, abs=0.1)


def test_greedy_and_cautious_treat_undecided_gaps_as_open_and_closed(two_gaps) -> None:
    cautious = _core("cautious", (0, 0, 6, 6), (5.0, 3.0))
    cautious.observe(two_gaps, 0)
    assert cautious._effective_p(0.6, failed=False) == 0.0
    assert cautious._effective_p(0.97, failed=False) == 1.0
    greedy = _core("greedy", (0, 0, 6, 6), (5.0, 3.0))
    assert greedy._effective_p(0.06, failed=False) == 1.0
    assert greedy._effective_p(0.04, failed=False) == 0.0
    assert greedy._effective_p(0.9, failed=True) == 0.0


@pytest.fixture(scope="module")
def far_gap():
    """A wall at x = 4 m (y 0.1-4.5 m, free above) with a 0.52 m gap at y = 2.5 m, seen from
    3.6 m away (wide width distribution), and an empty view looking away from it."""
    segs = wall_segments(4.0, [(0.1, 2.24), (2.76, 4.5)], 0.12)
    far = model_of(segs, (0.4, 2.5, 0.0))
    away = model_of([], (2.0, 2.5, math.pi / 2))
    return far, away


def test_planner_looks_before_committing_when_looking_is_cheap(far_gap) -> None:
    far, away = far_gap
    (region,) = far.most_probable.critical_regions
    assert 0.4 < region.p_passable < 0.8 and region.width_std_m > 0.15
    core = _core("planner", (0, 0, 7, 6), (6.0, 2.5))
    core.observe(far, 0)
    core.observe(away, 1)  # the gap is out of view now, 2 m to the robot's right
    decision = core.plan((2.0, 2.5, math.pi / 2, 0.0))
    assert decision.mode is Mode.LOOK
    assert decision.look_at == pytest.approx([4.0, 2.5], abs=0.05)
    assert decision.gains[("look", decision.gate)] > 0
    # A costly look is not worth it: the planner does not look (it moves: follows or approaches).
    costly = _core("planner", (0, 0, 7, 6), (6.0, 2.5), look_cost_m=50.0)
    costly.observe(far, 0)
    costly.observe(away, 1)
    assert costly.plan((2.0, 2.5, math.pi / 2, 0.0)).mode in (Mode.FOLLOW, Mode.APPROACH)


def test_a_look_is_valued_with_the_gates_exact_passability_not_its_gaussian_width(
    far_gap,
) -> None:
    far, away = far_gap

    def look_gain(shift_std: float) -> float:
        core = _core("planner", (0, 0, 7, 6), (6.0, 2.5))
        core.observe(far, 0)
        core.observe(away, 1)
        (gate,) = core.gates.gates
        # a width mean 4 std wider: as a normal, certainly passable (p_wider 0.99997); the
        # exact passability of the model, which the route weights use, is unchanged
        gate.width_mean_m += shift_std * gate.width_std_m
        decision = core.plan((2.0, 2.5, math.pi / 2, 0.0))
        return decision.gains[("look", 0)]

    assert look_gain(0.0) > 0.05
    assert look_gain(4.0) == pytest.approx(look_gain(0.0), abs=1e-12)


def test_the_calibrated_width_gives_the_exact_passability_before_and_after_a_look() -> None:
    # the sideways case of issue 16: the width as a normal says 0.694, the exact model 0.573
    std, width = 0.12, 0.5
    for p in (0.02, 0.3, 0.573, 0.694, 0.97):
        mean = calibrated_mean(p, std, width)
        assert p_wider(mean, std, width) == pytest.approx(p, abs=1e-12)
        # the preposterior mean of p' is p (a look is expected to confirm nothing on average)
        after = expected_after_measurement(mean, std, 0.05, width, lambda q: q)
        assert after == pytest.approx(p, abs=1e-6)
    assert p_wider(calibrated_mean(1.0, std, width), std, width) == pytest.approx(1.0)
    assert calibrated_mean(0.5, 0.0, width) == pytest.approx(width)
    with pytest.raises(ValueError, match="p must be"):
        calibrated_mean(1.5, std, width)
    with pytest.raises(ValueError, match="std_m"):
        calibrated_mean(0.5, -0.1, width)


def test_greedy_never_looks(far_gap) -> None:
    far, away = far_gap
    core = _core("greedy", (0, 0, 7, 6), (6.0, 2.5))
    core.observe(far, 0)
    core.observe(away, 1)
    assert core.plan((2.0, 2.5, math.pi / 2, 0.0)).mode is Mode.FOLLOW


def test_a_bump_closes_the_gate_being_crossed(far_gap) -> None:
    far, _ = far_gap
    core = _core("planner", (0, 0, 7, 6), (6.0, 2.5))
    core.observe(far, 0)
    assert core.bump((3.7, 2.5, 0.0, 0.0), backwards=False) == [0]
    assert core.gates.gates[0].failed and core.gates.gates[0].p_passable == 0.0
    row, col = core.spec.cell_of(np.array([[4.0, 2.5]]))[0]
    assert core.occupancy.occupied()[row, col]
    assert _crossing_y(core.plan((3.0, 2.5, 0.0, 0.0)).waypoints, 4.0) > 4.5  # round the wall


# ------------------------------------------------------------------------------ decision maths
def test_p_wider_and_predicted_std() -> None:
    assert p_wider(0.5, 0.1, 0.5) == pytest.approx(0.5)
    assert p_wider(0.7, 0.1, 0.5) == pytest.approx(0.97725, abs=1e-5)
    assert p_wider(0.6, 0.0, 0.5) == 1.0 and p_wider(0.4, 0.0, 0.5) == 0.0
    assert predicted_std(0.2, 4.0, 2.0) == pytest.approx(0.05)  # quarter at half the distance
    assert predicted_std(0.2, 4.0, 0.1) == pytest.approx(0.01)  # floor


def test_value_of_information_is_zero_for_a_useless_or_certain_look() -> None:
    costs = GateCosts(
        to_entry_m=2.0, cross_m=0.6, beyond_m=2.0, fail_m=1.0, alt_from_entry_m=6.0, alt_m=6.5
    )
    assert costs.via(1.0) == pytest.approx(4.6)
    assert costs.via(0.0) == pytest.approx(9.0)
    assert value_of_information(0.5, 0.15, 0.15 * 1e3, 0.5, costs) == pytest.approx(0, abs=1e-3)
    assert value_of_information(0.9, 0.01, 0.01, 0.5, costs) == pytest.approx(0, abs=1e-9)
    voi = value_of_information(0.52, 0.15, 0.02, 0.5, costs)
    assert voi > 0.3
    # A perfect measurement: E[min(via(1{w > W}), alt)] = p via(1) + (1 - p) alt.
    p = p_wider(0.52, 0.15, 0.5)
    exact = p * costs.via(1.0) + (1 - p) * costs.alt_m
    after = expected_after_measurement(0.52, 0.15, 1e-6, 0.5, costs.commit)
    assert after == pytest.approx(exact, abs=2e-3)


# ------------------------------------------------------------------------------ bumps and following
def test_a_bump_with_a_measured_normal_marks_the_face_not_across_the_heading() -> None:
    """Sliding east along a wall below it (normal pointing south): the mark lies along the wall."""
    core = _core("planner", (0, 0, 7, 6), (6.0, 1.0))
    core.bump((3.0, 2.0, 0.0, 0.0), backwards=False, step=5, normal=np.array([0.0, -1.0]))
    occupied = core.occupancy.occupied()

    def marked(x: float, y: float) -> bool:
        row, col = core.spec.cell_of(np.array([[x, y]]))[0]
        return bool(occupied[row, col])

    assert marked(2.75, 2.3) and marked(3.25, 2.3)  # along the face above the robot
    assert not marked(3.3, 1.8) and not marked(3.3, 2.0)  # nothing across the way ahead


def test_forgetting_old_bumps_reopens_a_map_they_closed(far_gap) -> None:
    """Old bump marks closing every way leave no route (the agent then forgets them: relax)."""
    far, _ = far_gap
    core = _core("planner", (0, 0, 7, 6), (6.0, 2.5))
    core.observe(far, 0)
    for y in np.arange(0.2, 6.0, 0.5):
        core.occupancy.add_bump(np.array([5.0, y]), 0.0, 0.6, step=1)
    assert core.plan((1.0, 2.5, 0.0, 0.0)).mode is Mode.NONE
    core.relax(100 - core.config.relax_keep_steps)
    assert core.plan((1.0, 2.5, 0.0, 0.0)).mode is not Mode.NONE


@pytest.mark.parametrize(("bump_step", "reopened"), [(10, True), (90, False)])
def test_the_relax_reopens_the_only_gap_an_old_bump_closed(bump_step, reopened) -> None:
    """A wall across the whole room with one undecided 0.52 m gap: a bump at its mouth closes
    it and leaves no route. At step 100 the relax (keeping the last 30 steps) opens it again
    when the bump is old (the robot can try again), not when it is recent."""
    segs = wall_segments(4.0, [(0.0, 2.24), (2.76, 6.0)], 0.12)
    core = _core("planner", (0, 0, 7, 6), (6.0, 2.5))
    core.observe(model_of(segs, (0.4, 2.5, 0.0)), 0)
    assert core.bump((3.6, 2.5, 0.0, 0.0), backwards=False, step=bump_step) == [0]
    assert core.plan((3.0, 2.5, 0.0, 0.0)).mode is Mode.NONE
    core.relax(100 - core.config.relax_keep_steps)
    decision = core.plan((3.0, 2.5, 0.0, 0.0))
    assert core.gates.gates[0].failed is not reopened
    if reopened:
        assert decision.mode is not Mode.NONE
        assert _crossing_y(decision.waypoints, 4.0) == pytest.approx(2.5, abs=0.15)
    else:
        assert decision.mode is Mode.NONE


def test_the_expected_gate_weight() -> None:
    """``L + (1 - p) max(0, C_fail + V_alt - L - V_open)``: certain, undecided, no worse."""
    assert expected_gate_weight(1.0, 1.0, 2.0, 10.0, 3.0) == 1.0
    assert expected_gate_weight(1.0, 0.25, 2.0, 10.0, 3.0) == pytest.approx(1.0 + 0.75 * 8.0)
    assert expected_gate_weight(1.0, 0.25, 2.0, 0.5, 3.0) == 1.0  # the alternative is no worse


@pytest.mark.parametrize(
    ("keep", "expected_y"), [({}, 2.0), ({"keep_route_m": 0.0, "keep_route_share": 0.0}, 4.0)]
)
def test_a_replan_keeps_its_route_unless_the_hysteresis_is_off(keep, expected_y) -> None:
    """Two wide gaps (y = 2 and 4 m) in a wall at x = 3 m, the goal midway beyond: from just
    below the middle the route takes the lower gap; 0.2 m above the middle the upper one is 0.3
    m shorter, within the default margin (0.5 m), so the route is kept unless the margin is 0."""
    segs = wall_segments(3.0, [(0.1, 1.4), (2.6, 3.4), (4.6, 5.9)], 0.03)
    core = _core("greedy", (0, 0, 6, 6), (5.0, 3.0), **keep)
    core.observe(model_of(segs, (1.0, 2.9, 0.0)), 0)
    assert _crossing_y(core.plan((1.0, 2.9, 0.0, 0.0)).waypoints, 3.0) == pytest.approx(
        2.0, abs=0.2
    )
    replanned = core.plan((1.0, 3.1, 0.0, 0.0))
    assert _crossing_y(replanned.waypoints, 3.0) == pytest.approx(expected_y, abs=0.2)


def test_the_hysteresis_margins_are_checked() -> None:
    with pytest.raises(ValueError, match="keep_route_m"):
        NavigatorConfig(keep_route_m=-0.1)
    with pytest.raises(ValueError, match="keep_route_share"):
        NavigatorConfig(keep_route_share=1.5)
