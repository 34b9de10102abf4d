"""Segment-based stereo (issue 3) against ground truth and against OpenCV's StereoSGBM.

Renders seeded scenes of every family at 320x240 (views from the start pose, and views facing
the front of a bookshelf where the scene has one), adds Gaussian pixel noise, runs
extraction -> matching -> triangulation, and reports (flat JSON, units in the names):

* ``stereo_{extract,match,triangulate,total}_median_ms``: time per pair (both images' extraction,
  matching, triangulation), the median over ``repeats`` runs of each view, then over the views;
  ``sgbm_median_ms``: StereoSGBM per pair; ``render_stereo_median_ms``: the renderer per pair.
  The machine is shared and its load varies: ``stereo_total_over_sgbm_ratio`` (median over the
  views of the stereo time over SGBM's, measured back to back) is the load-independent figure.
* ``stereo_depth_abs_err_median_m`` / ``sgbm_depth_abs_err_median_m``: depth error at the
  segment pixels (the midpoints of the certain matches) for both methods (SGBM gets the best of
  the three pixels across the edge, chosen with the truth: it has no edge model).
* ``stereo_certain_within_1px_fraction``: of the matches with probability >= 0.99, the fraction
  whose disparity (at the midpoint of the overlapping part) is within 1 px of the truth
  (acceptance >= 0.95). The true disparity of a left pixel is ``f b / Z`` with ``Z`` the
  renderer's depth, the nearest within +-1 px along the row (an edge belongs to its front surface).
* Ambiguity (acceptance: the true candidate is among the candidates >= 95 % of the time). Over the
  left segments with several kept candidates ("ambiguous"), a candidate is *true* if its
  disparity is within 1 px of the truth.
  ``stereo_ambiguous_true_included_fraction``: the fraction of ambiguous left segments whose kept
  candidates include a true one, over all of them.
  ``stereo_ambiguous_true_available_count`` / ``..._included_when_available_fraction``: the same
  over the ambiguous left segments whose true partner was *available*: a segment of the right
  image's extraction that, paired with the left segment, passes the matching constraints
  (epipolar overlap, direction, photometric, disparity range: ``match_candidates``, i.e. it was a
  candidate before the histograms decided) and is true. This is not tautological: it says nothing
  about the histograms' decision, which is what is measured. The others
  (``stereo_ambiguous_no_true_candidate_count``) are left edges whose partner the right image does
  not have: occluded, out of view, or a view-dependent contour seen at another 3D line.
  ``stereo_ambiguous_segments_bookshelf_count``: ambiguous segments in bookshelf views.
* ``stereo_outline_within_1p96_fraction``: floor endpoints (of unambiguous segments) on a true
  obstacle outline whose error across the outline, over the standard deviation the covariance
  gives in that direction, is within 1.96 (acceptance 0.90 to 0.98, ideal 0.95); all matches,
  wrong ones included. ``stereo_outline_correct_within_1p96_fraction``: the same over the
  correct matches (disparity within 1 px), i.e. the calibration of the covariance itself.
* NEES (normalised estimation error squared, ``r^T C^-1 r`` of a floor endpoint, 2-D: ideal mean
  2, median 1.39, 95 % below 5.99), over the endpoints of segments that image a *vertical* edge of
  a rendered obstacle part: their true floor point is the part's footprint corner, the one whose
  projection is nearest the segment (within 2 px in the image and 5 % in depth).
  ``stereo_nees_mean_correct_matches`` (the meaningful figure: the covariance describes the
  localisation error of a correct match; a wrong match is a gross error outside that Gaussian
  model, whose rate ``stereo_certain_within_1px_fraction`` gives), ``..._median_correct_matches``,
  ``stereo_nees_within_5p99_correct_fraction``; ``stereo_nees_mean`` over all matches is
  dominated by the few wrong ones (errors of 10 sigma and more) and is reported for completeness.

    python scripts/bench_stereo.py [--json FILE] [--n-scenes N] [--quick]
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import cv2
import numpy as np
from _figures import print_figures, write_figures

from modeling.matching import StereoMatches, match_candidates, match_segments
from modeling.observation import FloorObservation
from modeling.pipeline import to_gray
from modeling.rig import HeadPose, StereoRig
from modeling.segments import extract_segment_pair
from modeling.triangulation import triangulate_to_floor

HEAD_HEIGHT_M = 0.8
FAMILIES = ("room", "corridor", "cluttered", "office")


@dataclass
class ViewResult:
    """Per-view measurements (lists are concatenated over views)."""

    family: str
    bookshelf_view: bool
    t_extract_ms: float = 0.0
    t_match_ms: float = 0.0
    t_triangulate_ms: float = 0.0
    t_sgbm_ms: float = 0.0
    t_render_ms: float = 0.0
    certain_err_px: list[float] = field(default_factory=list)
    ambiguous_has_true: list[bool] = field(default_factory=list)
    ambiguous_has_true_available: list[bool] = field(default_factory=list)
    n_ambiguous_no_true_candidate: int = 0
    n_ambiguous_segments: int = 0
    stereo_depth_err_m: list[float] = field(default_factory=list)
    sgbm_depth_err_m: list[float] = field(default_factory=list)
    outline_z: list[float] = field(default_factory=list)
    nees: list[float] = field(default_factory=list)
    outline_z_correct: list[float] = field(default_factory=list)
    nees_correct: list[float] = field(default_factory=list)


def scene_views(n_scenes: int, seed: int = 0) -> Iterator[tuple[object, HeadPose, str, bool]]:
    """``(scene, head_pose, family, faces_bookshelf)`` for ``n_scenes`` seeded scenes.

    Each scene gives the view from its start pose and, if it has a bookshelf, a view of the
    bookshelf's front from 1.6 to 3.2 m.
    """
    from stereo_nav_env.scenes import ObstacleKind, generate_scene

    rng = np.random.default_rng(seed)
    for i in range(n_scenes):
        family = FAMILIES[i % len(FAMILIES)]
        scene = generate_scene(seed + i, family=family)
        x, y, h = scene.start
        yield scene, HeadPose(x_m=x, y_m=y, heading_rad=h, height_m=HEAD_HEIGHT_M), family, False
        shelves = [o for o in scene.obstacles if o.kind is ObstacleKind.BOOKSHELF]
        for _ in range(20):
            if not shelves:
                break
            ob = shelves[int(rng.integers(len(shelves)))]
            fp = ob.footprint
            a, b = fp[0], fp[1]
            e = b - a
            normal = np.array([e[1], -e[0]]) / np.linalg.norm(e)  # outward, front side
            dist = rng.uniform(1.6, 3.2)
            lateral = rng.uniform(-0.3, 0.3) * np.linalg.norm(e)
            p = (a + b) / 2 + normal * dist + lateral * e / np.linalg.norm(e)
            if not scene.is_free(p, 0.5, 0.0):
                continue
            heading = math.atan2(-normal[1], -normal[0]) + rng.uniform(-0.25, 0.25)
            pose = HeadPose(x_m=p[0], y_m=p[1], heading_rad=heading, height_m=HEAD_HEIGHT_M)
            yield scene, pose, family, True
            break


def true_disparity(depth: np.ndarray, rig: StereoRig, uv: np.ndarray, half: int = 1) -> np.ndarray:
    """True disparity at left pixels ``uv`` (n, 2): the nearest depth within ``half`` px along the
    row (an edge belongs to its front surface); NaN where nothing is seen."""
    H, W = depth.shape
    u = np.clip(np.rint(uv[:, 0]).astype(int), 0, W - 1)
    v = np.clip(np.rint(uv[:, 1]).astype(int), 0, H - 1)
    cols = np.clip(u[:, None] + np.arange(-half, half + 1)[None, :], 0, W - 1)
    z = depth[v[:, None], cols].min(axis=1)
    return np.where(np.isfinite(z), rig.fb / z, np.nan)


def _vertical_edge_truth(
    P: np.ndarray,
    u_mid: float,
    rig: StereoRig,
    pose: HeadPose,
    corners: np.ndarray,
    *,
    max_px: float = 2.0,
    max_depth_frac: float = 0.05,
) -> np.ndarray | None:
    """The true floor point of a segment imaging a vertical obstacle edge, or ``None``.

    ``P`` (3, 3): world points of the segment's ends and midpoint at the true disparity. The edge is
    vertical if they share their floor point (within 1 cm); its truth is then the footprint corner
    of a rendered part (``corners`` (k, 2), world) whose projection is nearest the segment's column
    ``u_mid``, among those within ``max_px`` in the image and ``max_depth_frac`` in depth.
    """
    if np.ptp(P[:, 0]) >= 0.01 or np.ptp(P[:, 1]) >= 0.01:
        return None
    C = pose.world_to_cam(np.column_stack([corners, np.zeros(len(corners))]))
    z_true = float(pose.world_to_cam(P[2:3])[0, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        u = rig.focal_px * C[:, 0] / C[:, 2] + rig.cx_px
    near = (C[:, 2] > 0) & (np.abs(C[:, 2] - z_true) <= max_depth_frac * z_true)
    near &= np.abs(u - u_mid) <= max_px
    if not np.any(near):
        return None
    cand = np.flatnonzero(near)
    return corners[cand[np.argmin(np.abs(u[cand] - u_mid))]]


def _outline_errors(
    obs: FloorObservation,
    matches: StereoMatches,
    depth: np.ndarray,
    rig: StereoRig,
    pose: HeadPose,
    footprints: list[np.ndarray],
    corners: np.ndarray,
    on_outline_m: float = 0.025,
) -> tuple[list[float], list[float], list[bool], list[bool]]:
    """Normalised across-outline errors of floor endpoints on true obstacle outlines, NEES of the
    endpoints of vertical obstacle edges, and for each whether its match is correct (disparity
    within 1 px of the truth at the midpoint)."""
    z_scores: list[float] = []
    nees: list[float] = []
    z_ok: list[bool] = []
    nees_ok: list[bool] = []
    outlines = [(fp, np.roll(fp, -1, axis=0) - fp) for fp in footprints]
    for seg in obs.segments:
        rows = np.flatnonzero(matches.left_index == seg.source)
        if rows.size != 1:
            continue
        ends = matches.left_endpoints[rows[0]]
        mid = ends.mean(axis=0)
        pts = np.vstack([ends, mid[None, :]])
        dtrue = true_disparity(depth, rig, pts)
        if not np.all(np.isfinite(dtrue)):
            continue
        correct = bool(abs(matches.disparity_px[rows[0]].mean() - dtrue[2]) <= 1.0)
        P = pose.cam_to_world(rig.triangulate(pts[:, 0], pts[:, 1], dtrue))
        # full 2-D NEES where the 3D edge is vertical (its floor point is known in full)
        truth = _vertical_edge_truth(P, float(mid[0]), rig, pose, corners)
        if truth is not None:
            for k in range(2):
                r = seg.endpoints[k] - truth
                nees.append(float(r @ np.linalg.solve(seg.cov[k], r)))
                nees_ok.append(correct)
        h = P[:, 2]
        inband = (h > 0.05) & (h < 1.0)
        if not np.any(inband):
            continue
        true_xy = P[inband, :2]
        # the footprint whose outline the segment lies on
        best = None
        for a, ab in outlines:
            L2 = np.einsum("ij,ij->i", ab, ab)
            t = np.clip(np.einsum("kij,ij->ki", true_xy[:, None, :] - a[None], ab) / L2, 0, 1)
            close = a[None] + t[..., None] * ab[None]
            dist = np.linalg.norm(true_xy[:, None, :] - close, axis=-1).min(axis=1)
            if np.all(dist <= on_outline_m):
                best = (a, ab, L2)
                break
        if best is None:
            continue
        a, ab, L2 = best
        normals = np.stack([ab[:, 1], -ab[:, 0]], axis=1) / np.sqrt(L2)[:, None]
        for k in range(2):
            est = seg.endpoints[k]
            t = np.clip(((est - a) * ab).sum(axis=1) / L2, 0, 1)
            dist = np.linalg.norm(est - (a + t[:, None] * ab), axis=1)
            j = int(np.argmin(dist))
            n = normals[j]
            err = float(n @ (est - a[j]))
            std = math.sqrt(float(n @ seg.cov[k] @ n))
            z_scores.append(err / std)
            z_ok.append(correct)
    return z_scores, nees, z_ok, nees_ok


def evaluate_view(
    renderer: object,
    scene: object,
    pose: HeadPose,
    rig: StereoRig,
    rng: np.random.Generator,
    *,
    family: str,
    bookshelf_view: bool,
    noise_sigma: float = 2.0,
    sgbm: object | None = None,
    repeats: int = 1,
) -> ViewResult:
    """Render one view, run the stereo stages (timed), compare with ground truth."""
    res = ViewResult(family=family, bookshelf_view=bookshelf_view)
    t0 = time.perf_counter()
    left, right = renderer.render_stereo(pose)  # type: ignore[attr-defined]
    res.t_render_ms = (time.perf_counter() - t0) * 1e3
    depth = renderer.render_depth(pose)  # type: ignore[attr-defined]
    gl = to_gray(left).astype(np.float64)
    gr = to_gray(right).astype(np.float64)
    gl = np.clip(np.rint(gl + rng.normal(0, noise_sigma, gl.shape)), 0, 255).astype(np.uint8)
    gr = np.clip(np.rint(gr + rng.normal(0, noise_sigma, gr.shape)), 0, 255).astype(np.uint8)

    te, tm, tt = [], [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sl, sr = extract_segment_pair(gl, gr)
        t1 = time.perf_counter()
        matches = match_segments(sl, sr, rig)
        t2 = time.perf_counter()
        obs = triangulate_to_floor(matches, rig, pose)
        t3 = time.perf_counter()
        te.append(t1 - t0)
        tm.append(t2 - t1)
        tt.append(t3 - t2)
    res.t_extract_ms = float(np.median(te)) * 1e3
    res.t_match_ms = float(np.median(tm)) * 1e3
    res.t_triangulate_ms = float(np.median(tt)) * 1e3

    if len(matches):
        mids = matches.left_endpoints.mean(axis=1)
        d_est = matches.disparity_px.mean(axis=1)
        d_true = true_disparity(depth, rig, mids)
        err = np.abs(d_est - d_true)
        certain = (matches.probability >= 0.99) & np.isfinite(d_true)
        res.certain_err_px = err[certain].tolist()
        z_true = rig.fb / d_true[certain]
        res.stereo_depth_err_m = np.abs(rig.fb / d_est[certain] - z_true).tolist()
        amb = matches.ambiguous & np.isfinite(d_true)
        # the true partner was available if some candidate that passed the constraints (before
        # the histograms decided) has the true disparity
        cand = match_candidates(sl, sr, rig)
        c_rows = cand.rows_px.mean(axis=1)
        c_mid = np.column_stack([sl.u_at(cand.left_index, c_rows), c_rows])
        c_err = np.abs(cand.disparity_px.mean(axis=1) - true_disparity(depth, rig, c_mid))
        available = set(cand.left_index[c_err <= 1.0].tolist())
        for li in np.unique(matches.left_index[amb]):
            rows = matches.left_index == li
            has = bool(np.any(err[rows] <= 1.0))
            res.ambiguous_has_true.append(has)
            if int(li) in available:
                res.ambiguous_has_true_available.append(has)
            else:
                res.n_ambiguous_no_true_candidate += 1
        res.n_ambiguous_segments = len(obs.ambiguous)

        if sgbm is not None:
            t0 = time.perf_counter()
            disp16 = sgbm.compute(gl, gr)  # type: ignore[attr-defined]
            res.t_sgbm_ms = (time.perf_counter() - t0) * 1e3
            disp = disp16.astype(np.float64) / 16.0
            u = np.clip(np.rint(mids[certain, 0]).astype(int), 0, rig.width_px - 1)
            v = np.clip(np.rint(mids[certain, 1]).astype(int), 0, rig.height_px - 1)
            # SGBM at the segment pixel (best of +-1 px across the edge: it has no edge model)
            cols = np.clip(u[:, None] + np.arange(-1, 2)[None, :], 0, rig.width_px - 1)
            ds = disp[v[:, None], cols]
            dt = d_true[certain]
            pick = np.argmin(np.abs(np.where(ds > 0, ds, np.inf) - dt[:, None]), axis=1)
            dsel = ds[np.arange(ds.shape[0]), pick]
            z_sgbm = np.where(dsel > 0, rig.fb / np.maximum(dsel, 1e-6), np.inf)
            res.sgbm_depth_err_m = np.minimum(np.abs(z_sgbm - rig.fb / dt), 100.0).tolist()

        obstacles = scene.obstacles  # type: ignore[attr-defined]
        footprints = [np.asarray(o.footprint) for o in obstacles]
        corners = np.vstack([np.asarray(p.footprint) for o in obstacles for p in o.parts])
        z, nees, z_ok, nees_ok = _outline_errors(
            obs, matches, depth, rig, pose, footprints, corners
        )
        res.outline_z, res.nees = z, nees
        res.outline_z_correct = [x for x, ok in zip(z, z_ok, strict=True) if ok]
        res.nees_correct = [x for x, ok in zip(nees, nees_ok, strict=True) if ok]
    elif sgbm is not None:
        t0 = time.perf_counter()
        sgbm.compute(gl, gr)  # type: ignore[attr-defined]
        res.t_sgbm_ms = (time.perf_counter() - t0) * 1e3
    return res


def make_sgbm(rig: StereoRig) -> object:
    """StereoSGBM with the rig's disparity range (rounded up to a multiple of 16)."""
    num = int(math.ceil(rig.max_disparity_px / 16.0) * 16)
    block = 5
    return cv2.StereoSGBM_create(
        minDisparity=0,
        numDisparities=num,
        blockSize=block,
        P1=8 * block * block,
        P2=32 * block * block,
        uniquenessRatio=5,
        mode=cv2.STEREO_SGBM_MODE_SGBM,
    )


def evaluate(
    n_scenes: int = 20,
    *,
    seed: int = 0,
    noise_sigma: float = 2.0,
    sgbm: bool = True,
    repeats: int = 1,
) -> list[ViewResult]:
    """All views of ``n_scenes`` seeded scenes."""
    from stereo_nav_env.render import StereoRenderer

    rig = StereoRig()
    rng = np.random.default_rng(seed + 12345)
    matcher = make_sgbm(rig) if sgbm else None
    results: list[ViewResult] = []
    renderer = None
    try:
        for scene, pose, family, shelf in scene_views(n_scenes, seed):
            if renderer is None:
                renderer = StereoRenderer(rig, scene)  # type: ignore[arg-type]
            elif renderer.scene is not scene:
                renderer.set_scene(scene)  # type: ignore[arg-type]
            results.append(
                evaluate_view(
                    renderer,
                    scene,
                    pose,
                    rig,
                    rng,
                    family=family,
                    bookshelf_view=shelf,
                    noise_sigma=noise_sigma,
                    sgbm=matcher,
                    repeats=repeats,
                )
            )
    finally:
        if renderer is not None:
            renderer.close()
    return results


def summarise(results: list[ViewResult]) -> dict[str, float]:
    """The flat dict of figures (definitions in the module docstring)."""

    def cat(name: str) -> np.ndarray:
        return np.array([x for r in results for x in getattr(r, name)], dtype=np.float64)

    def med(name: str) -> float:
        return float(np.median([getattr(r, name) for r in results]))

    def stat(fn: object, x: np.ndarray) -> float:
        return float(fn(x)) if x.size else float("nan")  # type: ignore[operator]

    certain = cat("certain_err_px")
    amb = cat("ambiguous_has_true")
    amb_av = cat("ambiguous_has_true_available")
    z = cat("outline_z")
    zc = cat("outline_z_correct")
    nees = cat("nees")
    nc = cat("nees_correct")
    total = [r.t_extract_ms + r.t_match_ms + r.t_triangulate_ms for r in results]
    total_arr = np.array(total)
    sgbm_arr = np.array([r.t_sgbm_ms for r in results])
    return {
        "stereo_views_count": float(len(results)),
        # speed
        "render_stereo_median_ms": med("t_render_ms"),
        "stereo_extract_median_ms": med("t_extract_ms"),
        "stereo_match_median_ms": med("t_match_ms"),
        "stereo_triangulate_median_ms": med("t_triangulate_ms"),
        "stereo_total_median_ms": float(np.median(total)),
        "sgbm_median_ms": med("t_sgbm_ms"),
        "stereo_total_over_sgbm_ratio": stat(np.median, total_arr / sgbm_arr)
        if np.all(sgbm_arr > 0)
        else float("nan"),
        # accuracy of the certain matches, against SGBM
        "stereo_depth_abs_err_median_m": stat(np.median, cat("stereo_depth_err_m")),
        "sgbm_depth_abs_err_median_m": stat(np.median, cat("sgbm_depth_err_m")),
        "stereo_disparity_abs_err_median_px": stat(np.median, certain),
        "stereo_certain_matches_count": float(certain.size),
        "stereo_certain_within_1px_fraction": stat(np.mean, certain <= 1.0),
        # ambiguity
        "stereo_ambiguous_left_segments_count": float(amb.size),
        "stereo_ambiguous_true_included_fraction": stat(np.mean, amb),
        "stereo_ambiguous_true_available_count": float(amb_av.size),
        "stereo_ambiguous_true_included_when_available_fraction": stat(np.mean, amb_av),
        "stereo_ambiguous_no_true_candidate_count": float(
            sum(r.n_ambiguous_no_true_candidate for r in results)
        ),
        "stereo_ambiguous_segments_count": float(sum(r.n_ambiguous_segments for r in results)),
        "stereo_ambiguous_segments_bookshelf_count": float(
            sum(r.n_ambiguous_segments for r in results if r.bookshelf_view)
        ),
        # calibration of the floor covariances
        "stereo_outline_endpoints_count": float(z.size),
        "stereo_outline_within_1p96_fraction": stat(np.mean, np.abs(z) <= 1.96),
        "stereo_outline_correct_within_1p96_fraction": stat(np.mean, np.abs(zc) <= 1.96),
        "stereo_nees_correct_endpoints_count": float(nc.size),
        "stereo_nees_mean_correct_matches": stat(np.mean, nc),
        "stereo_nees_median_correct_matches": stat(np.median, nc),
        "stereo_nees_within_5p99_correct_fraction": stat(np.mean, nc <= 5.991),
        "stereo_nees_endpoints_count": float(nees.size),
        "stereo_nees_mean": stat(np.mean, nees),
    }


def run(
    n_scenes: int = 20, *, seed: int = 0, noise_sigma: float = 2.0, quick: bool = False
) -> dict[str, float]:
    """Figures of the segment stereo on ``n_scenes`` rendered scenes (4 with ``quick``)."""
    if quick:
        n_scenes = min(n_scenes, 4)
    return summarise(
        evaluate(n_scenes, seed=seed, noise_sigma=noise_sigma, repeats=1 if quick else 5)
    )


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument("--n-scenes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", type=float, default=2.0, help="pixel noise sigma, grey levels")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    figures = run(args.n_scenes, seed=args.seed, noise_sigma=args.noise, quick=args.quick)
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
