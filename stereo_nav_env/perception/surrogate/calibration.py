"""The surrogate's calibration: measure the stereo pipeline against the true scene.

:func:`calibrate` returns the rates table that ``data/surrogate_rates.json`` holds
(:class:`~stereo_nav_env.perception.surrogate.rates.SurrogateRates` and what was measured);
``scripts/measure_surrogate.py`` runs it and writes the file.

Views: for each family and ``--scenes`` seeded scenes, the head poses of a scripted drive
(``--steps`` steps, the env with the surrogate perception drives it: the poses do not depend on
perception), and the views facing the front of a bookshelf of
:func:`agents.evaluation.stereo_accuracy.scene_views`. Each view is rendered with 2 grey levels of
pixel noise and run through the stereo stages (extraction, matching, triangulation). The truth is
the set of vertical edges the head sees
(:func:`stereo_nav_env.perception.surrogate.visibility.visible_edges`: where they are in the image,
their true disparity ``f b / Z``). A segment images the seen edge nearest to it whose column (in its
image: ``u - f b / Z`` in the right one) is within 2 px of its middle and whose rows hold that
middle (one edge each: a leg's outline segment does not also find the leg's front corner two pixels
away); an edge is found when a matched left segment images it (the nearest, when several do); then:

* ``detection`` (per edge class, :data:`stereo_nav_env.perception.surrogate.sensor.EDGE_CLASSES`,
  and depth bin): of the seen edges with contrast in both images (a piece in each,
  :func:`stereo_nav_env.perception.surrogate.photometry.image_pieces`: the surrogate drops the
  others itself), the fractions a segment images in both images, in the left one only, in the right
  one only;
* ``end_loss_px``: how far the left segment of an edge imaged by one stops short of each end of
  the edge's seen run (the median);
* ``false_match_rate`` (per depth bin): of the edges found with one (certain) match, those whose
  disparity is more than 1 px off, beyond the surrogate's own (it is measured without its drawn
  false matches: its matcher and the association make some); ``false_error_px``: the stereo's
  errors;
* ``error_scale``: the robust standard deviation (1.4826 MAD) of the disparity errors of the
  correct certain matches over the standard deviation the error model gives them.

Stored beside them under ``"measured"``, for both pipelines on the same views (the surrogate with
the rates read at the start): the miss rates per class and depth bin (no matched segment images
the edge), the fraction of found edges with several candidates per class, the offsets of wrong
candidates from the true disparity, and on the repeated edges of bookshelves (sides and
dividers) the fraction found ambiguous, the mean number of candidates, whether the true one is
among them and its mean probability. The surrogate's detection rates are the stereo's measured
ones; run the script twice after a change to the surrogate, so that the figures stored for the
surrogate are those of the rates written.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from typing import Any, cast

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from modeling.stereo.matching import StereoMatches, match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments, SegmentOptions, extract_segment_pair
from modeling.types import FloatArray
from stereo_nav_env.perception.noise import normal_noisy_grey
from stereo_nav_env.perception.surrogate.photometry import image_pieces
from stereo_nav_env.perception.surrogate.rates import (
    EDGE_CLASSES,
    SurrogateRates,
    default_rates,
    edge_classes,
)
from stereo_nav_env.perception.surrogate.sensor import surrogate_segments
from stereo_nav_env.perception.surrogate.visibility import SceneEdges, VisibleEdges, visible_edges
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import ObstacleKind, Scene
from stereo_nav_env.sim.views import STANDARD_FAMILIES, scene_views

DEPTH_BINS_M = (0.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0)
ASSOCIATE_PX = 2.0
MIN_EDGES_PER_BIN = 10
CORRECT_PX = 1.0


def drive_action(i: int) -> NDArray[np.float32]:
    """The scripted drive of step ``i`` (forward, a slow weave, the head panning)."""
    return np.array([0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)], dtype=np.float32)


def views(n_scenes: int, steps: int, seed: int) -> Iterator[tuple[Scene, HeadPose, bool]]:
    """``(scene, head pose, bookshelf view)`` of the drives and of the bookshelf views."""
    for f, family in enumerate(STANDARD_FAMILIES):
        env = gym.make(  # the v0 rules and observation: the drives the rates were measured on
            "StereoNav-v1",
            rules="v0",
            observation_mode="model",
            scenario=family,
            perception="surrogate",
            diagnostics=False,
        )
        base = env.unwrapped
        for k in range(n_scenes):
            env.reset(seed=seed + 100 * f + k)
            for i in range(steps):
                yield cast(Scene, base.scene), base.head_pose, False  # type: ignore[attr-defined]
                _, _, terminated, truncated, _ = env.step(drive_action(i))
                if terminated or truncated:
                    break
        env.close()
    for view in scene_views(4 * n_scenes, seed=seed):
        if view.bookshelf_view:
            yield view.scene, view.pose, True


def nearest_edge(mid: FloatArray, u: FloatArray, vis: VisibleEdges) -> NDArray[np.int64]:
    """The seen edge each segment images (-1: none): the one nearest in column to its middle
    ``mid`` (s, 2) ``(u, v)``, within ``ASSOCIATE_PX``, whose rows (within 2 px) hold the middle;
    ``u`` (e,) the edges' columns in that image."""
    if mid.shape[0] == 0 or u.shape[0] == 0:
        return np.full(mid.shape[0], -1, dtype=np.int64)
    du = np.abs(mid[:, None, 0] - u[None, :])
    inside = (mid[:, None, 1] >= vis.v_top - 2.0) & (mid[:, None, 1] <= vis.v_bottom + 2.0)
    du = np.where(inside & (du <= ASSOCIATE_PX), du, np.inf)  # (s, e)
    out: NDArray[np.int64] = np.where(np.isfinite(du.min(axis=1)), np.argmin(du, axis=1), -1)
    return out


def end_losses(left: ImageSegments, vis: VisibleEdges) -> list[float]:
    """How far the left segment of each seen edge imaged by exactly one stops short of the
    edge's seen run, at its top and at its bottom, px (two numbers per such edge)."""
    out: list[float] = []
    if len(vis) == 0:
        return out
    e = nearest_edge(left.endpoints.mean(axis=1), vis.u, vis)
    count = np.bincount(e[e >= 0], minlength=len(vis))
    for s in np.flatnonzero((e >= 0) & (count[np.maximum(e, 0)] == 1)).tolist():
        out.append(float(left.endpoints[s, 0, 1] - vis.v_top[e[s]]))
        out.append(float(vis.v_bottom[e[s]] - left.endpoints[s, 1, 1]))
    return out


def detected(
    left: ImageSegments, right: ImageSegments, vis: VisibleEdges, rig: StereoRig
) -> FloatArray:
    """(2, e) whether some segment of the left, of the right image images each seen edge
    (:func:`nearest_edge`; in the right image the edge's column is ``u - f b / Z``)."""
    out = np.zeros((2, len(vis)))
    for k, (segs, u) in enumerate(((left, vis.u), (right, vis.u - rig.fb / vis.Z))):
        e = nearest_edge(segs.endpoints.mean(axis=1), u, vis)
        out[k, e[e >= 0]] = 1.0
    return out


def associate(matches: StereoMatches, vis: VisibleEdges) -> dict[int, NDArray[np.int64]]:
    """For each seen edge imaged by a matched left segment: the rows of that segment's matches.

    A segment images one edge: the seen edge nearest in column, within ``ASSOCIATE_PX``, whose
    rows hold the segment's middle. An edge imaged by several segments (a wall's edge broken by
    an occluder) takes the nearest of them. An edge next to another one (a leg's front corner, a
    few pixels from its outline) is found only by a segment of its own, not by its neighbour's.
    """
    out: dict[int, NDArray[np.int64]] = {}
    if len(matches) == 0 or len(vis) == 0:
        return out
    lefts, first = np.unique(matches.left_index, return_index=True)
    mid = matches.left_endpoints[first].mean(axis=1)  # (s, 2) u, v
    nearest = nearest_edge(mid, vis.u, vis)  # each segment's edge
    du = np.abs(mid[:, 0, None] - vis.u[None, :])
    du = np.where(nearest[:, None] == np.arange(len(vis))[None, :], du, np.inf)
    best = np.argmin(du, axis=0)
    for e in np.flatnonzero(np.isfinite(du.min(axis=0))).tolist():
        out[e] = np.flatnonzero(matches.left_index == lefts[best[e]])
    return out


def edge_records(
    matches: StereoMatches,
    seen_in: FloatArray,
    vis: VisibleEdges,
    rig: StereoRig,
    repeated: NDArray[np.bool_],
    plain: NDArray[np.bool_],
    classes: NDArray[np.int64],
) -> dict[str, list[Any]]:
    """Per seen edge: depth, kind (plain, its class), in which images a segment images it
    (``seen_in``, :func:`detected`), found, certain, false, normalised errors, ambiguity
    figures."""
    rec: dict[str, list[Any]] = {
        k: []
        for k in ("depth", "found", "false", "certain_depth", "z", "false_err", "amb", "n_cand")
    }
    rec.update(
        p_true=[],
        true_in=[],
        plain=[],
        cls=[],
        ambiguous=[],
        other_amb=[],
        other_depth=[],
        wrong_offset=[],
    )
    rec["seen_in"] = seen_in.T.tolist()
    found = associate(matches, vis)
    d_true = rig.fb / vis.Z
    for e in range(len(vis)):
        rec["depth"].append(float(vis.Z[e]))
        rec["plain"].append(bool(plain[e]))
        rec["cls"].append(int(classes[e]))
        rows = found.get(e)
        rec["found"].append(rows is not None)
        rec["ambiguous"].append(rows is not None and rows.size > 1)
        if rows is None:
            continue
        d = matches.disparity_px[rows]  # (m, 2)
        err = d.mean(axis=1) - d_true[e]
        if rows.size == 1:
            rec["certain_depth"].append(float(vis.Z[e]))
            bad = abs(float(err[0])) > CORRECT_PX
            rec["false"].append(bad)
            if bad:
                rec["false_err"].append(abs(float(err[0])))
            else:
                var = matches.disparity_var[rows[0]]
                rec["z"].extend(((d[0] - d_true[e]) / np.sqrt(var)).tolist())
        if not repeated[e]:
            rec["other_amb"].append(rows.size > 1)
            rec["other_depth"].append(float(vis.Z[e]))
            if rows.size > 1 and np.any(np.abs(err) <= CORRECT_PX):  # the true one among them
                rec["wrong_offset"].extend(err[np.abs(err) > CORRECT_PX].tolist())
        if repeated[e]:
            rec["amb"].append(rows.size > 1)
            rec["n_cand"].append(int(rows.size))
            ok = np.abs(err) <= CORRECT_PX
            rec["true_in"].append(bool(ok.any()))
            p = matches.probability[rows]
            rec["p_true"].append(float(p[ok].max()) if ok.any() else 0.0)
    return rec


def _bookshelf_repeated(scene: Scene, edges: SceneEdges, vis: VisibleEdges) -> NDArray[np.bool_]:
    """Whether each seen edge is a repeated edge of a bookshelf (its group has several edges)."""
    part_obstacle = np.concatenate(
        [np.full(len(ob.drawn_parts), o) for o, ob in enumerate(scene.obstacles)]
    ).astype(np.int64)
    shelf = np.array([ob.kind is ObstacleKind.BOOKSHELF for ob in scene.obstacles])
    counts = np.bincount(edges.corner_group)
    is_shelf = shelf[part_obstacle[edges.corner_part[vis.corner]]]
    out: NDArray[np.bool_] = is_shelf & (counts[vis.group] > 1)
    return out


def measure(n_scenes: int, steps: int, seed: int, rates: SurrogateRates) -> dict[str, Any]:
    """The stereo's records over the views, and the surrogate's on the same views."""
    stereo: dict[str, list[Any]] = {}
    surrogate: dict[str, list[Any]] = {}
    bookshelf_views = 0
    renderer: StereoRenderer | None = None
    rig = StereoRig()
    rng = np.random.default_rng(seed)  # the pixel noise
    rng_surrogate = np.random.default_rng(seed + 1)  # apart: the stereo's views stay the same
    cache: tuple[Scene, SceneEdges] | None = None
    options = SegmentOptions()
    n_views = 0
    for scene, head, shelf_view in views(n_scenes, steps, seed):
        if renderer is None:
            renderer = StereoRenderer(rig, scene)
        elif renderer.scene is not scene:
            renderer.set_scene(scene)
        if cache is None or cache[0] is not scene:
            cache = (scene, SceneEdges.of(scene))
        edges = cache[1]
        left, right = renderer.render_stereo(head)
        gl, gr = normal_noisy_grey(left, rng, 2.0), normal_noisy_grey(right, rng, 2.0)
        sl, sr = extract_segment_pair(gl, gr, options)
        vis = visible_edges(
            edges, head, rig, trim_px=options.trim_px, min_length_px=options.min_length_px
        )
        repeated = _bookshelf_repeated(scene, edges, vis)
        plain = edges.corner_plain[vis.corner]
        classes = edge_classes(edges, vis)
        # the detection rates are of the edges with contrast in both images
        pieces = image_pieces(
            edges,
            head,
            rig,
            vis.u,
            vis.Z,
            vis.v_top,
            vis.v_bottom,
            options,
            end_loss_px=rates.end_loss_px,
        )
        has_piece = np.isin(np.arange(len(vis)), pieces[0].edge) & np.isin(
            np.arange(len(vis)), pieces[1].edge
        )
        for records, (left_segs, right_segs) in (
            (stereo, (sl, sr)),
            (surrogate, surrogate_segments(edges, rig, head, rng_surrogate, rates, options)),
        ):
            seen_in = detected(left_segs, right_segs, vis, rig)
            seen_in[:, ~has_piece] = np.nan
            matches = match_segments(left_segs, right_segs, rig)
            records_of = edge_records(matches, seen_in, vis, rig, repeated, plain, classes)
            records_of["end_loss"] = end_losses(left_segs, vis)
            for key, value in records_of.items():
                records.setdefault(key, []).extend(value)
        n_views += 1
        bookshelf_views += int(shelf_view)
    if renderer is not None:
        renderer.close()
    return {"stereo": stereo, "surrogate": surrogate, "views": n_views, "shelf": bookshelf_views}


def by_depth(depth: list[float], flag: list[bool]) -> list[float]:
    """The mean of ``flag`` in each of :data:`DEPTH_BINS_M` (0 where a bin is empty)."""
    d, f = np.asarray(depth), np.asarray(flag, dtype=np.float64)
    k = np.clip(np.searchsorted(DEPTH_BINS_M, d, side="right") - 1, 0, len(DEPTH_BINS_M) - 2)
    out = []
    for b in range(len(DEPTH_BINS_M) - 1):
        sel = k == b
        out.append(round(float(f[sel].mean()), 4) if sel.any() else 0.0)
    return out


def _of_class(rec: dict[str, list[Any]], cls: int) -> list[int]:
    """The records of the seen edges of one class (an index into ``EDGE_CLASSES``)."""
    return [k for k, c in enumerate(rec["cls"]) if c == cls]


def _found_of_class(rec: dict[str, list[Any]], cls: int) -> list[int]:
    """The records of the found seen edges of one class."""
    return [k for k in _of_class(rec, cls) if rec["found"][k]]


def miss_by_depth(rec: dict[str, list[Any]], cls: int) -> list[float]:
    """The miss rate (no matched segment images the edge) per depth bin of one class."""
    sel = _of_class(rec, cls)
    return by_depth([rec["depth"][k] for k in sel], [not rec["found"][k] for k in sel])


def detection_by_depth(rec: dict[str, list[Any]], cls: int) -> list[list[float]]:
    """Per depth bin, the fractions of the seen edges of one class with contrast in both images
    (a piece in each, :func:`~stereo_nav_env.perception.surrogate.photometry.image_pieces`) imaged
    in both images, in the left one only, in the right one only; a bin of fewer than
    ``MIN_EDGES_PER_BIN`` edges takes the nearest bin's that has them (none: all bins pooled)."""
    sel = [k for k in _of_class(rec, cls) if not math.isnan(rec["seen_in"][k][0])]
    d = np.asarray([rec["depth"][k] for k in sel], dtype=np.float64)
    seen = np.asarray([rec["seen_in"][k] for k in sel], dtype=bool).reshape(-1, 2)
    patterns = np.stack(
        [seen[:, 0] & seen[:, 1], seen[:, 0] & ~seen[:, 1], ~seen[:, 0] & seen[:, 1]], axis=1
    )
    n_bins = len(DEPTH_BINS_M) - 1
    k = np.clip(np.searchsorted(DEPTH_BINS_M, d, side="right") - 1, 0, n_bins - 1)
    count = np.bincount(k, minlength=n_bins)
    full = np.flatnonzero(count >= MIN_EDGES_PER_BIN)
    rows = []
    for b in range(n_bins):
        if full.size:
            sel_b = k == int(full[np.argmin(np.abs(full - b))])
        else:
            sel_b = np.ones(k.size, dtype=bool)
        rate = patterns[sel_b].mean(axis=0) if sel_b.any() else np.zeros(3)
        rows.append([math.floor(float(x) * 1e4) / 1e4 for x in rate])  # sums stay <= 1
    return rows


def summary(rec: dict[str, list[Any]]) -> dict[str, Any]:
    """The figures of one pipeline's records."""
    z = np.asarray(rec["z"])
    scale = 1.4826 * float(np.median(np.abs(z - np.median(z)))) if z.size else 1.0
    amb = np.asarray(rec["amb"], dtype=bool)
    p_true = np.asarray(rec["p_true"])
    n_cand = np.asarray(rec["n_cand"])
    true_in = np.asarray(rec["true_in"], dtype=bool)
    return {
        "edges_seen": len(rec["depth"]),
        "edges_found": int(np.sum(rec["found"])),
        "miss_rate": by_depth(rec["depth"], [not f for f in rec["found"]]),
        "miss_rate_by_class": {name: miss_by_depth(rec, c) for c, name in enumerate(EDGE_CLASSES)},
        "detection": {name: detection_by_depth(rec, c) for c, name in enumerate(EDGE_CLASSES)},
        "ambiguous_rate_by_class": {
            name: round(float(np.mean([rec["ambiguous"][k] for k in sel])), 4) if sel else 0.0
            for name, sel in ((n, _found_of_class(rec, c)) for c, n in enumerate(EDGE_CLASSES))
        },
        "certain_matches": len(rec["false"]),
        "false_match_rate": by_depth(rec["certain_depth"], rec["false"]),
        "false_match_rate_all": round(float(np.mean(rec["false"])), 4) if rec["false"] else 0.0,
        "false_error_px": [
            round(float(q), 3)
            for q in np.quantile(rec["false_err"] or [2.0], np.linspace(0, 1, 11))
        ],
        "error_scale": round(scale, 4),
        "end_loss_px": round(float(np.median(rec["end_loss"])), 3) if rec["end_loss"] else 0.0,
        "other_ambiguous_rate": by_depth(rec["other_depth"], rec["other_amb"]),
        "wrong_candidate_offset_px": [
            round(float(q), 3)
            for q in np.quantile(rec["wrong_offset"] or [0.0], np.linspace(0.05, 0.95, 10))
        ],
        "shelf_repeated_found": int(amb.size),
        "shelf_ambiguous_rate": round(float(amb.mean()), 4) if amb.size else 0.0,
        "shelf_candidates_mean_when_ambiguous": round(float(n_cand[amb].mean()), 3)
        if amb.any()
        else 0.0,
        "shelf_true_included_when_ambiguous": round(float(true_in[amb].mean()), 4)
        if amb.any()
        else 0.0,
        "shelf_p_true_mean_when_ambiguous": round(float(p_true[amb].mean()), 4)
        if amb.any()
        else 0.0,
        "shelf_p_true_quartiles_when_ambiguous": [
            round(float(q), 3) for q in np.quantile(p_true[amb], [0.25, 0.5, 0.75])
        ]
        if amb.any()
        else [],
    }


def calibrate(n_scenes: int = 3, steps: int = 40, seed: int = 1000) -> dict[str, Any]:
    """The surrogate's rates table, measured on the stereo pipeline (the module doc).

    Args:
        n_scenes: Seeded scenes per family.
        steps: Steps of each scripted drive.
        seed: The first scene seed.

    Returns:
        The JSON-friendly table: the :class:`SurrogateRates` fields, and under ``"measured"`` the
        figures of both pipelines on the same views.
    """
    # the surrogate is measured without its drawn false matches: the association
    # alone makes some of each (an edge a few pixels from another takes its segment); the rates
    # written make up the difference to the stereo's
    zero = (0.0,) * (len(DEPTH_BINS_M) - 1)
    rates = dataclasses.replace(default_rates(), false_match_rate=zero)
    result = measure(n_scenes, steps, seed, rates)
    stereo = summary(result["stereo"])
    natural = summary(result["surrogate"])

    def excess(stereo_rates: list[float], natural_rates: list[float]) -> list[float]:
        """The rate that, on top of the surrogate's own, gives the stereo's."""
        return [
            round(max(0.0, (a - b) / (1.0 - b)), 4) if b < 1 else 0.0
            for a, b in zip(stereo_rates, natural_rates, strict=True)
        ]

    false = excess(stereo["false_match_rate"], natural["false_match_rate"])
    table = {
        "depth_bins_m": list(DEPTH_BINS_M),
        "detection": stereo["detection"],
        "false_match_rate": false,
        "false_error_px": stereo["false_error_px"],
        "error_scale": stereo["error_scale"],
        "end_loss_px": stereo["end_loss_px"],
    }
    SurrogateRates.from_dict(table)  # checks it
    table["measured"] = {
        "views": result["views"],
        "bookshelf_views": result["shelf"],
        "scenes_per_family": n_scenes,
        "steps_per_drive": steps,
        "seed": seed,
        "stereo": stereo,
        "surrogate_without_false_matches": natural,
    }
    return table
