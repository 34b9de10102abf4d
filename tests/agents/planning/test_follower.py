"""The route follower: pure pursuit, the gaze ahead along the route, and looking at a point."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.base import ControlLimits
from agents.planning.config import NavigatorConfig
from agents.planning.follower import PathFollower, RouteDriver, pan_towards
from stereo_nav_env.config import EnvConfig

_KW = {"max_speed_mps": 0.5, "max_turn_rate_rps": math.pi / 2, "dt_s": 0.1}


def _driver(gaze_ahead_m: float = 1.0) -> RouteDriver:
    return RouteDriver(
        pursuit=PathFollower(lookahead_m=0.35, **_KW),
        limits=ControlLimits.from_config(EnvConfig()),
        gaze_ahead_m=gaze_ahead_m,
    )


def test_the_follower_does_not_turn_round_for_a_step_back() -> None:
    """A route that steps back to a cell behind the robot and then passes it again."""
    route = np.array([[1.0, 1.0], [0.9, 1.0], [0.8, 1.0], [1.0, 1.02], [2.0, 1.0]])
    forward, _ = PathFollower(lookahead_m=0.35, **_KW).command((1.0, 1.0, 0.0), route)
    assert forward == 0.0  # pursues the step back: turns round on the spot
    forward, turn = PathFollower(lookahead_m=0.35, shortcut_m=0.15, **_KW).command(
        (1.0, 1.0, 0.0), route
    )
    assert forward > 0.5 and abs(turn) < 0.5


def test_the_gaze_point_lies_round_the_next_corner_of_the_route() -> None:
    """The planner points its head at the route 1 m ahead: round a corner 0.5 m ahead."""
    follower = PathFollower(**_KW)
    route = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, -2.0]])
    ahead = follower.point_ahead(np.array([0.0, 0.0]), route, 1.0)
    assert ahead == pytest.approx([0.5, -0.5])
    assert NavigatorConfig().gaze_ahead_m > 0


def test_the_head_looks_round_the_corner_only_when_gazing() -> None:
    route = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, -2.0]])
    pose = (0.0, 0.0, 0.0, 0.0)
    _, _, pan = _driver().follow(pose, route, gaze=True)
    assert pan == pytest.approx(math.atan2(-0.5, 0.5) / (math.pi / 2))  # towards (0.5, -0.5)
    assert _driver().follow(pose, route, gaze=False)[2] == 0.0
    assert _driver(gaze_ahead_m=0.0).follow(pose, route, gaze=True)[2] == 0.0


def test_a_look_within_reach_pans_and_slows_and_one_behind_turns_the_body() -> None:
    route = np.array([[0.0, 0.0], [3.0, 0.0]])
    pose = (0.0, 0.0, 0.0, 0.0)
    follow_forward, _, _ = _driver().follow(pose, route, gaze=False)
    forward, turn, pan = _driver().look(pose, route, np.array([1.0, 1.0]))
    assert pan == pytest.approx(0.5) and forward == pytest.approx(0.5 * follow_forward)
    forward, turn, pan = _driver().look(pose, route, np.array([-1.0, -0.1]))
    assert forward == 0.0 and turn == -1.0 and pan == -1.0
    assert pan_towards(np.array([0.0, 1.0]), np.zeros(2), 0.0, math.pi / 2) == pytest.approx(
        (math.pi / 2, 1.0)
    )


def test_a_point_is_seen_within_the_field_of_view_of_the_panned_head() -> None:
    driver = _driver()
    assert driver.sees(np.array([2.0, 0.0]), (0.0, 0.0, 0.0, 0.0))
    assert not driver.sees(np.array([0.0, 2.0]), (0.0, 0.0, 0.0, 0.0))
    assert driver.sees(np.array([0.0, 2.0]), (0.0, 0.0, 0.0, math.pi / 2))
