"""A detour of the dev split taken for lost progress: the planner forgot the way it found blocked.

Dev episode 5 of suite seed 4242 (``corridor``, reset seed 424200005, stereo) ran out its 500
steps. At steps 202 and 219 the robot, heading for a gap at (8.2, 1.4), bumped into it, and the
route it planned next (steps 223-291) turned back west, away from the goal, its expected cost up
from 4.4 m to 8.1 m. At step 296, 100 steps after the robot last came nearer to the goal, the
progress watch fired: the planner forgot what it had seen and its bumps older than 200 steps, and
went back east to the gap it had found blocked, switching between the two ways round until the
steps ran out. The test feeds the recovery the episode's poses (steps 186-300, to the centimetre)
and the expected costs of the routes planned there: a route whose cost rose by more than
``progress_reset_m`` is a detour begun, and restarts the progress watch, so it no longer fires.
"""

from __future__ import annotations

import math

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.recovery import Recovery
from stereo_nav_env.config import EnvConfig

_GOAL = (10.2985, 1.7856)
_FIRST_STEP = 186
_POSES = """
    7.74 0.84  7.78 0.86  7.82 0.87  7.85 0.90  7.89 0.94  7.92 0.97  7.95 1.01  7.98 1.06
    8.01 1.10  8.03 1.14  8.06 1.18  8.09 1.22  8.11 1.27  8.14 1.31  8.16 1.35  8.19 1.40
    8.20 1.44  8.19 1.41  8.17 1.39  8.16 1.36  8.14 1.34  8.14 1.34  8.14 1.34  8.14 1.34
    8.14 1.34  8.14 1.34  8.14 1.34  8.14 1.34  8.15 1.34  8.16 1.36  8.18 1.37  8.19 1.40
    8.20 1.43  8.20 1.46  8.20 1.43  8.20 1.40  8.20 1.37  8.20 1.34  8.20 1.34  8.20 1.34
    8.20 1.34  8.20 1.34  8.20 1.34  8.20 1.34  8.20 1.34  8.20 1.34  8.20 1.34  8.20 1.34
    8.20 1.34  8.20 1.34  8.18 1.34  8.16 1.33  8.14 1.31  8.11 1.28  8.09 1.25  8.07 1.21
    8.05 1.16  8.03 1.12  8.01 1.08  7.98 1.05  7.94 1.02  7.90 1.00  7.85 0.98  7.81 0.96
    7.76 0.94  7.71 0.93  7.66 0.92  7.61 0.91  7.56 0.90  7.51 0.90  7.46 0.89  7.41 0.89
    7.36 0.88  7.31 0.88  7.26 0.87  7.22 0.87  7.17 0.87  7.12 0.88  7.07 0.89  7.02 0.90
    6.97 0.91  6.92 0.92  6.88 0.93  6.84 0.96  6.81 0.99  6.78 1.02  6.75 1.06  6.74 1.10
    6.74 1.06  6.75 1.04  6.76 1.01  6.77 0.98  6.76 1.00  6.75 1.03  6.72 1.06  6.69 1.08
    6.65 1.09  6.68 1.08  6.71 1.06  6.73 1.05  6.76 1.04  6.74 1.05  6.71 1.05  6.67 1.06
    6.63 1.06  6.61 1.05  6.58 1.04  6.54 1.02  6.51 0.99  6.47 0.96  6.43 0.92  6.43 0.92
    6.43 0.92  6.43 0.92  6.43 0.92
"""
"""(x_m, y_m) of the robot after each step from 186 on (what the agent sees at the next step)."""
_ROUTE_COSTS = {
    188: 3.77,
    193: 3.43,
    198: 3.43,
    206: 3.89,
    211: 3.89,
    216: 4.37,
    223: 8.05,
    228: 8.05,
    233: 8.05,
    238: 8.05,
    243: 7.83,
    248: 7.42,
    253: 7.28,
    258: 6.88,
    263: 64.94,
    268: 7.62,
    277: 56.0,
    286: 90.63,
    291: 29.75,
    296: 4.55,
}
"""Expected cost (metres) of the route planned at a step (every re-plan of those steps)."""


def _lost_steps(config: NavigatorConfig) -> list[int]:
    values = [float(v) for v in _POSES.split()]
    poses = list(zip(values[::2], values[1::2], strict=True))
    limits = ControlLimits.from_config(EnvConfig())
    x, y = poses[0]
    rec = Recovery(config, limits, (x, y, 0.0), math.dist((x, y), _GOAL))
    lost = []
    for k, (x, y) in enumerate(poses, start=1):
        # The pose after step s is what the agent sees at step s + 1; the watches count from
        # the first step replayed (episode step 187) as step 1.
        step = _FIRST_STEP + k
        distance = math.dist((x, y), _GOAL)
        events = rec.update((x, y, 0.0), k, collided=False, goal_distance_m=distance)
        if events.lost:
            lost.append(step)
        if step in _ROUTE_COSTS:
            rec.route_cost(_ROUTE_COSTS[step], k, distance)
    return lost


def test_a_detour_after_a_blocked_way_is_not_taken_for_lost_progress() -> None:
    assert _lost_steps(NavigatorConfig()) == []


def test_without_the_reset_the_progress_watch_fires_where_the_episode_forgot() -> None:
    assert _lost_steps(NavigatorConfig(progress_reset_m=0.0)) == [296]
