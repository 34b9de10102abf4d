"""The surrogate's ground lines (``ground_lines=True``): the floor contacts of the faces the head
sees, with the stereo's lowest-line rule and error model (``surrogate.sensor`` step 7). Ground
truth: the obstacles' footprints."""

from __future__ import annotations

import os

import numpy as np
import pytest
import shapely

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from modeling.observation import FloorSegment
from modeling.stereo.ground_lines import GROUND_SOURCE, GroundLineOptions, line_ground_segments
from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.config import EnvConfig
from stereo_nav_env.perception.surrogate.floor import visible_ground_lines
from stereo_nav_env.perception.surrogate.sensor import perceive_surrogate, surrogate_ground_lines
from stereo_nav_env.perception.surrogate.visibility import SceneEdges
from stereo_nav_env.sim.scenes import Obstacle, Scene, make_obstacle, oriented_rect

RIG = StereoRig()
HEAD = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
WALL_X = 3.5  # the face-on wall's front, metres ahead of the head
BOX_X = 2.0  # the low box's front


def _wall() -> Obstacle:
    """A wall seen face-on across the whole image (no vertical edge in view), front at
    ``WALL_X``."""
    return make_obstacle(
        "wall", oriented_rect([WALL_X + 0.05, 0.0], 0.1, 12.0, 0.0), color=(0.8, 0.8, 0.75)
    )


def _box(x_front: float, half_width: float, height_m: float) -> Obstacle:
    fp = [[x_front, -half_width], [x_front + 0.6, -half_width]]
    fp += [[x_front + 0.6, half_width], [x_front, half_width]]
    return make_obstacle("box", fp, height_m=height_m, color=(0.55, 0.35, 0.2))


def _scene(*obstacles: Obstacle) -> Scene:
    return Scene(
        name="t", bounds=(-1, -5, 12, 5), obstacles=obstacles, start=(0, 0, 0), goal=(11, 0)
    )


def _ground(scene: Scene, seed: int = 0) -> list[FloorSegment]:
    """The surrogate's ground-line floor segments of ``scene`` seen from ``HEAD``."""
    lines = surrogate_ground_lines(SceneEdges.of(scene), RIG, HEAD, np.random.default_rng(seed))
    return line_ground_segments(lines, RIG, HEAD)


def _normal_sigma(seg: FloorSegment, normal: np.ndarray) -> np.ndarray:
    """(2,) standard deviation of each end along the unit ``normal`` (2,), metres."""
    return np.sqrt(np.einsum("i,kij,j->k", normal, seg.cov, normal))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_face_on_wall_and_a_low_box_give_segments_on_their_true_contacts(seed: int) -> None:
    """Segment stereo measures nothing of a face-on wall; the surrogate's ground lines put it,
    and the low box in front of it, on their true floor contacts within their stated error
    (4 standard deviations across the contact), with the stereo's covariance."""
    scene = _scene(_wall(), _box(BOX_X, 0.4, 0.4))
    added = _ground(scene, seed)
    assert added and all(s.source == GROUND_SOURCE for s in added)
    assert all(np.array_equal(s.height_m, np.zeros(2)) for s in added)
    on_wall = [s for s in added if abs(s.endpoints[:, 0] - WALL_X).max() <= 0.3]
    on_box = [s for s in added if abs(s.endpoints[:, 0] - BOX_X).max() <= 0.3]
    assert len(on_wall) + len(on_box) == len(added)
    # the wall's contact is seen left and right of the box (which hides its middle), ~2.9 m in all
    assert sum(abs(s.endpoints[1, 1] - s.endpoints[0, 1]) for s in on_wall) >= 2.0
    assert on_box and sum(abs(s.endpoints[1, 1] - s.endpoints[0, 1]) for s in on_box) >= 0.6
    for segs, x_true in ((on_wall, WALL_X), (on_box, BOX_X)):
        for s in segs:
            sigma = _normal_sigma(s, np.array([1.0, 0.0]))
            assert (np.abs(s.endpoints[:, 0] - x_true) <= 4.0 * sigma).all()
    # the box (0.4 m high, |y| <= 0.4) hides the wall's contact behind it, over |y| < 0.54 at
    # 3.5 m (the sight lines over its back edge): no wall segment reaches within 0.4 of y = 0
    for s in on_wall:
        assert np.sign(s.endpoints[0, 1]) == np.sign(s.endpoints[1, 1])
        assert np.abs(s.endpoints[:, 1]).min() >= 0.4
    # the depth error grows as Z^2: the wall's (3.5 m) across-contact sigma exceeds the box's (2 m)
    assert min(_normal_sigma(s, np.array([1.0, 0.0])).min() for s in on_wall) > max(
        _normal_sigma(s, np.array([1.0, 0.0])).max() for s in on_box
    )


def test_the_error_drawn_is_the_error_stated() -> None:
    """Over many draws, the ends' errors across the wall's contact have the spread the
    covariance states (normalised errors of standard deviation about 1)."""
    scene = _scene(_wall())
    z = []
    for seed in range(40):
        for s in _ground(scene, seed):
            sigma = _normal_sigma(s, np.array([1.0, 0.0]))
            z.extend(((s.endpoints[:, 0] - WALL_X) / sigma).tolist())
    z_arr = np.array(z)
    assert z_arr.size >= 40
    assert abs(z_arr.mean()) < 0.35
    assert 0.7 < z_arr.std() < 1.3


def test_a_face_hidden_behind_a_tall_box_gives_no_segment() -> None:
    """A wall whose contact a tall box in front hides from the head gives no ground line. (The
    box stands nearer than the image's lowest row reaches, so its own contact is not in the
    image: no lower line drops the wall's; only the occlusion does.)"""
    hidden_wall = make_obstacle(
        "wall", oriented_rect([WALL_X + 0.05, 0.0], 0.1, 1.0, 0.0), color=(0.8, 0.8, 0.75)
    )
    assert EnvConfig().blind_range_m > 1.0
    tall = _box(1.0, 0.8, 1.5)  # hides the floor beyond it over |y| < 0.8 x / 1.6 at least
    assert not _ground(_scene(hidden_wall, tall))
    # alone, the same wall is seen
    assert any(abs(s.endpoints[:, 0] - WALL_X).max() <= 0.3 for s in _ground(_scene(hidden_wall)))


def test_the_lowest_line_rule_keeps_the_nearest_contact_in_each_column() -> None:
    """A short wall's floor contact is seen above a low, wider box's in the image, over the same
    columns: as in the stereo, only the box's (nearer, lower in the image) is kept."""
    short_wall = make_obstacle(
        "wall", oriented_rect([WALL_X + 0.05, 0.0], 0.1, 1.6, 0.0), color=(0.8, 0.8, 0.75)
    )
    low = _box(BOX_X, 1.0, 0.1)  # 0.1 m high: the wall's contact is seen above it
    edges = SceneEdges.of(_scene(short_wall, low))
    lines = visible_ground_lines(edges, HEAD, RIG, max_range_m=5.0)
    wall_row = RIG.principal_point_px[1] + RIG.focal_px * HEAD.height_m / WALL_X
    assert np.isclose(lines[:, :, 1], wall_row).all(axis=1).any()  # the wall's contact is seen
    kept = line_ground_segments(lines, RIG, HEAD)
    assert kept
    assert all(abs(s.endpoints[:, 0] - BOX_X).max() <= 1e-6 for s in kept)


def test_ground_lines_off_adds_nothing_and_draws_nothing() -> None:
    """``ground_lines=False`` (the default) gives the model of before; on, the face-on wall
    enters the model as an obstacle at its contact."""
    scene = _scene(_wall())
    edges = SceneEdges.of(scene)
    kw = {"robot_width_m": 0.5, "robot_height_m": 1.0, "eps": 0.05, "max_situations": 8}
    rng_off, rng_default = np.random.default_rng(5), np.random.default_rng(5)
    off = perceive_surrogate(edges, RIG, HEAD, rng_off, ground_lines=False, **kw)
    assert off == perceive_surrogate(edges, RIG, HEAD, rng_default, **kw)
    assert rng_off.random() == rng_default.random()
    assert not any(abs(o.points[:, 0] - WALL_X).max() < 0.3 for o in off.situations[0].obstacles)
    on = perceive_surrogate(edges, RIG, HEAD, np.random.default_rng(5), ground_lines=True, **kw)
    assert any(abs(o.points[:, 0] - WALL_X).max() < 0.3 for o in on.situations[0].obstacles)


def test_the_config_takes_ground_lines_with_the_surrogate_only_among_the_unrendered() -> None:
    assert EnvConfig.from_kwargs(perception="surrogate", ground_lines=True).ground_lines
    for perception in ("dense", "truth"):
        with pytest.raises(ValueError, match="ground_lines"):
            EnvConfig.from_kwargs(perception=perception, ground_lines=True)


def test_the_surrogate_and_the_rendered_stereo_agree_on_the_ground_lines() -> None:
    """The rendered stereo's ground lines and the surrogate's of one scene (a face-on wall, a
    low box before it) lie on the same contacts: every stereo segment's ends are within 4
    combined standard deviations of a surrogate segment on the same contact, and the seen
    lengths of the wall's contact agree within 30 %."""
    from modeling.stereo.ground_lines import add_ground_lines
    from modeling.stereo.matching import match_segments
    from modeling.stereo.segments import extract_segment_pair
    from modeling.stereo.triangulation import triangulate_to_floor
    from tests.integration.rendering import noisy_grey_pair

    scene = _scene(_wall(), _box(BOX_X, 0.4, 0.4))
    segs_l, segs_r = extract_segment_pair(*noisy_grey_pair(scene, RIG, HEAD))
    floor = triangulate_to_floor(match_segments(segs_l, segs_r, RIG), RIG, HEAD)
    stereo = list(add_ground_lines(segs_l, floor, RIG, HEAD).segments[len(floor.segments) :])
    surrogate = _ground(scene)
    assert stereo and surrogate
    across = np.array([1.0, 0.0])
    for s in stereo:
        sigma_s = _normal_sigma(s, across)
        near = [
            t
            for t in surrogate
            if abs(np.mean(t.endpoints[:, 0]) - np.mean(s.endpoints[:, 0])) <= 0.3
        ]
        assert near, f"no surrogate segment on the stereo's contact {s.endpoints.tolist()}"
        line = shapely.MultiLineString([t.endpoints for t in near])
        for k in range(2):
            sigma = np.hypot(sigma_s[k], max(_normal_sigma(t, across).max() for t in near))
            gap = shapely.distance(shapely.Point(s.endpoints[k]), line)
            assert gap <= 4.0 * sigma + 0.05  # across, and the ends' 5 cm sampling along

    def wall_length(segs: list[FloorSegment]) -> float:
        on = [s for s in segs if abs(s.endpoints[:, 0] - WALL_X).max() <= 0.3]
        return float(sum(abs(s.endpoints[1, 1] - s.endpoints[0, 1]) for s in on))

    assert wall_length(surrogate) == pytest.approx(wall_length(stereo), rel=0.3)


def test_bad_lines_name_themselves() -> None:
    with pytest.raises(ValueError, match="lines"):
        line_ground_segments(np.zeros((2, 4)), RIG, HEAD)
    assert line_ground_segments(np.zeros((0, 2, 2)), RIG, HEAD, GroundLineOptions()) == []
