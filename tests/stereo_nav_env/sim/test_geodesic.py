"""The geodesic distance field against distances known by construction."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest

from stereo_nav_env.sim.geodesic import GeodesicField
from stereo_nav_env.sim.scenes import Obstacle, Scene, make_obstacle, oriented_rect


def _room(obstacles: Sequence[Obstacle] = (), goal: tuple[float, float] = (8.0, 3.0)) -> Scene:
    return Scene(
        name="test",
        bounds=(0.0, 0.0, 10.0, 6.0),
        obstacles=tuple(obstacles),
        start=(1.0, 3.0, 0.0),
        goal=goal,
    )


def test_open_floor_gives_the_straight_distance_within_three_percent() -> None:
    field = GeodesicField.build(_room(), 0.25, 0.05)
    for x, y in [(1.0, 3.0), (2.0, 1.0), (7.0, 5.0), (4.4, 2.2), (8.0, 1.0)]:
        d = math.hypot(x - 8.0, y - 3.0)
        assert field((x, y)) == pytest.approx(d, rel=0.03, abs=0.05)


def test_a_wall_with_a_door_makes_the_robot_go_through_the_door() -> None:
    # a wall across the room at x = 5 with a 1 m door at y in [4.5, 5.5]
    walls = [
        make_obstacle("wall", oriented_rect((5.0, 2.25), 4.5, 0.1, math.pi / 2)),
        make_obstacle("wall", oriented_rect((5.0, 5.75), 0.5, 0.1, math.pi / 2)),
    ]
    field = GeodesicField.build(_room(walls), 0.25, 0.05)
    door = np.array([5.0, 5.0])
    via_door = np.linalg.norm(door - [1.0, 3.0]) + np.linalg.norm(door - [8.0, 3.0])
    assert field((1.0, 3.0)) == pytest.approx(via_door, rel=0.03)
    # a door narrower than the robot closes the way: cells left of it are farther than any route
    narrow = [
        make_obstacle("wall", oriented_rect((5.0, 2.6), 5.2, 0.1, math.pi / 2)),
        make_obstacle("wall", oriented_rect((5.0, 5.8), 0.4, 0.1, math.pi / 2)),
    ]
    closed = GeodesicField.build(_room(narrow), 0.25, 0.05)
    assert not closed.reachable[int(3.0 / 0.05), int(1.0 / 0.05)]
    assert math.isfinite(closed((1.0, 3.0)))


def test_the_field_is_finite_everywhere_and_grows_into_obstacles() -> None:
    box = make_obstacle("box", oriented_rect((5.0, 3.0), 1.0, 1.0))
    field = GeodesicField.build(_room([box]), 0.25, 0.05)
    assert np.all(np.isfinite(field.distance))
    assert not field.free[int(3.0 / 0.05), int(5.0 / 0.05)]
    assert field((5.0, 3.0)) > field((5.0, 4.0))  # inside the box: farther than beside it


def test_bad_arguments_are_value_errors() -> None:
    with pytest.raises(ValueError, match="robot_radius_m"):
        GeodesicField.build(_room(), 0.0)
    with pytest.raises(ValueError, match="cell_m"):
        GeodesicField.build(_room(), 0.25, -0.1)
