"""Diagnostics against ground truth, on hand-made observations of hand-made scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling.memory.fusion import ModelMemory, fuse
from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from stereo_nav_env.diagnostics import (
    DIAGNOSTIC_NAMES,
    GroundTruth,
    memory_beliefs,
    memory_diagnostics,
    model_diagnostics,
    normalised_outline_errors,
    normalised_outline_errors_reference,
)
from stereo_nav_env.sim.scenes import Obstacle, Scene, make_obstacle, oriented_rect

SIGMA = 0.03
COV = np.tile(np.diag([SIGMA**2, SIGMA**2]), (2, 1, 1))


def _seg(a: tuple[float, float], b: tuple[float, float]) -> FloorSegment:
    return FloorSegment(endpoints=np.array([a, b], dtype=float), cov=COV)


def _scene(*obstacles: Obstacle) -> Scene:
    return Scene(
        name="t", bounds=(-1.0, -3.0, 8.0, 3.0), obstacles=obstacles, start=(0, 0, 0), goal=(7, 0)
    )


def test_normalised_errors_across_the_nearest_outline() -> None:
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    edges = np.stack([square, np.roll(square, -1, axis=0)], axis=1)
    pts = np.array([[1.1, 0.5], [0.5, -0.2], [0.5, 1.0], [0.5, 0.9]])
    cov = np.tile(np.diag([0.01, 0.04]), (4, 1, 1))
    z = normalised_outline_errors(pts, cov, edges)
    # 0.1 m across x (sigma 0.1), 0.2 m across y (sigma 0.2), on an edge, 0.1 m inside (sigma 0.2)
    assert z.tolist() == pytest.approx([1.0, 1.0, 0.0, 0.5])
    assert np.isnan(normalised_outline_errors(pts, cov, np.zeros((0, 2, 2)))).all()


def test_nees_and_coverage_of_endpoints_off_the_outline_by_known_sigmas() -> None:
    box = make_obstacle("box", oriented_rect((4.0, 0.0), 1.0, 2.0))  # front face at x = 3.5
    truth = GroundTruth.of(_scene(box), 0.5)
    obs = FloorObservation(
        segments=(
            _seg((3.53, 0.2), (3.53, 0.6)),  # 1 sigma inside the front face
            _seg((3.44, -0.6), (3.44, -0.2)),  # 2 sigma in front of it
        ),
        viewpoint=np.zeros(3),
    )
    d = model_diagnostics(build_model(obs, 0.5), truth)
    assert d["nees_mean"] == pytest.approx((1 + 1 + 4 + 4) / 4)
    assert d["coverage_95"] == 0.5 and d["endpoints"] == 4.0
    assert "p_true_candidate" not in d and d["ambiguous_segments"] == 0.0


def test_p_true_candidate_is_the_probability_of_the_candidate_on_the_outline() -> None:
    box = make_obstacle("box", oriented_rect((4.0, 0.0), 1.0, 2.0))
    truth = GroundTruth.of(_scene(box), 0.5)
    amb = AmbiguousSegment(
        candidates=(_seg((2.9, 0.2), (2.9, 0.6)), _seg((3.5, 0.2), (3.5, 0.6))),
        probabilities=(0.7, 0.3),
    )
    obs = FloorObservation(
        segments=(_seg((3.5, -0.6), (3.5, -0.2)),), ambiguous=(amb,), viewpoint=np.zeros(3)
    )
    d = model_diagnostics(build_model(obs, 0.5), truth)
    assert d["p_true_candidate"] == pytest.approx(0.3) and d["ambiguous_segments"] == 1.0


def test_p_true_candidate_of_an_ambiguity_of_false_matches_only_is_its_none_mass() -> None:
    box = make_obstacle("box", oriented_rect((4.0, 0.0), 1.0, 2.0))  # front face at x = 3.5
    truth = GroundTruth.of(_scene(box), 0.5)
    far = AmbiguousSegment(  # 0.6 m and 1.5 m (20 and 50 sigma) in front of the face
        candidates=(_seg((2.9, 0.2), (2.9, 0.6)), _seg((2.0, 0.2), (2.0, 0.6))),
        probabilities=(0.5, 0.2),
    )
    obs = FloorObservation(
        segments=(_seg((3.5, -0.6), (3.5, -0.2)),), ambiguous=(far,), viewpoint=np.zeros(3)
    )
    d = model_diagnostics(build_model(obs, 0.5), truth)
    assert d["p_true_candidate"] == pytest.approx(0.3)  # p_none: no candidate is real


def test_passability_brier_over_a_doubtful_gap_in_view() -> None:
    # two thin walls at x in [3.5, 3.6], 0.55 m apart across y: wider than the 0.5 m robot
    a = make_obstacle("wall", oriented_rect((3.55, 1.0), 1.0, 0.1, math.pi / 2))
    b = make_obstacle("wall", oriented_rect((3.55, -0.55), 1.0, 0.1, math.pi / 2))
    truth = GroundTruth.of(_scene(a, b), 0.5)
    assert truth.gap_passable.tolist() == [True]
    segs = (_seg((3.5, 0.5), (3.5, 1.5)), _seg((3.5, -1.05), (3.5, -0.05)))
    model = build_model(FloorObservation(segments=segs, viewpoint=np.zeros(3)), 0.5)
    (region,) = model.situations[0].critical_regions
    d = model_diagnostics(model, truth)
    assert d["gaps_in_view"] == 1.0 and d["gaps_scored"] == 1.0
    assert d["passability_brier"] == pytest.approx((1.0 - region.p_passable) ** 2)
    # looking the other way, the gap is out of view: the figure is left out, its counts are 0
    away = build_model(
        FloorObservation(segments=segs, viewpoint=np.array([0.0, 0.0, math.pi])), 0.5
    )
    d = model_diagnostics(away, truth)
    assert d["gaps_in_view"] == 0.0 and "passability_brier" not in d
    assert list(d) == [n for n in DIAGNOSTIC_NAMES if n in d]


def test_ground_truth_outlines_include_legs_and_exclude_parts_above_the_band() -> None:
    table = make_obstacle("table", oriented_rect((4.0, 0.0), 1.2, 0.7), 0.75)
    truth = GroundTruth.of(_scene(table), 0.5)
    n_parts = sum(1 for p in table.parts if p.z_max_m >= 0.05 and p.z_min_m <= 1.0)
    assert n_parts >= 5  # the top and four legs
    assert truth.edges.shape == (sum(p.footprint.shape[0] for p in table.parts), 2, 2)
    low = GroundTruth.of(_scene(table), 0.5, max_height_m=0.5)  # below the top: legs only
    assert low.edges.shape[0] < truth.edges.shape[0]


def test_an_empty_observation_has_only_counts() -> None:
    truth = GroundTruth.of(_scene(), 0.5)
    d = model_diagnostics(build_model(FloorObservation(viewpoint=np.zeros(3)), 0.5), truth)
    assert d == {
        "endpoints": 0.0,
        "ambiguous_segments": 0.0,
        "gaps_in_view": 0.0,
        "gaps_scored": 0.0,
        "situations": float(len(build_model(FloorObservation(), 0.5).situations)),
        "residual_probability": 0.0,
    }


@pytest.mark.parametrize("seed", range(6))
def test_outline_error_loop_equals_its_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, e = int(rng.integers(1, 40)), int(rng.integers(1, 25))
    pts = rng.uniform(-3.0, 3.0, (n, 2))
    a = rng.uniform(0.01, 0.3, (n, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2) + 1e-6 * np.eye(2)
    edges = rng.uniform(-3.0, 3.0, (e, 2, 2))
    edges[0] = [pts[0], pts[0] + 1.0]  # a point exactly on an edge
    got = normalised_outline_errors(pts, cov, edges)
    np.testing.assert_array_equal(got, normalised_outline_errors_reference(pts, cov, edges))
    assert got[0] == 0.0


def _ghost_and_wall() -> tuple[EnvironmentModel, FloorSegment, GroundTruth]:
    """A view whose one ambiguity is a ghost (0.6) or the wall at x = 4 (0.4, the true one)."""
    height = np.array([0.0, 0.5])
    wall = FloorSegment(endpoints=np.array([[4.0, -0.5], [4.0, 0.5]]), cov=COV, height_m=height)
    ghost = FloorSegment(endpoints=np.array([[2.5, -0.3], [2.5, 0.3]]), cov=COV, height_m=height)
    truth = GroundTruth(
        edges=np.array([[[4.0, -1.0], [4.0, 1.0]]]),
        gap_points=np.zeros((0, 2, 2)),
        gap_passable=np.zeros(0, dtype=bool),
    )
    amb = AmbiguousSegment(candidates=(ghost, wall), probabilities=(0.6, 0.4))
    return build_model(FloorObservation(ambiguous=(amb,)), 0.5), wall, truth


def test_memory_beliefs_read_the_memory_at_the_true_candidate() -> None:
    view, wall, truth = _ghost_and_wall()
    memory = fuse(ModelMemory.empty(), FloorObservation(segments=(wall,)))  # existence 0.5
    assert memory_beliefs(view, memory, truth, 13.28) == [(0.4, 0.5)]
    # no candidate on the outline: the truth is "none", believed as 1 - the largest belief
    far = GroundTruth(
        edges=truth.edges + 5.0, gap_points=truth.gap_points, gap_passable=truth.gap_passable
    )
    ((p_view, belief),) = memory_beliefs(view, memory, far, 13.28)
    assert p_view == pytest.approx(0.0) and belief == 0.5


def test_memory_p_true_candidate_scores_the_views_ambiguities_resolved_or_open() -> None:
    view, wall, truth = _ghost_and_wall()
    # the memory resolved the wall (a remembered segment, existence 0.9): the view's ambiguity
    # scores 0.9 though the memory holds no ambiguity open
    resolved = ModelMemory(segments=(wall,), existence=(0.9,), last_seen=(0,))
    model = build_model(resolved.observation(), 0.5)
    d = memory_diagnostics(model, resolved, 13.28, view, truth)
    assert d["memory_p_true_candidate"] == pytest.approx(0.9)
    assert "memory_open_p_true_candidate" not in d and d["memory_ambiguous_segments"] == 0.0
    # the memory holds the view's ambiguity open: both figures are its probability of the wall
    held = fuse(ModelMemory.empty(), view.observation)
    p_wall = held.ambiguous[0].probabilities[1]
    assert 0.3 < p_wall <= 0.4  # the view's 0.4, shrunk towards "none" by the first view
    d = memory_diagnostics(build_model(held.observation(), 0.5), held, 13.28, view, truth)
    assert d["memory_open_p_true_candidate"] == pytest.approx(p_wall)
    assert d["memory_p_true_candidate"] == pytest.approx(p_wall)
    # a view without ambiguities: nothing to score
    plain = build_model(FloorObservation(segments=(wall,)), 0.5)
    assert "memory_p_true_candidate" not in memory_diagnostics(model, resolved, 13.28, plain, truth)
