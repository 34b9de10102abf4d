"""A world-frame model memory fused over observations (issue 16; the step named in section 6).

The paper models one view and leaves the integration over a sequence of observations as future
work ("it is also necessary to extend the proposed method so that it can incrementally model the
environment using data from a sequence of observations"). :func:`fuse` folds one
:class:`~modeling.observation.FloorObservation` into a :class:`ModelMemory`:

1. **Association** (:mod:`modeling.memory.association`): each new unambiguous segment is paired
   with a remembered one by a chi-square gate on the 4-dof endpoint difference (both orders),
   one-to-one (:func:`scipy.optimize.linear_sum_assignment`); a pair fuses as the product of the
   endpoint Gaussians, the new view's information weighted by how new its viewpoint is (see
   *Correlated views* below). A new segment that matches no remembered segment but a candidate of a
   remembered ambiguity is evidence for that candidate (and fuses into it); any other enters as a
   new segment with ``initial_existence``. Only the endpoint gate is used: a longer or shorter
   piece of a remembered edge enters as a segment of its own.
2. **Existence**: every remembered segment carries ``P(real)``, updated by Bayes in odds form
   with the likelihood ratio of the evidence: seen again ``pd / pf`` (``detection_probability``,
   ``false_match_rate``); lying in the floor the new view sees free and not detected
   ``(1 - pd) / (1 - pf)``; otherwise 1 (unchanged). A segment is seen free when its two
   endpoints and its midpoint are (:mod:`modeling.memory.visibility`: in the field of view, in
   range, beyond ``near_range_m`` and below the image's lower edge (``head_height_m``,
   ``half_vfov_rad``, at the segment's top height), at least ``free_margin_m`` short of what
   the view sees along that ray; the occluders are the new view's segments and all its
   candidates) and the new view could have matched it: a segment imaged at less than
   ``min_image_angle_deg`` to the rows (a face's bottom edge seen face-on: the segment stereo
   drops such lines) is not evidence either way
   (:func:`~modeling.memory.visibility.flat_in_image`). Below
   ``min_existence`` a segment is forgotten; existence is capped at ``max_existence`` so that
   enough contrary evidence always fades a segment.
3. **Ambiguity**: a new ambiguous segment is associated with the remembered ambiguity whose
   candidates its candidates match (gate per candidate pair; one-to-one between ambiguities,
   then between their candidates). Each remembered candidate ``i`` is re-weighted by Bayes,
   ``p_i' ∝ p_i r_i`` and ``p_none' ∝ p_none`` (``p_none = 1 - sum p``: "no obstacle here", the
   reference hypothesis, under which every candidate is a false match): ``r_i = pd / pf`` when a
   new unambiguous segment coincides with it, or a remembered segment that the new view detects
   (after its fusion; a candidate and a segment in one place are one edge, and the detection is
   evidence for both), ``1 + q_j (pd / pf - 1)`` when candidate ``j``
   (probability ``q_j``) of the new ambiguous segment does, ``(1 - pd) / (1 - pf)`` when it lies
   in the floor seen free and nothing coincides, 1 otherwise. A candidate whose posterior reaches
   ``resolve_probability`` becomes an ordinary segment (existence: its posterior; fused into
   a remembered segment it coincides with); when the none mass does, the ambiguity goes.
   Candidates below ``min_candidate_probability`` are pruned (two stay while the none mass is 0,
   one otherwise) and the rest renormalised. A new ambiguity that matches no remembered one
   enters with its ``p_none`` raised to ``none_prior``, re-weighted by the remembered segments
   its candidates coincide with (:func:`~modeling.memory.ambiguity.explain_new`: candidate ``j``
   on a segment of existence ``e`` by ``1 + e (pd / pf - 1)``, the segment by
   ``1 + q_j (pd / pf - 1)``); when that resolves it to such a candidate, it is that segment
   seen again and fuses into it.
4. **Seen floor**: :attr:`ModelMemory.seen` is the union of every view's visible area (one
   shapely geometry, simplified to ``seen_tolerance_m`` and coarser while it has more than
   ``max_seen_vertices`` vertices); floor never seen is unknown (:meth:`ModelMemory.unknown`).
5. **Bounds**: at most ``max_segments`` segments (the lowest existence, then the least recently
   seen, go first), ``max_ambiguous`` ambiguities (the most probably empty, then the least
   recently seen, go first), ``max_contacts`` contacts (the oldest go first).

Contacts (:func:`add_contact`) are certain: a short segment across the contact normal, never
faded by free-space evidence, replaced by a newer contact within ``contact_merge_m``.
:func:`build_memory_model` runs :func:`~modeling.model.build.build_model` on
:meth:`ModelMemory.observation` (the segments with existence at least ``report_existence``, the
contacts and the open ambiguities, at the latest viewpoint), so its critical regions carry the
narrowed widths of the fused endpoints.

*Correlated views.* Two views from nearly one viewpoint share most of their errors (the same
edge at the same image position, the same quantisation); only the pixel noise is new. The
endpoint information a view adds to a remembered segment is therefore weighted by
:func:`view_weight`: ``repeat_information`` (0.5) from the viewpoint the segment was last fused
from (:attr:`ModelMemory.fused_from`), rising linearly to 1 (the plain product of Gaussians) at
``independent_baseline_m`` (0.5 m) from it: a view from where the segment was last fused adds
half an independent view's information, one 5 cm on (a step of the env at full speed) 0.55, one
half a metre or more away a whole one. On the office
drive of ``scripts/memory_eval.py`` this brings the fused endpoints' 95 % coverage from 0.89 to
0.91 (the single view's: 0.98). What the weighting leaves, a floor holds: a fused endpoint's
standard deviation is at least ``min_sigma_m`` (1.5 mm) in every direction
(:func:`~modeling.memory.association.floored_covariances`), for the error that every view of an
edge shares (where the segment extraction puts the edge against where it is) and no number of
views averages away. Without it, the endpoints fused over tens of views reached sub-millimetre
standard deviations across their outline; those under 1 cm (57 % of the fused endpoints on that
drive) were within their 95 % ellipse 0.90 of the time, the others 0.97 to 0.99. With it the
coverage is 0.96. Existence and the candidates' probabilities still take every view as
independent evidence: a robot standing still that sees the same false match again and again
makes it confident.

Speed: the association gate, the endpoint fusion and the free-space test run compiled loops
(:mod:`modeling.memory._kernels.association`, :mod:`modeling.memory._kernels.visibility`) whose
NumPy references stay beside them (``gated_pairs_reference``, ``fused_segments_reference``,
``_seen_free_reference``; tests compare them exactly), and a fuse reuses the arrays of the
candidates that did not change (most are out of view).

Frames: world, metres; covariances m^2; angles radians; probabilities in [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from dataclasses import replace as dataclasses_replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike

from modeling.memory._kernels.visibility import segments_seen_free
from modeling.memory.ambiguity import Candidates, candidates_of, explain_new, reweight
from modeling.memory.association import (
    SegmentStack,
    assign,
    concat,
    fused_segments,
    gated_pairs,
    odds_update,
    replaced,
    stack_of,
    take,
)
from modeling.memory.options import MemoryOptions
from modeling.memory.visibility import Visibility, flat_in_image, visibility
from modeling.model.build import ModelCache, ModelOptions, build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from modeling.types import FloatArray
from modeling.validation import finite_array, integer, positive, with_overrides

__all__ = ["MemoryOptions", "ModelMemory", "add_contact", "build_memory_model", "fuse"]

_EMPTY_SEEN = shapely.Polygon()


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ModelMemory:
    """What the robot knows of the floor after some views (see the module docstring).

    Attributes:
        segments: Fused unambiguous segments, world frame.
        existence: P(segment is real), one per segment.
        ambiguous: The ambiguities still open, their probabilities Bayes-updated (they may sum to
            less than 1: the rest is "no obstacle here").
        contacts: Bumps as short segments across the contact normal (certain, never faded).
        seen: The floor seen so far (a shapely geometry, world frame); the rest is unknown.
        viewpoint: (3,) ``(x_m, y_m, heading_rad)`` of the latest observation.
        fov_rad: Field of view of the latest observation, radians.
        max_range_m: Range of the latest observation, metres.
        views: Observations fused.
        last_seen: The view (1-based count) that last detected each segment (0: never; a resolved
            candidate counts from its ambiguity).
        ambiguous_seen: The view that last detected each ambiguity.
        report_existence: :meth:`observation` keeps the segments at least this probable.
        segment_arrays: The segments as arrays (derived: computed from ``segments`` when None;
            :func:`fuse` passes the arrays it has).
        fused_from: (n, 2) ``(x_m, y_m)`` of the viewpoint each segment was last fused from
            (NaN, the default: not known, the next view counts as independent).
        candidate_arrays: The ambiguities' candidates as arrays (derived likewise).
    """

    segments: tuple[FloorSegment, ...] = ()
    existence: tuple[float, ...] = ()
    ambiguous: tuple[AmbiguousSegment, ...] = ()
    contacts: tuple[FloorSegment, ...] = ()
    seen: Any = _EMPTY_SEEN
    viewpoint: FloatArray = field(default_factory=lambda: np.zeros(3))
    fov_rad: float = math.radians(64.0)
    max_range_m: float = 8.0
    views: int = 0
    last_seen: tuple[int, ...] = ()
    ambiguous_seen: tuple[int, ...] = ()
    report_existence: float = 0.3
    segment_arrays: SegmentStack | None = field(default=None, repr=False)
    candidate_arrays: Candidates | None = field(default=None, repr=False)
    fused_from: FloatArray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        n = len(self.segments)
        for name in ("segments", "contacts"):
            if not all(isinstance(s, FloorSegment) for s in getattr(self, name)):
                raise ValueError(f"{name} must all be FloorSegment instances")
        if not all(isinstance(a, AmbiguousSegment) for a in self.ambiguous):
            raise ValueError("ambiguous must all be AmbiguousSegment instances")
        if self.segment_arrays is None:
            object.__setattr__(self, "segment_arrays", stack_of(self.segments))
        elif self.segment_arrays.ends.shape[0] != n:
            raise ValueError(f"segment_arrays must have {n} rows")
        if self.candidate_arrays is None:
            object.__setattr__(self, "candidate_arrays", candidates_of(self.ambiguous))
        origins = np.full((n, 2), np.nan) if self.fused_from is None else self.fused_from
        origins = np.array(origins, dtype=np.float64)
        if origins.shape != (n, 2):
            raise ValueError(f"fused_from must have shape ({n}, 2), got {origins.shape}")
        origins.setflags(write=False)
        object.__setattr__(self, "fused_from", origins)
        for name, length in (
            ("existence", n),
            ("last_seen", n),
            ("ambiguous_seen", len(self.ambiguous)),
        ):
            if len(getattr(self, name)) != length:
                raise ValueError(
                    f"{name} must have {length} entries, got {len(getattr(self, name))}"
                )
        if n and not (0.0 <= min(self.existence) and max(self.existence) <= 1.0):
            raise ValueError("existence must lie in [0, 1]")
        if not isinstance(self.seen, shapely.Geometry):
            raise ValueError(f"seen must be a shapely geometry, got {type(self.seen).__name__}")
        vp = finite_array(self.viewpoint, "viewpoint", (3,))
        vp.setflags(write=False)
        object.__setattr__(self, "viewpoint", vp)
        object.__setattr__(self, "views", integer(self.views, "views", low=0))

    @classmethod
    def empty(cls) -> ModelMemory:
        """The memory before any view: nothing known, every floor unknown."""
        return cls()

    def observation(self) -> FloorObservation:
        """What :func:`~modeling.model.build.build_model` runs on: the segments at least
        ``report_existence`` probable, then the contacts; the open ambiguities; the latest
        viewpoint, field of view and range."""
        keep = tuple(
            s
            for s, e in zip(self.segments, self.existence, strict=True)
            if e >= self.report_existence
        )
        return FloorObservation(
            segments=keep + self.contacts,
            ambiguous=self.ambiguous,
            viewpoint=self.viewpoint,
            fov_rad=self.fov_rad,
            max_range_m=self.max_range_m,
        )

    def unknown(self, bounds: Any) -> Any:
        """The floor within ``bounds`` (a shapely geometry, world frame) never seen."""
        if not isinstance(bounds, shapely.Geometry):
            raise ValueError(f"bounds must be a shapely geometry, got {type(bounds).__name__}")
        return shapely.difference(bounds, self.seen)


# ------------------------------------------------------------------------------- fusion
def _near_limit(opts: MemoryOptions, top_m: FloatArray | float) -> FloatArray:
    """The distance (metres) within which a point of height ``top_m`` is out of the image: the
    camera's depression limit ``(head_height_m - top) / tan(half_vfov_rad)`` (none when
    ``head_height_m`` is 0), at least ``near_range_m``."""
    top = np.asarray(top_m, dtype=np.float64)
    if opts.head_height_m <= 0.0:
        return np.full(top.shape, opts.near_range_m)
    out: FloatArray = np.maximum(
        opts.near_range_m, (opts.head_height_m - top) / math.tan(opts.half_vfov_rad)
    )
    return out


def _seen_free(vis: Visibility, segs: SegmentStack, opts: MemoryOptions) -> np.ndarray:
    """(n,) bool: both endpoints and the midpoint of each segment are seen free, each judged
    at the segment's top height (the part of an obstacle that could be seen):
    :func:`_seen_free_reference`, compiled (:func:`modeling.memory._kernels.visibility.
    segments_seen_free`; the same results)."""
    if segs.ends.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    out: np.ndarray = segments_seen_free(
        np.ascontiguousarray(segs.ends),
        segs.heights.max(axis=1),
        vis.origin,
        vis.heading,
        vis.half_fov,
        vis.reach,
        opts.free_margin_m,
        np.array([opts.near_range_m, opts.head_height_m, math.tan(opts.half_vfov_rad)]),
    )
    return out


def _seen_free_reference(vis: Visibility, segs: SegmentStack, opts: MemoryOptions) -> np.ndarray:
    """:func:`_seen_free` in NumPy, through :meth:`Visibility.seen_free` (the readable version)."""
    ends = segs.ends
    n = ends.shape[0]
    if n == 0:
        return np.zeros(0, dtype=bool)
    mid = (ends[:, 0] + ends[:, 1]) / 2.0  # = ends.mean(axis=1), bit for bit, but cheaper
    pts = np.concatenate([ends[:, 0], ends[:, 1], mid])
    near = np.tile(_near_limit(opts, segs.heights.max(axis=1)), 3)
    out: np.ndarray = np.all(vis.seen_free(pts, opts.free_margin_m, near).reshape(3, n), axis=0)
    return out


def _evidence_free(vis: Visibility, segs: SegmentStack, opts: MemoryOptions) -> np.ndarray:
    """(n,) bool: each segment lies in the floor ``vis`` sees free (:func:`_seen_free`) where
    the view could have matched it (not imaged along the rows:
    :func:`~modeling.memory.visibility.flat_in_image`): its absence there is evidence that it
    is not real."""
    free = _seen_free(vis, segs, opts)
    if free.any():
        free &= ~flat_in_image(
            vis, segs.ends, segs.heights, opts.head_height_m, opts.min_image_angle_deg
        )
    return free


def view_weight(
    fused_from: FloatArray, viewpoint: FloatArray, opts: MemoryOptions
) -> FloatArray | None:
    """(k,) the information weight of a new view of segments last fused from ``fused_from``
    (k, 2), seen now from ``viewpoint`` (2,): ``repeat_information + (1 - repeat_information)
    min(1, d / independent_baseline_m)`` for a viewpoint ``d`` metres away, 1 where
    ``fused_from`` is NaN (not known); None (every weight 1: the plain product) when
    ``independent_baseline_m`` is 0."""
    if opts.independent_baseline_m <= 0.0:
        return None
    d = np.hypot(fused_from[:, 0] - viewpoint[0], fused_from[:, 1] - viewpoint[1])
    k = opts.repeat_information
    out: FloatArray = np.where(
        np.isnan(d), 1.0, k + (1.0 - k) * np.minimum(d / opts.independent_baseline_m, 1.0)
    )
    return out


def _candidates_from(
    ambiguous: tuple[AmbiguousSegment, ...], sources: tuple[Candidates, ...]
) -> Candidates:
    """:func:`~modeling.memory.ambiguity.candidates_of` of ``ambiguous`` (the same arrays), the
    rows of candidates that ``sources`` hold (the same objects) taken from their arrays and only
    the others stacked: most ambiguities are out of view and unchanged from view to view."""
    segs = [c for a in ambiguous for c in a.candidates]
    row_of: dict[int, int] = {}
    offset = 0
    for src in sources:
        for k, seg in enumerate(src.segments):
            row_of.setdefault(id(seg), offset + k)
        offset += len(src.segments)
    rows = [row_of.get(id(seg), -1) for seg in segs]
    missing = [i for i, r in enumerate(rows) if r < 0]
    for j, i in enumerate(missing):
        rows[i] = offset + j
    extra = stack_of([segs[i] for i in missing])
    stack = take(concat(*(src.stack for src in sources), extra), np.array(rows, dtype=np.int64))
    return Candidates(
        stack=stack,
        owner=np.repeat(
            np.arange(len(ambiguous), dtype=np.int64), [len(a.candidates) for a in ambiguous]
        ),
        prob=np.array([p for a in ambiguous for p in a.probabilities], dtype=np.float64),
        segments=segs,
    )


def _keep_bounded(n: int, limit: int, keys: tuple[np.ndarray, ...]) -> np.ndarray:
    """Indices (ascending) of at most ``limit`` of ``n`` items, dropping those first in the
    lexicographic order of ``keys`` (the first key most significant)."""
    if n <= limit:
        return np.arange(n)
    order = np.lexsort(tuple(reversed(keys)))  # np.lexsort sorts by its last key first
    return np.sort(order[n - limit :])


def _seen_union(seen: Any, visible: Any, opts: MemoryOptions) -> Any:
    """``seen`` grown by ``visible``, simplified (more coarsely while it has too many vertices)."""
    tol = opts.seen_tolerance_m
    out = shapely.simplify(shapely.union(seen, visible), tol)
    while shapely.get_num_coordinates(out) > opts.max_seen_vertices:
        tol *= 2.0
        out = shapely.simplify(out, tol)
    return out


def fuse(
    memory: ModelMemory,
    observation: FloorObservation,
    options: MemoryOptions | None = None,
    **overrides: Any,
) -> ModelMemory:
    """Fold one observation into the memory (see the module docstring for the steps).

    Pure and deterministic: the same inputs give the same memory; neither input is changed.

    Args:
        memory: The memory so far (:meth:`ModelMemory.empty` before the first view).
        observation: The new view's floor segments, world frame.
        options: The :class:`MemoryOptions` (default: their defaults).
        **overrides: Fields of :class:`MemoryOptions` to replace.

    Returns:
        The memory after the view: its segments, ambiguities and seen floor updated, its
        viewpoint, field of view and range those of ``observation``.

    Raises:
        ValueError: Bad arguments or options, naming them.
    """
    _check_type(memory, "memory", ModelMemory)
    _check_type(observation, "observation", FloorObservation)
    opts = with_overrides(options, MemoryOptions, overrides)
    view = memory.views + 1
    pd, pf = opts.detection_probability, opts.false_match_rate
    new = stack_of(observation.segments)
    new_cands = candidates_of(observation.ambiguous)
    occluders = np.concatenate([new.ends, new_cands.stack.ends])
    floor_near = float(_near_limit(opts, 0.0))
    vis = visibility(observation, occluders, n_rays=opts.n_rays, near_m=floor_near)

    # 1. Association of the new unambiguous segments with the remembered ones; fusion.
    mem = memory.segment_arrays
    assert mem is not None and memory.candidate_arrays is not None  # set by __post_init__
    pairs = assign(gated_pairs(new.ends, new.cov, mem.ends, mem.cov, opts.gate_chi2))
    segments = list(memory.segments)
    here = observation.viewpoint[:2]
    assert memory.fused_from is not None  # set by __post_init__
    fused_from = memory.fused_from.copy()
    floor = opts.min_sigma_m**2
    fused, fused_arrays = fused_segments(
        mem, new, pairs, view_weight(fused_from[pairs.cols], here, opts), min_var=floor
    )
    fused_from[pairs.cols] = here
    for k, seg in zip(pairs.cols.tolist(), fused, strict=True):
        segments[k] = seg
    current = replaced(mem, pairs.cols, fused_arrays)
    # 2. Ambiguities: the unmatched new segments and the new ambiguous ones as evidence on the
    # remembered ambiguities; the new ambiguities that match none against the segments.
    unmatched = np.ones(new.ends.shape[0], dtype=bool)
    unmatched[pairs.rows] = False
    rest = np.flatnonzero(unmatched)
    amb = reweight(
        memory.ambiguous,
        memory.candidate_arrays,
        memory.ambiguous_seen,
        take(new, rest),
        observation.ambiguous,
        new_cands,
        lambda segs: _evidence_free(vis, segs, opts),
        opts=opts,
        view=view,
        detected_segments=fused_arrays,
    )
    prior = np.asarray(memory.existence, dtype=np.float64)
    fresh = explain_new(observation.ambiguous, amb, current, prior, opts)
    absorbed = fresh.absorbed
    if absorbed.rows.shape[0]:
        more, more_arrays = fused_segments(
            current,
            amb.new_candidates.stack,
            absorbed,
            view_weight(fused_from[absorbed.cols], here, opts),
            min_var=floor,
        )
        fused_from[absorbed.cols] = here
        for k, seg in zip(absorbed.cols.tolist(), more, strict=True):
            segments[k] = seg
        current = replaced(current, absorbed.cols, more_arrays)
    # 3. Existence: seen again gains, seen free and not detected loses, unseen unchanged.
    detected = np.zeros(len(segments), dtype=bool)
    detected[pairs.cols] = True
    touched = detected | (fresh.segment_ratio != 1.0)  # absorbed ones among them
    ratio = np.where(detected, pd / pf, 1.0)
    ratio[~touched & _evidence_free(vis, mem, opts)] = (1.0 - pd) / (1.0 - pf)
    existence = odds_update(prior, ratio * fresh.segment_ratio, opts.max_existence)
    last_seen = np.where(touched, view, np.asarray(memory.last_seen, dtype=np.int64))
    # 4. Resolved candidates: a remembered segment seen again when they coincide with one, new
    # segments otherwise; then the new segments (neither associated nor evidence for a
    # candidate).
    resolved = [(seg, p, s) for seg, p, s in amb.resolved] + [
        (seg, p, view) for seg, p in fresh.resolved
    ]
    res_arrays = stack_of([seg for seg, _, _ in resolved])
    res_pairs = assign(
        gated_pairs(res_arrays.ends, res_arrays.cov, current.ends, current.cov, opts.gate_chi2)
    )
    if res_pairs.rows.shape[0]:
        more, more_arrays = fused_segments(current, res_arrays, res_pairs, min_var=floor)
        for k, r, seg in zip(res_pairs.cols.tolist(), res_pairs.rows.tolist(), more, strict=True):
            segments[k] = seg
            existence[k] = max(existence[k], min(resolved[r][1], opts.max_existence))
            last_seen[k] = max(last_seen[k], resolved[r][2])
        current = replaced(current, res_pairs.cols, more_arrays)
    not_fused = np.ones(len(resolved), dtype=bool)
    not_fused[res_pairs.rows] = False
    adding = np.flatnonzero(not_fused)
    entering = np.delete(rest, amb.consumed)
    all_segments = segments + [observation.segments[i] for i in entering.tolist()]
    all_segments += [resolved[i][0] for i in adding.tolist()]
    arrays = concat(current, take(new, entering), take(res_arrays, adding))
    all_existence = np.concatenate(
        [
            existence,
            np.full(entering.shape[0], opts.initial_existence),
            np.array([min(resolved[i][1], opts.max_existence) for i in adding.tolist()]),
        ]
    )
    all_from = np.concatenate(
        [fused_from, np.tile(here, (entering.shape[0], 1)), np.full((adding.shape[0], 2), np.nan)]
    )
    all_seen = np.concatenate(
        [
            last_seen,
            np.full(entering.shape[0], view, dtype=np.int64),
            np.array([resolved[i][2] for i in adding.tolist()], dtype=np.int64),
        ]
    )
    # 5. Forget the faded, then bound the size (lowest existence, then least recently seen).
    alive = np.flatnonzero(all_existence >= opts.min_existence)
    keep = alive[
        _keep_bounded(alive.shape[0], opts.max_segments, (all_existence[alive], all_seen[alive]))
    ]
    ambiguous = amb.ambiguous + tuple(fresh.ambiguous)
    amb_seen = amb.seen + (view,) * len(fresh.ambiguous)
    if len(ambiguous) > opts.max_ambiguous:
        none = np.array([a.p_none for a in ambiguous])
        kept = _keep_bounded(
            len(ambiguous), opts.max_ambiguous, (-none, np.asarray(amb_seen, dtype=np.int64))
        ).tolist()
        ambiguous = tuple(ambiguous[i] for i in kept)
        amb_seen = tuple(amb_seen[i] for i in kept)
    return ModelMemory(
        segments=tuple(all_segments[i] for i in keep.tolist()),
        existence=tuple(all_existence[keep].tolist()),
        ambiguous=ambiguous,
        contacts=memory.contacts,
        seen=_seen_union(memory.seen, vis.polygon(), opts),
        viewpoint=observation.viewpoint,
        fov_rad=observation.fov_rad,
        max_range_m=observation.max_range_m,
        views=view,
        last_seen=tuple(all_seen[keep].tolist()),
        ambiguous_seen=tuple(amb_seen),
        report_existence=opts.report_existence,
        segment_arrays=take(arrays, keep),
        candidate_arrays=_candidates_from(ambiguous, (memory.candidate_arrays, new_cands)),
        fused_from=all_from[keep],
    )


def add_contact(
    memory: ModelMemory,
    point_xy: ArrayLike,
    normal_xy: ArrayLike,
    *,
    height_m: float,
    options: MemoryOptions | None = None,
) -> ModelMemory:
    """The memory with a bump: a segment of ``contact_length_m`` across the contact normal,
    centred on the contact point, endpoints of standard deviation ``contact_sigma_m``, heights
    ``(0, height_m)``.

    A contact is certain (existence 1) and never faded by free-space evidence (the robot touched
    it; the world is static). It replaces the contacts whose midpoints lie within
    ``contact_merge_m`` of the point (a robot pushing against an obstacle bumps every step), and
    the oldest go beyond ``max_contacts``.

    Args:
        memory: The memory.
        point_xy: (2,) contact point, world frame, metres.
        normal_xy: (2,) contact normal (any non-zero length; its sign does not matter).
        height_m: Height of the obstacle touched, metres (> 0).
        options: The :class:`MemoryOptions` (default: their defaults).

    Raises:
        ValueError: Bad arguments, naming them.
    """
    _check_type(memory, "memory", ModelMemory)
    opts = with_overrides(options, MemoryOptions, {})
    p = finite_array(point_xy, "point_xy", (2,))
    n = finite_array(normal_xy, "normal_xy", (2,))
    length = math.hypot(float(n[0]), float(n[1]))
    if length == 0.0:
        raise ValueError("normal_xy must not be zero")
    h = positive(height_m, "height_m")
    tangent = np.array([-n[1], n[0]]) / length
    half = 0.5 * opts.contact_length_m * tangent
    cov = np.tile(np.eye(2) * opts.contact_sigma_m**2, (2, 1, 1))
    contact = FloorSegment(
        endpoints=np.stack([p - half, p + half]), cov=cov, height_m=np.array([0.0, h])
    )
    kept = [
        c
        for c in memory.contacts
        if math.dist(c.midpoint.tolist(), p.tolist()) >= opts.contact_merge_m
    ]
    contacts = [*kept, contact][-opts.max_contacts :] if opts.max_contacts else []
    return dataclasses_replace(memory, contacts=tuple(contacts))


def build_memory_model(
    memory: ModelMemory,
    robot_width_m: float,
    options: ModelOptions | None = None,
    *,
    cache: ModelCache | None = None,
    **overrides: Any,
) -> EnvironmentModel:
    """The fused environment model: :func:`~modeling.model.build.build_model` on
    :meth:`ModelMemory.observation` (situations over the ambiguities still open, critical regions
    with the widths of the fused endpoints, the occluded area from the latest viewpoint).

    Args:
        memory: The memory.
        robot_width_m: Robot width (diameter), metres, > 0.
        options: The :class:`~modeling.model.build.ModelOptions` (default: their defaults).
        cache: A :class:`~modeling.model.build.ModelCache` kept from one call to the next (the
            memory's model is built after every view, and often from the same remembered
            segments): the same model, with less work where they did not change.
        **overrides: Fields of :class:`~modeling.model.build.ModelOptions` to replace.
    """
    _check_type(memory, "memory", ModelMemory)
    return build_model(memory.observation(), robot_width_m, options, cache=cache, **overrides)


def _check_type(value: Any, name: str, cls: type) -> None:
    if not isinstance(value, cls):
        raise ValueError(f"{name} must be a {cls.__name__}, got {type(value).__name__}")
