"""Floor observations: ``FloorSegment.stack`` (many segments checked in bulk) and ``face_value``
(an observation with its uncertainty dropped: issue 43's ``stereo_means``).

The reduction keeps the means, replaces every covariance by ``NEGLIGIBLE_STD_M^2 I`` (a zero one is
refused by ``FloorSegment``), and reduces each ambiguous segment to its most probable choice; the
model built from it has one situation and no critical region where the uncertain model had
several situations and undecided gaps.
"""

from __future__ import annotations

import numpy as np
import pytest

from modeling.model.build import build_model
from modeling.model.gaps import Relation
from modeling.observation import (
    NEGLIGIBLE_STD_M,
    FloorObservation,
    FloorSegment,
    face_value,
    negligible_covariance,
)
from tests.modeling.model.test_figures import W, amb, box, observe, seg


def test_a_zero_covariance_is_refused_so_face_value_uses_a_negligible_one() -> None:
    with pytest.raises(ValueError, match="cov must be positive definite"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.zeros((2, 2, 2)))
    cov = negligible_covariance()
    assert np.array_equal(cov, np.stack([np.eye(2) * NEGLIGIBLE_STD_M**2] * 2))
    assert NEGLIGIBLE_STD_M == 1e-6
    with pytest.raises(ValueError, match="std_m"):
        negligible_covariance(0.0)


def test_means_are_kept_and_every_covariance_becomes_negligible() -> None:
    segments = [seg((0.0, 0.0), (1.0, 0.0), sigma=0.2), seg((2.0, 1.0), (2.5, 3.0), sigma=0.05)]
    obs = observe(segments)
    out = face_value(obs)
    assert out.ambiguous == ()
    assert [s.source for s in out.segments] == [s.source for s in segments]
    for got, want in zip(out.segments, segments, strict=True):
        assert np.array_equal(got.endpoints, want.endpoints)
        assert np.array_equal(got.height_m, want.height_m)
        assert np.array_equal(got.cov, negligible_covariance())
    assert np.array_equal(out.viewpoint, obs.viewpoint)
    assert (out.fov_rad, out.max_range_m) == (obs.fov_rad, obs.max_range_m)
    assert np.array_equal(face_value(obs, std_m=0.01).segments[0].cov[1], np.eye(2) * 1e-4)


def test_each_ambiguous_segment_becomes_its_most_probable_choice() -> None:
    a = [seg((0.0, 2.0), (1.0, 2.0)), seg((0.0, 4.0), (1.0, 4.0)), seg((0.0, 6.0), (1.0, 6.0))]
    b = [seg((3.0, 2.0), (4.0, 2.0))]
    c = [seg((6.0, 2.0), (7.0, 2.0)), seg((6.0, 3.0), (7.0, 3.0))]
    obs = observe(
        [seg((0.0, 0.0), (1.0, 0.0))],
        [
            amb(a, [0.2, 0.5, 0.3]),  # the second candidate
            amb(b, [0.3]),  # "no obstacle here" (0.7) wins: nothing
            amb(c, [0.5, 0.5]),  # a tie: the first
        ],
    )
    out = face_value(obs)
    assert out.ambiguous == ()
    ends = [s.endpoints.tolist() for s in out.segments]
    assert ends == [
        [[0.0, 0.0], [1.0, 0.0]],
        a[1].endpoints.tolist(),
        c[0].endpoints.tolist(),
    ]
    # a lone candidate as probable as "none" is kept (an obstacle is not thrown away on a tie)
    (kept,) = face_value(observe([], [amb(b, [0.5])])).segments
    assert np.array_equal(kept.endpoints, b[0].endpoints)


def test_the_model_at_face_value_has_one_situation_and_no_undecided_gap() -> None:
    # Two boxes 0.52 m apart with 5 cm endpoint errors: the gap is undecided for a 0.5 m robot.
    # An ambiguous post between them: at x = 1.26 (p 0.6, closing the gap) or far away (p 0.4).
    boxes = box(0.0, 0.0, 1.0, 1.0, sigma=0.05) + box(1.52, 0.0, 2.52, 1.0, sigma=0.05)
    post = amb(
        [seg((1.26, 0.4), (1.26, 0.6), 0.05), seg((1.26, 8.4), (1.26, 8.6), 0.05)], [0.6, 0.4]
    )
    uncertain = build_model(observe(boxes, [post]), W)
    assert len(uncertain.situations) == 2
    assert any(s.critical_regions for s in uncertain.situations)

    model = build_model(face_value(observe(boxes, [post])), W)
    (situation,) = model.situations
    assert situation.probability == 1.0 and model.residual_probability == 0.0
    assert situation.critical_regions == ()
    assert len(model.relations) > 0
    assert int(Relation.UNDECIDED) not in model.relations.kind.tolist()
    # the post (the most probable candidate) joins the two boxes into one obstacle
    assert len(situation.obstacles) == 1

    # without the post, the 0.52 m gap is passable at face value: two obstacles, no region
    (alone,) = build_model(face_value(observe(boxes)), W).situations
    assert len(alone.obstacles) == 2 and alone.critical_regions == ()


def test_bad_input_is_refused_naming_the_field() -> None:
    with pytest.raises(ValueError, match="observation must be a FloorObservation"):
        face_value("observation")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="std_m"):
        face_value(FloorObservation(), std_m=-1.0)


def test_stack_makes_the_segments_the_constructor_makes_and_checks_in_bulk() -> None:
    rng = np.random.default_rng(0)
    ends = rng.normal(size=(3, 2, 2))
    a = rng.normal(size=(3, 2, 2, 2)) * 0.1
    cov = a @ np.swapaxes(a, -1, -2) + 1e-4 * np.eye(2)
    heights = rng.uniform(0.0, 1.0, (3, 2))
    source = np.array([4, -1, 7])
    got = FloorSegment.stack(ends, cov, heights, source)
    assert len(got) == 3
    for k, made in enumerate(got):
        want = FloorSegment(
            endpoints=ends[k], cov=cov[k], height_m=heights[k], source=int(source[k])
        )
        assert np.array_equal(made.endpoints, want.endpoints)
        assert np.allclose(made.cov, want.cov, rtol=0, atol=1e-15)
        assert np.array_equal(made.height_m, want.height_m) and made.source == want.source
        assert not made.endpoints.flags.writeable and not made.cov.flags.writeable
    assert (
        FloorSegment.stack(
            np.zeros((0, 2, 2)), np.zeros((0, 2, 2, 2)), np.zeros((0, 2)), np.zeros(0, int)
        )
        == ()
    )
    bad_cov = cov.copy()
    bad_cov[1, 0] = -np.eye(2)
    with pytest.raises(ValueError, match="cov must be positive definite"):
        FloorSegment.stack(ends, bad_cov, heights, source)
    with pytest.raises(ValueError, match="endpoints contains NaN"):
        FloorSegment.stack(np.where(ends > 1.0, np.nan, ends), cov, heights, source)
    with pytest.raises(ValueError, match="height_m must have shape"):
        FloorSegment.stack(ends, cov, heights[:2], source)
    with pytest.raises(ValueError, match="cov must have shape"):
        FloorSegment.stack(ends, cov[:2], heights, source)
    with pytest.raises(ValueError, match="source must be"):
        FloorSegment.stack(ends, cov, heights, np.array([0.5, 1.0, 2.0]))
