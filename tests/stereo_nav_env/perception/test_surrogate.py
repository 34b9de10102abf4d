"""The surrogate perception: the visibility sweep, ambiguous shelf fronts, the depth growth of
the covariances, determinism, the configuration field, and that it renders nothing."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.stereo.matching import match_candidates, match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments
from modeling.stereo.triangulation import triangulate_to_floor
from stereo_nav_env.config import EnvConfig
from stereo_nav_env.env import StereoNavEnv
from stereo_nav_env.perception.surrogate._kernels.segments import piece_fits
from stereo_nav_env.perception.surrogate.floor import (
    floor_hidden,
    floor_hidden_reference,
    visible_floor_lines,
    visible_floor_lines_reference,
)
from stereo_nav_env.perception.surrogate.rates import EDGE_CLASSES, SurrogateRates, default_rates
from stereo_nav_env.perception.surrogate.sensor import (
    perceive_surrogate,
    piece_fits_reference,
    surrogate_segments,
    surrogate_segments_reference,
)
from stereo_nav_env.perception.surrogate.visibility import (
    SceneEdges,
    seen_runs,
    seen_runs_reference,
    visible_edges,
    visible_edges_reference,
)
from stereo_nav_env.sim.scenes import BoxPart, Obstacle, ObstacleKind, Scene, generate_scene
from stereo_nav_env.sim.scenes.parts import make_obstacle, oriented_rect

RIG = StereoRig()
HEAD = HeadPose(x_m=0.5, y_m=2.5, heading_rad=0.0, height_m=0.8)
BINS = (0.0, 100.0)
EXACT = SurrogateRates(  # every edge imaged in both images, nothing false: the error model alone
    depth_bins_m=BINS,
    detection={name: ((1.0, 0.0, 0.0),) for name in EDGE_CLASSES},
    false_match_rate=(0.0,),
    false_error_px=(2.0,),
    error_scale=1.0,
    end_loss_px=0.0,
)


def _scene(*obstacles: Obstacle) -> Scene:
    return Scene(
        name="test",
        bounds=(0.0, 0.0, 10.0, 5.0),
        obstacles=obstacles,
        start=(0.5, 2.5, 0.0),
        goal=(9.0, 2.5),
    )


def _box(x: float, y: float, size: float, height: float) -> Obstacle:
    return make_obstacle(ObstacleKind.BOX, oriented_rect([x, y], size, size), height)


def _visible(scene: Scene) -> tuple[SceneEdges, np.ndarray]:
    edges = SceneEdges.of(scene)
    vis = visible_edges(edges, HEAD, RIG, trim_px=2, min_length_px=12.0)
    return edges, vis


def _random_heads(
    family: str, rng: np.random.Generator, per_scene: int
) -> Iterator[tuple[Scene, SceneEdges, int, HeadPose]]:
    """``(scene, edges, trial, head)``: ``per_scene`` heads drawn from ``rng`` anywhere in each of
    three seeded scenes of ``family`` (drawn lazily: the caller's draws between them stay in
    order)."""
    for seed in range(3):
        scene = generate_scene(seed, family=family)
        edges = SceneEdges.of(scene)
        x0, y0, x1, y1 = scene.bounds
        for trial in range(per_scene):
            head = HeadPose(
                x_m=rng.uniform(x0, x1),
                y_m=rng.uniform(y0, y1),
                heading_rad=rng.uniform(-math.pi, math.pi),
                height_m=rng.uniform(0.5, 1.2),
            )
            yield scene, edges, trial, head


def test_the_sweep_hides_what_is_behind_a_box() -> None:
    front = _box(3.0, 2.5, 0.6, 0.7)
    behind = _box(6.0, 2.5, 0.4, 0.5)  # lower than the sight lines over the front box allow
    edges, vis = _visible(_scene(front, behind))
    _, alone = _visible(_scene(behind))
    hidden = {4, 5, 6, 7}  # the corners of the box behind (the second obstacle)
    assert len(alone) >= 2 and set(alone.corner.tolist()) <= {0, 1, 2, 3}
    assert not hidden & set(vis.corner.tolist())
    # the front box's two front corners (x = 2.7) are seen whole, from the floor up to 0.7 m
    seen_front = vis.corner[edges.corner_xy[vis.corner, 0] < 2.8]
    assert len(seen_front) == 2


def test_a_tall_edge_behind_a_box_is_seen_above_the_sight_line_over_it() -> None:
    front = _box(3.0, 2.5, 0.6, 0.7)
    pillar = _box(6.0, 2.5, 0.2, 2.0)  # front corners at x = 5.9, y = 2.4 and 2.6
    edges, vis = _visible(_scene(front, pillar))
    k = np.flatnonzero(np.all(np.isclose(edges.corner_xy[vis.corner], [5.9, 2.4]), axis=1))
    assert k.size == 1
    # the sight line leaves the box (x = 3.3) at t1 = 2.8 / 5.4 of the way: the heights below
    # Hh + (0.7 - Hh) / t1 are hidden
    t1 = (3.3 - 0.5) / (5.9 - 0.5)
    assert vis.z_low[k[0]] == pytest.approx(0.8 + (0.7 - 0.8) / t1, abs=1e-9)
    # its top (2 m) is below the image's first rows there (3.24 m at 5.4 m): seen up to the top
    assert vis.z_high[k[0]] == 2.0


def _shelf_scene() -> Scene:
    # the front (first side) faces -y, towards a head looking along -y from 2.5 m away
    shelf = make_obstacle(ObstacleKind.BOOKSHELF, oriented_rect([5.0, 4.0], 1.8, 0.35, 0.0))
    return _scene(shelf)


def test_a_bookshelf_front_gives_ambiguous_candidates_with_the_true_one_among_them() -> None:
    scene = _shelf_scene()
    head = HeadPose(x_m=5.0, y_m=1.3, heading_rad=math.pi / 2, height_m=0.8)
    model = perceive_surrogate(
        SceneEdges.of(scene),
        RIG,
        head,
        np.random.default_rng(0),
        robot_width_m=0.5,
        robot_height_m=1.0,
        eps=0.05,
        max_situations=64,
        rates=SurrogateRates(**{**_fields(EXACT), "error_scale": 1e-6}),  # the means exact
    )
    ambiguous = model.observation.ambiguous
    whole = [amb for amb in ambiguous if amb.p_none == 0.0]  # every candidate in the band
    assert len(whole) >= 2
    corners = np.vstack([p.footprint for p in scene.obstacles[0].parts])
    for amb in ambiguous:
        # the true candidate: both floor points on a corner of a shelf side or divider
        dist = [
            np.linalg.norm(c.endpoints[:, None] - corners[None], axis=-1).min(axis=1).max()
            for c in amb.candidates
        ]
        assert max(dist) > 0.3  # the others stand at the other dividers' disparities
        if amb.p_none == 0.0:  # (else the true one may be what left the height band)
            assert len(amb.candidates) >= 2 and math.isclose(sum(amb.probabilities), 1.0)
            assert min(dist) < 0.005
    assert len(model.situations) > 1


@pytest.mark.parametrize("depth_m", [2.0, 4.0])
def test_covariances_grow_with_depth_as_the_triangulation_error_model(depth_m: float) -> None:
    # a prism floating in the height band (0.2 to 0.6 m): no band clip, nothing hides it
    part = BoxPart(
        footprint=oriented_rect([0.5 + depth_m + 0.1, 2.5], 0.2, 0.2),
        z_min_m=0.2,
        z_max_m=0.6,
        color=(0.5, 0.5, 0.5),
    )
    ob = Obstacle(
        kind=ObstacleKind.BOX,
        footprint=part.footprint,
        height_m=0.6,
        color=(0.5, 0.5, 0.5),
        parts=(part,),
    )
    left, right = surrogate_segments(
        SceneEdges.of(_scene(ob)), RIG, HEAD, np.random.default_rng(1), EXACT
    )
    assert len(left) == 2  # the two front corners at depth ``depth_m``
    matches = match_segments(left, right, RIG)
    floor = triangulate_to_floor(matches, RIG, HEAD)
    assert len(floor.segments) == 2
    for seg in floor.segments:
        i = seg.source
        v = left.endpoints[i, :, 1]
        var_d = left.u_var_at(np.array([i, i]), v) + right.u_var_at(np.array([i, i]), v)
        # the head looks along +x: the depth variance is (Z^2 / (f b))^2 var_d exactly
        Z = seg.endpoints[:, 0] - HEAD.x_m
        assert np.allclose(seg.cov[:, 0, 0], (Z**2 / RIG.fb) ** 2 * var_d, rtol=1e-9)
        # and the drawn depths are errors of that size (within 3 standard deviations)
        assert np.all(np.abs(Z - depth_m) < 3.0 * np.sqrt(seg.cov[:, 0, 0]))


def test_the_same_seed_gives_the_same_surrogate_rollout_and_another_seed_another() -> None:
    def rollout(seed: int) -> list[object]:
        env = gym.make("StereoNav-v0", perception="surrogate")
        obs, _ = env.reset(seed=seed)
        out: list[object] = [obs["raster"].tobytes()]
        for i in range(30):
            obs, reward, *_, info = env.step(np.array([0.4, 0.2, math.sin(i / 4)], np.float32))
            out += [
                obs["raster"].tobytes(),
                obs["critical_regions"].tobytes(),
                reward,
                info["model"],
                info["diagnostics"],
            ]
        env.close()
        return out

    a, b, c = rollout(3), rollout(3), rollout(4)
    assert all(x == y for x, y in zip(a, b, strict=True))
    assert any(x != y for x, y in zip(a, c, strict=True))  # the noise comes from np_random


def test_the_surrogate_makes_no_renderer_and_keeps_the_spaces() -> None:
    stereo = gym.make("StereoNav-v0")
    env = gym.make("StereoNav-v0", perception="surrogate")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    base = env.unwrapped
    assert isinstance(base, StereoNavEnv)
    assert base.perception._renderer is None  # no OpenGL context was made
    assert base.perception.stereo_pair() is None
    assert env.observation_space == stereo.observation_space
    assert env.action_space == stereo.action_space
    with pytest.raises(RuntimeError, match="surrogate"):
        base.render_stereo()
    env.close()
    stereo.close()


def test_perception_is_a_validated_config_field() -> None:
    assert EnvConfig().perception == "stereo"
    with pytest.raises(ValueError, match="perception"):
        EnvConfig.from_kwargs(perception="lidar")
    with pytest.raises(ValueError, match="observation_mode"):
        EnvConfig.from_kwargs(perception="surrogate", observation_mode="images")
    assert EnvConfig().ground_lines is False
    assert EnvConfig.from_kwargs(perception="surrogate", ground_lines=True).ground_lines
    with pytest.raises(ValueError, match="ground_lines"):
        EnvConfig.from_kwargs(perception="truth", ground_lines=True)
    with pytest.raises(ValueError, match="ground_lines"):
        EnvConfig.from_kwargs(ground_lines="yes")


def test_the_packaged_rates_are_valid_and_bad_rates_are_value_errors() -> None:
    rates = default_rates()
    assert set(rates.detection) == set(EDGE_CLASSES)
    assert all(len(rows) == len(rates.depth_bins_m) - 1 for rows in rates.detection.values())
    assert rates.error_scale > 0 and rates.end_loss_px >= 0
    with pytest.raises(ValueError, match=r"detection\['chair'\]"):
        SurrogateRates(
            **{**_fields(EXACT), "detection": {**EXACT.detection, "chair": ((1.5, 0, 0),)}}
        )
    with pytest.raises(ValueError, match=r"detection\['box_crease'\]"):  # more than certain
        bad = {**EXACT.detection, "box_crease": ((0.6, 0.3, 0.2),)}
        SurrogateRates(**{**_fields(EXACT), "detection": bad})
    with pytest.raises(ValueError, match="detection must map"):
        SurrogateRates(**{**_fields(EXACT), "detection": {"wall": ((1.0, 0.0, 0.0),)}})
    with pytest.raises(ValueError, match="end_loss_px"):
        SurrogateRates(**{**_fields(EXACT), "end_loss_px": -1.0})
    with pytest.raises(ValueError, match="depth_bins_m"):
        SurrogateRates(**{**_fields(EXACT), "depth_bins_m": (2.0, 1.0)})


def _fields(rates: SurrogateRates) -> dict[str, object]:
    return {f.name: getattr(rates, f.name) for f in dataclasses.fields(SurrogateRates) if f.init}


def _leg(x: float, y: float) -> BoxPart:
    return BoxPart(
        footprint=oriented_rect([x, y], 0.05, 0.05), z_min_m=0.0, z_max_m=0.45, color=LEG_COLOR
    )


LEG_COLOR = (0.22, 0.18, 0.15)


def _legs_and_wall(wall_y: tuple[float, float]) -> Scene:
    """Two identical legs of one chair 2 m ahead (y = 2.3 and 2.7), a wall panel just behind
    them spanning ``wall_y``."""
    legs = (_leg(2.5, 2.3), _leg(2.5, 2.7))
    chair = Obstacle(
        kind=ObstacleKind.CHAIR,
        footprint=oriented_rect([2.5, 2.5], 0.05, 0.45),
        height_m=0.45,
        color=LEG_COLOR,
        parts=legs,
    )
    lo, hi = wall_y
    wall = make_obstacle(ObstacleKind.WALL, oriented_rect([2.7, (lo + hi) / 2], 0.1, hi - lo), 2.0)
    return _scene(chair, wall)


def _columns(edges: SceneEdges, vis: object, part: int, image: int) -> np.ndarray:
    sel = edges.corner_part[vis.corner] == part  # type: ignore[attr-defined]
    u = vis.u[sel] - image * RIG.fb / vis.Z[sel]  # type: ignore[attr-defined]
    return np.asarray(u)


@pytest.mark.parametrize(("wall_y", "look_alike"), [((2.1, 2.9), True), ((2.1, 2.45), False)])
def test_identical_legs_look_alike_only_in_front_of_the_same_background(
    wall_y: tuple[float, float], look_alike: bool
) -> None:
    # the matcher pairs the left leg's (y = 2.3, right in the image) outlines with the other
    # leg's right-image outlines when both stand in front of the wall, not when the other one
    # stands in front of the floor: what lies beside an edge decides what it can be taken for
    edges, vis = _visible(_legs_and_wall(wall_y))
    left, right = surrogate_segments(edges, RIG, HEAD, np.random.default_rng(0), EXACT)
    a_cols = _columns(edges, vis, 0, 0)
    b_cols = _columns(edges, vis, 1, 1)
    assert a_cols.size >= 2 and b_cols.size >= 2
    cand = match_candidates(left, right, RIG)
    of_a = np.min(np.abs(left.u_center[cand.left_index, None] - a_cols[None]), axis=1) < 1.0
    to_b = np.min(np.abs(right.u_center[cand.right_index, None] - b_cols[None]), axis=1) < 1.0
    assert bool(np.any(of_a & to_b)) is look_alike
    # each leg matches itself in both cases
    own = np.min(np.abs(right.u_center[cand.right_index, None] - _columns(edges, vis, 0, 1)), 1)
    assert np.any(of_a & (own < 1.0))


def test_creases_and_outlines_take_their_own_detection_rates() -> None:
    # a box seen corner-on shows two outlines and its front corner, a crease between two faces
    box = make_obstacle(ObstacleKind.BOX, oriented_rect([3.0, 2.5], 0.5, 0.5, math.pi / 4), 0.6)
    edges, vis = _visible(_scene(box))
    assert sorted(vis.crease.tolist()) == [False, False, True]
    front = vis.u[vis.crease][0]
    no_crease = SurrogateRates(
        **{**_fields(EXACT), "detection": {**EXACT.detection, "box_crease": ((0.0, 0.0, 0.0),)}}
    )
    left, right = surrogate_segments(edges, RIG, HEAD, np.random.default_rng(0), no_crease)
    assert left.u_center.size >= 2 and right.u_center.size >= 2
    assert np.all(np.abs(left.u_center - front) > 5.0)  # nothing at the crease
    left_all, _ = surrogate_segments(edges, RIG, HEAD, np.random.default_rng(0), EXACT)
    assert np.any(np.abs(left_all.u_center - front) < 1.0)


def test_rates_at_depth_take_the_bin_clipped_to_the_first_and_last() -> None:
    two_bins = {
        "depth_bins_m": (1.0, 2.0, 4.0),
        "detection": {name: ((0.5, 0.25, 0.0), (0.1, 0.0, 0.2)) for name in EDGE_CLASSES},
        "false_match_rate": (0.1, 0.3),
    }
    rates = SurrogateRates(**{**_fields(EXACT), **two_bins})
    depths = np.array([0.5, 1.0, 1.99, 2.0, 3.0, 4.0, 9.0])
    assert rates.depth_bin(depths).tolist() == [0, 0, 0, 1, 1, 1, 1]
    assert rates.false_rate_at(depths).tolist() == [0.1] * 3 + [0.3] * 4
    p = rates.detection_at(np.zeros(7, dtype=np.int64), depths)
    assert p.tolist() == [[0.5, 0.25, 0.0]] * 3 + [[0.1, 0.0, 0.2]] * 4


def test_an_edge_imaged_in_one_image_only_gives_a_segment_there_only() -> None:
    edges, _ = _visible(_scene(_box(3.0, 2.5, 0.5, 0.6)))
    counts = []
    for rates_of_class in ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)):
        detection = {name: (rates_of_class,) for name in EDGE_CLASSES}
        rates = SurrogateRates(**{**_fields(EXACT), "detection": detection})
        left, right = surrogate_segments(edges, RIG, HEAD, np.random.default_rng(0), rates)
        counts.append((left.u_center.size > 0, right.u_center.size > 0))
    assert counts == [(True, False), (False, True), (False, False)]


def test_segments_stop_the_end_loss_short_of_the_seen_run() -> None:
    box = _box(3.0, 2.5, 0.6, 0.7)
    edges, vis = _visible(_scene(box))
    short = SurrogateRates(**{**_fields(EXACT), "end_loss_px": 3.0})
    for rates, loss in ((EXACT, 0.0), (short, 3.0)):
        left, _ = surrogate_segments(edges, RIG, HEAD, np.random.default_rng(0), rates)
        assert left.endpoints.shape[0] == len(vis) == 2
        order = np.argsort(left.u_center)
        np.testing.assert_allclose(left.endpoints[order, 0, 1], vis.v_top[np.argsort(vis.u)] + loss)
        np.testing.assert_allclose(
            left.endpoints[order, 1, 1], vis.v_bottom[np.argsort(vis.u)] - loss
        )


@pytest.mark.parametrize("family", ["office", "cluttered", "room", "corridor"])
def test_the_compiled_sweep_equals_its_numpy_reference(family: str) -> None:
    rng = np.random.default_rng(7)
    hidden = runs_cut = 0
    for scene, edges, _, head in _random_heads(family, rng, 20):
        x0, y0, x1, y1 = scene.bounds
        every = np.arange(edges.corner_xy.shape[0])
        low = edges.corner_z[:, 0] - rng.uniform(0.0, 0.2, every.size)
        high = edges.corner_z[:, 1] + rng.uniform(0.0, 0.2, every.size)
        got, want = (
            seen_runs(edges, head, every, low, high),
            seen_runs_reference(edges, head, every, low, high),
        )
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        runs_cut += int(np.count_nonzero(want[1] - want[0] < high - low))
        points = np.c_[rng.uniform(x0, x1, 40), rng.uniform(y0, y1, 40)]
        mask = floor_hidden(edges, head, points)
        assert np.array_equal(mask, floor_hidden_reference(edges, head, points))
        hidden += int(mask.sum())
    assert runs_cut > 0 and hidden > 0  # the poses do see parts hide one another


@pytest.mark.parametrize("family", ["office", "cluttered", "room", "corridor"])
def test_the_compiled_floor_lines_equal_their_numpy_reference(family: str) -> None:
    rng = np.random.default_rng(11)
    lines = 0
    for _scene, edges, trial, head in _random_heads(family, rng, 30):
        corners = (  # every corner, or those the head sees (a face joins only those)
            np.arange(edges.corner_xy.shape[0])
            if trial % 2
            else visible_edges(edges, head, RIG, trim_px=2.0, min_length_px=10.0).corner
        )
        for samples in (1, 5):
            got = visible_floor_lines(edges, head, RIG, corners, samples=samples, max_range_m=5.0)
            want = visible_floor_lines_reference(
                edges, head, RIG, corners, samples=samples, max_range_m=5.0
            )
            assert got.shape == want.shape and np.array_equal(got, want)
            lines += want.shape[0]
    assert lines > 0
    none = visible_floor_lines(edges, HEAD, RIG, np.zeros(0, np.int64), max_range_m=5.0)
    assert none.shape == (0, 2, 2)


def test_the_surrogate_segments_are_what_image_segments_checks_would_make() -> None:
    # they skip ImageSegments' conversions and checks: those must leave them unchanged
    found = 0
    for seed in range(3):
        scene = generate_scene(seed, family="office")
        edges = SceneEdges.of(scene)
        x, y, heading = scene.start
        head = HeadPose(x_m=x, y_m=y, heading_rad=heading, height_m=0.8)
        for image in surrogate_segments(edges, RIG, head, np.random.default_rng(seed), EXACT):
            fields = {f.name: getattr(image, f.name) for f in dataclasses.fields(image)}
            checked = ImageSegments(**fields)
            for name, value in fields.items():
                if isinstance(value, np.ndarray):
                    again = getattr(checked, name)
                    same = again.dtype == value.dtype and again.shape == value.shape
                    kept = value.size == 0 or np.shares_memory(again, value)
                    assert same and kept, name  # no conversion
                    assert value.flags.c_contiguous and not value.flags.writeable, name
            assert checked.image_shape == image.image_shape == (RIG.height_px, RIG.width_px)
            found += len(image)
    assert found > 0


@pytest.mark.parametrize("family", ["office", "cluttered", "room", "corridor"])
def test_the_compiled_edge_search_equals_its_numpy_reference(family: str) -> None:
    rng = np.random.default_rng(13)
    seen = creases = 0
    for _scene, edges, _, head in _random_heads(family, rng, 30):
        got = visible_edges(edges, head, RIG, trim_px=2.0, min_length_px=10.0)
        want = visible_edges_reference(edges, head, RIG, trim_px=2.0, min_length_px=10.0)
        for f in dataclasses.fields(want):
            a, b = getattr(got, f.name), getattr(want, f.name)
            assert a.dtype == b.dtype and np.array_equal(a, b), f.name
        seen += len(want)
        creases += int(want.crease.sum())
    assert seen > 0 and creases > 0


def test_the_compiled_piece_fits_equal_their_numpy_reference() -> None:
    rng = np.random.default_rng(5)
    for m in (0, 1, 7, 40):
        top = rng.uniform(0.0, 200.0, m)
        bottom = top + rng.uniform(3.0, 80.0, m)
        centre = rng.uniform(0.0, 320.0, m)
        draw = rng.standard_normal((3, m)) * 1.3
        got = piece_fits(top, bottom, centre, draw, 0.25, 0.04)
        want = piece_fits_reference(top, bottom, centre, draw, 0.25, 0.04)
        for a, b in zip(got, want, strict=True):
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
    # the errors' scale follows the fit: more rows, a smaller offset's and slope's variance
    ends, u_c, v_c, slope, *_ = piece_fits_reference(
        np.zeros(2), np.array([9.0, 99.0]), np.zeros(2), np.ones((3, 2)), 1.0, 0.0
    )
    assert np.allclose(u_c, [1.0 / math.sqrt(10.0), 0.1])
    assert np.allclose(slope, [1.0 / math.sqrt(82.5), 1.0 / math.sqrt(83325.0)])
    assert np.allclose(ends[:, :, 1], [[0.0, 9.0], [0.0, 99.0]]) and np.allclose(v_c, [4.5, 49.5])


LOSSY = SurrogateRates(  # every outcome and false matches often: all the branches taken
    depth_bins_m=(0.0, 2.0, 4.0, 100.0),
    detection={
        name: ((0.5, 0.15, 0.15), (0.6, 0.1, 0.1), (0.3, 0.2, 0.2)) for name in EDGE_CLASSES
    },
    false_match_rate=(0.3, 0.5, 0.7),
    false_error_px=(1.5, 3.0, 7.0),
    error_scale=1.7,
    end_loss_px=1.0,
)


@pytest.mark.parametrize("family", ["office", "cluttered", "room", "corridor"])
def test_the_compiled_surrogate_segments_equal_their_numpy_reference(family: str) -> None:
    heads = np.random.default_rng(17)
    one_sided = segments = 0
    for _scene, edges, trial, head in _random_heads(family, heads, 25):
        rates = LOSSY if trial % 2 else default_rates()
        got_rng, want_rng = np.random.default_rng(trial), np.random.default_rng(trial)
        got = surrogate_segments(edges, RIG, head, got_rng, rates)
        want = surrogate_segments_reference(edges, RIG, head, want_rng, rates)
        for a, b in zip(got, want, strict=True):
            assert a.image_shape == b.image_shape
            for f in dataclasses.fields(b):
                x, y = getattr(a, f.name), getattr(b, f.name)
                if isinstance(y, np.ndarray):
                    assert x.dtype == y.dtype and x.shape == y.shape, f.name
                    assert np.array_equal(x, y) and x.flags.c_contiguous, f.name
        # the same draws, in the same order: the generators end in the same state
        assert got_rng.bit_generator.state == want_rng.bit_generator.state
        one_sided += len(want[0]) != len(want[1])
        segments += len(want[0])
    assert segments > 0 and one_sided > 0
