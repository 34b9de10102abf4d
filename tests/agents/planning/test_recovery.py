"""Recovery from bumps and stalls: the back-off, the contact normals, the watches."""

from __future__ import annotations

import math

import pytest

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.recovery import Recovery
from stereo_nav_env.config import EnvConfig

_CFG = NavigatorConfig()


def _recovery() -> Recovery:
    return Recovery(_CFG, ControlLimits.from_config(EnvConfig()), (0.0, 0.0, 0.0), 5.0)


def test_a_head_on_bump_measures_its_normal_and_backs_off() -> None:
    rec = _recovery()
    rec.commanded(1.0)  # full speed ahead, and the robot did not move: blocked along +x
    events = rec.update((0.0, 0.0, 0.0), 1, collided=True, goal_distance_m=5.0)
    assert events.replan and events.bump is not None and not events.bump.backwards
    assert events.bump.normal == pytest.approx([-1.0, 0.0])
    commands = [rec.escape_command(0.0, 1 + k) for k in range(_CFG.backoff_steps)]
    assert commands == [(-0.6, 0.0)] * _CFG.backoff_steps
    assert rec.escape_command(0.0, 9) is None and not rec.escaping


def test_wedged_front_and_back_the_escape_turns_sideways() -> None:
    rec = _recovery()
    rec.commanded(1.0)
    rec.update((0.0, 0.0, 0.0), 1, collided=True, goal_distance_m=5.0)
    forward, _ = rec.escape_command(0.0, 1) or (0.0, 0.0)
    rec.commanded(forward)  # backing off, and blocked behind too
    events = rec.update((0.0, 0.0, 0.0), 2, collided=True, goal_distance_m=5.0)
    assert events.bump is not None and events.bump.normal == pytest.approx([1.0, 0.0])
    forward, turn = rec.escape_command(0.0, 2) or (math.nan, math.nan)
    assert turn == 1.0 and abs(forward) < 1e-9  # a quarter turn first, standing


def test_a_touch_beside_the_path_gives_no_normal() -> None:
    rec = _recovery()
    rec.commanded(1.0)
    moved = 0.5 * 0.1  # the full step was made: nothing blocked
    events = rec.update((moved, 0.0, 0.0), 1, collided=True, goal_distance_m=5.0)
    assert events.bump is not None and events.bump.normal is None


def test_standing_still_counts_as_a_bump_and_no_progress_as_lost() -> None:
    rec = _recovery()
    stalled = [
        rec.update((0.0, 0.0, 0.0), step, collided=False, goal_distance_m=5.0).stalled
        for step in range(1, _CFG.stall_steps + 2)
    ]
    assert stalled == [False] * _CFG.stall_steps + [True]
    assert rec.escape_command(0.0, _CFG.stall_steps + 1) == (-0.6, 0.0)
    rec = _recovery()
    lost = []
    for step in range(1, _CFG.forget_steps + 2):
        x = 0.2 * step  # moving (no stall) but never nearer to the goal
        lost.append(rec.update((x, 0.0, 0.0), step, collided=False, goal_distance_m=5.0).lost)
    assert lost == [False] * _CFG.forget_steps + [True]
    assert not rec.update((0.0, 0.0, 0.0), 200, collided=False, goal_distance_m=4.0).lost
