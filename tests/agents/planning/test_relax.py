"""A relax that could not relax: the planner drove at the goal into the face it had just hit.

Dev episode 61 of suite seed 5151 (``corridor``, reset seed 515100061, stereo) ran out its 500
steps with 38 collision steps. The only way on is a 0.66 m gap between a box (from y = 1.66 m)
and a chair (up to y = 1.0 m) at x = 5.8-6.2 m. The box's west face, seen head-on, is not
measured: at step 151 the robot hit it, and the 1 m mark across its heading ran 0.22 m past the
box's corner, over the gap; that bump also closed two gates next to the corner (between phantom
points of the views). No route was left. The relax forgot what was seen and the bumps older than
30 steps, but not that bump or the gates it closed, so there was still none, and the robot drove
straight at the goal into the same face: 36 bumps there from step 151 on. The test rebuilds the
planner's memory as it was at step 155 (its gates, to the millimetre, and the recent bump) and
checks that the relax, which now also forgets the remembered gates, finds a way under the mark
(with the episode's views, through the gap: the episode now ends at the goal in 381 steps).
"""

from __future__ import annotations

import numpy as np

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.gridmap import Gate
from agents.planning.planner import Mode, PlannerCore
from stereo_nav_env.config import EnvConfig

_BOUNDS = (0.0, 0.0, 10.213295426078176, 2.903676047920852)
_GOAL = (8.921194326924601, 0.9002306426732996)
_POSE = (5.423, 1.877, 0.154, 0.0)
"""The robot at step 155, as the relax ran."""
_STEP = 155
_BUMP = ((5.843, 1.941), 0.154, 1.0, 151)
"""(centre, heading, length, step) of the mark of the bump at step 151 (no contact normal)."""


def _a(rows: list[list[float]]) -> np.ndarray:
    return np.array(rows, dtype=np.float64)


def _gates() -> list[Gate]:
    """The planner's remembered gates at step 155 (three closed by bumps)."""
    return [
        Gate(
            ends=_a([[5.739, 0.538], [5.264, 0.525]]),
            width_mean_m=0.479,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[5.788, 0.589], [5.213, 0.573], [5.215, 0.474], [5.79, 0.489]]),
            seen_distance_m=1.44,
            viewed_distance_m=1.44,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[6.289, 2.37], [5.789, 2.367]]),
            width_mean_m=0.500,
            width_std_m=0.008,
            p_passable=0.498,
            polygon=_a([[6.339, 2.42], [5.739, 2.417], [5.739, 2.317], [6.339, 2.32]]),
            seen_distance_m=0.80,
            viewed_distance_m=0.72,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.825, 1.663], [5.825, 1.663]]),
            width_mean_m=0.222,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[5.775, 1.613], [5.875, 1.613], [5.875, 1.713], [5.775, 1.713]]),
            seen_distance_m=0.56,
            viewed_distance_m=0.49,
            failed=True,
            crossed=False,
        ),
        Gate(
            ends=_a([[4.251, 0.516], [4.481, 0.87]]),
            width_mean_m=0.433,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[4.251, 0.516], [4.495, 0.868], [4.481, 0.87], [4.242, 0.52]]),
            seen_distance_m=2.47,
            viewed_distance_m=1.61,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.766, 1.662], [5.724, 1.388]]),
            width_mean_m=0.353,
            width_std_m=0.089,
            p_passable=0.000,
            polygon=_a([[5.756, 1.383], [5.798, 1.66], [5.766, 1.662], [5.724, 1.388]]),
            seen_distance_m=3.61,
            viewed_distance_m=0.71,
            failed=True,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.774, 1.662], [5.137, 1.48]]),
            width_mean_m=0.665,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[5.808, 1.724], [5.075, 1.514], [5.102, 1.418], [5.836, 1.628]]),
            seen_distance_m=0.73,
            viewed_distance_m=0.43,
            failed=True,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.093, 1.487], [4.582, 1.457]]),
            width_mean_m=0.512,
            width_std_m=0.020,
            p_passable=1.000,
            polygon=_a([[5.14, 1.54], [4.529, 1.504], [4.535, 1.405], [5.146, 1.44]]),
            seen_distance_m=2.02,
            viewed_distance_m=2.02,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.728, 0.547], [5.798, 0.996]]),
            width_mean_m=0.473,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[5.77, 0.49], [5.855, 1.037], [5.756, 1.053], [5.671, 0.505]]),
            seen_distance_m=1.45,
            viewed_distance_m=1.29,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[6.175, 1.014], [5.814, 0.988]]),
            width_mean_m=0.366,
            width_std_m=0.020,
            p_passable=0.000,
            polygon=_a([[6.221, 1.067], [5.76, 1.034], [5.767, 0.935], [6.228, 0.968]]),
            seen_distance_m=1.23,
            viewed_distance_m=1.23,
            failed=False,
            crossed=False,
        ),
        Gate(
            ends=_a([[5.328, 0.43], [5.114, 0.865]]),
            width_mean_m=0.485,
            width_std_m=0.016,
            p_passable=0.169,
            polygon=_a([[5.395, 0.407], [5.137, 0.932], [5.048, 0.888], [5.305, 0.363]]),
            seen_distance_m=1.38,
            viewed_distance_m=1.29,
            failed=False,
            crossed=False,
        ),
    ]


def _core() -> PlannerCore:
    core = PlannerCore(
        _BOUNDS,
        np.asarray(_GOAL),
        ControlLimits.from_config(EnvConfig()),
        NavigatorConfig(policy="planner"),
    )
    centre, heading, length, step = _BUMP
    core.occupancy.add_bump(np.asarray(centre), heading, length, step)
    core.gates.gates = _gates()
    return core


def test_the_relax_finds_the_gap_the_remembered_gates_closed() -> None:
    core = _core()
    core.occupancy.forget(_STEP - core.config.relax_keep_steps)  # the relax as it was
    core.forget_route()
    assert core.plan(_POSE).mode is Mode.NONE
    core.forget_gates()  # the relax now
    decision = core.plan(_POSE)
    assert decision.mode is Mode.FOLLOW
    route = decision.waypoints
    east = route[route[:, 0] >= 6.0]
    assert east.shape[0] and east[0, 1] < 1.44  # under the mark (the chair is forgotten too)
    assert np.hypot(*(route[-1] - np.asarray(_GOAL))) < 0.5
