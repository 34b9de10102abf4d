"""The model cache (:class:`modeling.model.build.ModelCache`): the same models as without it."""

from __future__ import annotations

import dataclasses

import numpy as np

from modeling.model.build import EnvironmentModel, ModelCache, build_model
from modeling.observation import FloorObservation
from tests.modeling.model.test_compiled_model import (
    _model_record,
    _recorded_observations,
    _shelf_observation,
)


def _full_record(model: EnvironmentModel) -> list[object]:
    """The situations (:func:`_model_record`), the relations and the base model's fields."""
    rel = model.relations
    return [
        _model_record(model),
        [getattr(rel, f.name).tobytes() for f in dataclasses.fields(rel)],
        model.item_segment.tobytes(),
        model.item_candidate.tobytes(),
        model.kept_segments,
        model.eliminated_segments,
        model.eliminated_ambiguous,
        model.merged_ambiguous,
        model.units,
        model.groups,
        model.observation is not None,
    ]


def _moved(obs: FloorObservation, dx: float, dy: float, dh: float) -> FloorObservation:
    """``obs`` seen from another viewpoint (the same segments)."""
    return dataclasses.replace(obs, viewpoint=obs.viewpoint + np.array([dx, dy, dh]))


def test_models_built_with_a_cache_equal_those_built_without() -> None:
    v0, v1, v2 = _recorded_observations()
    rng = np.random.default_rng(7)
    shelf = _shelf_observation(rng)
    while len(shelf.ambiguous) < 3:
        shelf = _shelf_observation(rng)
    sequence = [
        v0,
        _moved(v0, 0.3, -0.2, 0.4),  # the same segments from another viewpoint
        v1,
        v1,
        v2,
        _moved(v2, -0.5, 0.1, -0.3),
        v0,
        shelf,
        _moved(shelf, 6.0, 9.0, 0.0),  # far off: the candidates' ranks change
        shelf,
    ]
    cache = ModelCache()
    for obs in sequence:
        got = build_model(obs, 0.5, cache=cache)
        want = build_model(obs, 0.5)
        assert _full_record(got) == _full_record(want)
        assert got.observation is obs
    assert cache.hits == 5  # v0 moved, v1 again, v2 moved, the shelf twice
    assert 1 <= cache.full_hits < cache.hits  # moved viewpoints reorder some units: both paths


def test_a_cache_keys_on_the_options_and_the_width() -> None:
    v0 = _recorded_observations()[0]
    cache = ModelCache()
    build_model(v0, 0.5, cache=cache)
    for width, eps in ((0.6, 0.05), (0.6, 0.1)):
        got = build_model(v0, width, cache=cache, eps=eps)
        assert _full_record(got) == _full_record(build_model(v0, width, eps=eps))
    assert cache.hits == 0
