"""Hypothesis over the modeling core: any floor observation gives a valid model or a ValueError.

Degenerate inputs are generated on purpose: coincident endpoints, near-singular and huge
covariances, coincident and collinear segments, ambiguous candidates on top of each other, and
large observations. The number of examples comes from the hypothesis profile: ``ci`` (the
default, a few hundred) or ``soak`` (10,000: ``make fuzz``), see ``tests/conftest.py``.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

ROBOT_WIDTH_M = 0.5


def _cov(rng: np.random.Generator, kind: str) -> np.ndarray:
    """A positive-definite (2, 2) covariance of the given kind."""
    a = rng.uniform(0.0, math.pi)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    if kind == "huge":
        sd = rng.uniform(10.0, 1e3, 2)
    elif kind == "singular":  # condition number up to 1e10
        sd = np.array([rng.uniform(0.01, 0.3), rng.uniform(1e-6, 1e-5)])
    elif kind == "tiny":
        sd = rng.uniform(1e-6, 1e-4, 2)
    else:
        sd = rng.uniform(0.005, 0.2, 2)
    cov = rot @ np.diag(sd**2) @ rot.T
    return 0.5 * (cov + cov.T)


def _segment(rng: np.random.Generator, kind: str, cov_kind: str, scale: float) -> FloorSegment:
    a = rng.uniform(-scale, scale, 2)
    if kind == "point":  # both endpoints at one place
        b = a.copy()
    elif kind == "short":
        b = a + rng.normal(0.0, 1e-4, 2)
    else:
        ang = rng.uniform(0.0, 2.0 * math.pi)
        b = a + rng.uniform(0.05, 2.0) * np.array([math.cos(ang), math.sin(ang)])
    return FloorSegment(
        endpoints=np.array([a, b]), cov=np.stack([_cov(rng, cov_kind), _cov(rng, cov_kind)])
    )


@st.composite
def observations(draw: st.DrawFn) -> FloorObservation:
    """Random floor observations, degenerate ones often."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_seg = draw(st.sampled_from([0, 1, 2, 5, 12, 40, 1000]) | st.integers(0, 30))
    n_amb = draw(st.integers(0, 4))
    seg_kind = draw(st.sampled_from(["normal", "point", "short", "mixed"]))
    cov_kind = draw(st.sampled_from(["normal", "huge", "singular", "tiny", "mixed"]))
    duplicate = draw(st.booleans())
    scale = draw(st.sampled_from([0.5, 4.0, 40.0]))

    def one() -> FloorSegment:
        k = rng.choice(["normal", "point", "short"]) if seg_kind == "mixed" else seg_kind
        c = rng.choice(["normal", "huge", "singular", "tiny"]) if cov_kind == "mixed" else cov_kind
        return _segment(rng, str(k), str(c), scale)

    segments = [one() for _ in range(n_seg)]
    if duplicate and segments:
        segments.append(segments[int(rng.integers(len(segments)))])  # an exact duplicate
    ambiguous = []
    for _ in range(n_amb):
        m = int(rng.integers(2, 5))
        cands = [one() for _ in range(m)]
        if duplicate and m > 1:
            cands[1] = cands[0]  # two candidates at the same place
        p = rng.dirichlet(np.ones(m))
        p = p / p.sum()
        ambiguous.append(AmbiguousSegment(candidates=tuple(cands), probabilities=tuple(p)))
    heading = float(rng.uniform(-math.pi, math.pi))
    return FloorObservation(
        segments=tuple(segments),
        ambiguous=tuple(ambiguous),
        viewpoint=np.array([float(rng.uniform(-scale, scale)), -scale - 1.0, heading]),
    )


def assert_valid(model: EnvironmentModel, obs: FloorObservation) -> None:
    """Every invariant a consumer of the model relies on."""
    probs = np.array([s.probability for s in model.situations])
    assert probs.size >= 1
    assert np.all(np.isfinite(probs)) and np.all(probs >= 0.0) and np.all(probs <= 1.0 + 1e-12)
    assert np.all(np.diff(probs) <= 1e-12), "situations are sorted by probability"
    assert 0.0 <= model.residual_probability <= 1.0
    assert math.isclose(probs.sum() + model.residual_probability, 1.0, abs_tol=1e-9)
    n_amb = len(obs.ambiguous)
    for sit in model.situations:
        assert all(0 <= a < n_amb for a in sit.choice)
        for a, c in sit.choice.items():
            assert 0 <= c < len(obs.ambiguous[a].candidates)
        for ob in sit.obstacles:
            assert ob.points.ndim == 2 and ob.points.shape[1] == 2
            assert np.all(np.isfinite(ob.points)) and np.all(np.isfinite(ob.polygon))
            assert ob.polygon.ndim == 2 and ob.polygon.shape[1] == 2
        n_ob = len(sit.obstacles)
        for region in sit.critical_regions:
            i, j = region.obstacles
            assert 0 <= i < j < n_ob
            assert 0.0 <= region.p_passable <= 1.0
            assert math.isfinite(region.width_mean_m) and region.width_mean_m >= 0.0
            assert math.isfinite(region.width_std_m) and region.width_std_m >= 0.0
            assert np.all(np.isfinite(region.polygon)) and np.all(np.isfinite(region.narrowest))
    for ring in model.occluded:
        assert ring.ndim == 2 and ring.shape[1] == 2 and np.all(np.isfinite(ring))


@given(observations(), st.integers(1, 64))
def test_any_observation_gives_a_valid_model(obs: FloorObservation, k: int) -> None:
    model = build_model(obs, ROBOT_WIDTH_M, max_situations=k)
    assert len(model.situations) <= k
    assert_valid(model, obs)


@given(observations(), st.sampled_from([0.0, -1.0, math.nan, math.inf]))
def test_a_bad_robot_width_is_a_value_error(obs: FloorObservation, width: float) -> None:
    try:
        build_model(obs, width)
    except ValueError as exc:
        assert "robot_width_m" in str(exc)
    else:  # pragma: no cover - the assertion names the case
        raise AssertionError(f"robot_width_m={width} was accepted")
