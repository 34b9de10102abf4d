"""Triangulation to the floor: exact geometry, linearised covariance vs Monte Carlo, height band,
ambiguity bookkeeping, the end-to-end helper and bad input."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from modeling.observation import FloorObservation
from modeling.stereo.faces import FACE_SOURCE
from modeling.stereo.matching import StereoMatches
from modeling.stereo.pipeline import stereo_to_floor
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import extract_segment_pair
from modeling.stereo.triangulation import (
    TriangulationOptions,
    triangulate_points,
    triangulate_to_floor,
)
from tests.modeling.synth import render_pair

RIG = StereoRig()
CX, CY = RIG.principal_point_px
POSE = HeadPose(x_m=1.0, y_m=2.0, heading_rad=math.pi / 2, height_m=0.8)


def _matches(
    rows: list[tuple[int, float, float, float, float, float]], var: float = 0.1
) -> StereoMatches:
    """rows: (left_index, probability, u, v_top, v_bottom, disparity) of vertical edges."""
    m = len(rows)
    li = np.array([r[0] for r in rows])
    p = np.array([r[1] for r in rows])
    ends = np.array([[[r[2], r[3]], [r[2], r[4]]] for r in rows], dtype=float).reshape(m, 2, 2)
    d = np.array([[r[5], r[5]] for r in rows], dtype=float).reshape(m, 2)
    return StereoMatches(
        left_index=li,
        right_index=np.arange(m),
        probability=p,
        left_endpoints=ends,
        disparity_px=d,
        disparity_var=np.full((m, 2), 2 * var),
        u_left_var=np.full((m, 2), var),
        v_var=np.ones((m, 2)),
        peak_disparity_px=d[:, 0] if m else np.zeros(0),
        peak_height=p * 10,
        opposite_polarity=np.zeros(m, dtype=bool),
    )


def test_vertical_edge_lands_at_the_true_floor_point_with_clipped_heights() -> None:
    # a vertical edge at X = 0.3 m, Z = 2 m in the left camera frame, from 1.3 m down to the floor
    Z, X = 2.0, 0.3
    d = RIG.fb / Z
    u = RIG.focal_px * X / Z + CX
    v_top = RIG.focal_px * (0.8 - 1.3) / Z + CY  # height 1.3 m
    v_bot = RIG.focal_px * (0.8 - 0.0) / Z + CY  # the floor
    obs = triangulate_to_floor(_matches([(7, 1.0, u, v_top, v_bot, d)]), RIG, POSE)
    assert len(obs.segments) == 1 and obs.ambiguous == ()
    seg = obs.segments[0]
    assert seg.source == 7
    # heading +90 deg: camera z (forward) is world +y, camera x (right) is world +x
    want = np.array([1.0 + X, 2.0 + Z])
    np.testing.assert_allclose(seg.endpoints, [want, want], atol=1e-9)
    np.testing.assert_allclose(seg.height_m, [1.0, 0.05], atol=1e-9)  # clipped to the band
    np.testing.assert_allclose(obs.viewpoint, [1.0, 2.0, math.pi / 2])
    assert obs.fov_rad == pytest.approx(RIG.hfov_rad) and obs.max_range_m == RIG.max_depth_m
    # depth std ~ Z^2 / (f b) * sigma_d along world y (the optical axis)
    sd = math.sqrt(0.2) * Z**2 / RIG.fb
    assert math.sqrt(seg.cov[0, 1, 1]) == pytest.approx(sd, rel=1e-6)
    assert seg.cov[0, 1, 1] > 10 * seg.cov[0, 0, 0]


def test_linearised_covariance_matches_monte_carlo() -> None:
    rng = np.random.default_rng(0)
    u, v, d = 220.0, 150.0, 12.0
    var_ul, var_ur, var_v = 0.09, 0.12, 1.0
    _, cov = triangulate_points(
        np.array([u]),
        np.array([v]),
        np.array([d]),
        np.array([var_ul]),
        np.array([var_ul + var_ur]),
        np.array([var_ul]),
        np.array([var_v]),
        RIG,
    )
    n = 200_000
    ul = u + rng.normal(0, math.sqrt(var_ul), n)
    ur = u - d + rng.normal(0, math.sqrt(var_ur), n)
    vv = v + rng.normal(0, math.sqrt(var_v), n)
    P = RIG.triangulate(ul, vv, ul - ur)
    mc = np.cov(P.T)
    np.testing.assert_allclose(cov[0], mc, rtol=0.05, atol=1e-6)


def test_height_band_drops_and_clips() -> None:
    Z = 3.0
    d = RIG.fb / Z
    u = 200.0

    def v_of(h: float) -> float:
        return RIG.focal_px * (0.8 - h) / Z + CY

    rows = [
        (0, 1.0, u, v_of(2.0), v_of(1.5), d),  # entirely above the robot: dropped
        (1, 1.0, u, v_of(0.04), v_of(0.0), d),  # on the floor: dropped
        (2, 1.0, u, v_of(0.6), v_of(0.2), d),  # inside: kept unchanged
    ]
    obs = triangulate_to_floor(_matches(rows), RIG, POSE)
    assert [s.source for s in obs.segments] == [2]
    np.testing.assert_allclose(obs.segments[0].height_m, [0.6, 0.2], atol=1e-9)
    tight = triangulate_to_floor(_matches(rows), RIG, POSE, min_height_m=0.3, max_height_m=0.5)
    np.testing.assert_allclose(tight.segments[0].height_m, [0.5, 0.3], atol=1e-9)


def test_a_point_match_crosses_no_band_edge_and_nothing_raises() -> None:
    # both ends of a row at one image point: the band crossing t = (k d0 - (v0 - cy) b) /
    # (dv b - k dd) divides by zero (dv = dd = 0); above the band it is dropped, inside it is kept
    # as a point at its height
    Z = 3.0
    d = RIG.fb / Z

    def v_of(h: float) -> float:
        return RIG.focal_px * (0.8 - h) / Z + CY

    rows = [(0, 1.0, 200.0, v_of(1.5), v_of(1.5), d), (1, 1.0, 200.0, v_of(0.4), v_of(0.4), d)]
    obs = triangulate_to_floor(_matches(rows), RIG, POSE)
    assert [s.source for s in obs.segments] == [1]
    np.testing.assert_allclose(obs.segments[0].height_m, [0.4, 0.4], atol=1e-9)
    np.testing.assert_array_equal(obs.segments[0].endpoints[0], obs.segments[0].endpoints[1])


def test_ambiguous_candidates_in_the_band_keep_their_probabilities() -> None:
    u = 200.0
    v0 = RIG.focal_px * (0.8 - 0.9) / 2.0 + CY
    v1 = RIG.focal_px * (0.8 - 0.1) / 2.0 + CY
    rows = [(3, 0.5, u, v0, v1, 15.6), (3, 0.3, u, v0, v1, 30.0), (3, 0.2, u, v0, v1, 45.0)]
    obs = triangulate_to_floor(_matches(rows), RIG, POSE)
    assert obs.segments == () and len(obs.ambiguous) == 1
    amb = obs.ambiguous[0]
    assert len(amb.candidates) == 3 and amb.probabilities == pytest.approx((0.5, 0.3, 0.2))
    assert amb.p_none == 0.0
    assert all(c.source == 3 for c in amb.candidates)
    # nearer candidates (larger disparity) lie closer to the viewpoint
    dist = [np.linalg.norm(c.midpoint - obs.viewpoint[:2]) for c in amb.candidates]
    assert dist[0] > dist[1] > dist[2]


def test_candidates_outside_the_height_band_keep_their_mass_as_no_obstacle() -> None:
    # Issue 16c: a candidate above the band is a possible match that is no obstacle; its mass
    # stays as p_none, it is not spread over the survivors (a 0.4 candidate never becomes certain).
    u = 200.0
    v0 = RIG.focal_px * (0.8 - 0.9) / 2.0 + CY
    v1 = RIG.focal_px * (0.8 - 0.1) / 2.0 + CY
    # one of three above 1 m: the others keep (0.5, 0.3), p_none = 0.2
    some_out = [(3, 0.5, u, v0, v1, 15.6), (3, 0.3, u, v0, v1, 30.0), (3, 0.2, u, 5.0, 15.0, 15.6)]
    obs3 = triangulate_to_floor(_matches(some_out), RIG, POSE)
    assert obs3.ambiguous[0].probabilities == pytest.approx((0.5, 0.3))
    assert obs3.ambiguous[0].p_none == pytest.approx(0.2)
    # two candidates, the 0.6 one above 1 m: the 0.4 survivor stays a 0.4 possibility
    two_out = [(5, 0.6, u, 10.0, 20.0, 15.6), (5, 0.4, u, v0, v1, 15.6)]
    obs2 = triangulate_to_floor(_matches(two_out), RIG, POSE)
    assert obs2.segments == () and len(obs2.ambiguous) == 1
    (amb,) = obs2.ambiguous
    assert len(amb.candidates) == 1 and amb.candidates[0].source == 5
    assert amb.probabilities == pytest.approx((0.4,)) and amb.p_none == pytest.approx(0.6)
    # every candidate out of the band: nothing is emitted
    all_out = [(6, 0.6, u, 10.0, 20.0, 15.6), (6, 0.4, u, 10.0, 20.0, 30.0)]
    obs0 = triangulate_to_floor(_matches(all_out), RIG, POSE)
    assert obs0.segments == () and obs0.ambiguous == ()
    # a none mass below min_probability is ignored like a candidate below it: one certain segment
    tiny = [(7, 1.0 - 1e-8, u, v0, v1, 15.6), (7, 1e-8, u, 10.0, 20.0, 15.6)]
    obs1 = triangulate_to_floor(_matches(tiny), RIG, POSE)  # min_probability 1e-6
    assert [s.source for s in obs1.segments] == [7] and obs1.ambiguous == ()
    # ... but not below a smaller floor
    obs1b = triangulate_to_floor(_matches(tiny), RIG, POSE, min_probability=1e-9)
    assert obs1b.segments == () and obs1b.ambiguous[0].p_none == pytest.approx(1e-8)


def test_empty_matches_give_empty_observation() -> None:
    obs = triangulate_to_floor(StereoMatches.empty(), RIG, POSE)
    assert isinstance(obs, FloorObservation) and obs.segments == () and obs.ambiguous == ()


def test_wrong_arguments_raise_naming_them() -> None:
    m = StereoMatches.empty()
    with pytest.raises(ValueError, match="matches"):
        triangulate_to_floor(None, RIG, POSE)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="rig"):
        triangulate_to_floor(m, None, POSE)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="head_pose"):
        triangulate_to_floor(m, RIG, (0, 0, 0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="min_height_m"):
        triangulate_to_floor(m, RIG, POSE, min_height_m=1.0, max_height_m=0.5)
    with pytest.raises(ValueError, match="min_probability"):
        triangulate_to_floor(m, RIG, POSE, min_probability=1.0)
    with pytest.raises(ValueError, match="max_height_m"):
        triangulate_to_floor(m, RIG, POSE, max_height_m=float("inf"))
    with pytest.raises(ValueError, match="bogus"):
        triangulate_to_floor(m, RIG, POSE, bogus=1.0)
    with pytest.raises(ValueError, match="TriangulationOptions"):
        triangulate_to_floor(m, RIG, POSE, {"min_height_m": 0.1})  # type: ignore[arg-type]


def test_options_object_and_keywords_agree() -> None:
    u = 200.0
    v0 = RIG.focal_px * (0.8 - 0.9) / 2.0 + CY
    v1 = RIG.focal_px * (0.8 - 0.1) / 2.0 + CY
    m = _matches([(1, 1.0, u, v0, v1, 15.6)])
    band = TriangulationOptions(min_height_m=0.3, max_height_m=0.5)
    by_object = triangulate_to_floor(m, RIG, POSE, band)
    by_keywords = triangulate_to_floor(m, RIG, POSE, min_height_m=0.3, max_height_m=0.5)
    np.testing.assert_allclose(by_object.segments[0].height_m, [0.5, 0.3], atol=1e-9)
    np.testing.assert_array_equal(
        by_object.segments[0].endpoints, by_keywords.segments[0].endpoints
    )
    # a keyword overrides the object's field
    wide = triangulate_to_floor(m, RIG, POSE, band, max_height_m=1.0)
    np.testing.assert_allclose(wide.segments[0].height_m, [0.9, 0.3], atol=1e-9)


@pytest.mark.parametrize("tilt", [0.0, 0.3, -0.15])
def test_floor_covariance_is_the_world_xy_block_of_the_3d_one(tilt: float) -> None:
    # slanted segments at several depths seen from a turned (and tilted) head: the floor
    # covariance must be the (x, y) block of R (J S J^T) R^T, the means the triangulated points,
    # the heights their world z (with a tilt, the row's variance moves the floor point too)
    rng = np.random.default_rng(5)
    pose = HeadPose(x_m=-1.0, y_m=0.5, heading_rad=2.3, height_m=0.8, tilt_rad=tilt)
    n = 12
    u0 = rng.uniform(20, 300, n)
    v0 = rng.uniform(130, 160, n)
    v1 = v0 + rng.uniform(20, 60, n)
    d = rng.uniform(8, 40, (n, 2))
    m = StereoMatches(
        left_index=np.arange(n),
        right_index=np.arange(n),
        probability=np.ones(n),
        left_endpoints=np.stack(
            [np.stack([u0, v0], -1), np.stack([u0 + rng.uniform(-9, 9, n), v1], -1)], axis=1
        ),
        disparity_px=d,
        disparity_var=rng.uniform(0.05, 0.5, (n, 2)),
        u_left_var=rng.uniform(0.01, 0.04, (n, 2)),
        v_var=np.ones((n, 2)),
        peak_disparity_px=d.mean(axis=1),
        peak_height=np.ones(n),
        opposite_polarity=np.zeros(n, dtype=bool),
    )
    obs = triangulate_to_floor(m, RIG, pose, min_height_m=-10.0, max_height_m=10.0)
    assert len(obs.segments) == n
    R = pose.R_cam2world
    for seg in obs.segments:
        k = seg.source
        P, C = triangulate_points(
            m.left_endpoints[k, :, 0],
            m.left_endpoints[k, :, 1],
            m.disparity_px[k],
            m.u_left_var[k],
            m.disparity_var[k],
            m.u_left_var[k],
            m.v_var[k],
            RIG,
        )
        P_w = pose.cam_to_world(P)
        np.testing.assert_allclose(seg.endpoints, P_w[:, :2], atol=1e-12)
        np.testing.assert_allclose(seg.height_m, P_w[:, 2], atol=1e-12)
        np.testing.assert_allclose(seg.cov, (R @ C @ R.T)[:, :2, :2], rtol=1e-10, atol=1e-15)


def test_row_order_and_invalid_rows() -> None:
    u = 200.0
    v0 = RIG.focal_px * (0.8 - 0.9) / 2.0 + CY
    v1 = RIG.focal_px * (0.8 - 0.1) / 2.0 + CY
    rows = [(3, 0.3, u, v0, v1, 30.0), (1, 1.0, u, v0, v1, 15.6), (3, 0.7, u, v0, v1, 15.6)]
    obs = triangulate_to_floor(_matches(rows), RIG, POSE)  # rows not grouped by left segment
    assert [s.source for s in obs.segments] == [1]
    assert obs.ambiguous[0].probabilities == pytest.approx((0.7, 0.3))  # most probable first
    # zero, negative or non-finite disparities: those rows are dropped, nothing raises
    bad = [(0, 1.0, u, v0, v1, 0.0), (1, 1.0, u, v0, v1, -5.0), (2, 1.0, u, v0, v1, np.inf)]
    obs_bad = triangulate_to_floor(_matches([*bad, (4, 1.0, u, v0, v1, 15.6)]), RIG, POSE)
    assert [s.source for s in obs_bad.segments] == [4] and obs_bad.ambiguous == ()


def test_stereo_to_floor_end_to_end_grey_and_rgb() -> None:
    rng = np.random.default_rng(0)
    # a board at X in [-0.4, -0.1], Z = 2 m, from 1.4 m above the camera down to the floor
    left, right, _ = render_pair(RIG, [(-0.4, -0.1, -0.6, 0.8, 2.0, 200.0)], noise=2.0, rng=rng)
    pose = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
    obs = stereo_to_floor(left, right, RIG, pose, close_faces=False)  # the paper's stages
    assert len(obs.segments) == 2
    xs = sorted(float(s.endpoints[:, 0].mean()) for s in obs.segments)
    np.testing.assert_allclose(xs, [2.0, 2.0], atol=0.05)  # world x = depth
    ys = sorted(float(s.endpoints[:, 1].mean()) for s in obs.segments)
    np.testing.assert_allclose(ys, [0.1, 0.4], atol=0.01)  # world y = -X_cam
    # by default the board's bottom edge also joins its two edges (modeling.stereo.faces)
    closed = stereo_to_floor(left, right, RIG, pose)
    assert len(closed.segments) == 3
    (face,) = [s for s in closed.segments if s.source == FACE_SOURCE]
    np.testing.assert_allclose(sorted(face.endpoints[:, 1]), [0.1, 0.4], atol=0.01)
    rgb = stereo_to_floor(np.dstack([left] * 3), np.dstack([right] * 3), RIG, pose)
    assert len(rgb.segments) == 3
    with pytest.raises(ValueError, match="close_faces"):
        stereo_to_floor(left, right, RIG, pose, close_faces="yes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="left"):
        stereo_to_floor(left.astype(np.float32), right, RIG, pose)
    with pytest.raises(ValueError, match="right"):
        stereo_to_floor(left, right[:, :100], RIG, pose)
    with pytest.raises(ValueError, match="unknown"):
        stereo_to_floor(left, right, RIG, pose, bogus=1)


def test_the_rigs_sigma_px_drives_the_endpoint_covariance() -> None:
    # Issue 16e: StereoRig.sigma_px is the floor of the per-point variance of the segment fit. On
    # clean edges (no pixel noise, no correlated bias) the floor holds for every segment, so the
    # whole floor covariance scales with sigma_px^2: doubling it doubles every endpoint std.
    left, right, _ = render_pair(RIG, [(-0.4, -0.1, -0.6, 0.8, 2.0, 200.0)])
    pose = HeadPose(x_m=0.0, y_m=0.0, heading_rad=0.0, height_m=0.8)
    obs = {}
    for sigma in (0.5, 1.0):
        rig = dataclasses.replace(RIG, sigma_px=sigma)
        sl, sr = extract_segment_pair(left, right, rig=rig, bias_sigma_px=0.0)
        assert np.all(sl.point_var == sigma**2) and np.all(sr.point_var == sigma**2)
        obs[sigma] = stereo_to_floor(left, right, rig, pose, bias_sigma_px=0.0)
    a, b = obs[0.5], obs[1.0]
    assert len(a.segments) == len(b.segments) >= 2
    for sa, sb in zip(a.segments, b.segments, strict=True):
        np.testing.assert_array_equal(sa.endpoints, sb.endpoints)  # the means do not move
        np.testing.assert_allclose(sb.cov, 4.0 * sa.cov, rtol=1e-12)
        std_a = np.sqrt(np.linalg.eigvalsh(sa.cov))
        np.testing.assert_allclose(np.sqrt(np.linalg.eigvalsh(sb.cov)), 2.0 * std_a, rtol=1e-9)
