"""Diagnostics: how well the model of one observation agrees with the true scene.

:func:`model_diagnostics` returns ``info["diagnostics"]``, a dict of floats. A figure that has
nothing to measure in this view (its count is 0) is left out rather than given as NaN, so that two
equal rollouts give equal infos (NaN != NaN defeats Gymnasium's determinism check) and vector envs
still merge infos (they mask missing keys); read figures with ``.get(name, math.nan)``. The counts
are always present.

* ``nees_mean``, ``coverage_95``, ``endpoints``: over the endpoints of the unambiguous floor
  segments (not the faces' segments that join two of them), the error of the mean across the
  nearest true outline, normalised by the standard deviation the endpoint's covariance gives in
  that direction: ``z = |e| / sqrt(n^T C n)`` with
  ``e`` the vector from the nearest point of a true outline to the mean and ``n = e / |e|``.
  ``nees_mean`` is the mean of ``z^2`` (one degree of freedom: ideal 1; above 1 the covariances
  are too small), ``coverage_95`` the fraction with ``|z| <= 1.96`` (ideal 0.95), ``endpoints``
  their number. The true outlines are the edges of every rendered part whose height range meets
  the kept band (0.05 m to the robot's height), so table legs and shelf boards count. The error
  along an outline is not measured (the true point an endpoint stands for is not known there), and
  a wrong match that lands on another outline counts as right: both make these figures optimistic.
* ``p_true_candidate``, ``ambiguous_segments``: for each ambiguous segment, the candidate that is
  true is the one whose endpoints lie best on the true outlines (least mean ``z^2``), provided
  that mean is at most chi^2_2(0.99) = 9.21; when no candidate lies that near an outline, every
  candidate is a false match and the true choice is "no obstacle here" (its probability
  ``p_none``, 0 when the candidates sum to 1). ``p_true_candidate`` is the mean probability the
  model gave the true choice (1 would be perfect disambiguation; ``1 / m`` for m equal
  candidates is chance).
* ``passability_brier``, ``gaps_in_view``, ``gaps_scored``: the true doubtful gaps
  (:meth:`Scene.doubtful_gaps`, widths within 30 % of the robot width) whose two closest points
  lie in the field of view and range are ``gaps_in_view``. For each, the model's probability that
  the robot passes is the least ``p_passable`` of the relations whose two closest points lie at
  the gap's two sides (each within a Mahalanobis distance of chi^2_2(0.99) = 9.21 of the true
  point, with 0.1 m of slack added to the covariance), among the relations present in a
  situation, averaged over the situations weighted by their probability (situations without
  such a relation are left out; a gap no situation sees is not scored). ``passability_brier`` is
  the mean squared difference between that probability and the truth (1 if the gap is wider than
  the robot, else 0) over the ``gaps_scored`` gaps: 0 is perfect, 0.25 is a coin toss.
* ``situations``, ``residual_probability``: the model's count of situations and its left-out mass.

The env gives the same figures of the fused model
(:func:`modeling.memory.fusion.build_memory_model`, ``info["memory_model"]``) beside these, named
``memory_<name>`` (:func:`memory_diagnostics`: ``memory_passability_brier``, ``memory_coverage_95``,
...): its fused segments and the candidates of the ambiguities still open, against the same true
outlines; its gaps scored are those in the latest view, as for the single view. Two figures of the
ambiguities differ:

* ``memory_p_true_candidate`` scores the *same* ambiguities as ``p_true_candidate``, those of the
  latest view, each with the memory's belief in its true choice once the view is fused
  (:func:`memory_beliefs`): the largest existence of a remembered segment (one reported, at least
  ``report_existence``) or probability of an open candidate within the association gate of the
  true candidate; when no candidate is real, 1 minus the largest such belief over its candidates.
  An ambiguity the memory has resolved is scored too, right (belief near 1) or wrong (near 0);
* ``memory_open_p_true_candidate`` is ``p_true_candidate`` of the fused model itself: only the
  ambiguities the memory still holds open. One leaves the figure when it resolves (at
  ``MemoryOptions.resolve_probability``), so the figure measures the ambiguities the memory
  could not decide and moves with that threshold as much as with the evidence.

Everything is vectorised over endpoints and outline edges; the ground truth that does not change
within an episode is prepared once per scene by :meth:`GroundTruth.of`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from modeling.geometry import wrap_angle
from modeling.jit import compiled_on_first_call
from modeling.memory.association import gated_pairs, stack_of
from modeling.memory.fusion import ModelMemory
from modeling.model.records import EnvironmentModel
from modeling.stereo.faces import FACE_SOURCE
from modeling.types import FloatArray
from stereo_nav_env.sim.scenes import Scene

__all__ = [
    "DIAGNOSTIC_NAMES",
    "GroundTruth",
    "memory_beliefs",
    "memory_diagnostics",
    "model_diagnostics",
    "normalised_outline_errors",
]

DIAGNOSTIC_NAMES = (
    "nees_mean",
    "coverage_95",
    "endpoints",
    "p_true_candidate",
    "ambiguous_segments",
    "passability_brier",
    "gaps_in_view",
    "gaps_scored",
    "situations",
    "residual_probability",
)
_CHI2_2_99 = 9.2103
_GAP_SLACK_M = 0.1


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class GroundTruth:
    """What diagnostics need from the true scene, computed once per scene.

    Attributes:
        edges: (E, 2, 2) true outline edges, world metres (every part in the height band).
        gap_points: (G, 2, 2) the two closest points of each doubtful gap, world metres.
        gap_passable: (G,) bool, whether each gap is wider than the robot.
    """

    edges: FloatArray
    gap_points: FloatArray
    gap_passable: NDArray[np.bool_]

    @classmethod
    def of(
        cls,
        scene: Scene,
        robot_width_m: float,
        *,
        min_height_m: float = 0.05,
        max_height_m: float = 1.0,
    ) -> GroundTruth:
        """The ground truth of ``scene`` for a robot of ``robot_width_m`` (metres)."""
        edges = [
            np.stack([part.footprint, np.roll(part.footprint, -1, axis=0)], axis=1)
            for ob in scene.obstacles
            for part in ob.parts
            if part.z_max_m >= min_height_m and part.z_min_m <= max_height_m
        ]
        gaps = scene.doubtful_gaps(robot_width_m)
        return cls(
            edges=np.concatenate(edges) if edges else np.zeros((0, 2, 2)),
            gap_points=np.array([[g.point_i, g.point_j] for g in gaps], dtype=np.float64).reshape(
                -1, 2, 2
            ),
            gap_passable=np.array([g.width_m > robot_width_m for g in gaps], dtype=bool),
        )


def normalised_outline_errors(points: FloatArray, cov: FloatArray, edges: FloatArray) -> FloatArray:
    """``z`` (n,) of points (n, 2) with covariances (n, 2, 2) against outline edges (E, 2, 2).

    ``z = |e| / sqrt(n^T C n)``, ``e`` from the nearest point of any edge to the point,
    ``n = e / |e|`` (0 where the point lies on an edge). NaN for every point if there is no edge.
    A compiled loop (0.1-0.3 ms a step with the model's outlines) equal to
    :func:`normalised_outline_errors_reference`, the same in NumPy.
    """
    n = points.shape[0]
    if n == 0:
        return np.zeros(0)
    if edges.shape[0] == 0:
        return np.full(n, np.nan)
    out: FloatArray = _outline_errors(
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(cov, dtype=np.float64),
        np.ascontiguousarray(edges, dtype=np.float64),
    )
    return out


def normalised_outline_errors_reference(
    points: FloatArray, cov: FloatArray, edges: FloatArray
) -> FloatArray:
    """:func:`normalised_outline_errors` in NumPy, for at least one point and one edge."""
    n = points.shape[0]
    ax, ay = edges[:, 0, 0], edges[:, 0, 1]
    bx, by = edges[:, 1, 0] - ax, edges[:, 1, 1] - ay
    inv_l2 = 1.0 / np.maximum(bx * bx + by * by, 1e-18)
    px = points[:, 0:1] - ax  # (n, E): from each edge's start to each point
    py = points[:, 1:2] - ay
    t = np.clip((px * bx + py * by) * inv_l2, 0.0, 1.0)
    ex = px - t * bx  # from the nearest point on each edge to the point
    ey = py - t * by
    best = np.argmin(ex * ex + ey * ey, axis=1)
    rows = np.arange(n)
    err_x, err_y = ex[rows, best], ey[rows, best]
    length = np.hypot(err_x, err_y)
    on_edge = length <= 1e-12
    safe = np.where(on_edge, 1.0, length)
    ux, uy = err_x / safe, err_y / safe
    var = ux * (cov[:, 0, 0] * ux + cov[:, 0, 1] * uy) + uy * (
        cov[:, 1, 0] * ux + cov[:, 1, 1] * uy
    )
    return np.where(on_edge, 0.0, length / np.sqrt(np.maximum(var, 1e-18)))


@compiled_on_first_call
def _outline_errors(points: FloatArray, cov: FloatArray, edges: FloatArray) -> FloatArray:
    """:func:`normalised_outline_errors` for at least one point and one edge (one pass)."""
    n = points.shape[0]
    out = np.empty(n)
    for k in range(n):
        best_d2 = np.inf
        best_x = 0.0
        best_y = 0.0
        for e in range(edges.shape[0]):
            ax, ay = edges[e, 0, 0], edges[e, 0, 1]
            bx, by = edges[e, 1, 0] - ax, edges[e, 1, 1] - ay
            inv_l2 = 1.0 / max(bx * bx + by * by, 1e-18)
            px, py = points[k, 0] - ax, points[k, 1] - ay
            t = min(max((px * bx + py * by) * inv_l2, 0.0), 1.0)
            ex, ey = px - t * bx, py - t * by  # from the nearest point on the edge to the point
            d2 = ex * ex + ey * ey
            if d2 < best_d2:
                best_d2, best_x, best_y = d2, ex, ey
        length = np.hypot(best_x, best_y)
        if length > 1e-12:
            ux, uy = best_x / length, best_y / length
            var = ux * (cov[k, 0, 0] * ux + cov[k, 0, 1] * uy) + uy * (
                cov[k, 1, 0] * ux + cov[k, 1, 1] * uy
            )
            out[k] = length / np.sqrt(max(var, 1e-18))
        else:
            out[k] = 0.0
    return out


def _outline_figures(model: EnvironmentModel, truth: GroundTruth) -> dict[str, float]:
    """Endpoint figures of the unambiguous segments and the true-candidate figures, at once.

    A face's floor segment (``source == FACE_SOURCE``, :mod:`modeling.stereo.faces`) does not count:
    it joins endpoints that are measured already, and would count them twice."""
    segs = [s for s in model.observation.segments if s.source != FACE_SOURCE]
    amb = model.observation.ambiguous
    cands = [c for a in amb for c in a.candidates]
    items = [*segs, *cands]
    out = {
        "nees_mean": math.nan,
        "coverage_95": math.nan,
        "endpoints": float(2 * len(segs)),
        "p_true_candidate": math.nan,
        "ambiguous_segments": float(len(amb)),
    }
    if not items:
        return out
    points = np.concatenate([s.endpoints for s in items])
    z = normalised_outline_errors(points, np.concatenate([s.cov for s in items]), truth.edges)
    n = 2 * len(segs)
    if n:
        out["nees_mean"] = float(np.mean(z[:n] ** 2))
        out["coverage_95"] = float(np.mean(np.abs(z[:n]) <= 1.96))
    if amb:
        score = (z[n:] ** 2).reshape(-1, 2).mean(axis=1)
        p_true: list[float] = []
        start = 0
        for a in amb:
            m = len(a.candidates)
            best = int(np.argmin(score[start : start + m]))
            on_outline = score[start + best] <= _CHI2_2_99
            p_true.append(a.probabilities[best] if on_outline else a.p_none)
            start += m
        out["p_true_candidate"] = float(np.mean(p_true))
    return out


def _active_items(model: EnvironmentModel) -> NDArray[np.bool_]:
    """(S, N) bool: which relation items (segments and candidates) each situation contains."""
    seg = np.asarray(model.item_segment)
    cand = np.asarray(model.item_candidate).reshape(-1, 2)
    kept = np.zeros(len(model.observation.segments) + 1, dtype=bool)
    kept[list(model.kept_segments)] = True
    base = (seg >= 0) & kept[np.where(seg >= 0, seg, -1)]
    n_amb = len(model.observation.ambiguous)
    out = np.repeat(base[None], len(model.situations), axis=0)
    is_cand = cand[:, 0] >= 0
    for k, situation in enumerate(model.situations):
        chosen = np.full(n_amb + 1, -2, dtype=np.int64)
        for a, c in {**model.merged_ambiguous, **situation.choice}.items():
            chosen[a] = c
        out[k] |= is_cand & (chosen[np.where(is_cand, cand[:, 0], -1)] == cand[:, 1])
    return out


def _near(points: FloatArray, cov: FloatArray, target: FloatArray) -> NDArray[np.bool_]:
    """Whether each point (r, 2) with covariance (r, 2, 2) plus the slack ``_GAP_SLACK_M^2`` on its
    diagonal is within squared Mahalanobis distance chi^2_2(0.99) of ``target`` (2,)."""
    slack = _GAP_SLACK_M**2
    c00, c11 = cov[:, 0, 0] + slack, cov[:, 1, 1] + slack
    c01, c10 = cov[:, 0, 1], cov[:, 1, 0]
    dx, dy = points[:, 0] - target[0], points[:, 1] - target[1]
    det = c00 * c11 - c01 * c10
    m2 = c11 * (dx * dx) - 2 * c01 * dx * dy + c00 * (dy * dy)
    near: NDArray[np.bool_] = m2 / det <= _CHI2_2_99
    return near


def _gap_figures(model: EnvironmentModel, truth: GroundTruth) -> dict[str, float]:
    nan = {"passability_brier": math.nan, "gaps_in_view": 0.0, "gaps_scored": 0.0}
    if truth.gap_points.shape[0] == 0:
        return nan
    obs = model.observation
    vx, vy, heading = (float(v) for v in obs.viewpoint)
    d = truth.gap_points - np.array([vx, vy])  # (G, 2, 2)
    rng = np.hypot(d[..., 0], d[..., 1])
    bearing = np.arctan2(d[..., 1], d[..., 0])
    bearing = wrap_angle(bearing - heading)
    in_view = np.all((rng <= obs.max_range_m) & (np.abs(bearing) <= 0.5 * obs.fov_rad), axis=1)
    if not np.any(in_view):
        return nan
    rel = model.relations
    sq_err: list[float] = []
    if len(rel) and model.situations:
        weights = np.array([s.probability for s in model.situations])
        active = _active_items(model)
        for g in np.flatnonzero(in_view).tolist():
            a, b = truth.gap_points[g]
            forward = _near(rel.point_i, rel.cov_i, a) & _near(rel.point_j, rel.cov_j, b)
            backward = _near(rel.point_i, rel.cov_i, b) & _near(rel.point_j, rel.cov_j, a)
            rows = np.flatnonzero(forward | backward)
            if rows.size == 0:
                continue
            present = active[:, rel.i[rows]] & active[:, rel.j[rows]]  # (S, rows)
            p = np.where(present, rel.p_passable[rows][None], np.inf).min(axis=1)
            seen = np.isfinite(p)
            if not np.any(seen) or weights[seen].sum() <= 0:
                continue
            p_hat = float(np.sum(weights[seen] * p[seen]) / weights[seen].sum())
            sq_err.append((p_hat - float(truth.gap_passable[g])) ** 2)
    return {
        "passability_brier": float(np.mean(sq_err)) if sq_err else math.nan,
        "gaps_in_view": float(np.count_nonzero(in_view)),
        "gaps_scored": float(len(sq_err)),
    }


def model_diagnostics(
    model: EnvironmentModel, truth: GroundTruth, *, prefix: str = ""
) -> dict[str, float]:
    """``info["diagnostics"]``: the figures of the module docstring, keyed by name.

    Args:
        model: The model of the latest observation (or the fused model of the episode's views:
            its segments and candidates are measured alike, and its gaps in the latest view).
        truth: The scene's ground truth (:meth:`GroundTruth.of`).
        prefix: Put before every name (the env gives the fused model's figures as
            ``memory_<name>``).

    Returns:
        A new dict of floats keyed by ``prefix`` + the names of :data:`DIAGNOSTIC_NAMES`, in that
        order, without the figures that have nothing to measure (see the module docstring).
    """
    out: dict[str, float] = {}
    out.update(_outline_figures(model, truth))
    out.update(_gap_figures(model, truth))
    out["situations"] = float(len(model.situations))
    out["residual_probability"] = float(model.residual_probability)
    return {prefix + name: out[name] for name in DIAGNOSTIC_NAMES if not math.isnan(out[name])}


def memory_beliefs(
    model: EnvironmentModel, memory: ModelMemory, truth: GroundTruth, gate_chi2: float
) -> list[tuple[float, float]]:
    """``(view's, memory's)`` probability of the true choice of each ambiguity of ``model``'s
    view (the module docstring), the true choice found as for ``p_true_candidate``.

    Args:
        model: The model of the view (its ambiguous segments are scored).
        memory: The memory with that view fused.
        truth: The scene's ground truth.
        gate_chi2: The association gate (squared Mahalanobis distance of an endpoint pair) within
            which a remembered segment or candidate stands for a view's candidate.
    """
    segs, cands = memory.segment_arrays, memory.candidate_arrays
    assert segs is not None and cands is not None  # made by ModelMemory.__post_init__
    existence = np.asarray(memory.existence)
    reported = existence >= memory.report_existence
    out: list[tuple[float, float]] = []
    for amb in model.observation.ambiguous:
        st = stack_of(list(amb.candidates))
        z = normalised_outline_errors(st.ends.reshape(-1, 2), st.cov.reshape(-1, 2, 2), truth.edges)
        score = (z**2).reshape(-1, 2).mean(axis=1)
        best = int(np.argmin(score))
        real = bool(score[best] <= _CHI2_2_99)
        belief = np.zeros(len(amb.candidates))
        for ends, cov, p in (
            (segs.ends[reported], segs.cov[reported], existence[reported]),
            (cands.stack.ends, cands.stack.cov, np.asarray(cands.prob)),
        ):
            pairs = gated_pairs(st.ends, st.cov, ends, cov, gate_chi2)
            np.maximum.at(belief, pairs.rows, p[pairs.cols])
        view = amb.probabilities[best] if real else amb.p_none
        out.append((view, float(belief[best]) if real else 1.0 - float(belief.max())))
    return out


def memory_diagnostics(
    memory_model: EnvironmentModel,
    memory: ModelMemory,
    gate_chi2: float,
    view_model: EnvironmentModel,
    truth: GroundTruth,
) -> dict[str, float]:
    """The fused model's figures, ``memory_<name>`` (the module docstring): those of
    :func:`model_diagnostics` with ``memory_p_true_candidate`` over the ambiguities of
    ``view_model`` (:func:`memory_beliefs`) and the fused model's own, over the ambiguities
    still open, as ``memory_open_p_true_candidate``."""
    out = model_diagnostics(memory_model, truth, prefix="memory_")
    own = out.pop("memory_p_true_candidate", None)
    if own is not None:
        out["memory_open_p_true_candidate"] = own
    beliefs = memory_beliefs(view_model, memory, truth, gate_chi2)
    if beliefs:
        out["memory_p_true_candidate"] = float(np.mean([b for _, b in beliefs]))
    return out
