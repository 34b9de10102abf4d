"""The pymunk world: motion, collisions without tunnelling, the panning stereo head."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from stereo_nav_env.config import WorldConfig
from stereo_nav_env.sim.scenes import Obstacle, Scene, generate_scene, make_obstacle, oriented_rect
from stereo_nav_env.sim.world import World, _clip


def _scene(*obstacles: Obstacle, start: tuple[float, float, float] = (1.0, 2.0, 0.0)) -> Scene:
    return Scene(name="t", bounds=(0, 0, 6, 4), obstacles=obstacles, start=start, goal=(5.5, 2.0))


def test_free_motion_follows_the_commands() -> None:
    world = World(_scene())
    for _ in range(10):
        result = world.step(0.5, 0.0, 0.0)
        assert not result.collided
        assert result.distance_m == pytest.approx(0.05)
    s = world.state
    assert (s.x_m, s.y_m) == pytest.approx((1.5, 2.0))
    world.step(9.0, 100.0, 0.0)  # clipped to 0.5 m/s and pi/2 rad/s
    assert world.state.heading_rad == pytest.approx(math.pi / 2 * 0.1)
    assert math.hypot(world.state.x_m - 1.5, world.state.y_m - 2.0) == pytest.approx(0.05, rel=0.01)


def test_turning_in_place_does_not_move() -> None:
    world = World(_scene())
    for _ in range(10):
        world.step(0.0, -1.0, 0.0)
    s = world.state
    assert (s.x_m, s.y_m) == pytest.approx((1.0, 2.0), abs=1e-9)
    assert s.heading_rad == pytest.approx(-1.0)


@pytest.mark.parametrize("heading", [0.0, 0.4])
def test_no_tunnelling_through_a_thin_wall_at_top_speed(heading: float) -> None:
    wall = make_obstacle("wall", oriented_rect([3.0, 2.0], 0.02, 3.8))  # 2 cm thick, x in 2.99-3.01
    world = World(_scene(wall, start=(1.0, 1.0, heading)))
    r = world.config.robot_radius_m
    collided = []
    for _ in range(120):
        collided.append(world.step(0.5, 0.0, 0.0).collided)
        assert world.state.x_m <= 2.99 - r + 0.006  # at most one substep (5 mm) of overlap
    assert world.state.x_m > 2.99 - r - 0.01  # it did reach the wall
    first = collided.index(True)
    assert not any(collided[:first]) and all(collided[first:])
    assert world.in_collision()


def test_collision_with_a_concave_footprint() -> None:
    ell = make_obstacle(
        "box", [[3.0, 1.0], [4.0, 1.0], [4.0, 3.0], [3.5, 3.0], [3.5, 1.5], [3.0, 1.5]]
    )
    world = World(_scene(ell, start=(3.75, 0.5, math.pi / 2)))
    for _ in range(60):
        world.step(0.5, 0.0, 0.0)
    assert world.state.y_m <= 1.0 - 0.25 + 0.006


@pytest.mark.parametrize("heading", [0.0, 0.4])
def test_a_collision_reports_the_contact_point_and_the_surface_normal(heading: float) -> None:
    wall = make_obstacle("wall", oriented_rect([3.0, 2.0], 0.1, 3.8))  # its face at x = 2.95
    world = World(_scene(wall, start=(1.0, 1.6, heading)))
    for _ in range(80):
        hit = world.step(0.5, 0.0, 0.0)
        if hit.collided:
            break
        assert hit.contacts == ()
    assert hit.collided
    (contact,) = hit.contacts
    s = world.state
    assert contact.point_xy[0] == pytest.approx(2.95, abs=1e-6)  # on the wall's face
    assert contact.normal_xy == pytest.approx((-1.0, 0.0), abs=1e-6)  # out of the wall
    # the point lies where the robot's disc touches the face: level with its centre
    assert contact.point_xy[1] == pytest.approx(s.y_m, abs=0.02)


def test_reset_forgets_contacts() -> None:
    wall = make_obstacle("wall", oriented_rect([3.0, 2.0], 0.1, 3.8))
    world = World(_scene(wall))
    for _ in range(60):
        world.step(0.5, 0.0, 0.0)
    world.reset()
    for _ in range(5):
        world.step(0.0, 1.0, 0.0)
    assert (world.state.x_m, world.state.y_m) == pytest.approx((1.0, 2.0), abs=1e-12)


def test_head_pans_at_a_limited_rate_within_limits() -> None:
    world = World(_scene())
    world.step(0.0, 0.0, math.pi)  # target beyond the limit: clipped to 90 deg
    assert world.state.pan_rad == pytest.approx(math.radians(9.0))
    for _ in range(20):
        world.step(0.0, 0.0, math.pi)
    assert world.state.pan_rad == pytest.approx(math.pi / 2)
    world.step(0.0, 0.0, math.pi / 2 - 0.01)
    assert world.state.pan_rad == pytest.approx(math.pi / 2 - 0.01)


def test_head_pose_is_the_left_optical_centre() -> None:
    world = World(_scene(start=(1.0, 2.0, 0.3)))
    for _ in range(5):
        world.step(0.0, 0.0, 0.5)
    s = world.state
    pose = world.head_pose(0.12)
    gaze = 0.3 + 0.5
    assert pose.heading_rad == pytest.approx(gaze)
    assert pose.height_m == 0.8
    left = np.array([pose.x_m, pose.y_m])
    centre = np.array([s.x_m, s.y_m])
    np.testing.assert_allclose(left - centre, 0.06 * np.array([-math.sin(gaze), math.cos(gaze)]))
    right = pose.right_camera_position(__import__("modeling").StereoRig())[:2]
    np.testing.assert_allclose((left + right) / 2, centre, atol=1e-12)  # head centred on the robot


def test_generated_scene_start_is_collision_free() -> None:
    for family in ("room", "corridor"):
        world = World(generate_scene(1, family=family))
        assert not world.in_collision()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"robot_width_m": 0.0}, "robot_width_m"),
        ({"max_speed_m_s": -1.0}, "max_speed_m_s"),
        ({"substeps": 0}, "substeps"),
        ({"substeps": 1, "robot_width_m": 0.3}, "substeps"),  # 5 cm per substep could tunnel
        ({"pan_limit_rad": 4.0}, "pan_limit_rad"),
        ({"head_height_m": 1.5}, "head_height_m"),
    ],
)
def test_invalid_config_names_the_field(kwargs: dict[str, Any], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        WorldConfig(**kwargs)


def test_invalid_commands_are_named() -> None:
    world = World(_scene())
    with pytest.raises(ValueError, match="turn_rate_rad_s"):
        world.step(0.1, float("nan"), 0.0)
    with pytest.raises(ValueError, match="scene"):
        World("not a scene")  # type: ignore[arg-type]


def test_clip_is_numpys_to_the_sign_of_zero() -> None:
    for value in (-2.0, -1.0, -0.5, -0.0, 0.0, 1e-300, 0.5, 1.0, 2.0, math.pi):
        for limit in (0.0, 0.5, 1.0, math.pi / 2):
            want = float(np.clip(value, -limit, limit))
            got = _clip(value, limit)
            assert got == want and math.copysign(1.0, got) == math.copysign(1.0, want)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_skipping_contact_queries_changes_nothing(seed: int) -> None:
    """The substeps far from every obstacle skip their contact query and the others are
    queried latest first: the same results, bit for bit, as querying after every substep (the
    reference loop), on a drive of a generated room that keeps running into its furniture."""
    scene = generate_scene(seed, family="room")
    fast, reference = World(scene), World(scene)
    reference.query_every_substep = True
    rng = np.random.default_rng(seed)
    kinds = {"clear": 0, "partly": 0, "collided": 0, "earlier only": 0}
    for _ in range(400):
        v, w, pan = rng.uniform(-0.2, 0.5), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)
        skipped = fast.untouched_substeps(abs(v) * fast.config.dt_s / 10, 10)
        ours, theirs = fast.step(v, w, pan), reference.step(v, w, pan)
        assert ours == theirs
        assert fast.state == reference.state
        kinds["clear" if skipped == 10 else "partly"] += 1
        kinds["collided"] += ours.collided
        kinds["earlier only"] += ours.collided and not fast.in_collision()
    # the drive covers the paths: all skipped, some, contacts at the end and before it only
    assert all(n > 0 for n in kinds.values()), kinds
