"""Measure the stereo pipeline against the true scene, and write the surrogate's rates.

    python scripts/measure_surrogate.py [--scenes N] [--steps N] [--out FILE] [--json FILE]

Views: for each family and ``--scenes`` seeded scenes, the head poses of a scripted drive
(``--steps`` steps, the env with the surrogate perception drives it: the poses do not depend on
perception), and the views facing the front of a bookshelf of
:func:`stereo_nav_env.stereo_eval.scene_views`. Each view is rendered with 2 grey levels of pixel
noise and run through the stereo stages (extraction, matching, triangulation). The truth is the
set of vertical edges the head sees (:func:`stereo_nav_env.surrogate_visibility.visible_edges`:
where they are in the image, their true disparity ``f b / Z``). A left segment images an edge when
its middle lies within 2 px of the edge's column and within its rows (the nearest such segment;
one segment may image several edges a few pixels apart, a leg's corners); then:

* ``miss_rate_plain``, ``miss_rate_furniture`` (per depth bin): the seen edges no matched left
  segment images, of walls and boxes, and of furniture (``miss_rate``: all of them);
* ``false_match_rate`` (per depth bin): of the edges found with one (certain) match, those whose
  disparity is more than 1 px off, beyond the surrogate's own (it is measured without false
  matches: the association alone makes some); ``false_error_px``: the stereo's errors;
* ``stray_rate`` (per depth bin): how often an edge that is not a repeated shelf edge must get a
  stray candidate for the surrogate to be as ambiguous there as the stereo (the stereo's
  ambiguous fraction over the surrogate's without strays), ``stray_offset_px``: the disparity
  offsets of the stereo's other candidates there (deciles);
* ``error_scale``: the robust standard deviation (1.4826 MAD) of the disparity errors of the
  correct certain matches over the standard deviation the error model gives them;
* on the repeated edges of bookshelves (sides and dividers): the fraction found ambiguous, the
  mean number of candidates, whether the true one is among them and its mean probability; the same
  for the surrogate on the same views (its rates being the ones measured), for comparison.

The first four are the table the surrogate reads (``stereo_nav_env/data/surrogate_rates.json``,
``--out``); the rest is stored beside them under ``"measured"``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import pathlib
import sys
from collections.abc import Iterator
from typing import Any, cast

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.matching import StereoMatches, match_segments
from modeling.rig import HeadPose, StereoRig
from modeling.segments import extract_segment_pair
from stereo_nav_env.render import StereoRenderer
from stereo_nav_env.scenes import ObstacleKind, Scene
from stereo_nav_env.stereo_eval import FAMILIES, noisy_gray, scene_views
from stereo_nav_env.surrogate import RATES_FILE, SurrogateRates, default_rates, surrogate_segments
from stereo_nav_env.surrogate_visibility import SceneEdges, VisibleEdges, visible_edges

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEPTH_BINS_M = (0.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0)
ASSOCIATE_PX = 2.0
CORRECT_PX = 1.0

FloatArray = NDArray[np.float64]


def drive_action(i: int) -> NDArray[np.float32]:
    """The scripted drive of step ``i`` (forward, a slow weave, the head panning)."""
    return np.array([0.6, 0.3 * math.sin(i / 9.0), 0.8 * math.sin(i / 6.0)], dtype=np.float32)


def views(n_scenes: int, steps: int, seed: int) -> Iterator[tuple[Scene, HeadPose, bool]]:
    """``(scene, head pose, bookshelf view)`` of the drives and of the bookshelf views."""
    for f, family in enumerate(FAMILIES):
        env = gym.make("StereoNav-v0", scenario=family, perception="surrogate", diagnostics=False)
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


def associate(matches: StereoMatches, vis: VisibleEdges) -> dict[int, NDArray[np.int64]]:
    """For each seen edge imaged by a matched left segment: the rows of that segment's matches
    (the nearest segment in column, within ``ASSOCIATE_PX``, its middle within the edge's rows;
    one segment may image several edges a few pixels apart, such as a leg's corners)."""
    out: dict[int, NDArray[np.int64]] = {}
    if len(matches) == 0 or len(vis) == 0:
        return out
    lefts, first = np.unique(matches.left_index, return_index=True)
    mid = matches.left_endpoints[first].mean(axis=1)  # (s, 2) u, v
    du = np.abs(mid[:, None, 0] - vis.u[None, :])
    inside = (mid[:, None, 1] >= vis.v_top - 2.0) & (mid[:, None, 1] <= vis.v_bottom + 2.0)
    du = np.where(inside & (du <= ASSOCIATE_PX), du, np.inf)  # (s, e)
    best = np.argmin(du, axis=0)
    for e in np.flatnonzero(np.isfinite(du.min(axis=0))).tolist():
        out[e] = np.flatnonzero(matches.left_index == lefts[best[e]])
    return out


def edge_records(
    matches: StereoMatches,
    vis: VisibleEdges,
    rig: StereoRig,
    repeated: NDArray[np.bool_],
    plain: NDArray[np.bool_],
) -> dict[str, list[Any]]:
    """Per seen edge: depth, found, certain, false, normalised errors, ambiguity figures."""
    rec: dict[str, list[Any]] = {
        k: []
        for k in ("depth", "found", "false", "certain_depth", "z", "false_err", "amb", "n_cand")
    }
    rec.update(p_true=[], true_in=[], plain=[], other_amb=[], other_depth=[], stray_offset=[])
    found = associate(matches, vis)
    d_true = rig.fb / vis.Z
    for e in range(len(vis)):
        rec["depth"].append(float(vis.Z[e]))
        rec["plain"].append(bool(plain[e]))
        rows = found.get(e)
        rec["found"].append(rows is not None)
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
            if rows.size > 1:
                rec["stray_offset"].extend(np.abs(d.mean(axis=1)[1:] - d.mean(axis=1)[0]).tolist())
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
        [np.full(len(ob.parts), o) for o, ob in enumerate(scene.obstacles)]
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
        gl, gr = noisy_gray(left, rng, 2.0), noisy_gray(right, rng, 2.0)
        sl, sr = extract_segment_pair(gl, gr)
        vis = visible_edges(edges, head, rig, trim_px=2, min_length_px=12.0)
        repeated = _bookshelf_repeated(scene, edges, vis)
        plain = edges.corner_plain[vis.corner]
        stereo_matches = match_segments(sl, sr, rig)
        for key, value in edge_records(stereo_matches, vis, rig, repeated, plain).items():
            stereo.setdefault(key, []).extend(value)
        s_left, s_right = surrogate_segments(edges, rig, head, rng_surrogate, rates)
        s_matches = match_segments(s_left, s_right, rig)
        for key, value in edge_records(s_matches, vis, rig, repeated, plain).items():
            surrogate.setdefault(key, []).extend(value)
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
        "miss_rate_plain": by_depth(
            [d for d, p in zip(rec["depth"], rec["plain"], strict=True) if p],
            [not f for f, p in zip(rec["found"], rec["plain"], strict=True) if p],
        ),
        "miss_rate_furniture": by_depth(
            [d for d, p in zip(rec["depth"], rec["plain"], strict=True) if not p],
            [not f for f, p in zip(rec["found"], rec["plain"], strict=True) if not p],
        ),
        "certain_matches": len(rec["false"]),
        "false_match_rate": by_depth(rec["certain_depth"], rec["false"]),
        "false_match_rate_all": round(float(np.mean(rec["false"])), 4) if rec["false"] else 0.0,
        "false_error_px": [
            round(float(q), 3)
            for q in np.quantile(rec["false_err"] or [2.0], np.linspace(0, 1, 11))
        ],
        "error_scale": round(scale, 4),
        "other_ambiguous_rate": by_depth(rec["other_depth"], rec["other_amb"]),
        "stray_offset_px": [
            round(float(q), 3)
            for q in np.quantile(rec["stray_offset"] or [5.0], np.linspace(0.05, 0.95, 10))
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--scenes", type=int, default=3, help="scenes per family")
    parser.add_argument("--steps", type=int, default=40, help="steps of each drive")
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        default=ROOT / "stereo_nav_env" / "data" / RATES_FILE,
        help="the rates table to write",
    )
    parser.add_argument("--dry-run", action="store_true", help="print, write nothing")
    args = parser.parse_args(argv)
    # the surrogate is measured without stray candidates and false matches: the association
    # alone makes some of each (an edge a few pixels from another takes its segment); the rates
    # written make up the difference to the stereo's
    zero = (0.0,) * (len(DEPTH_BINS_M) - 1)
    rates = dataclasses.replace(default_rates(), stray_rate=zero, false_match_rate=zero)
    result = measure(args.scenes, args.steps, args.seed, rates)
    stereo = summary(result["stereo"])
    natural = summary(result["surrogate"])

    def excess(stereo_rates: list[float], natural_rates: list[float]) -> list[float]:
        """The rate that, on top of the surrogate's own, gives the stereo's."""
        return [
            round(max(0.0, (a - b) / (1.0 - b)), 4) if b < 1 else 0.0
            for a, b in zip(stereo_rates, natural_rates, strict=True)
        ]

    stray = excess(stereo["other_ambiguous_rate"], natural["other_ambiguous_rate"])
    false = excess(stereo["false_match_rate"], natural["false_match_rate"])
    table = {
        "depth_bins_m": list(DEPTH_BINS_M),
        "miss_rate_plain": stereo["miss_rate_plain"],
        "miss_rate_furniture": stereo["miss_rate_furniture"],
        "false_match_rate": false,
        "false_error_px": stereo["false_error_px"],
        "stray_rate": stray,
        "stray_offset_px": stereo["stray_offset_px"],
        "error_scale": stereo["error_scale"],
    }
    SurrogateRates.from_dict(table)  # checks it
    table["measured"] = {
        "views": result["views"],
        "bookshelf_views": result["shelf"],
        "scenes_per_family": args.scenes,
        "steps_per_drive": args.steps,
        "seed": args.seed,
        "stereo": stereo,
        "surrogate_without_strays_and_false_matches": natural,
    }
    text = json.dumps(table, indent=2) + "\n"
    print(text)
    if not args.dry_run:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
