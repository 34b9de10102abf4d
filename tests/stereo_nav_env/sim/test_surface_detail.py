"""Surface detail as data of the scene: generation, validation, determinism (issue 42)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from shapely.geometry import Polygon

from stereo_nav_env.sim.scenes import (
    STANDARD_FAMILIES,
    DetailKind,
    FaceFeature,
    ObstacleKind,
    add_surface_detail,
    generate_scene,
    load_map,
    load_scenario,
    make_obstacle,
    oriented_rect,
    plain_surfaces,
    save_map,
    scene_from_json,
    scene_to_json,
)

SEAM = {
    "kind": "seam",
    "face": 0,
    "offset_m": 0.5,
    "width_m": 0.02,
    "z_min_m": 0.0,
    "z_max_m": 0.7,
    "color": (0.3, 0.3, 0.3),
}


def _features(scene):  # -> list of (obstacle kind, feature)
    return [(ob.kind, f) for ob in scene.obstacles for f in ob.detail]


@pytest.mark.parametrize("family", STANDARD_FAMILIES)
def test_detail_is_deterministic_per_seed(family: str) -> None:
    a = _features(load_scenario(family, 17, surface_detail=True))
    b = _features(load_scenario(family, 17, surface_detail=True))
    c = _features(load_scenario(family, 18, surface_detail=True))
    assert a and a == b
    assert a != c


def test_detail_leaves_the_scene_itself_alone() -> None:
    plain = generate_scene(9, family="office")
    detailed = add_surface_detail(plain, 9)
    assert detailed.bounds == plain.bounds and detailed.start == plain.start
    for p, d in zip(plain.obstacles, detailed.obstacles, strict=True):
        np.testing.assert_array_equal(p.footprint, d.footprint)
        assert p.parts == d.parts and p.height_m == d.height_m
        assert len(d.detail_parts) == len(d.detail)
    assert all(not ob.detail for ob in plain_surfaces(detailed).obstacles)
    assert plain_surfaces(plain) is plain


def test_kinds_suit_the_faces() -> None:
    kinds: dict[ObstacleKind, set[DetailKind]] = {}
    for family in STANDARD_FAMILIES:
        for seed in range(4):
            for kind, f in _features(load_scenario(family, seed, surface_detail=True)):
                kinds.setdefault(kind, set()).add(f.kind)
    assert kinds[ObstacleKind.WALL] == {DetailKind.SEAM, DetailKind.DOOR_FRAME}
    assert kinds[ObstacleKind.BOX] == {DetailKind.SEAM, DetailKind.FRONT}
    assert kinds[ObstacleKind.BOOKSHELF] == {DetailKind.SPINE}
    assert ObstacleKind.TABLE not in kinds and ObstacleKind.CHAIR not in kinds


def test_strips_sit_on_their_faces() -> None:
    scene = load_scenario("room", 4, surface_detail=True)
    for ob in scene.obstacles:
        body = Polygon(ob.footprint)
        for f, part in zip(ob.detail, ob.detail_parts, strict=True):
            strip = Polygon(part.footprint)
            assert strip.is_valid and strip.area > 0
            if f.kind is DetailKind.SPINE:  # a book stands inside its shelf
                assert body.contains(strip)
            else:  # a strip is on the face: at most a few mm outside the footprint
                assert body.buffer(0.0031).contains(strip)
                assert strip.intersects(body.exterior)


def test_walls_get_detail_only_inside_the_room() -> None:
    scene = load_scenario("open", 2, surface_detail=True)
    x0, y0, x1, y1 = scene.bounds
    for ob in scene.obstacles:
        for part in ob.detail_parts:
            c = part.footprint.mean(axis=0)
            assert x0 < c[0] < x1 and y0 < c[1] < y1


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"kind": "poster"}, "kind"),
        ({"face": -1}, "face"),
        ({"face": 1.5}, "face"),
        ({"width_m": 0.0}, "width_m"),
        ({"offset_m": float("nan")}, "offset_m"),
        ({"z_min_m": 0.8, "z_max_m": 0.2}, "z_min_m/z_max_m"),
        ({"color": (1.2, 0.0, 0.0)}, "color"),
    ],
)
def test_feature_validation_names_the_field(change: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        FaceFeature(**{**SEAM, **change})


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"face": 4}, r"detail\[0\]\.face"),
        ({"offset_m": 0.995}, r"detail\[0\]\.offset_m/width_m"),
        ({"offset_m": 0.005}, r"detail\[0\]\.offset_m/width_m"),
        ({"z_max_m": 0.9}, r"detail\[0\]\.z_max_m"),
    ],
)
def test_obstacle_validation_names_the_feature(change: dict, message: str) -> None:
    ob = make_obstacle("box", oriented_rect([0, 0], 1.0, 0.5), height_m=0.8)
    with pytest.raises(ValueError, match=message):
        type(ob)(
            kind=ob.kind,
            footprint=ob.footprint,
            height_m=ob.height_m,
            color=ob.color,
            parts=ob.parts,
            detail=(FaceFeature(**{**SEAM, **change}),),
        )


# ------------------------------------------------------------------------------ map format
def test_map_round_trip_keeps_the_detail(tmp_path) -> None:
    scene = load_scenario("room", 6, surface_detail=True)
    path = save_map(scene, tmp_path / "room.json")
    back = load_map(path)
    assert _features(back) == _features(scene)
    for a, b in zip(scene.obstacles, back.obstacles, strict=True):
        for pa, pb in zip(a.detail_parts, b.detail_parts, strict=True):
            np.testing.assert_allclose(pa.footprint, pb.footprint, atol=1e-6)
    assert "detail" not in json.dumps(scene_to_json(plain_surfaces(scene)))


def test_a_maps_detail_follows_the_switch(tmp_path) -> None:
    scene = load_scenario("room", 6, surface_detail=True)
    path = str(save_map(scene, tmp_path / "room.json"))
    assert _features(load_scenario(path, surface_detail=True)) == _features(scene)
    assert not _features(load_scenario(path))  # off: plain faces
    bundled = load_scenario("two_gaps", surface_detail=True)  # lists none: drawn from its name
    assert _features(bundled) and _features(bundled) == _features(
        load_scenario("two_gaps", surface_detail=True)
    )
    assert not _features(load_scenario("two_gaps"))


def _map_with(detail: object) -> dict:
    box = {"kind": "box", "rect": {"center": [2.0, 2.0], "size": [1.0, 0.5]}, "detail": detail}
    return {"bounds": [0, 0, 5, 4], "start": [0.5, 0.5, 0], "goal": [4.5, 3.5], "obstacles": [box]}


GOOD = {"kind": "seam", "face": 0, "offset": 0.5, "width": 0.02, "z": [0, 0.7], "color": [0, 0, 0]}


@pytest.mark.parametrize(
    ("detail", "message"),
    [
        ("seams", r"obstacles\[0\]\.detail must be a list"),
        ([{**GOOD, "kind": "poster"}], r"obstacles\[0\]\.detail\[0\]\.kind must be one of"),
        ([{**GOOD, "face": -1}], r"obstacles\[0\]\.detail\[0\]\.face must be a non-negative"),
        ([{**GOOD, "face": 7}], r"obstacles\[0\]\.detail\[0\]\.face must be a side"),
        ([{**GOOD, "width": 0}], r"obstacles\[0\]\.detail\[0\]\.width must be positive"),
        ([{**GOOD, "offset": 0.999}], r"obstacles\[0\]\.detail\[0\]\.offset_m/width_m"),
        ([{**GOOD, "z": [0.5, 0.1]}], r"obstacles\[0\]\.detail\[0\]\.z must satisfy"),
        ([{**GOOD, "z": [0.0, 3.0]}], r"obstacles\[0\]\.detail\[0\]\.z_max_m must not exceed"),
        ([{**GOOD, "color": [2, 0, 0]}], r"obstacles\[0\]\.detail\[0\]\.color"),
        ([{**GOOD, "depth": 1}], r"obstacles\[0\]\.detail\[0\] has unknown keys \['depth'\]"),
        ([{k: v for k, v in GOOD.items() if k != "z"}], r"detail\[0\]\.z is missing"),
    ],
)
def test_map_validation_rejects_bad_detail(detail: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        scene_from_json(_map_with(detail))


def test_map_detail_has_a_limit() -> None:
    with pytest.raises(ValueError, match=r"detail has 513 features, more than the limit of 512"):
        scene_from_json(_map_with([GOOD] * 513))
