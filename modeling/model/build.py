"""Obstacles, free spaces and possible situations from a floor observation (paper section 4).

:func:`build_model` turns a :class:`~modeling.observation.FloorObservation` into an
:class:`~modeling.model.records.EnvironmentModel`: a list of possible situations with their
probabilities, each made of obstacles and critical regions, plus the occluded area. Its steps
(ARCHITECTURE.md, stages 5-10), each in a module of its own:

1. Items and their relations, isolated short segments (section 4.1): :mod:`modeling.model.items`.
2. Ambiguous segments moving together (Fig. 7), the elimination of those with one effect
   (Fig. 8) and the independent groups (Fig. 9): :mod:`modeling.model.ambiguity`.
3. The k most probable situations (Eq. 2), each partitioned into obstacles (components of
   impassable relations, convex-hull polygons: :mod:`modeling.model.obstacles`), critical regions
   and passages: :mod:`modeling.model.situations`.
4. The occluded area behind the obstacles of the most probable situation (their skeletons):
   :mod:`modeling.model.occlusion`.

A :class:`ModelCache` passed to successive calls (the fused memory's model, built every step)
keeps the last call's intermediate results: when the items (every endpoint, covariance and
height, bit for bit), the ambiguous segments' probabilities and the options are those of the
last call, its relations and isolated short segments are taken again; when the units moving
together (the one step that reads the viewpoint besides the occlusion) are equal too, so are the
elimination, the groups and the situations. The occlusion is always made anew. Where the items
changed, the relation rows of the pairs of items that did not are taken from the last call's
(:class:`~modeling.model.relations.EarlierRelations`), and so are those pairs themselves when
the unchanged items kept their order: only the pairs of the changed items are looked for. The
model is the one made without the
cache (tests hold them equal on recorded fused observations).

The records are in :mod:`modeling.model.records` (re-exported here). Frames: world, metres;
covariances m^2; probabilities in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from modeling.model.ambiguity import (
    Elimination,
    Unit,
    eliminate_units_of_one_effect,
    independent_groups,
    units_moving_together,
)
from modeling.model.gaps import _check_eps
from modeling.model.items import (
    Isolation,
    Items,
    isolated_short_segments,
    item_relations,
    items_of,
)
from modeling.model.occlusion import occluded_polygons, occluders_of
from modeling.model.records import CriticalRegion, EnvironmentModel, Obstacle, Passage, Situation
from modeling.model.relations import EarlierRelations
from modeling.model.situations import enumerate_situations
from modeling.observation import FloorObservation
from modeling.validation import integer, positive, with_overrides

__all__ = [
    "CriticalRegion",
    "EnvironmentModel",
    "ModelCache",
    "ModelOptions",
    "Obstacle",
    "Passage",
    "Situation",
    "build_model",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class ModelOptions:
    """The options of :func:`build_model`.

    Attributes:
        eps: Classification tolerance in (0, 0.5): passable if ``p > 1 - eps``, impassable if
            ``p < eps``, undecided otherwise.
        max_situations: At most this many situations are returned, most probable first (>= 1).
        min_isolated_3d_length_m: Isolated segments whose 3D length (the floor length and the
            height extent: ``hypot(length_m, |height_m[1] - height_m[0]|)``) is below this are
            dropped as likely false matches (metres, >= 0). A vertical edge, zero long on the
            floor, counts its height.
        outline_buffer_m: Half-width of the rectangle that stands for the polygon of an obstacle
            whose points are collinear (one segment, or a straight wall), metres (> 0).
    """

    eps: float = 0.05
    max_situations: int = 64
    min_isolated_3d_length_m: float = 0.1
    outline_buffer_m: float = 0.02

    def __post_init__(self) -> None:  # checked once here, stored as plain Python numbers
        object.__setattr__(self, "eps", _check_eps(self.eps))
        object.__setattr__(
            self, "max_situations", integer(self.max_situations, "max_situations", low=1)
        )
        length = positive(
            self.min_isolated_3d_length_m, "min_isolated_3d_length_m", allow_zero=True
        )
        object.__setattr__(self, "min_isolated_3d_length_m", length)
        object.__setattr__(
            self, "outline_buffer_m", positive(self.outline_buffer_m, "outline_buffer_m")
        )


_AfterUnits = tuple[Elimination, tuple[tuple[int, ...], ...], list[Situation], float]
"""What :func:`build_model` makes from the units: elimination, groups, situations, residual."""


@dataclass(slots=True, eq=False)
class ModelCache:
    """The intermediate results of the last :func:`build_model` call given this cache (see the
    module docstring); empty at first. Mutable: each call replaces its content.

    Attributes:
        key: What the relations and isolated short segments depend on: the options, the robot
            width, the items' arrays (bytes), their candidates and the ambiguous segments'
            probabilities.
        earlier: The relations of those items, with the items' arrays: taken whole when the
            key is the same; where the items changed, the rows of the pairs that did not are
            taken from them (:class:`~modeling.model.relations.EarlierRelations`).
        isolation: Their isolated short segments.
        units: The units moving together (Fig. 7).
        after_units: The elimination, the groups, the situations and the residual made from
            those units.
        hits: Calls that took the relations again (for tests and benchmarks).
        full_hits: Calls that took the situations again.
    """

    key: tuple[Any, ...] | None = None
    earlier: EarlierRelations | None = None
    isolation: Isolation | None = None
    units: list[Unit] = field(default_factory=list)
    after_units: _AfterUnits | None = None
    hits: int = 0
    full_hits: int = 0


def _cache_key(
    items: Items, observation: FloorObservation, width: float, opts: ModelOptions
) -> tuple[Any, ...]:
    """What the relations, the isolated short segments and (with the units) the situations of
    ``items`` depend on, compared bit for bit."""
    return (
        opts,
        width,
        items.ends.tobytes(),
        items.covs.tobytes(),
        items.heights.tobytes(),
        items.of_ambiguous,
        [a.probabilities for a in observation.ambiguous],
    )


def _same_units(a: list[Unit], b: list[Unit]) -> bool:
    """Whether the units ``a`` and ``b`` are equal (members, items, choices, probabilities bit
    for bit)."""
    return len(a) == len(b) and all(
        u.members == v.members
        and u.items == v.items
        and u.choices == v.choices
        and u.probabilities.tobytes() == v.probabilities.tobytes()
        for u, v in zip(a, b, strict=True)
    )


def build_model(
    observation: FloorObservation,
    robot_width_m: float,
    options: ModelOptions | None = None,
    *,
    cache: ModelCache | None = None,
    **overrides: Any,
) -> EnvironmentModel:
    """Model obstacles, free spaces and possible situations from a floor observation.

    Args:
        observation: The floor segments (unambiguous and ambiguous), world frame.
        robot_width_m: Robot width (diameter), metres, > 0.
        options: The :class:`ModelOptions` (default: their defaults).
        cache: The :class:`ModelCache` of successive calls (the model is the same with or without
            it; see the module docstring), updated here.
        **overrides: Fields of :class:`ModelOptions` to replace (``eps=0.1``,
            ``max_situations=8``, ...).

    Returns:
        The :class:`~modeling.model.records.EnvironmentModel` (see the module docstring for the
        steps).

    Raises:
        ValueError: Bad arguments, naming them.
    """
    if not isinstance(observation, FloorObservation):
        raise ValueError(
            f"observation must be a FloorObservation, got {type(observation).__name__}"
        )
    width = positive(robot_width_m, "robot_width_m")
    opts = with_overrides(options, ModelOptions, overrides)  # validated by ModelOptions
    eps, min_len, buffer_m = opts.eps, opts.min_isolated_3d_length_m, opts.outline_buffer_m

    # Section 4.1: items, their relations, isolated short segments.
    items = items_of(observation)
    key = None if cache is None else _cache_key(items, observation, width, opts)
    hit = cache is not None and cache.key == key
    if hit:
        assert cache is not None and cache.earlier is not None and cache.isolation is not None
        rel, isolation = cache.earlier.relations, cache.isolation
        cache.hits += 1
    else:
        rel = item_relations(items, width, eps, None if cache is None else cache.earlier)
        isolation = isolated_short_segments(items, rel, min_len)
    # Section 4.2: units moving together (Fig. 7), elimination (Fig. 8), groups (Fig. 9).
    units = units_moving_together(
        observation, isolation.live_ambiguous, items.of_ambiguous, items.ends, width
    )
    if hit and cache is not None and cache.after_units and _same_units(units, cache.units):
        elimination, groups, situations, residual = cache.after_units
        cache.full_hits += 1
    else:
        base_active = np.zeros(items.ends.shape[0], dtype=bool)
        base_active[list(isolation.kept_segments)] = True
        elimination = eliminate_units_of_one_effect(units, rel, items.ambiguous, base_active)
        groups = independent_groups(units, elimination, rel, items.ambiguous)
        # Eq. 2: the k most probable situations, with their obstacles, regions and passages.
        situations, residual = enumerate_situations(
            items,
            rel,
            units,
            elimination,
            max_situations=opts.max_situations,
            robot_width_m=width,
            outline_buffer_m=buffer_m,
        )
    if cache is not None:
        cache.key, cache.isolation, cache.units = key, isolation, units
        cache.earlier = EarlierRelations(
            items.ends, items.covs, width, rel, eps=eps, group=items.ambiguous
        )
        cache.after_units = (elimination, groups, situations, residual)
    # Occlusion: behind the obstacles of the most probable situation.
    occluded = occluded_polygons(observation, occluders_of(situations[0]))
    return EnvironmentModel(
        situations=tuple(situations),
        residual_probability=residual,
        occluded=occluded,
        observation=observation,
        robot_width_m=width,
        eps=eps,
        relations=rel,
        item_segment=items.segment,
        item_candidate=items.candidate,
        kept_segments=isolation.kept_segments,
        eliminated_segments=isolation.eliminated_segments,
        eliminated_ambiguous=tuple(
            sorted(isolation.eliminated_ambiguous + list(elimination.eliminated))
        ),
        merged_ambiguous=dict(sorted(elimination.merged.items())),
        units=tuple(units[u].members for u in elimination.remaining),
        groups=groups,
    )
