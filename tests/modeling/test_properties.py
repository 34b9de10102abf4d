"""Property-based tests of the model (hypothesis)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import modeling.model.situations as situations_module
from modeling.model.build import build_model
from modeling.model.gaps import gap_passable_probability
from modeling.model.records import Situation
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from tests.modeling.records import situation_record

W = 0.5


def _cov(rng: np.random.Generator) -> np.ndarray:
    a = rng.uniform(0, math.pi)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return R @ np.diag(rng.uniform(0.005, 0.15, 2) ** 2) @ R.T


def _seg(rng: np.random.Generator) -> FloorSegment:
    a = rng.uniform(0, 4, 2)
    ang = rng.uniform(0, 2 * math.pi)
    b = a + rng.uniform(0.05, 1.5) * np.array([math.cos(ang), math.sin(ang)])
    return FloorSegment(endpoints=np.array([a, b]), cov=np.stack([_cov(rng), _cov(rng)]))


@st.composite
def observations(draw: st.DrawFn) -> FloorObservation:
    seed = draw(st.integers(0, 2**31 - 1))
    n_seg = draw(st.integers(0, 10))
    n_amb = draw(st.integers(0, 3))
    rng = np.random.default_rng(seed)
    ambs = []
    for _ in range(n_amb):
        m = int(rng.integers(2, 4))
        p = rng.dirichlet(np.ones(m))
        ambs.append(
            AmbiguousSegment(candidates=tuple(_seg(rng) for _ in range(m)), probabilities=tuple(p))
        )
    return FloorObservation(
        segments=tuple(_seg(rng) for _ in range(n_seg)),
        ambiguous=tuple(ambs),
        viewpoint=np.array([2.0, -3.0, math.pi / 2]),
    )


# Deterministic (the same examples every run) and without an example database.
SETTINGS = settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
    database=None,
)


@SETTINGS
@given(observations(), st.integers(1, 12))
def test_probabilities_and_residual_sum_to_one(obs: FloorObservation, k: int) -> None:
    m = build_model(obs, W, max_situations=k)
    probs = [s.probability for s in m.situations]
    assert 1 <= len(probs) <= k
    assert math.fsum(probs) + m.residual_probability == pytest.approx(1.0, abs=1e-12)
    assert probs == sorted(probs, reverse=True)
    assert m.residual_probability >= 0


def _reordered(obs: FloorObservation) -> tuple[FloorObservation, np.ndarray]:
    """The segments in reverse order, each with its endpoints swapped; and old -> new index."""
    n = len(obs.segments)
    flipped = tuple(
        FloorSegment(endpoints=s.endpoints[::-1], cov=s.cov[::-1]) for s in obs.segments[::-1]
    )
    new = FloorObservation(segments=flipped, viewpoint=obs.viewpoint)
    return new, np.arange(n)[::-1].copy()


@SETTINGS
@given(observations())
def test_relations_are_symmetric_and_listed_once(obs: FloorObservation) -> None:
    m = build_model(obs, W)
    rel = m.relations
    assert np.all(rel.i < rel.j)
    pairs = set(zip(rel.i.tolist(), rel.j.tolist(), strict=True))
    assert len(pairs) == len(rel)
    for a, b in list(pairs)[:20]:
        assert rel.kind_of(a, b) == rel.kind_of(b, a)
        assert rel.p_of(a, b) == rel.p_of(b, a)
    # Symmetric in substance: with the segments in reverse order and each segment's endpoints
    # swapped, every pair (now seen from the other side) has the same relation.
    plain = FloorObservation(segments=obs.segments, viewpoint=obs.viewpoint)
    r1 = build_model(plain, W).relations
    flipped, new_index = _reordered(plain)
    r2 = build_model(flipped, W).relations
    t1 = {(a, b): (k, p) for a, b, k, p in zip(r1.i, r1.j, r1.kind, r1.p_passable, strict=True)}
    t2 = {
        (min(new_index[a], new_index[b]), max(new_index[a], new_index[b])): (k, p)
        for a, b, k, p in zip(r2.i, r2.j, r2.kind, r2.p_passable, strict=True)
    }
    assert t1.keys() == t2.keys()
    for key, (k1, p1) in t1.items():
        k2, p2 = t2[key]
        assert abs(p1 - p2) < 1e-9
        if min(abs(p1 - 0.05), abs(p1 - 0.95)) > 1e-6:
            assert k1 == k2


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 60), st.floats(0.0, 3.0))
def test_union_find_components_match_scipy(seed: int, n: int, density: float) -> None:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from modeling.model.obstacles import components as _components

    rng = np.random.default_rng(seed)
    m = int(density * n)
    i, j = rng.integers(0, n, m), rng.integers(0, n, m)
    labels = _components(n, i, j)
    _, ref = connected_components(coo_matrix((np.ones(m), (i, j)), shape=(n, n)), directed=False)
    # The same partition, each component labelled by its smallest node.
    assert len(set(zip(labels.tolist(), ref.tolist(), strict=True))) == len(set(ref.tolist()))
    assert len(set(labels.tolist())) == len(set(ref.tolist()))
    for c in set(labels.tolist()):
        assert c == np.flatnonzero(labels == c).min()


@settings(max_examples=200, deadline=None, derandomize=True, database=None)
@given(
    st.lists(st.lists(st.floats(0.01, 1.0), min_size=1, max_size=4), min_size=0, max_size=6),
    st.integers(1, 40),
)
def test_k_best_situations_are_the_exact_top_k(weights: list[list[float]], k: int) -> None:
    import itertools

    from modeling.model.situations import k_best as _k_best

    probs = [np.sort(np.array(w) / sum(w))[::-1] for w in weights]
    got = _k_best(probs, k)
    every = sorted(
        (
            math.prod(float(p[s]) for p, s in zip(probs, state, strict=True))
            for state in itertools.product(*(range(len(p)) for p in probs))
        ),
        reverse=True,
    )
    assert len(got) == min(k, len(every))
    assert [g[0] for g in got] == pytest.approx(every[: len(got)], rel=1e-12, abs=1e-15)
    assert len({g[1] for g in got}) == len(got)  # no choice twice
    for prob, state in got:
        assert prob == pytest.approx(
            math.prod(float(p[s]) for p, s in zip(probs, state, strict=True))
        )


@SETTINGS
@given(observations())
def test_obstacles_partition_the_kept_items(obs: FloorObservation) -> None:
    m = build_model(obs, W)
    for s in m.situations:
        segs = [x for o in s.obstacles for x in o.segments]
        cands = [c for o in s.obstacles for c in o.candidates]
        assert len(segs) == len(set(segs))
        assert len(cands) == len(set(cands))
        assert sorted(segs) == list(m.kept_segments)
        expected = {(a, c) for a, c in s.choice.items()} | set(m.merged_ambiguous.items())
        assert set(cands) == expected
        for reg in s.critical_regions:
            i, j = reg.obstacles
            assert 0 <= i < j < len(s.obstacles)
            assert 0.0 <= reg.p_passable <= 1.0


@SETTINGS
@given(observations(), st.integers(2, 12))
def test_situations_assembled_together_equal_each_assembled_alone(
    obs: FloorObservation, k: int
) -> None:
    # the situations are partitioned in one pass over all of them: none may see another's items
    calls: list[tuple[Any, ...]] = []
    batched = situations_module._situations

    def recording(*args: Any) -> list[Situation]:
        calls.append(args)
        return batched(*args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(situations_module, "_situations", recording)
        together = build_model(obs, W, max_situations=k).situations
    ctx, actives, probabilities, choices, width = calls[0]
    alone = [
        batched(ctx, [a], [p], [c], width)[0]
        for a, p, c in zip(actives, probabilities, choices, strict=True)
    ]
    alone.sort(key=lambda s: -s.probability)  # as enumerate_situations orders them
    assert [situation_record(s) for s in together] == [situation_record(s) for s in alone]


@SETTINGS
@given(
    observations(),
    st.floats(-math.pi, math.pi),
    st.floats(-20, 20),
    st.floats(-20, 20),
)
def test_rigid_motion_changes_no_relation_and_no_probability(
    obs: FloorObservation, angle: float, tx: float, ty: float
) -> None:
    m1 = build_model(obs, W)
    m2 = build_model(obs.transformed(angle, np.array([tx, ty])), W)
    r1, r2 = m1.relations, m2.relations

    def table(r):
        return {
            (a, b): (k, p)
            for a, b, k, p in zip(
                r.i.tolist(), r.j.tolist(), r.kind.tolist(), r.p_passable.tolist(), strict=True
            )
        }

    t1, t2 = table(r1), table(r2)
    for key in set(t1) | set(t2):
        k1, p1 = t1.get(key, (0, 1.0))
        k2, p2 = t2.get(key, (0, 1.0))
        assert abs(p1 - p2) < 1e-6
        if min(abs(p1 - 0.05), abs(p1 - 0.95)) > 1e-6:
            assert k1 == k2
    assert [s.probability for s in m1.situations] == pytest.approx(
        [s.probability for s in m2.situations], abs=1e-12
    )
    assert [len(s.obstacles) for s in m1.situations] == [len(s.obstacles) for s in m2.situations]
    assert [len(s.critical_regions) for s in m1.situations] == [
        len(s.critical_regions) for s in m2.situations
    ]


@SETTINGS
@given(observations())
def test_pairs_left_out_are_surely_passable(obs: FloorObservation) -> None:
    # Every pair of items, by brute force: the relation table lists all pairs that are not
    # surely passable, with the same probability, and leaves out only pairs above 1 - eps / 1000.
    from modeling.model.relations import closest_points

    m = build_model(obs, W)
    ends = np.array(
        [s.endpoints for s in obs.segments]
        + [c.endpoints for a in obs.ambiguous for c in a.candidates]
    ).reshape(-1, 2, 2)
    covs = np.array(
        [s.cov for s in obs.segments] + [c.cov for a in obs.ambiguous for c in a.candidates]
    ).reshape(-1, 2, 2, 2)
    n = ends.shape[0]
    i, j = np.triu_indices(n, k=1)
    if i.size == 0:
        return
    s, t = closest_points(ends[i, 0], ends[i, 1], ends[j, 0], ends[j, 1])
    pi = (1 - s)[:, None] * ends[i, 0] + s[:, None] * ends[i, 1]
    pj = (1 - t)[:, None] * ends[j, 0] + t[:, None] * ends[j, 1]
    ci = ((1 - s) ** 2)[:, None, None] * covs[i, 0] + (s**2)[:, None, None] * covs[i, 1]
    cj = ((1 - t) ** 2)[:, None, None] * covs[j, 0] + (t**2)[:, None, None] * covs[j, 1]
    p = np.array([gap_passable_probability(pi[k], ci[k], pj[k], cj[k], W) for k in range(i.size)])
    listed = {
        (a, b): q
        for a, b, q in zip(m.relations.i, m.relations.j, m.relations.p_passable, strict=True)
    }
    amb_of = np.r_[
        np.full(len(obs.segments), -1),
        np.repeat(np.arange(len(obs.ambiguous)), [len(a.candidates) for a in obs.ambiguous]),
    ].astype(int)
    for k, (a, b) in enumerate(zip(i.tolist(), j.tolist(), strict=True)):
        if amb_of[a] >= 0 and amb_of[a] == amb_of[b]:
            assert (a, b) not in listed  # candidates of one segment never coexist
        elif (a, b) in listed:
            assert abs(listed[a, b] - p[k]) < 1e-4
        else:
            assert p[k] > 1 - 0.05 / 1000 - 1e-9


def test_examined_pairs_grow_linearly_with_the_segments() -> None:
    from modeling.model.relations import segment_relations

    def grid(side: int) -> tuple[np.ndarray, np.ndarray]:
        # Short walls on a 1.2 m grid, stereo-like covariances (depth sd 5 cm).
        xy = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) * 1.2
        ends = np.stack([xy, xy + np.array([0.6, 0.1])], axis=1)
        cov = np.broadcast_to(np.diag([0.05**2, 0.005**2]), (xy.shape[0], 2, 2, 2)).copy()
        return ends, cov

    counts = []
    for side in (15, 45):  # 225 and 2025 segments
        ends, cov = grid(side)
        counts.append(len(segment_relations(ends, cov, W, 0.05)) / ends.shape[0])
    assert counts[1] < 1.3 * counts[0] < 20
