"""A stall of the dev split: the planner wedged between two boxes, its back-off never ending.

Dev episode 2 of suite seed 4242 (``cluttered``, reset seed 424200002, stereo) ran out its 500
steps with 55 collision steps: at step 182 the robot, driving east through the 0.57 m gap between
two boxes, grazed the corner of one; its back-off was bumped again at step 193, and every further
contact redirected it along a normal estimated from the blocked motion (the two faces alternating),
so it shuffled on the spot for 96 steps without re-planning. The test feeds the recovery the
episode's poses, contact flags and the commands sent up to that second bump (the same on the old
and the new recovery), then drives the escape's commands: the fixed recovery retraces the way in
and ends the back-off, where the old one set off along a contact normal, away from it.
"""

from __future__ import annotations

import math

import pytest

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.recovery import Recovery
from stereo_nav_env.config import EnvConfig

# (step, x_m, y_m, heading_rad, collided, forward sent) of the episode, steps 178-193 (the test
# counts from 178 as step 1: the stall and progress watches start there).
_EPISODE = (
    (178, 3.8216882851139267, 1.8821529287597694, 0.30522719635178164, False, 0.973241005034915),
    (179, 3.8689698619764603, 1.8934503333077353, 0.14814756367229195, False, 0.9996868815600432),
    (180, 3.9184632339286636, 1.9004343375728536, 0.13045148747854526, False, 0.9900283433264689),
    (181, 3.9677637261907455, 1.9046568656327136, 0.03042659615804555, False, 0.9999575743891098),
    (182, 4.017531370888978, 1.9080784516036147, 0.02391305581437407, True, -0.6),
    (183, 3.987539946802068, 1.9073611282702445, 0.02391305581437407, True, -6.363908671539648e-06),
    (184, 3.98753962927804, 1.907361143132565, -0.13316657686511557, False, -0.015292931676434224),
    (185, 3.986791577435164, 1.9075157833286323, -0.2902462095446052, False, -0.05844861096249531),
    (186, 3.984060226581866, 1.9085467790174975, -0.4473258422240951, False, -0.12524902319503647),
    (187, 3.9786249108896974, 1.9116444995732556, -0.604405474903585, False, -0.20915527859889707),
    (188, 3.970469365416603, 1.9181736234627247, -0.7614851075830749, False, -0.30195404828589006),
    (189, 3.9603148449228587, 1.9293254273098255, -0.9185647402625647, False, -0.39456154211200517),
    (190, 3.9494889185978472, 1.9457937213858245, -1.0756443729420542, False, -0.4779126933471922),
    (191, 3.9396578889484197, 1.9675466711113456, -1.232724005621543, False, -0.5438485105669315),
    (192, 3.9324806421717673, 1.9937461211151335, -1.3898036383010317, False, -0.5859147365799039),
    (193, 3.9360295522523288, 2.0187377953538257, -1.5436265016864361, True, None),
)
_WAY_IN = _EPISODE[0][1:3]
"""Where the robot was before the gap (step 178)."""


def test_a_robot_bumped_again_while_backing_off_retraces_its_way_in() -> None:
    limits = ControlLimits.from_config(EnvConfig())
    _, x, y, heading, _, _ = _EPISODE[0]
    rec = Recovery(NavigatorConfig(), limits, (x, y, heading), 5.0)
    for step, x, y, heading, collided, forward in _EPISODE:
        rec.update((x, y, heading), step - 177, collided=collided, goal_distance_m=5.0)
        if rec.escaping:
            rec.escape_command(heading, step - 177)
        if forward is not None:
            rec.commanded(forward)
    assert rec.escaping
    start = math.dist((x, y), _WAY_IN)
    # Drive the escape's commands (no further contact) until it hands back to the planner.
    steps = 0
    command = rec.escape_command(heading, 16)
    while command is not None and steps < 100:
        forward, turn = command
        rec.commanded(forward)
        heading += turn * limits.max_turn_rate_rad_s * limits.dt_s
        x += forward * limits.max_speed_m_s * limits.dt_s * math.cos(heading)
        y += forward * limits.max_speed_m_s * limits.dt_s * math.sin(heading)
        steps += 1
        rec.update((x, y, heading), 16 + steps, collided=False, goal_distance_m=5.0)
        command = rec.escape_command(heading, 16 + steps)
    assert steps <= 30
    assert math.dist((x, y), _WAY_IN) < 0.5 * start
    assert math.dist((x, y), _WAY_IN) == pytest.approx(0.0, abs=0.1)
