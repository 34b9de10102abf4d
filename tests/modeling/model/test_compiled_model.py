"""The model's compiled loops equal their readable references (modeling.model.obstacles,
modeling.model.partitions and modeling.model.ambiguity, sections 4.1 and 4.2)."""

from __future__ import annotations

import itertools
import pathlib

import numpy as np
import pytest

import modeling.model.situations as situations_module
from modeling.model._kernels.ambiguity import ChoiceEffects, choice_effects
from modeling.model._kernels.hull import finish_hulls
from modeling.model.ambiguity import (
    Effect,
    Elimination,
    _base_state,
    _signature,
    candidate_adjacency,
    eliminate_units_of_one_effect,
    eliminate_units_of_one_effect_reference,
    units_moving_together,
    units_moving_together_reference,
)
from modeling.model.build import EnvironmentModel, build_model
from modeling.model.gaps import Relation
from modeling.model.items import isolated_short_segments, item_relations, items_of
from modeling.model.obstacles import (
    components,
    components_reference,
    finish_hulls_reference,
    geos_hull_sets,
)
from modeling.model.partitions import situation_partitions, situation_partitions_reference
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from tests.modeling.model.test_figures import seg
from tests.modeling.records import situation_record


def _random_sets(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` point sets of every kind: spread, collinear, coincident, one or two points."""
    sets = []
    for _ in range(n):
        kind = rng.integers(0, 5)
        m = int(rng.integers(1, 8))
        if kind == 0:  # spread: a proper hull
            pts = rng.normal(size=(m + 3, 2))
        elif kind == 1:  # collinear, in random order
            t = rng.uniform(-2.0, 2.0, m + 2)
            pts = rng.normal(size=2) + t[:, None] * rng.normal(size=2)
        elif kind == 2:  # coincident
            pts = np.repeat(rng.normal(size=(1, 2)), m, axis=0)
        elif kind == 3:  # almost collinear (a thin hull from GEOS)
            t = rng.uniform(-2.0, 2.0, m + 3)
            pts = np.stack([t, 1e-13 * rng.normal(size=t.shape[0])], axis=1)
        else:  # one or two points
            pts = rng.normal(size=(int(rng.integers(1, 3)), 2))
        sets.append(pts)
    index = np.repeat(np.arange(n), [s.shape[0] for s in sets])
    return np.concatenate(sets), index


@pytest.mark.parametrize("seed", range(6))
def test_finish_hulls_kernel_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 12
    points, index = _random_sets(rng, n)
    grow = rng.uniform(0.01, 0.2, n)
    sets = geos_hull_sets(points, index, n, grow)
    flat_before = sets.flat.copy()
    got = finish_hulls(sets)
    want = finish_hulls_reference(sets)
    np.testing.assert_array_equal(got.offsets, want.offsets)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(sets.flat, flat_before)  # the inputs are not changed
    assert got.offsets[-1] == got.vertices.shape[0]


def test_finish_hulls_kernel_equals_reference_on_one_grow_for_all() -> None:
    rng = np.random.default_rng(11)
    points, index = _random_sets(rng, 8)
    sets = geos_hull_sets(points, index, 8, 0.05)
    got, want = finish_hulls(sets), finish_hulls_reference(sets)
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(got.offsets, want.offsets)


@pytest.mark.parametrize("seed", range(8))
def test_union_find_equals_the_csgraph_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for n in (1, 2, 7, 40, 300):
        m = int(rng.integers(0, 2 * n + 1))
        i, j = rng.integers(0, n, m), rng.integers(0, n, m)
        got, want = components(n, i, j), components_reference(n, i, j)
        assert got.dtype == want.dtype == np.int64
        np.testing.assert_array_equal(got, want)


def _situation_inputs(rng: np.random.Generator, n_sit: int, n: int, m: int) -> tuple:
    """Random partition inputs: ``m`` relations among ``n`` items of every kind, in ``n_sit``
    situations with random active items; ``p_passable`` and distances with ties."""
    i = rng.integers(0, max(n - 1, 1), m)
    j = np.minimum(i + rng.integers(1, max(n, 2), m), max(n - 1, 0))
    kind = rng.integers(0, 3, m)  # impassable, undecided, short passable
    act = rng.random((n_sit, n)) < rng.uniform(0.3, 1.0)
    p = np.round(rng.random(m), 1)  # ties within groups: row order decides
    d = np.round(rng.uniform(0.0, 2.0, m), 1)
    return act, i, j, kind == 0, kind == 1, kind == 2, p, d


@pytest.mark.parametrize("seed", range(10))
def test_partition_kernel_equals_its_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    cases = [(1, 0, 0), (1, 1, 0), (2, 3, 0)]  # degenerate: no items, no relations
    cases += [
        (int(rng.integers(1, 6)), int(rng.integers(2, 40)), int(rng.integers(0, 120)))
        for _ in range(12)
    ]
    multi = shared = 0
    for n_sit, n, m in cases:
        args = _situation_inputs(rng, n_sit, n, m)
        if n_sit > 1 and rng.random() < 0.5:  # situations that share most items, as models do
            act = args[0]
            act[1:] = act[0] | (rng.random(act[1:].shape) < 0.1)
        got, want = situation_partitions(*args), situation_partitions_reference(*args)
        for name, g, w in zip(got._fields, got, want, strict=True):
            for a, b in zip(g, w, strict=True) if isinstance(g, tuple) else [(g, w)]:
                assert np.asarray(a).dtype == np.asarray(b).dtype, name
                np.testing.assert_array_equal(a, b, err_msg=name)
        multi += int((np.diff(got.first_obst) > 1).any() and got.und[0].size > 1)
        shared += int(got.counts.shape[0] < got.obstacle.shape[0])
    assert multi >= 3  # several obstacles and undecided groups to sort, not only empty cases
    assert shared >= 1  # obstacles found again in later situations


def _shelf_observation(rng: np.random.Generator) -> FloorObservation:
    """Ambiguous segments of every kind for Fig. 7: rows of repeated edges whose candidates move
    together (a shelf front seen at several disparities), some with a "none" choice, some
    displaced inconsistently or out of reach of each other, and candidates at equal distances
    from the viewpoint (ties of the rank order)."""
    ambiguous = []
    for _ in range(int(rng.integers(0, 6))):
        m = int(rng.integers(1, 4))
        mass = float(rng.choice([1.0, 0.8])) if m > 1 else float(rng.uniform(0.2, 0.9))
        x0, y0 = rng.uniform(-3.0, 3.0), rng.uniform(1.0, 6.0)
        step = rng.normal(size=2) * rng.choice([0.05, 0.4])  # displacement between candidates
        tie = rng.random() < 0.2  # candidates 0 and 1 mirrored about the viewpoint: equal ranks
        for k in range(int(rng.integers(1, 4))):  # a row: the same candidates, displaced alike
            base = np.array([x0 + 0.3 * k, y0]) + rng.normal(size=2) * rng.choice([0.0, 0.05, 1.0])
            if rng.random() < 0.15:  # a stray member: another count or another "none" mass
                m, mass = (2, 0.8) if m == 1 else (m, 1.0 if mass < 1.0 else 0.8)
            ends = [
                np.stack([a, a + rng.normal(size=2) * 0.3]) for a in base + np.outer(range(m), step)
            ]
            if tie and m > 1:  # candidate 1 mirrors 0 about the viewpoint's line x = 0
                ends[1] = ends[0] * [-1.0, 1.0]
            cands = [seg(e[0], e[1]) for e in ends]
            p = rng.dirichlet(np.ones(m)) * mass if m > 1 else np.array([mass])
            ambiguous.append(
                AmbiguousSegment(candidates=tuple(cands), probabilities=tuple(p.tolist()))
            )
    return FloorObservation(
        segments=(seg((0.0, 0.0), (1.0, 0.0)),),
        ambiguous=tuple(ambiguous),
        viewpoint=np.array([0.0, -2.0, 1.5708]),
    )


@pytest.mark.parametrize("seed", range(8))
def test_moving_together_kernel_equals_its_numpy_reference(seed: int) -> None:
    """Fig. 7's units: members, items by rank, choices and probabilities equal to the last bit
    (on every live subset: some segments eliminated before)."""
    rng = np.random.default_rng(seed)
    joined = 0
    for _ in range(40):
        obs = _shelf_observation(rng)
        items = items_of(obs)
        n_amb = len(obs.ambiguous)
        live = sorted(rng.choice(n_amb, size=int(rng.integers(0, n_amb + 1)), replace=False))
        width = float(rng.choice([0.4, 0.6, 2.0]))
        args = (obs, [int(a) for a in live], items.of_ambiguous, items.ends, width)
        got, want = units_moving_together(*args), units_moving_together_reference(*args)
        assert len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            assert (g.members, g.items, g.choices) == (w.members, w.items, w.choices)
            assert g.probabilities.tobytes() == w.probabilities.tobytes()
        joined += sum(len(u.members) > 1 for u in got)
    assert joined >= 3  # units of several members, not only singletons


_DRIVE = pathlib.Path(__file__).parent / "data" / "memory_drive.npz"
"""Three fused observations recorded on ``scripts/bench_env.py``'s drive (the default scene,
``memory=True``): a median one (69 segments, 10 ambiguities), the largest (115 segments, 37
ambiguities, 4,786 relations, 64 situations) and the most ambiguous (38 ambiguities)."""


def _recorded_observations() -> list[FloorObservation]:
    data = np.load(_DRIVE)
    out = []
    for k in range(3):

        def segments(prefix: str, k: int = k) -> list[FloorSegment]:
            ends, cov, height = (data[f"v{k}_{prefix}{f}"] for f in ("ends", "cov", "height"))
            return [
                FloorSegment(endpoints=e, cov=c, height_m=h)
                for e, c, h in zip(ends, cov, height, strict=True)
            ]

        cands, probs = segments("cand_"), data[f"v{k}_cand_prob"].tolist()
        at = np.concatenate(([0], np.cumsum(data[f"v{k}_cand_count"]))).tolist()
        view = data[f"v{k}_view"]
        out.append(
            FloorObservation(
                segments=tuple(segments("")),
                ambiguous=tuple(
                    AmbiguousSegment(candidates=tuple(cands[a:b]), probabilities=tuple(probs[a:b]))
                    for a, b in itertools.pairwise(at)
                ),
                viewpoint=view[:3],
                fov_rad=float(view[3]),
                max_range_m=float(view[4]),
            )
        )
    return out


def _model_record(model: EnvironmentModel) -> list[object]:
    """Every field of every situation's obstacles, regions and passages, arrays as bytes."""
    return [situation_record(s) for s in model.situations] + [
        model.residual_probability,
        [r.tobytes() for r in model.occluded],
    ]


@pytest.mark.parametrize("case", range(9))
def test_situations_from_the_compiled_partitions_equal_the_readable_ones(case: int) -> None:
    # the recorded fused observations of an env drive, then shelves of every kind of ambiguity
    if case < 3:
        obs = _recorded_observations()[case]
    else:
        obs = _shelf_observation(np.random.default_rng(100 + case))
    got = build_model(obs, 0.5)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(situations_module, "situation_partitions", situation_partitions_reference)
        want = build_model(obs, 0.5)
    assert _model_record(got) == _model_record(want)
    if case == 1:
        assert len(got.situations) == 64 and len(got.relations) > 4000


def _random_factors(rng: np.random.Generator) -> list[np.ndarray]:
    """Up to 12 factors of 1-5 choices each, sorted descending, with ties and tiny ones."""
    out = []
    for _ in range(int(rng.integers(0, 13))):
        m = int(rng.integers(1, 6))
        kind = rng.integers(0, 3)
        if kind == 0:
            w = rng.uniform(0.01, 1.0, m)
        elif kind == 1:  # ties
            w = np.repeat(rng.uniform(0.1, 1.0, 1), m)
        else:  # some (almost) zero
            w = np.where(rng.random(m) < 0.5, 1e-320, rng.uniform(0.01, 1.0, m))
        out.append(np.sort(w / w.sum())[::-1])
    return out


@pytest.mark.parametrize("seed", range(40))
def test_k_best_kernel_equals_the_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    probs = _random_factors(rng)
    for k in (1, 2, 7, 64, 200):
        got = situations_module.k_best(probs, k)
        want = situations_module.k_best_reference(probs, k)
        assert [s for _, s in got] == [s for _, s in want]
        assert [np.float64(p).tobytes() for p, _ in got] == [
            np.float64(p).tobytes() for p, _ in want
        ]


def _elimination_record(e: Elimination) -> list[object]:
    return [e.remaining, e.eliminated, e.fixed_items, e.merged, e.active.tobytes(), e.affected]


@pytest.mark.parametrize("case", range(6))
def test_compiled_elimination_equals_its_python_reference(case: int) -> None:
    """Fig. 8 with each round's signatures from the compiled pass equals the Python signatures'
    elimination: on the recorded fused observations and shelf scenes, with the base model's
    items and with random extra items active (other labels, merges and undecided pairs)."""
    rng = np.random.default_rng(40 + case)
    obs = _recorded_observations()[case] if case < 3 else _shelf_observation(rng)
    items = items_of(obs)
    rel = item_relations(items, 0.5, 0.05)
    isolation = isolated_short_segments(items, rel, 0.1)
    units = units_moving_together(
        obs, isolation.live_ambiguous, items.of_ambiguous, items.ends, 0.5
    )
    base = np.zeros(items.ends.shape[0], dtype=bool)
    base[list(isolation.kept_segments)] = True
    bases = [base, base | (rng.random(base.shape[0]) < 0.2), np.zeros_like(base)]
    adjacency = candidate_adjacency(rel, items.ambiguous)
    counts = {"eliminated": 0, "remaining": 0}
    effect_of = dict(enumerate((Effect.NEW, Effect.MERGE, Effect.UNDECIDED, Effect.NEAR)))
    size = items.ends.shape[0] + 1
    n_changes = 0
    for active in bases:
        # Each choice's signature: the compiled codes decoded, against the Python signature.
        choices = [c for u in units for c in u.items]
        codes, starts = choice_effects(
            ChoiceEffects(
                ri=rel.i,
                rj=rel.j,
                kind=rel.kind,
                is_cand=items.ambiguous >= 0,
                active=active,
                items=np.array([x for c in choices for x in c], dtype=np.int64),
                starts=np.cumsum([0, *(len(c) for c in choices)]),
            ),
            int(Relation.IMPASSABLE),
            int(Relation.UNDECIDED),
        )
        labels, und_pairs = _base_state(rel, active)
        for k, choice in enumerate(choices):
            mine = codes[starts[k] : starts[k + 1]].tolist()
            decoded = {(effect_of[c // size // size], c // size % size, c % size) for c in mine}
            want_sig = _signature(choice, adjacency, labels.tolist(), und_pairs, active.tolist())
            assert decoded == want_sig
            n_changes += len(mine)
        got = eliminate_units_of_one_effect(units, rel, items.ambiguous, active)
        want = eliminate_units_of_one_effect_reference(units, rel, adjacency, active)
        assert _elimination_record(got) == _elimination_record(want)
        counts["eliminated"] += len(got.eliminated)
        counts["remaining"] += len(got.remaining)
    assert len(units) > 0 and counts["remaining"] > 0 and n_changes > 0
    assert case >= 3 or counts["eliminated"] > 0  # the recorded ones eliminate some units
