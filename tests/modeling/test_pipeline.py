"""model_from_stereo: a synthetic stereo pair to an environment model, options routed per stage."""

from __future__ import annotations

import numpy as np
import pytest

from modeling import model_from_stereo as exported
from modeling.model.build import build_model
from modeling.pipeline import model_from_stereo
from modeling.stereo.faces import FaceOptions
from modeling.stereo.matching import MatchOptions
from modeling.stereo.pipeline import STEREO_STAGES, route_options, stereo_to_floor
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import SegmentOptions
from modeling.stereo.triangulation import TriangulationOptions
from tests.modeling.synth import render_pair

RIG = StereoRig()
POSE = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)  # looking along world +x
W = 0.5


def bars(gap_m: float, depth_m: float = 2.5) -> tuple[np.ndarray, np.ndarray]:
    """RGB pair of two 0.3 m wide, 1 m high boards standing on the floor, ``gap_m`` apart."""
    xa = -0.5 * gap_m - 0.3
    xb = 0.5 * gap_m
    rects = [(xa, xa + 0.3, -0.2, 0.8, depth_m, 200.0), (xb, xb + 0.3, -0.2, 0.8, depth_m, 40.0)]
    left, right, _ = render_pair(RIG, rects, noise=2.0, rng=np.random.default_rng(0))
    return np.dstack([left] * 3), np.dstack([right] * 3)


def test_two_bars_far_apart_give_two_obstacles_where_they_stand() -> None:
    left, right = bars(1.2)
    m = model_from_stereo(left, right, RIG, POSE, W)
    assert exported is model_from_stereo
    (s,) = m.situations
    assert s.probability == 1.0
    assert len(s.obstacles) == 2 and s.critical_regions == ()
    # World y = -X_cam: the boards' edges are at y = +-0.6 and +-0.9, x = depth = 2.5.
    centres = sorted((tuple(o.points.mean(axis=0)) for o in s.obstacles), key=lambda c: c[1])
    np.testing.assert_allclose(centres, [(2.5, -0.75), (2.5, 0.75)], atol=0.05)
    # The same as the two stages called by hand.
    ref = build_model(stereo_to_floor(left, right, RIG, POSE), W)
    assert [len(x.obstacles) for x in ref.situations] == [len(x.obstacles) for x in m.situations]
    np.testing.assert_allclose(ref.relations.p_passable, m.relations.p_passable)


def test_bars_closer_than_the_robot_give_one_obstacle() -> None:
    left, right = bars(0.3)
    m = model_from_stereo(left, right, RIG, POSE, W)
    # In every situation the boards' segments are one obstacle; any other obstacle is a
    # free-standing position of an ambiguous segment (a possible object in that situation only).
    for s in m.situations:
        (boards,) = [o for o in s.obstacles if o.segments]
        assert boards.segments == m.kept_segments
        assert all(o.candidates and not o.segments for o in s.obstacles if o is not boards)


def test_options_reach_their_stage() -> None:
    left, right = bars(1.2)
    m = model_from_stereo(left, right, RIG, POSE, W, eps=0.1, max_situations=3)
    assert m.eps == 0.1
    assert len(m.situations[0].obstacles) == 2
    # A height band above the boards keeps nothing: an empty, certain model.
    empty = model_from_stereo(left, right, RIG, POSE, W, min_height_m=1.2, max_height_m=2.0)
    assert len(empty.observation.segments) == 0
    (s,) = empty.situations
    assert s.obstacles == () and s.probability == 1.0


def test_every_stage_option_is_accepted_and_reaches_its_stage() -> None:
    # Each stage's keyword options are routed by the fields of its options dataclass, so the
    # newer ones are not refused as unknown: a bad value fails in its own stage, naming it.
    left, right = bars(1.2)
    floor = stereo_to_floor(left, right, RIG, POSE, near_px=1.0, max_near_grey_diff=12.0)
    assert len(floor.segments) > 0
    with pytest.raises(ValueError, match="near_px"):
        stereo_to_floor(left, right, RIG, POSE, near_px=-1.0)
    with pytest.raises(ValueError, match="max_near_grey_diff"):
        model_from_stereo(left, right, RIG, POSE, W, max_near_grey_diff=-1.0)


def test_unknown_and_bad_options_are_value_errors_naming_them() -> None:
    left, right = bars(1.2)
    with pytest.raises(ValueError, match=r"bogus.*typo_eps|typo_eps.*bogus"):
        model_from_stereo(left, right, RIG, POSE, W, bogus=1, typo_eps=0.1)
    with pytest.raises(ValueError, match="robot_width_m"):
        model_from_stereo(left, right, RIG, POSE, -1.0)
    with pytest.raises(ValueError, match="eps"):
        model_from_stereo(left, right, RIG, POSE, W, eps=0.7)
    with pytest.raises(ValueError, match="left"):
        model_from_stereo(left[:, :, 0].astype(np.float32), right, RIG, POSE, W)


def test_flat_options_are_routed_by_the_fields_of_each_stage_dataclass() -> None:
    opts = route_options(
        {"max_height_m": 0.9, "rel_peak": 0.4, "bias_sigma_px": 0.2}, STEREO_STAGES
    )
    assert opts["triangulation"] == TriangulationOptions(max_height_m=0.9)
    assert opts["faces"] == FaceOptions(max_height_m=0.9)  # the tops bound follows the band
    assert opts["matching"] == MatchOptions(rel_peak=0.4)
    assert opts["segments"] == SegmentOptions(bias_sigma_px=0.2)
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['sigma_px'\]"):
        route_options({"sigma_px": 1.5}, STEREO_STAGES)  # the rig's, not an option
    assert route_options({}, STEREO_STAGES)["matching"] == MatchOptions()
    with pytest.raises(
        ValueError,
        match=r"unknown option\(s\) \['rel_peek'\] \(did you mean 'rel_peak'\?\); known: \[",
    ):
        route_options({"rel_peek": 0.4}, STEREO_STAGES)
