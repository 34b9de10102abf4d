"""Segment relations (modeling.model.relations): candidate pairs, closest points, classification."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modeling.model.gaps import Relation, gap_passable_probability
from modeling.model.relations import (
    EarlierRelations,
    _pairs_along_earlier,
    _pairs_and_params,
    candidate_pairs,
    closest_points_reference,
    earlier_rows,
    prune_sigmas,
    segment_relations,
)

W = 0.5
EPS = 0.05


def _layout(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2, 2) endpoints on a 1/8 m grid (boxes that merely touch occur) and (n, 2, 2, 2)
    stereo-like endpoint covariances."""
    rng = np.random.default_rng(seed)
    ends = np.round(rng.uniform(0.0, 6.0, (n, 2, 2)) * 8.0) / 8.0
    cov = np.broadcast_to(np.diag([0.05**2, 0.01**2]), (n, 2, 2, 2)).copy()
    return ends, cov


def _brute_force_pairs(ends: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Every pair ``i < j`` whose mean segments are within ``W + k (sigma_i + sigma_j)``."""
    n = ends.shape[0]
    i, j = np.triu_indices(n, k=1)
    s, t = closest_points_reference(ends[i, 0], ends[i, 1], ends[j, 0], ends[j, 1])
    pa = ends[i, 0] + s[:, None] * (ends[i, 1] - ends[i, 0])
    pb = ends[j, 0] + t[:, None] * (ends[j, 1] - ends[j, 0])
    sigma = np.sqrt((cov[:, :, 0, 0] + cov[:, :, 1, 1]).max(axis=1))
    keep = np.hypot(*(pb - pa).T) <= W + prune_sigmas(EPS) * (sigma[i] + sigma[j])
    return np.stack([i[keep], j[keep]], axis=1)


@pytest.mark.parametrize("n", [2, 7, 40, 150])
def test_candidate_pairs_are_the_brute_force_pairs_sorted(n: int) -> None:
    # The STRtree's envelope query loses no pair of the exact filter, and the rows come sorted
    # by (i, j), as the all-pairs loop it replaced gave them.
    ends, cov = _layout(n, seed=n)
    pairs = candidate_pairs(ends, cov, W, EPS)
    expected = _brute_force_pairs(ends, cov)
    assert pairs.dtype == np.int64 and np.array_equal(pairs, expected)
    assert n < 40 or len(pairs) > 0


def test_fewer_than_two_segments_have_no_pairs() -> None:
    ends, cov = _layout(1, seed=0)
    assert candidate_pairs(ends, cov, W).shape == (0, 2)
    assert len(segment_relations(ends, cov, W, EPS)) == 0


def test_a_doorway_is_undecided_and_a_wide_gap_passable() -> None:
    # Two collinear wall pieces along x; depth (y) sd 0.1 m at every endpoint.
    cov = np.broadcast_to(np.diag([0.01**2, 0.1**2]), (4, 2, 2, 2)).copy()
    ends = np.array(
        [
            [[-2.0, 0.0], [0.0, 0.0]],
            [[0.49, 0.0], [2.0, 0.0]],  # 0.49 m from the first: a doorway
            [[3.6, 0.0], [5.0, 0.0]],
            [[0.0, 0.05], [0.0, 1.0]],  # 5 cm from the first piece: impassable to it
        ]
    )
    rel = segment_relations(ends, cov, W, EPS)
    assert rel.kind_of(0, 1) is Relation.UNDECIDED
    assert rel.kind_of(1, 0) is Relation.UNDECIDED  # symmetric
    assert rel.kind_of(0, 3) is Relation.IMPASSABLE
    assert rel.kind_of(1, 2) is Relation.PASSABLE  # 1.6 m apart: not even listed
    assert rel.p_of(1, 2) == 1.0 and not np.any((rel.i == 1) & (rel.j == 2))
    # The doorway's closest points are the facing endpoints, with the endpoints' covariances.
    row = int(np.flatnonzero((rel.i == 0) & (rel.j == 1))[0])
    assert np.array_equal(rel.point_i[row], [0.0, 0.0]) and np.array_equal(
        rel.point_j[row], [0.49, 0.0]
    )
    assert np.array_equal(rel.cov_i[row], cov[0, 1]) and np.array_equal(rel.cov_j[row], cov[1, 0])
    assert rel.distance_m[row] == pytest.approx(0.49)
    exact = gap_passable_probability(
        rel.point_i[row], rel.cov_i[row], rel.point_j[row], rel.cov_j[row], W
    )
    assert rel.p_of(0, 1) == pytest.approx(exact, abs=1e-4) and 0.05 < exact < 0.95


def test_the_middle_of_a_long_wall_is_related() -> None:
    # A short segment facing the middle of a long wall: the closest point is interpolated, with
    # covariance (1 - t)^2 C0 + t^2 C1.
    c0, c1 = np.diag([0.02**2, 0.04**2]), np.diag([0.03**2, 0.01**2])
    ends = np.array([[[-3.0, 0.0], [3.0, 0.0]], [[1.5, 0.4], [1.5, 1.0]]])
    cov = np.array([[c0, c1], [c0, c0]])
    rel = segment_relations(ends, cov, W, EPS)
    t = 4.5 / 6.0
    np.testing.assert_allclose(rel.point_i[0], [1.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(rel.cov_i[0], (1 - t) ** 2 * c0 + t**2 * c1, rtol=1e-14)
    assert rel.kind_of(0, 1) is Relation.IMPASSABLE  # 0.4 m < 0.5 m


def test_given_pairs_in_either_order_give_the_same_rows() -> None:
    ends, cov = _layout(30, seed=3)
    rel = segment_relations(ends, cov, W, EPS)
    flipped = np.stack([rel.j, rel.i], axis=1)
    again = segment_relations(ends, cov, W, EPS, pairs=flipped)
    for name in (
        "i",
        "j",
        "point_i",
        "point_j",
        "cov_i",
        "cov_j",
        "distance_m",
        "p_passable",
        "kind",
    ):
        assert np.array_equal(getattr(again, name), getattr(rel, name)), name
    sub = rel.subset(rel.kind == Relation.IMPASSABLE)
    assert len(sub) == np.count_nonzero(rel.kind == Relation.IMPASSABLE) > 0
    assert np.all(sub.kind == Relation.IMPASSABLE) and np.all(sub.i < sub.j)


def test_grouped_segments_are_the_rows_of_other_groups_unchanged() -> None:
    ends, cov = _layout(40, seed=5)
    group = np.random.default_rng(5).integers(-1, 4, 40)
    rel = segment_relations(ends, cov, W, EPS)
    grouped = segment_relations(ends, cov, W, EPS, group=group)
    same = (group[rel.i] >= 0) & (group[rel.i] == group[rel.j])
    assert same.any() and not same.all()
    want = rel.subset(~same)
    for name in rel.__dataclass_fields__:
        assert np.array_equal(getattr(grouped, name), getattr(want, name)), name


def test_a_zero_width_robot_passes_everywhere() -> None:
    ends, cov = _layout(20, seed=4)
    rel = segment_relations(ends, cov, 0.0, EPS)
    assert len(rel) > 0 and np.all(rel.p_passable == 1.0) and np.all(rel.kind == Relation.PASSABLE)


def test_relations_taking_earlier_rows_equal_those_computed() -> None:
    """Rows taken from earlier relations (segments unchanged, moved, reordered, some changed,
    added or dropped) equal the rows computed, bit for bit."""
    rng = np.random.default_rng(11)
    n = 40
    ends = rng.uniform(0.0, 5.0, (n, 2, 2))
    cov = np.tile(np.eye(2) * 0.01, (n, 2, 1, 1)) * rng.uniform(0.2, 3.0, (n, 1, 1, 1))
    group = np.where(rng.random(n) < 0.3, rng.integers(0, 4, n), -1)
    first = segment_relations(ends, cov, W, EPS, group=group)
    # The next call: some segments changed, the rest shuffled, a few new ones, a few dropped.
    keep = rng.permutation(n)[: n - 4]
    ends2, cov2, group2 = ends[keep].copy(), cov[keep].copy(), group[keep].copy()
    ends2[:6] += rng.normal(scale=0.05, size=(6, 2, 2))
    ends2 = np.concatenate((ends2, rng.uniform(0.0, 5.0, (3, 2, 2))))
    cov2 = np.concatenate((cov2, np.tile(np.eye(2) * 0.01, (3, 2, 1, 1))))
    group2 = np.concatenate((group2, [-1, -1, 0]))
    earlier = EarlierRelations(ends, cov, W, first)
    for width in (W, W + 0.1):  # another width: nothing taken
        got = segment_relations(ends2, cov2, width, EPS, group=group2, earlier=earlier)
        want = segment_relations(ends2, cov2, width, EPS, group=group2)
        for f in dataclasses.fields(want):
            assert np.array_equal(getattr(got, f.name), getattr(want, f.name)), f.name
    taken = earlier_rows(ends2, cov2, _pairs_and_params(ends2, cov2, W, EPS), earlier)
    assert 0 < np.count_nonzero(taken >= 0) < taken.shape[0]


def _next_call(
    rng: np.random.Generator, ends: np.ndarray, cov: np.ndarray, group: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The segments of a next call in the fused memory's way: the same order, a few dropped,
    some changed a little, a few new ones appended, the groups renumbered."""
    n = ends.shape[0]
    keep = np.sort(rng.permutation(n)[: n - 4])
    ends2, cov2 = ends[keep].copy(), cov[keep].copy()
    group2 = np.where(group[keep] >= 0, group[keep] + 3, -1)
    moved = rng.permutation(keep.shape[0])[:8]
    ends2[moved] += rng.normal(scale=0.05, size=(8, 2, 2))
    ends2 = np.concatenate((ends2, rng.uniform(0.0, 5.0, (3, 2, 2))))
    cov2 = np.concatenate((cov2, np.tile(np.eye(2) * 0.01, (3, 2, 1, 1))))
    return ends2, cov2, np.concatenate((group2, [-1, -1, 9]))


@pytest.mark.parametrize("seed", [12, 13, 14])
def test_pairs_of_unchanged_segments_taken_from_earlier_relations_equal_those_found(
    seed: int,
) -> None:
    """Where the unchanged segments kept their order and grouping, their pairs come from the
    earlier relations and only the changed ones' are looked for: the relations equal those
    made anew, bit for bit; a reordering, a regrouping or another eps makes them anew."""
    rng = np.random.default_rng(seed)
    n = 60
    ends = rng.uniform(0.0, 5.0, (n, 2, 2))
    cov = np.tile(np.eye(2) * 0.01, (n, 2, 1, 1)) * rng.uniform(0.2, 3.0, (n, 1, 1, 1))
    group = np.where(rng.random(n) < 0.4, rng.integers(0, 6, n), -1)
    first = segment_relations(ends, cov, W, EPS, group=group)
    earlier = EarlierRelations(ends, cov, W, first, eps=EPS, group=group)
    ends2, cov2, group2 = _next_call(rng, ends, cov, group)
    merged = group2.copy()
    merged[merged >= 0] = 5  # every candidate of one ambiguous segment: another grouping
    flipped = np.arange(ends2.shape[0])[::-1]
    cases = [
        (ends2, cov2, group2, EPS, True),
        (ends2, cov2, merged, EPS, False),
        (ends2[flipped], cov2[flipped], group2[flipped], EPS, False),
        (ends2, cov2, group2, 2 * EPS, False),
    ]
    for e, c, g, eps, along in cases:
        got = segment_relations(e, c, W, eps, group=g, earlier=earlier)
        want = segment_relations(e, c, W, eps, group=g)
        for f in dataclasses.fields(want):
            assert np.array_equal(getattr(got, f.name), getattr(want, f.name)), f.name
        found = _pairs_along_earlier(e, c, W, eps, g, earlier)
        assert (found is not None) == along
        if found is not None:
            params, take = found
            assert np.array_equal(params.i, want.i) and np.array_equal(params.j, want.j)
            assert 0 < np.count_nonzero(take >= 0) < take.shape[0]
