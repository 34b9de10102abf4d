"""Scenes: the seeded generator's guarantees, true gaps, bundled maps and the JSON format."""

from __future__ import annotations

import copy
import json
import math
import pathlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from shapely.geometry import Polygon
from shapely.ops import unary_union

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.sim.scenes import (
    STANDARD_FAMILIES,
    ObstacleKind,
    Scene,
    available_maps,
    generate_scene,
    load_map,
    load_scenario,
    make_obstacle,
    oriented_rect,
    save_map,
    scene_from_json,
    scene_to_json,
)

W = 0.5  # robot width


@pytest.mark.parametrize("family", STANDARD_FAMILIES)
def test_generated_scenes_keep_their_guarantees(family: str) -> None:
    for seed in range(30):
        scene = generate_scene(seed, family=family, robot_width_m=W)
        assert scene.name == f"{family}-{seed}"
        assert scene.is_free(scene.start[:2], W) and scene.is_free(scene.goal, W)
        assert scene.route_exists(W)
        doubtful = scene.doubtful_gaps(W)
        assert len(doubtful) >= 2
        assert all(0.35 <= g.width_m <= 0.65 for g in doubtful)
        kinds = {ob.kind for ob in scene.obstacles}
        assert ObstacleKind.WALL in kinds and len(kinds) >= 2


def test_generator_route_holds_for_a_wider_robot() -> None:
    scene = generate_scene(3, family="room", robot_width_m=0.7)
    assert scene.route_exists(0.7)
    assert all(0.49 <= g.width_m <= 0.91 for g in scene.doubtful_gaps(0.7))


def test_generator_is_deterministic() -> None:
    a = scene_to_json(generate_scene(7, family="cluttered"))
    b = scene_to_json(generate_scene(7, family="cluttered"))
    c = scene_to_json(generate_scene(8, family="cluttered"))
    assert a == b
    assert a != c


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"robot_width_m": -0.5}, "robot_width_m"),
        ({"robot_width_m": float("nan")}, "robot_width_m"),
        ({"family": "castle"}, "family"),
        ({"margin_m": -0.1}, "margin_m"),
        ({"min_doubtful_gaps": -1}, "min_doubtful_gaps"),
    ],
)
def test_bad_generator_parameters_are_named(kwargs: dict[str, Any], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        generate_scene(0, **kwargs)


def test_bad_seed_is_named() -> None:
    with pytest.raises(ValueError, match="seed"):
        generate_scene(-1)


def _two_boxes(gap: float, blocker: bool = False) -> Scene:
    obstacles = [
        make_obstacle("box", oriented_rect([1.0, 2.0], 1.0, 1.0)),
        make_obstacle("box", oriented_rect([2.0 + gap, 2.0], 1.0, 1.0)),
    ]
    if blocker:
        obstacles.append(make_obstacle("box", oriented_rect([1.5 + gap / 2, 2.0], gap / 3, 1.2)))
    return Scene(
        name="t",
        bounds=(0, 0, 5, 4),
        obstacles=tuple(obstacles),
        start=(0.3, 0.3, 0),
        goal=(4.5, 3.5),
    )


def test_gaps_are_exact_ground_truth() -> None:
    (gap,) = _two_boxes(0.42).gaps()
    assert (gap.i, gap.j) == (0, 1)
    assert gap.width_m == pytest.approx(0.42)
    assert gap.point_i[0] == pytest.approx(1.5) and gap.point_j[0] == pytest.approx(1.92)
    assert not gap.passable(0.5) and gap.passable(0.4)
    assert len(_two_boxes(0.42).doubtful_gaps(0.5)) == 1
    assert _two_boxes(0.2).doubtful_gaps(0.5) == ()
    # a third obstacle in the middle splits the gap: the original pair is no longer a gap
    pairs = {(g.i, g.j) for g in _two_boxes(0.42, blocker=True).gaps()}
    assert (0, 1) not in pairs and (0, 2) in pairs and (1, 2) in pairs


def test_route_check_sees_a_closed_wall() -> None:
    wall = make_obstacle("wall", oriented_rect([2.5, 2.0], 4.0, 0.1, math.pi / 2))
    closed = Scene(name="c", bounds=(0, 0, 5, 4), obstacles=(wall,), start=(1, 2, 0), goal=(4, 2))
    assert not closed.route_exists(W)
    short = make_obstacle("wall", oriented_rect([2.5, 1.7], 3.4, 0.1, math.pi / 2))
    open_ = Scene(name="o", bounds=(0, 0, 5, 4), obstacles=(short,), start=(1, 2, 0), goal=(4, 2))
    assert open_.route_exists(W)  # 0.6 m left at the top: 0.5 m robot + 2 x 0.05 m margin
    assert not open_.route_exists(W, margin_m=0.06)


def test_parts_of_furniture() -> None:
    table = make_obstacle("table", oriented_rect([0, 0], 1.2, 0.8))
    assert len(table.parts) == 5  # top and four legs
    assert max(p.z_max_m for p in table.parts) == pytest.approx(0.75)
    legs = [p for p in table.parts if p.z_min_m == 0]
    assert len(legs) == 4 and all(p.z_max_m < 0.75 for p in legs)
    shelf = make_obstacle("bookshelf", oriented_rect([0, 0], 1.5, 0.35), height_m=1.8)
    full_height = [p for p in shelf.parts if p.z_min_m == 0 and p.z_max_m == pytest.approx(1.8)]
    assert len(full_height) >= 2 + 1 + 3  # sides, back, >= 3 dividers
    chair = make_obstacle("chair", oriented_rect([0, 0], 0.45, 0.45))
    assert len(chair.parts) == 6
    for ob in (table, shelf, chair):
        union = unary_union([Polygon(p.footprint) for p in ob.parts])
        assert union.difference(ob.polygon).area < 1e-9  # parts lie inside the collision outline
        assert ob.polygon.area == pytest.approx(union.convex_hull.area, rel=1e-6)


def test_default_map_shows_a_bookshelf_and_a_doubtful_gap_from_the_start() -> None:
    scene = load_scenario("default")
    assert scene.name == "default" and "default" in available_maps()
    rig = StereoRig()
    x, y, heading = scene.start
    head = HeadPose(x_m=x, y_m=y, heading_rad=heading, height_m=0.8)

    def in_view(p: np.ndarray) -> tuple[bool, float]:
        P = head.world_to_cam([p[0], p[1], 0.5])
        return bool(rig.in_image(rig.project(P)[0])[0]), float(P[0, 2])

    shelf = [ob for ob in scene.obstacles if ob.kind is ObstacleKind.BOOKSHELF]
    assert shelf and in_view(shelf[0].footprint.mean(axis=0))[0]
    seen = [in_view((g.point_i + g.point_j) / 2) for g in scene.doubtful_gaps(W)]
    assert any(visible and 3.0 <= depth <= 6.0 for visible, depth in seen)
    assert scene.route_exists(W)


def test_json_round_trip(tmp_path: pathlib.Path) -> None:
    scene = generate_scene(2, family="office")
    path = save_map(scene, tmp_path / "m.json")
    back = load_map(path)
    assert scene_to_json(back) == scene_to_json(scene)
    for a, b in zip(scene.obstacles, back.obstacles, strict=True):
        assert a.kind is b.kind and len(a.parts) == len(b.parts)
        np.testing.assert_allclose(a.footprint, b.footprint, atol=1e-6)
    # custom parts survive too
    data = scene_to_json(_two_boxes(0.4))
    data["obstacles"][0]["parts"] = [
        {"footprint": [[0.5, 1.5], [1.5, 1.5], [1.5, 2.5]], "z": [0.1, 0.3]}
    ]
    scene2 = scene_from_json(data)
    assert len(scene2.obstacles[0].parts) == 1
    assert scene_to_json(scene2)["obstacles"][0]["parts"][0]["z"] == [0.1, 0.3]


def _bad(mutate: Callable[[Any], object]) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(json.dumps(scene_to_json(load_scenario("default"))))
    mutate(data)
    return data


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (
            lambda d: d["obstacles"][2].__setitem__("footprint", [[0, 0], [1, 1]]),
            r"obstacles\[2\]\.footprint",
        ),
        (lambda d: d["obstacles"][1].__setitem__("kind", "sofa"), r"obstacles\[1\]\.kind"),
        (lambda d: d["obstacles"][0].__setitem__("height", -1), r"obstacles\[0\]\.height"),
        (lambda d: d["obstacles"][3].__setitem__("color", [2, 0, 0]), r"obstacles\[3\]\.color"),
        (
            lambda d: d["obstacles"][4].__setitem__(
                "parts", [{"footprint": [[0, 0], [1, 0], [0, 1]], "z": [1, 0]}]
            ),
            r"obstacles\[4\]\.parts\[0\]\.z",
        ),
        (
            lambda d: d["obstacles"][0].__setitem__("footprint", [[0, 0], [1, 1], [1, 0], [0, 1]]),
            r"obstacles\[0\]\.footprint",
        ),
        (lambda d: d.__setitem__("bounds", [0, 0, -1, 5]), "bounds"),
        (lambda d: d.__setitem__("start", [1, 2]), "start"),
        (lambda d: d.__setitem__("goal", [100, 2]), "goal"),
        (lambda d: d.pop("obstacles"), "obstacles"),
        (lambda d: d.__setitem__("format", "other/2"), "format"),
        (lambda d: d.__setitem__("colour", 1), "unknown keys"),
    ],
)
def test_malformed_maps_name_the_field(mutate: Callable[[Any], object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        scene_from_json(_bad(mutate))


def test_load_map_rejects_bad_json(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_map(path)
    with pytest.raises(ValueError, match="scenario"):
        load_scenario("nowhere")


def test_scene_validation() -> None:
    base = scene_to_json(load_scenario("two_gaps"))
    assert copy.deepcopy(base) == base
    with pytest.raises(ValueError, match="start"):
        Scene(name="x", bounds=(0, 0, 1, 1), obstacles=(), start=(5, 5, 0), goal=(0.5, 0.5))
    with pytest.raises(ValueError, match="robot_width_m"):
        load_scenario("default").route_exists(-1.0)
