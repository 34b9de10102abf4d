"""The fused model memory (issue 16, paper section 6): association and Gaussian fusion, existence,
ambiguity re-weighting, contacts, bounds."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import shapely
import shapely.affinity
from numpy.typing import ArrayLike

from modeling import (
    AmbiguousSegment,
    FloorObservation,
    FloorSegment,
    MemoryOptions,
    ModelMemory,
    add_contact,
    build_memory_model,
    fuse,
)
from modeling.memory.ambiguity import candidates_of
from modeling.memory.association import floored_covariances, stack_of

PD, PF = 0.8, 0.05  # the default detection probability and false-match rate
HIT, MISS = PD / PF, (1 - PD) / (1 - PF)  # the likelihood ratios of a detection and of a miss
NONE = 0.05  # the default none prior: a new ambiguity's candidates are scaled to 1 - NONE


def seg(a: ArrayLike, b: ArrayLike, cov: np.ndarray | None = None) -> FloorSegment:
    c = np.tile(np.eye(2) * 0.03**2, (2, 1, 1)) if cov is None else cov
    return FloorSegment(endpoints=np.array([a, b], dtype=np.float64), cov=c)


def view(
    segments: tuple[FloorSegment, ...] = (),
    ambiguous: tuple[AmbiguousSegment, ...] = (),
    at: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> FloorObservation:
    return FloorObservation(segments=segments, ambiguous=ambiguous, viewpoint=np.array(at))


def posterior(p: float, ratio: float) -> float:
    return p * ratio / (p * ratio + 1 - p)


def test_two_views_of_one_segment_fuse_to_the_product_of_gaussians() -> None:
    cov1 = np.array([[[0.04, 0.01], [0.01, 0.02]], [[0.03, -0.005], [-0.005, 0.01]]])
    cov2 = np.array([[[0.01, 0.0], [0.0, 0.05]], [[0.02, 0.004], [0.004, 0.03]]])
    first = seg((3.0, -0.5), (3.2, 0.5), cov1)
    # the second view, from a viewpoint 0.6 m away (beyond independent_baseline_m), sees the
    # same edge with its endpoints in the other order
    second = FloorSegment(endpoints=np.array([[3.25, 0.45], [2.9, -0.55]]), cov=cov2[::-1])
    memory = fuse(fuse(ModelMemory.empty(), view((first,))), view((second,), at=(0.0, 0.6, -0.1)))
    assert len(memory.segments) == 1
    got = memory.segments[0]
    for e, (m1, m2) in enumerate(zip(first.endpoints, second.endpoints[::-1], strict=True)):
        i1, i2 = np.linalg.inv(cov1[e]), np.linalg.inv(cov2[e])
        P = np.linalg.inv(i1 + i2)
        np.testing.assert_allclose(got.cov[e], P, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.endpoints[e], P @ (i1 @ m1 + i2 @ m2), rtol=0, atol=1e-12)
    assert memory.existence == pytest.approx((posterior(0.5, HIT),), abs=1e-12)
    assert memory.views == 2 and memory.last_seen == (2,)
    np.testing.assert_array_equal(memory.fused_from, [[0.0, 0.6]])


def test_floored_covariances_raise_the_minor_axis_only() -> None:
    angle = 0.3
    v = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    thin = v @ np.diag([1e-6, 4e-4]) @ v.T  # 1 mm across, 2 cm along
    wide = np.eye(2) * 1e-3
    got = floored_covariances(np.stack([thin, wide]), 0.005**2)
    np.testing.assert_allclose(got[0], v @ np.diag([0.005**2, 4e-4]) @ v.T, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(got[1], wide)  # above the floor: unchanged, bit for bit
    both_low = np.eye(2) * 1e-6
    np.testing.assert_allclose(floored_covariances(both_low[None], 1e-4)[0], np.eye(2) * 1e-4)
    np.testing.assert_array_equal(floored_covariances(np.stack([thin]), 0.0)[0], thin)


def test_floored_covariances_equal_clipping_the_eigenvalues() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(size=(400, 2, 2)) * 0.01
    cov = a @ a.transpose(0, 2, 1)
    floor = float(np.median(np.linalg.eigvalsh(cov)[:, 0]))
    w, v = np.linalg.eigh(cov)
    want = np.einsum("kij,kj,klj->kil", v, np.maximum(w, floor), v)
    np.testing.assert_allclose(floored_covariances(cov, floor), want, rtol=0, atol=1e-17)


def test_many_views_of_one_segment_stop_narrowing_at_min_sigma() -> None:
    cov = np.tile(np.diag([0.01**2, 0.03**2]), (2, 1, 1))
    memory, floored = ModelMemory.empty(), ModelMemory.empty()
    for k in range(40):  # independent views: viewpoints 0.6 m apart
        obs = view((seg((3.0, -0.5), (3.0, 0.5), cov),), at=(0.0, 0.6 * k, 0.0))
        memory, floored = fuse(memory, obs), fuse(floored, obs, min_sigma_m=0.004)
    assert len(memory.segments) == len(floored.segments) == 1
    plain = np.linalg.eigvalsh(memory.segments[0].cov)
    np.testing.assert_allclose(plain[:, 0], 0.01**2 / 40, rtol=1e-9)  # the product: 1.6 mm
    low = np.linalg.eigvalsh(floored.segments[0].cov)
    np.testing.assert_allclose(low[:, 0], 0.004**2, rtol=1e-9)  # held at the floor
    np.testing.assert_allclose(low[:, 1], plain[:, 1], rtol=1e-6)  # along: still the product


@pytest.mark.parametrize(
    ("second_at", "weight"),
    [
        ((0.0, 0.0, 0.0), 0.5),  # the same viewpoint: repeat_information
        ((0.2, 0.0, 0.1), 0.5 + 0.5 * 0.2 / 0.5),  # 0.2 m on: part of an independent view
        ((0.0, 0.5, 0.0), 1.0),  # independent_baseline_m away: an independent view
    ],
)
def test_a_view_from_near_the_last_viewpoint_adds_a_share_of_its_information(
    second_at: tuple[float, float, float], weight: float
) -> None:
    cov1 = np.array([[[0.04, 0.01], [0.01, 0.02]], [[0.03, -0.005], [-0.005, 0.01]]])
    cov2 = np.array([[[0.01, 0.0], [0.0, 0.05]], [[0.02, 0.004], [0.004, 0.03]]])
    first, second = seg((3.0, -0.5), (3.2, 0.5), cov1), seg((3.1, -0.45), (3.25, 0.45), cov2)
    memory = fuse(fuse(ModelMemory.empty(), view((first,))), view((second,), at=second_at))
    got = memory.segments[0]
    for e in range(2):
        i1, i2 = np.linalg.inv(cov1[e]), weight * np.linalg.inv(cov2[e])
        P = np.linalg.inv(i1 + i2)
        np.testing.assert_allclose(got.cov[e], P, rtol=0, atol=1e-12)
        mean = P @ (i1 @ first.endpoints[e] + i2 @ second.endpoints[e])
        np.testing.assert_allclose(got.endpoints[e], mean, rtol=0, atol=1e-12)
    # existence is updated as before: only the endpoints' information is shared
    assert memory.existence == pytest.approx((posterior(0.5, HIT),), abs=1e-12)
    # with independent_baseline_m 0, every view counts in full (the plain product)
    plain = fuse(
        fuse(ModelMemory.empty(), view((first,))),
        view((second,), at=second_at),
        independent_baseline_m=0.0,
    )
    P0 = np.linalg.inv(np.linalg.inv(cov1[0]) + np.linalg.inv(cov2[0]))
    np.testing.assert_allclose(plain.segments[0].cov[0], P0, rtol=0, atol=1e-12)


def test_standing_still_the_covariance_shrinks_like_half_views() -> None:
    wall = seg((4.0, -0.5), (4.0, 0.5))
    memory = ModelMemory.empty()
    for _ in range(5):
        memory = fuse(memory, view((wall,)))
    # the first view in full, four more at repeat_information 0.5: three views' information
    P = np.linalg.inv(3 * np.linalg.inv(wall.cov[0]))
    np.testing.assert_allclose(memory.segments[0].cov[0], P, rtol=0, atol=1e-15)


def test_an_ambiguity_seen_from_a_separating_viewpoint_resolves_to_the_true_candidate() -> None:
    true = seg((4.0, 0.5), (4.0, 1.0))
    false = seg((6.0, 0.75), (6.0, 1.4))  # a wrong disparity: farther along the first view's ray
    first = view(ambiguous=(AmbiguousSegment(candidates=(true, false), probabilities=(0.5, 0.5)),))
    memory = fuse(ModelMemory.empty(), first)
    assert len(memory.ambiguous) == 1 and memory.segments == ()
    # from the side: the true candidate is seen unambiguously, the false one's place is in view,
    # not occluded, and nothing is there
    again = seg((4.02, 0.48), (3.98, 1.03))
    side = (4.0, -3.0, math.pi / 2)
    vis_side = fuse(memory, view((again,), at=side))
    assert vis_side.ambiguous == ()
    assert len(vis_side.segments) == 1
    q = 0.5 * (1 - NONE)
    p_true = q * HIT / (q * HIT + q * MISS + NONE)
    assert vis_side.existence == pytest.approx((p_true,), abs=1e-12)
    got = vis_side.segments[0]
    i1, i2 = np.linalg.inv(true.cov[0]), np.linalg.inv(again.cov[0])
    P = np.linalg.inv(i1 + i2)
    np.testing.assert_allclose(got.cov[0], P, atol=1e-12)
    np.testing.assert_allclose(
        got.endpoints[0], P @ (i1 @ true.endpoints[0] + i2 @ again.endpoints[0]), atol=1e-12
    )
    model = build_memory_model(vis_side, 0.5)
    assert len(model.situations) == 1 and len(model.most_probable.obstacles) == 1


def test_a_candidate_matched_by_a_new_ambiguous_one_gains_by_its_probability() -> None:
    true, false = seg((4.0, 0.5), (4.0, 1.0)), seg((6.0, 0.75), (6.0, 1.4))
    memory = fuse(
        ModelMemory.empty(),
        view(ambiguous=(AmbiguousSegment(candidates=(true, false), probabilities=(0.5, 0.5)),)),
    )
    # seen again as ambiguous from far to the left, the false candidate out of view
    other = seg((1.0, 3.0), (1.2, 3.4))
    amb = AmbiguousSegment(
        candidates=(seg((4.0, 0.5), (4.0, 1.0)), other), probabilities=(0.7, 0.3)
    )
    later = fuse(memory, view(ambiguous=(amb,), at=(4.0, -3.0, math.pi / 2 + 0.45)))
    assert len(later.ambiguous) == 1 and later.segments == ()
    w_true, w_false = 0.5 * (1 - NONE) * (1 + 0.7 * (HIT - 1)), 0.5 * (1 - NONE)
    total = w_true + w_false + NONE
    got = later.ambiguous[0]
    assert got.probabilities == pytest.approx((w_true / total, w_false / total), abs=1e-12)
    assert got.p_none == pytest.approx(NONE / total, abs=1e-12)
    assert later.ambiguous_seen == (2,)


def test_a_false_segment_seen_free_fades_and_is_forgotten_one_out_of_view_is_kept() -> None:
    ghost = seg((3.0, -0.2), (3.0, 0.2))
    aside = seg((3.0, 1.4), (3.0, 1.7))  # 25-30 deg left of the first view
    memory = fuse(ModelMemory.empty(), view((ghost, aside)))
    assert memory.existence == (0.5, 0.5)
    turned = (0.0, 0.0, -0.4)  # the ghost now 19-27 deg left, in view; the other out of view
    once = fuse(memory, view(at=turned))
    assert once.existence == pytest.approx((posterior(0.5, MISS), 0.5), abs=1e-12)
    assert [s.endpoints.tolist() for s in once.observation().segments] == [aside.endpoints.tolist()]
    twice = fuse(once, view(at=turned))
    assert posterior(posterior(0.5, MISS), MISS) < MemoryOptions().min_existence
    assert len(twice.segments) == 1
    np.testing.assert_array_equal(twice.segments[0].endpoints, aside.endpoints)
    assert twice.existence == (0.5,)


def test_a_segment_behind_what_the_new_view_sees_is_unchanged() -> None:
    behind = seg((6.0, -0.2), (6.0, 0.2))
    wall = seg((3.0, -1.0), (3.0, 1.0))
    memory = fuse(ModelMemory.empty(), view((behind,)))
    later = fuse(memory, view((wall,)))  # the wall hides it now
    assert later.existence == (0.5, 0.5)


def test_the_near_blind_zone_is_not_seen_free() -> None:
    near = seg((1.0, -0.1), (1.0, 0.1))
    memory = fuse(ModelMemory.empty(), view((near,)))
    assert fuse(memory, view(), near_range_m=1.5).existence == (0.5,)
    assert fuse(memory, view()).existence == pytest.approx((posterior(0.5, MISS),))


def test_a_low_segment_below_the_image_is_not_seen_free_a_tall_one_is() -> None:
    low = FloorSegment(
        endpoints=np.array([[1.0, -0.1], [1.0, 0.1]]),
        cov=np.tile(np.eye(2) * 1e-4, (2, 1, 1)),
        height_m=np.array([0.0, 0.2]),
    )
    tall = FloorSegment(
        endpoints=np.array([[1.0, 0.3], [1.0, 0.45]]),
        cov=np.tile(np.eye(2) * 1e-4, (2, 1, 1)),
        height_m=np.array([0.0, 0.75]),
    )
    level_head = {"head_height_m": 0.8, "half_vfov_rad": math.atan(120 / 256)}
    memory = fuse(ModelMemory.empty(), view((low, tall)), **level_head)
    later = fuse(memory, view(), **level_head)
    # the low box's top (0.2 m) is in the image from 1.28 m on, the tall one's from 0.11 m
    assert later.existence == pytest.approx((0.5, posterior(0.5, MISS)), abs=1e-12)
    # the floor is in the image from 0.8 / tan(25 deg) = 1.71 m on
    unknown = later.unknown(shapely.box(-1, -3, 9, 3))
    assert unknown.contains(shapely.Point(1.5, 0.0))
    assert not unknown.contains(shapely.Point(1.9, 0.0))


def test_a_segment_imaged_along_the_rows_does_not_fade_where_seen_free() -> None:
    def floor_line(a: tuple[float, float], b: tuple[float, float], top: float) -> FloorSegment:
        return FloorSegment(
            endpoints=np.array([a, b]),
            cov=np.tile(np.eye(2) * 1e-4, (2, 1, 1)),
            height_m=np.array([0.0, top]) if a == b else np.array([top, top]),
        )

    face_on = floor_line((3.0, -0.3), (3.0, 0.0), 0.0)  # a face's bottom edge, seen face-on
    radial = floor_line((2.5, 0.4), (3.5, 0.4), 0.0)  # a bottom edge along the gaze: steep
    leg = floor_line((3.0, -0.6), (3.0, -0.6), 0.7)  # a vertical edge: a floor point
    head = {"head_height_m": 0.8, "half_vfov_rad": math.atan(120 / 256)}
    memory = fuse(ModelMemory.empty(), view((face_on, radial, leg)), **head)
    # the stereo could not have matched the face-on edge from here (its image is a row), the
    # radial one (about 70 degrees to the rows) and the leg (a column) it could have
    later = fuse(memory, view(), min_image_angle_deg=25.0, **head)
    miss = posterior(0.5, MISS)
    assert later.existence == pytest.approx((0.5, miss, miss), abs=1e-12)
    # with no angle limit every one of them fades
    assert fuse(memory, view(), **head).existence == pytest.approx((miss,) * 3, abs=1e-12)
    # seen along its length, the same face's edge is imaged steeply: its floor seen free counts
    along = (3.0, -2.5, math.pi / 2)
    aside = fuse(memory, view(at=along), min_image_angle_deg=25.0, **head)
    assert aside.existence[0] == pytest.approx(miss, abs=1e-12)


def test_flat_in_image_compares_the_image_angle_with_the_limit() -> None:
    from modeling.memory.visibility import Visibility, flat_in_image

    vis = Visibility(
        origin=np.zeros(2),
        heading=0.0,
        half_fov=0.5,
        angles=np.zeros(3),
        reach=np.zeros(3),
        near_m=0,
    )
    # floor points (x ahead, y across) image at (y / x, 0.8 / x): from (2, 0) to (4, y) the image
    # rises 0.2 over y / 4 - 0, so y = 4 * 0.2 / tan(a) is at a degrees to the rows
    at = [4.0 * 0.2 / math.tan(math.radians(a)) for a in (30.0, 20.0)]
    ends = np.array(
        [
            [[2.0, 0.0], [4.0, at[0]]],  # 30 degrees: steep enough
            [[2.0, 0.0], [4.0, at[1]]],  # 20 degrees: along the rows
            [[3.0, -0.3], [3.0, 0.3]],  # across the gaze: a row
            [[3.0, 0.5], [3.0, 0.52]],  # a leaning vertical edge (heights below): steep
            [[-1.0, 0.0], [1.0, 2.0]],  # one end behind the viewpoint
        ]
    )
    heights = np.array([[0.0, 0.0]] * 3 + [[0.0, 0.7], [0.0, 0.0]])
    flat = flat_in_image(vis, ends, heights, 0.8, 25.0)
    assert flat.tolist() == [False, True, True, False, False]
    assert not flat_in_image(vis, ends, heights, 0.8, 0.0).any()
    assert flat_in_image(vis, np.zeros((0, 2, 2)), np.zeros((0, 2)), 0.8, 25.0).shape == (0,)
    # the same segments turned with the view give the same answer
    turn = np.array([[0.0, -1.0], [1.0, 0.0]])  # 90 degrees
    vis_turned = vis._replace(origin=np.array([5.0, -2.0]), heading=math.pi / 2)
    moved = ends @ turn.T + vis_turned.origin
    assert flat_in_image(vis_turned, moved, heights, 0.8, 25.0).tolist() == flat.tolist()


def test_memory_size_stays_bounded_over_500_steps() -> None:
    rng = np.random.default_rng(16)
    opts = MemoryOptions(max_segments=120, max_ambiguous=10, max_contacts=5, max_seen_vertices=400)
    memory = ModelMemory.empty()
    for k in range(500):
        x, heading = 0.2 * k, 0.3 * math.sin(k / 25)
        ahead = rng.uniform([x + 2, -3], [x + 6, 3], size=(30, 2))
        dirs = rng.normal(size=(30, 2)) * 0.2
        segs = tuple(seg(p, p + d) for p, d in zip(ahead, dirs, strict=True))
        ambs = tuple(
            AmbiguousSegment(
                candidates=(
                    seg(p, p + np.array([0.1, 0.3])),
                    seg(p + 1, p + 1.2),
                ),
                probabilities=(0.6, 0.4),
            )
            for p in rng.uniform([x + 2, -2], [x + 5, 2], size=(2, 2))
        )
        memory = fuse(memory, view(segs, ambs, at=(x, 0.0, heading)), opts)
        if k % 7 == 0:
            memory = add_contact(memory, (x, 0.5 * (k % 3)), (0.0, 1.0), height_m=0.4, options=opts)
        assert len(memory.segments) <= 120 and len(memory.ambiguous) <= 10
        assert len(memory.contacts) <= 5
        assert shapely.get_num_coordinates(memory.seen) <= 400
    assert len(memory.segments) == 120 and memory.views == 500


def test_the_arrays_fuse_carries_equal_those_of_its_segments_and_candidates() -> None:
    # fuse reuses the rows of unchanged candidates and segments; they must equal a fresh stack
    rng = np.random.default_rng(5)
    memory = ModelMemory.empty()
    for k in range(40):
        x = 0.1 * k
        segs = tuple(seg(p, p + rng.normal(size=2) * 0.2) for p in rng.uniform(2, 6, (8, 2)))
        ambs = tuple(
            AmbiguousSegment(
                candidates=(seg(p, p + np.array([0.1, 0.3])), seg(p + 1.0, p + 1.2)),
                probabilities=(0.6, 0.4),
            )
            for p in rng.uniform([x + 2, -2], [x + 5, 2], size=(3, 2))
        )
        memory = fuse(memory, view(segs, ambs, at=(x, 0.0, 0.1 * math.sin(k))))
        cands, fresh = memory.candidate_arrays, candidates_of(memory.ambiguous)
        assert cands is not None and memory.segment_arrays is not None
        for got, want in zip(
            (*cands.stack, cands.owner, cands.prob),
            (*fresh.stack, fresh.owner, fresh.prob),
            strict=True,
        ):
            np.testing.assert_array_equal(got, want)
        assert all(a is b for a, b in zip(cands.segments, fresh.segments, strict=True))
        for got, want in zip(memory.segment_arrays, stack_of(memory.segments), strict=True):
            np.testing.assert_array_equal(got, want)
    assert len(memory.ambiguous) > 5  # some candidates stayed unchanged for several views


def test_the_bound_drops_the_lowest_existence_then_the_oldest() -> None:
    a, b, c = (
        seg((3.0, -1.5), (3.0, -1.2)),
        seg((3.0, 0.0), (3.0, 0.3)),
        seg((3.0, 1.2), (3.0, 1.5)),
    )
    memory = fuse(ModelMemory.empty(), view((a, b)), max_segments=2)
    memory = fuse(memory, view((a, c), at=(0.0, 0.0, 0.0)), max_segments=2)
    # b was seen free (lost), a seen again (gained), c new: b goes
    assert [s.endpoints[0, 1] for s in memory.segments] == pytest.approx([-1.5, 1.2], abs=0.01)
    # equal existence: the older one goes
    old = fuse(ModelMemory.empty(), view((a,), at=(0.0, 0.0, 2.0)), max_segments=2)
    old = fuse(old, view((b,), at=(0.0, 0.0, -2.0)), max_segments=2)
    old = fuse(old, view((c,), at=(0.0, 0.0, math.pi)), max_segments=2)
    assert [s.endpoints[0, 1] for s in old.segments] == pytest.approx([0.0, 1.2])


def test_fuse_is_deterministic_and_does_not_mutate_its_inputs() -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform([2, -2], [6, 2], size=(20, 2))
    obs1 = view(tuple(seg(p, p + np.array([0.2, 0.1])) for p in pts))
    obs2 = view(
        tuple(seg(p + 0.01, p + np.array([0.21, 0.1])) for p in pts[:12]), at=(0.5, 0.1, 0.1)
    )
    memory = fuse(ModelMemory.empty(), obs1)
    before = [s.endpoints.copy() for s in memory.segments], memory.existence, memory.seen.wkb
    out1, out2 = fuse(memory, obs2), fuse(memory, obs2)
    assert [s.endpoints.tolist() for s in memory.segments] == [e.tolist() for e in before[0]]
    assert memory.existence == before[1] and memory.seen.wkb == before[2]
    assert out1.existence == out2.existence and out1.last_seen == out2.last_seen
    for s1, s2 in zip(out1.segments, out2.segments, strict=True):
        np.testing.assert_array_equal(s1.endpoints, s2.endpoints)
        np.testing.assert_array_equal(s1.cov, s2.cov)
    assert shapely.equals_exact(out1.seen, out2.seen, 0.0)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("gate_chi2", -1.0),
        ("detection_probability", 1.5),
        ("detection_probability", 0.01),  # not above the false-match rate
        ("false_match_rate", 0.0),
        ("min_existence", 0.7),
        ("report_existence", 0.05),
        ("max_existence", 0.4),
        ("resolve_probability", 0.3),
        ("max_segments", 0),
        ("n_rays", 2.5),
        ("free_margin_m", -0.1),
        ("seen_tolerance_m", 0.0),
        ("contact_length_m", math.nan),
        ("half_vfov_rad", 2.0),
        ("head_height_m", -0.8),
        ("independent_baseline_m", -0.5),
        ("repeat_information", 0.0),
        ("repeat_information", 1.5),
        ("min_image_angle_deg", 90.0),
        ("min_image_angle_deg", -1.0),
    ],
)
def test_bad_options_raise_naming_the_field(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        MemoryOptions(**{field: value})
    with pytest.raises(ValueError, match=field):
        fuse(ModelMemory.empty(), view(), **{field: value})


def test_bad_arguments_raise_naming_them() -> None:
    with pytest.raises(ValueError, match="memory"):
        fuse("memory", view())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="observation"):
        fuse(ModelMemory.empty(), None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown MemoryOptions"):
        fuse(ModelMemory.empty(), view(), gate=3.0)
    with pytest.raises(ValueError, match="normal_xy"):
        add_contact(ModelMemory.empty(), (1.0, 0.0), (0.0, 0.0), height_m=0.3)
    with pytest.raises(ValueError, match="height_m"):
        add_contact(ModelMemory.empty(), (1.0, 0.0), (1.0, 0.0), height_m=-1.0)
    with pytest.raises(ValueError, match="existence"):
        ModelMemory(segments=(seg((0, 0), (1, 0)),), existence=(), last_seen=(1,))
    with pytest.raises(ValueError, match="segments"):
        ModelMemory(segments=("wall",), existence=(0.5,), last_seen=(1,))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fused_from"):
        ModelMemory(
            segments=(seg((0, 0), (1, 0)),),
            existence=(0.5,),
            last_seen=(1,),
            fused_from=np.zeros(2),
        )
    with pytest.raises(ValueError, match="bounds"):
        ModelMemory.empty().unknown([0, 1])


def test_an_empty_view_into_an_empty_memory_gives_an_empty_valid_memory_and_model() -> None:
    memory = fuse(ModelMemory.empty(), FloorObservation())
    assert memory.segments == () and memory.ambiguous == () and memory.contacts == ()
    assert memory.views == 1
    wedge = math.radians(64.0) / 2 * 8.0**2  # the whole field of view, seen free
    assert memory.seen.area == pytest.approx(wedge, rel=0.01)
    model = build_memory_model(memory, 0.5)
    assert len(model.situations) == 1 and model.most_probable.obstacles == ()
    assert build_memory_model(ModelMemory.empty(), 0.5).most_probable.obstacles == ()


def test_unknown_is_the_floor_never_seen() -> None:
    memory = fuse(ModelMemory.empty(), view((seg((4.0, -1.0), (4.0, 1.0)),)))
    bounds = shapely.box(-10, -10, 10, 10)
    unknown = memory.unknown(bounds)
    assert unknown.area == pytest.approx(bounds.area - memory.seen.area)
    assert not unknown.contains(shapely.Point(2.0, 0.0))  # in view, in front of the wall
    assert unknown.contains(shapely.Point(6.0, 0.0))  # behind the wall
    assert unknown.contains(shapely.Point(-2.0, 0.0))  # behind the robot


def test_a_contact_is_a_short_certain_segment_across_its_normal() -> None:
    memory = add_contact(ModelMemory.empty(), (2.0, 1.0), (0.0, -3.0), height_m=0.4)
    (c,) = memory.contacts
    np.testing.assert_allclose(c.endpoints, [[1.9, 1.0], [2.1, 1.0]], atol=1e-12)
    np.testing.assert_allclose(c.cov, np.tile(np.eye(2) * 0.02**2, (2, 1, 1)), atol=1e-15)
    np.testing.assert_array_equal(c.height_m, [0.0, 0.4])
    # seen free again and again: never faded
    for _ in range(5):
        memory = fuse(memory, view(at=(0.0, 1.0, 0.0)))
    assert len(memory.contacts) == 1
    model = build_memory_model(memory, 0.5)
    assert len(model.most_probable.obstacles) == 1
    # a second bump within contact_merge_m replaces the first
    memory = add_contact(memory, (2.05, 1.0), (0.0, 1.0), height_m=0.4)
    assert len(memory.contacts) == 1
    np.testing.assert_allclose(memory.contacts[0].midpoint, [2.05, 1.0], atol=1e-12)
    assert len(add_contact(memory, (3.0, 1.0), (1.0, 0.0), height_m=0.4).contacts) == 2


def _seen_from(points: np.ndarray, vp: np.ndarray) -> np.ndarray:
    """Stereo-like endpoint covariances: depth sigma 2 cm x d^2, lateral 5 mm x d."""
    out = []
    for p in points:
        d = p - vp
        dist = float(np.hypot(*d))
        u = d / dist
        n = np.array([-u[1], u[0]])
        out.append((0.02 * dist**2) ** 2 * np.outer(u, u) + (0.005 * dist) ** 2 * np.outer(n, n))
    return np.array(out)


def test_a_critical_regions_width_std_narrows_as_views_accumulate() -> None:
    left = np.array([[5.0, -0.8], [5.0, -0.25]])
    right = np.array([[5.0, 0.25], [5.0, 0.8]])  # a 0.5 m gap: the robot's width
    memory = ModelMemory.empty()
    stds = []
    for x in np.arange(0.0, 3.01, 0.5):
        vp = np.array([x, 0.0])
        segs = tuple(
            FloorSegment(endpoints=ends, cov=_seen_from(ends, vp)) for ends in (left, right)
        )
        memory = fuse(memory, view(segs, at=(x, 0.0, 0.0)))
        assert len(memory.segments) == 2
        (region,) = build_memory_model(memory, 0.5).most_probable.critical_regions
        stds.append(region.width_std_m)
    assert np.all(np.diff(stds) < 0)
    assert stds[-1] < 0.5 * stds[0]


def test_a_new_ambiguity_coinciding_with_a_remembered_segment_is_reweighted_or_absorbed() -> None:
    wall = seg((4.0, -0.5), (4.0, 0.5))
    # seen twice, from viewpoints 0.5 m apart (independent views)
    memory = fuse(fuse(ModelMemory.empty(), view((wall,))), view((wall,), at=(0.5, 0.0, 0.0)))
    e = posterior(0.5, HIT)
    assert memory.existence == pytest.approx((e,), abs=1e-12)
    ghost = seg((2.5, -0.3), (2.5, 0.3))  # the wrong disparity, nearer
    for q, absorbed in ((0.5, False), (0.6, True)):
        amb = AmbiguousSegment(candidates=(wall, ghost), probabilities=(q, 1 - q))
        later = fuse(memory, view(ambiguous=(amb,), at=(0.0, 0.0, 0.0)))
        w_wall, w_ghost = (1 - NONE) * q * (1 + e * (HIT - 1)), (1 - NONE) * (1 - q)
        p_wall = w_wall / (w_wall + w_ghost + NONE)
        assert (p_wall >= 0.95) == absorbed
        assert later.existence == pytest.approx((posterior(e, 1 + q * (HIT - 1)),), abs=1e-12)
        assert len(later.segments) == 1
        if absorbed:
            assert later.ambiguous == ()
            # the wall's Gaussian twice, then once more from 0.5 m on (an independent view)
            P = np.linalg.inv(3 * np.linalg.inv(wall.cov[0]))
            np.testing.assert_allclose(later.segments[0].cov[0], P, atol=1e-12)
        else:
            (open_,) = later.ambiguous
            total = w_wall + w_ghost + NONE
            assert open_.probabilities == pytest.approx(
                (w_wall / total, w_ghost / total), abs=1e-12
            )
            assert open_.p_none == pytest.approx(NONE / total, abs=1e-12)


def test_a_remembered_segment_seen_again_is_evidence_for_a_candidate_on_it() -> None:
    wall = seg((4.0, -0.5), (4.0, 0.5))
    ghost = seg((2.5, -0.3), (2.5, 0.3))
    memory = fuse(fuse(ModelMemory.empty(), view((wall,))), view((wall,), at=(0.5, 0.0, 0.0)))
    amb = AmbiguousSegment(candidates=(wall, ghost), probabilities=(0.5, 0.5))
    memory = fuse(memory, view(ambiguous=(amb,)))  # open: the wall's candidate at 0.94
    (open_,) = memory.ambiguous
    (p_wall, p_ghost), none = open_.probabilities, open_.p_none
    # the wall seen again, unambiguously: a detection of the wall's candidate too (pd / pf);
    # the ghost's place in view in front of it, nothing there (a miss)
    keep_open = {"resolve_probability": 0.9999, "min_candidate_probability": 0.0}
    again = fuse(memory, view((wall,), at=(0.5, 0.0, 0.0)), **keep_open)
    w = np.array([p_wall * HIT, p_ghost * MISS])
    (got,) = again.ambiguous
    assert got.probabilities == pytest.approx(tuple(w / (w.sum() + none)), abs=1e-12)
    assert again.ambiguous_seen == (4,)
    # with the default resolve probability it resolves into the wall
    resolved = fuse(memory, view((wall,), at=(0.5, 0.0, 0.0)))
    assert resolved.ambiguous == () and len(resolved.segments) == 1
    assert resolved.existence[0] >= w[0] / (w.sum() + none)


def test_a_resolved_candidate_coinciding_with_a_remembered_segment_fuses_into_it() -> None:
    true, false = seg((4.0, 0.5), (4.0, 1.0)), seg((6.0, 0.75), (6.0, 1.4))
    amb = AmbiguousSegment(candidates=(true, false), probabilities=(0.5, 0.5))
    # the ambiguity first, then its true edge unambiguously from a view that misses the false
    # candidate's place; then from the side
    memory = fuse(ModelMemory.empty(), view(ambiguous=(amb,)))
    side = fuse(memory, view((true,), at=(4.0, -3.0, math.pi / 2)))
    assert side.ambiguous == () and len(side.segments) == 1
    again = fuse(side, view((true,), at=(4.0, -3.0, math.pi / 2)))
    assert len(again.segments) == 1


def test_p_none_is_respected_and_resolves_when_every_candidate_is_seen_free() -> None:
    a, b = seg((3.0, -0.4), (3.0, -0.1)), seg((4.0, 0.2), (4.0, 0.5))
    amb = AmbiguousSegment(candidates=(a, b), probabilities=(0.4, 0.3))  # p_none 0.3
    memory = fuse(ModelMemory.empty(), view(ambiguous=(amb,)))
    assert memory.ambiguous[0].probabilities == (0.4, 0.3)  # above the none prior: as it is
    p, none = np.array([0.4, 0.3]), 0.3
    for _ in range(3):  # both places seen free again and again, nothing there
        memory = fuse(memory, view())
        p, none = p * MISS, none
        p, none = p / (p.sum() + none), none / (p.sum() + none)
        if none >= 0.95:
            break
        assert memory.ambiguous[0].probabilities == pytest.approx(tuple(p), abs=1e-12)
        assert memory.ambiguous[0].p_none == pytest.approx(none, abs=1e-12)
    assert none >= 0.95 and memory.ambiguous == ()
    assert build_memory_model(memory, 0.5).most_probable.obstacles == ()


def test_a_single_candidate_with_p_none_seen_again_becomes_a_segment() -> None:
    a = seg((3.0, -0.4), (3.0, -0.1))
    amb = AmbiguousSegment(candidates=(a,), probabilities=(0.6,))
    memory = fuse(ModelMemory.empty(), view(ambiguous=(amb,)))
    assert len(memory.ambiguous) == 1 and memory.segments == ()
    later = fuse(memory, view((a,)))
    assert later.ambiguous == ()
    assert later.existence == pytest.approx((0.6 * HIT / (0.6 * HIT + 0.4),), abs=1e-12)


def test_a_candidate_below_the_pruning_threshold_goes_one_stays_with_p_none() -> None:
    a, b = seg((3.0, -0.4), (3.0, -0.1)), seg((3.5, 0.8), (3.5, 1.0))
    amb = AmbiguousSegment(candidates=(a, b), probabilities=(0.5, 0.3))  # p_none 0.2
    memory = fuse(ModelMemory.empty(), view(ambiguous=(amb,)))
    # a seen free (in view), b hidden behind a wall that the new view sees
    wall = seg((2.5, 0.5), (2.5, 1.5))
    later = fuse(memory, view((wall,)), min_candidate_probability=0.4)
    w_a, w_b, none = 0.5 * MISS, 0.3, 0.2
    (open_,) = later.ambiguous
    assert len(open_.candidates) == 1
    np.testing.assert_array_equal(open_.candidates[0].endpoints, b.endpoints)
    assert open_.probabilities == pytest.approx((w_b / (w_b + none),), abs=1e-12)
    assert w_a / (w_a + w_b + none) < 0.4


def test_fuse_commutes_with_a_rigid_motion() -> None:
    rng = np.random.default_rng(7)
    pts = rng.uniform([2, -2], [6, 2], size=(12, 2))
    segs = tuple(seg(p, p + np.array([0.3, 0.1])) for p in pts)
    amb = AmbiguousSegment(
        candidates=(seg((3.0, 0.2), (3.0, 0.6)), seg((5.0, 0.4), (5.0, 1.1))),
        probabilities=(0.6, 0.3),
    )
    views = [
        view(segs, (amb,)),
        view(segs[:8], at=(0.5, 0.2, 0.15)),
        view(segs[4:], (amb,), at=(1.0, -0.3, -0.2)),
    ]
    angle, shift = 0.7, np.array([3.0, -1.5])
    plain, moved = ModelMemory.empty(), ModelMemory.empty()
    for obs in views:
        plain, moved = fuse(plain, obs), fuse(moved, obs.transformed(angle, shift))
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, -s], [s, c]])
    assert moved.existence == pytest.approx(plain.existence, abs=1e-9)
    assert len(moved.ambiguous) == len(plain.ambiguous)
    for a, b in zip(plain.segments, moved.segments, strict=True):
        np.testing.assert_allclose(b.endpoints, a.endpoints @ R.T + shift, atol=1e-9)
        np.testing.assert_allclose(b.cov, R @ a.cov @ R.T, atol=1e-12)
    for a, b in zip(plain.ambiguous, moved.ambiguous, strict=True):
        assert b.probabilities == pytest.approx(a.probabilities, abs=1e-9)
    area = shapely.affinity.translate(
        shapely.affinity.rotate(plain.seen, angle, (0, 0), True), *shift
    )
    assert shapely.symmetric_difference(area, moved.seen).area < 1e-3 * plain.seen.area


def test_a_memory_survives_a_pickle_round_trip() -> None:
    memory = fuse(ModelMemory.empty(), view((seg((3.0, -0.5), (3.0, 0.5)),)))
    memory = add_contact(memory, (1.0, 0.0), (1.0, 0.0), height_m=0.3)
    back = pickle.loads(pickle.dumps(memory))
    assert back.existence == memory.existence and back.views == memory.views
    np.testing.assert_array_equal(back.segments[0].cov, memory.segments[0].cov)
    assert shapely.equals_exact(back.seen, memory.seen, 0.0)
    assert fuse(back, view()).existence == fuse(memory, view()).existence
