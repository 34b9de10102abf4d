"""Segment-based stereo against rendered ground truth and against OpenCV's StereoSGBM.

Renders seeded scenes of every family at 320x240 (the view from each start pose, and a view
facing the front of a bookshelf where the scene has one), adds Gaussian pixel noise, runs
extraction -> matching -> triangulation (paper sections 3.1, 3.2) and compares the result with
the renderer's depth and the scenes' obstacle footprints. :func:`evaluate` measures the views,
:func:`summarise` turns them into a flat dict of figures (units in the names):

* ``stereo_{extract,match,triangulate,total}_median_ms``: time per pair (both images'
  extraction, matching, triangulation), the median over ``repeats`` runs of each view, then over
  the views; ``sgbm_median_ms``: StereoSGBM per pair; ``render_stereo_median_ms``: the renderer
  per pair. ``stereo_total_over_sgbm_ratio`` (median over the views of the stereo time over
  SGBM's, measured back to back) is the load-independent figure.
* ``stereo_depth_abs_err_median_m`` / ``sgbm_depth_abs_err_median_m``: depth error at the
  segment pixels (the midpoints of the certain matches) for both methods (SGBM gets the best of
  the three pixels across the edge, chosen with the truth: it has no edge model).
* ``stereo_certain_within_1px_fraction``: of the matches with probability >= 0.99, the fraction
  whose disparity (at the midpoint of the overlapping part) is within 1 px of the truth. The true
  disparity of a left pixel is ``f b / Z`` with ``Z`` the renderer's depth, the nearest within
  +-1 px along the row (an edge belongs to its front surface).
* Ambiguity. Over the left segments with several kept candidates ("ambiguous"), a candidate is
  *true* if its disparity is within 1 px of the truth.
  ``stereo_ambiguous_true_included_fraction``: the fraction of ambiguous left segments whose kept
  candidates include a true one. ``stereo_ambiguous_true_available_count`` /
  ``..._included_when_available_fraction``: the same over the ambiguous left segments whose true
  partner was *available*: a segment of the right image's extraction that, paired with the left
  segment, passes the matching constraints (``match_candidates``: before the histograms decide)
  and is true; this measures the histograms' decision only. The others
  (``stereo_ambiguous_no_true_candidate_count``) are left edges whose partner the right image
  does not have: occluded, out of view, or a view-dependent contour seen at another 3D line.
  ``stereo_ambiguous_segments_bookshelf_count``: ambiguous floor segments in bookshelf views.
* ``stereo_outline_within_1p96_fraction``: floor endpoints (of unambiguous segments) on a true
  obstacle outline whose error across the outline, over the standard deviation the covariance
  gives in that direction, is within 1.96 (ideal 0.95); all matches, wrong ones included.
  ``stereo_outline_correct_within_1p96_fraction``: the same over the correct matches (disparity
  within 1 px), i.e. the calibration of the covariance itself.
* NEES (normalised estimation error squared ``r^T C^-1 r`` of a floor endpoint, 2 dof: ideal
  mean 2, median 1.39, 95 % below 5.99), over the endpoints of segments that image a *vertical*
  edge of a rendered obstacle part: their true floor point is the part's footprint corner whose
  projection is nearest the segment (within 2 px in the image and 5 % in depth).
  ``stereo_nees_mean_correct_matches`` (the meaningful figure: the covariance describes the
  localisation error of a correct match; a wrong match is a gross error outside that Gaussian
  model, whose rate ``stereo_certain_within_1px_fraction`` gives),
  ``..._median_correct_matches``, ``stereo_nees_within_5p99_correct_fraction``;
  ``stereo_nees_mean`` over all matches is dominated by the few wrong ones.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.observation import FloorObservation
from modeling.stereo.matching import StereoMatches, match_candidates, match_segments
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.segments import ImageSegments, extract_segment_pair
from modeling.stereo.triangulation import triangulate_to_floor
from modeling.types import FloatArray
from stereo_nav_env.perception.noise import normal_noisy_grey
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.views import SceneView, scene_views


@dataclass(frozen=True, slots=True, kw_only=True)
class StageTimes:
    """Wall times of one view, milliseconds.

    ``extract_ms``, ``match_ms``, ``triangulate_ms``: medians over the repeats of the stereo
    stages; ``render_ms``: one render of the pair; ``sgbm_ms``: one StereoSGBM run (0: none).
    """

    extract_ms: float
    match_ms: float
    triangulate_ms: float
    render_ms: float
    sgbm_ms: float = 0.0


@dataclass(frozen=True, slots=True, kw_only=True)
class ViewResult:
    """The measurements of one view; :func:`summarise` concatenates the lists over views.

    Errors are in pixels (``_px``) or metres (``_m``); ``outline_z`` are across-outline errors
    over their standard deviation; ``nees`` are 2-D NEES values; the ``_correct`` variants keep
    the entries whose match is correct (disparity within 1 px of the truth).
    """

    family: str
    bookshelf_view: bool
    times: StageTimes
    certain_err_px: tuple[float, ...] = ()
    ambiguous_has_true: tuple[bool, ...] = ()
    ambiguous_has_true_available: tuple[bool, ...] = ()
    n_ambiguous_no_true_candidate: int = 0
    n_ambiguous_segments: int = 0
    stereo_depth_err_m: tuple[float, ...] = ()
    sgbm_depth_err_m: tuple[float, ...] = ()
    outline_z: tuple[float, ...] = ()
    nees: tuple[float, ...] = ()
    outline_z_correct: tuple[float, ...] = ()
    nees_correct: tuple[float, ...] = ()


def true_disparity(depth: FloatArray, rig: StereoRig, uv: FloatArray, half: int = 1) -> FloatArray:
    """(n,) true disparities ``f b / Z`` [px] at the left pixels ``uv`` (n, 2) [px].

    ``Z`` is the nearest of the renderer's depths ``depth`` (H, W) [m] within ``half`` px along
    the row (an edge belongs to its front surface); NaN where nothing is seen.
    """
    H, W = depth.shape
    u = np.clip(np.rint(uv[:, 0]).astype(int), 0, W - 1)
    v = np.clip(np.rint(uv[:, 1]).astype(int), 0, H - 1)
    cols = np.clip(u[:, None] + np.arange(-half, half + 1)[None, :], 0, W - 1)
    z = depth[v[:, None], cols].min(axis=1)
    result: FloatArray = np.where(np.isfinite(z), rig.fb / z, np.nan)
    return result


def vertical_edge_truth(
    P: FloatArray,
    u_mid: float,
    rig: StereoRig,
    pose: HeadPose,
    corners: FloatArray,
    *,
    max_px: float = 2.0,
    max_depth_frac: float = 0.05,
) -> FloatArray | None:
    """The true floor point (2,) [m, world] of a segment imaging a vertical edge, or ``None``.

    ``P`` (3, 3) [m, world]: the segment's ends and midpoint at the true disparity. The edge is
    vertical if they share their floor point (within 1 cm); its truth is then the corner of
    ``corners`` (k, 2) [m, world] (the rendered parts' footprints) whose projection is nearest
    the segment's column ``u_mid`` [px], among those within ``max_px`` in the image and
    ``max_depth_frac`` in depth.
    """
    if np.ptp(P[:, 0]) >= 0.01 or np.ptp(P[:, 1]) >= 0.01:
        return None
    C = pose.world_to_cam(np.column_stack([corners, np.zeros(len(corners))]))
    z_true = float(pose.world_to_cam(P[2:3])[0, 2])
    assert rig.cx_px is not None
    with np.errstate(divide="ignore", invalid="ignore"):
        u = rig.focal_px * C[:, 0] / C[:, 2] + rig.cx_px
    near = (C[:, 2] > 0) & (np.abs(C[:, 2] - z_true) <= max_depth_frac * z_true)
    near &= np.abs(u - u_mid) <= max_px
    if not np.any(near):
        return None
    cand = np.flatnonzero(near)
    corner: FloatArray = corners[cand[np.argmin(np.abs(u[cand] - u_mid))]]
    return corner


def _outline_of(
    true_xy: FloatArray, footprints: Sequence[FloatArray], on_outline_m: float
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """``(a, ab, |ab|^2)`` of the first footprint whose outline all ``true_xy`` lie on."""
    for fp in footprints:
        a = fp
        ab = np.roll(fp, -1, axis=0) - fp
        L2 = np.einsum("ij,ij->i", ab, ab)
        t = np.clip(np.einsum("kij,ij->ki", true_xy[:, None, :] - a[None], ab) / L2, 0, 1)
        close = a[None] + t[..., None] * ab[None]
        dist = np.linalg.norm(true_xy[:, None, :] - close, axis=-1).min(axis=1)
        if np.all(dist <= on_outline_m):
            return a, ab, L2
    return None


def outline_errors(
    obs: FloorObservation,
    matches: StereoMatches,
    depth: FloatArray,
    rig: StereoRig,
    pose: HeadPose,
    footprints: Sequence[FloatArray],
    corners: FloatArray,
    on_outline_m: float = 0.025,
) -> tuple[list[float], list[float], list[bool], list[bool]]:
    """Calibration of the floor endpoints of the unambiguous segments of one view.

    ``obs`` is triangulated from ``matches``; ``depth`` (H, W) [m] is the left view's;
    ``footprints`` (k_i, 2) and ``corners`` (k, 2) [m, world] are the true obstacle outlines and
    the rendered parts' footprint corners; a segment lies on an outline if its true floor
    points are within ``on_outline_m`` of it.

    Returns:
        ``(z, nees, z_ok, nees_ok)``: the across-outline errors over their standard deviation of
        the endpoints on a true outline; the 2-D NEES of the endpoints of vertical obstacle
        edges; for each, whether its match is correct (disparity within 1 px at the midpoint).
    """
    z_scores: list[float] = []
    nees: list[float] = []
    z_ok: list[bool] = []
    nees_ok: list[bool] = []
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
        truth = vertical_edge_truth(P, float(mid[0]), rig, pose, corners)
        if truth is not None:
            for k in range(2):
                r = seg.endpoints[k] - truth
                nees.append(float(r @ np.linalg.solve(seg.cov[k], r)))
                nees_ok.append(correct)
        h = P[:, 2]
        inband = (h > 0.05) & (h < 1.0)
        if not np.any(inband):
            continue
        best = _outline_of(P[inband, :2], footprints, on_outline_m)
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


def run_stereo(
    gl: NDArray[np.uint8], gr: NDArray[np.uint8], rig: StereoRig, pose: HeadPose, repeats: int
) -> tuple[ImageSegments, ImageSegments, StereoMatches, FloorObservation, list[float]]:
    """Extraction, matching and triangulation of a grey pair, each timed, ``repeats`` times.

    Returns:
        The last run's left and right segments, matches and floor observation, and the median
        time of each stage (extraction, matching, triangulation), milliseconds.
    """
    te, tm, tt = [], [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sl, sr = extract_segment_pair(gl, gr, rig=rig)
        t1 = time.perf_counter()
        matches = match_segments(sl, sr, rig)
        t2 = time.perf_counter()
        obs = triangulate_to_floor(matches, rig, pose)
        t3 = time.perf_counter()
        te.append(t1 - t0)
        tm.append(t2 - t1)
        tt.append(t3 - t2)
    return sl, sr, matches, obs, [float(np.median(t)) * 1e3 for t in (te, tm, tt)]


def ambiguity_figures(
    sl: ImageSegments,
    sr: ImageSegments,
    matches: StereoMatches,
    err_px: FloatArray,
    depth: FloatArray,
    rig: StereoRig,
    finite: NDArray[np.bool_],
) -> tuple[list[bool], list[bool], int]:
    """Whether each ambiguous left segment's kept candidates include a true one.

    ``err_px`` (m,): the disparity error of each match at its midpoint, pixels; ``finite``
    (m,): whether its true disparity is known; ``depth`` (H, W): the left view's depth, metres.

    Returns:
        ``(has_true, has_true_when_available, n_no_true_candidate)``: over all ambiguous left
        segments; over those whose true partner passed the matching constraints; and the count
        of the others.
    """
    amb = matches.ambiguous & finite
    # the true partner was available if some candidate that passed the constraints (before
    # the histograms decided) has the true disparity
    cand = match_candidates(sl, sr, rig)
    c_rows = cand.rows_px.mean(axis=1)
    c_mid = np.column_stack([sl.u_at(cand.left_index, c_rows), c_rows])
    c_err = np.abs(cand.disparity_px.mean(axis=1) - true_disparity(depth, rig, c_mid))
    available = set(cand.left_index[c_err <= 1.0].tolist())
    has_true: list[bool] = []
    has_true_available: list[bool] = []
    n_missing = 0
    for li in np.unique(matches.left_index[amb]):
        rows = matches.left_index == li
        has = bool(np.any(err_px[rows] <= 1.0))
        has_true.append(has)
        if int(li) in available:
            has_true_available.append(has)
        else:
            n_missing += 1
    return has_true, has_true_available, n_missing


def sgbm_depth_errors(
    disp16: NDArray[np.int16], uv: FloatArray, d_true: FloatArray, rig: StereoRig
) -> list[float]:
    """SGBM's (n,) depth errors [m] at the left pixels ``uv`` (n, 2) [px], capped at 100 m.

    ``disp16`` (H, W): SGBM's disparity in 1/16 px; ``d_true`` (n,) [px]: the true disparities.
    SGBM gets the best of the 3 pixels across the edge; no disparity counts as infinite depth.
    """
    disp = disp16.astype(np.float64) / 16.0
    u = np.clip(np.rint(uv[:, 0]).astype(int), 0, rig.width_px - 1)
    v = np.clip(np.rint(uv[:, 1]).astype(int), 0, rig.height_px - 1)
    cols = np.clip(u[:, None] + np.arange(-1, 2)[None, :], 0, rig.width_px - 1)
    ds = disp[v[:, None], cols]
    pick = np.argmin(np.abs(np.where(ds > 0, ds, np.inf) - d_true[:, None]), axis=1)
    dsel = ds[np.arange(ds.shape[0]), pick]
    z_sgbm = np.where(dsel > 0, rig.fb / np.maximum(dsel, 1e-6), np.inf)
    errors: list[float] = np.minimum(np.abs(z_sgbm - rig.fb / d_true), 100.0).tolist()
    return errors


def _timed_sgbm(
    sgbm: cv2.StereoSGBM, gl: NDArray[np.uint8], gr: NDArray[np.uint8]
) -> tuple[NDArray[np.int16], float]:
    t0 = time.perf_counter()
    disp16 = sgbm.compute(gl, gr)
    return np.asarray(disp16), (time.perf_counter() - t0) * 1e3


def evaluate_view(
    renderer: StereoRenderer,
    view: SceneView,
    rig: StereoRig,
    rng: np.random.Generator,
    *,
    noise_sigma: float = 2.0,
    sgbm: cv2.StereoSGBM | None = None,
    repeats: int = 1,
) -> ViewResult:
    """Render one view, run the stereo stages (timed), compare with ground truth.

    Args:
        renderer: A renderer of ``view.scene``.
        view: The view.
        rig: The stereo rig of the renderer.
        rng: Source of the pixel noise (the left image's, then the right's).
        noise_sigma: Pixel noise, grey levels.
        sgbm: StereoSGBM to compare with (timed and its depth errors measured), or ``None``.
        repeats: Runs of the stereo stages whose times are the median.
    """
    pose = view.pose
    t0 = time.perf_counter()
    left, right = renderer.render_stereo(pose)
    render_ms = (time.perf_counter() - t0) * 1e3
    depth = renderer.render_depth(pose)
    gl = normal_noisy_grey(left, rng, noise_sigma)
    gr = normal_noisy_grey(right, rng, noise_sigma)
    sl, sr, matches, obs, (extract_ms, match_ms, triangulate_ms) = run_stereo(
        gl, gr, rig, pose, repeats
    )
    sgbm_ms, disp16 = 0.0, None
    if sgbm is not None:
        disp16, sgbm_ms = _timed_sgbm(sgbm, gl, gr)
    times = StageTimes(
        extract_ms=extract_ms,
        match_ms=match_ms,
        triangulate_ms=triangulate_ms,
        render_ms=render_ms,
        sgbm_ms=sgbm_ms,
    )
    if not len(matches):
        return ViewResult(family=view.family, bookshelf_view=view.bookshelf_view, times=times)

    mids = matches.left_endpoints.mean(axis=1)
    d_est = matches.disparity_px.mean(axis=1)
    d_true = true_disparity(depth, rig, mids)
    err = np.abs(d_est - d_true)
    certain = (matches.probability >= 0.99) & np.isfinite(d_true)
    z_true = rig.fb / d_true[certain]
    has_true, has_true_available, n_missing = ambiguity_figures(
        sl, sr, matches, err, depth, rig, np.isfinite(d_true)
    )
    sgbm_err: list[float] = []
    if disp16 is not None:
        sgbm_err = sgbm_depth_errors(disp16, mids[certain], d_true[certain], rig)
    obstacles = view.scene.obstacles
    footprints = [np.asarray(o.footprint) for o in obstacles]
    corners = np.vstack([np.asarray(p.footprint) for o in obstacles for p in o.parts])
    z, nees, z_ok, nees_ok = outline_errors(obs, matches, depth, rig, pose, footprints, corners)
    return ViewResult(
        family=view.family,
        bookshelf_view=view.bookshelf_view,
        times=times,
        certain_err_px=tuple(err[certain].tolist()),
        stereo_depth_err_m=tuple(np.abs(rig.fb / d_est[certain] - z_true).tolist()),
        ambiguous_has_true=tuple(has_true),
        ambiguous_has_true_available=tuple(has_true_available),
        n_ambiguous_no_true_candidate=n_missing,
        n_ambiguous_segments=len(obs.ambiguous),
        sgbm_depth_err_m=tuple(sgbm_err),
        outline_z=tuple(z),
        nees=tuple(nees),
        outline_z_correct=tuple(x for x, ok in zip(z, z_ok, strict=True) if ok),
        nees_correct=tuple(x for x, ok in zip(nees, nees_ok, strict=True) if ok),
    )


def make_sgbm(rig: StereoRig) -> cv2.StereoSGBM:
    """StereoSGBM with the rig's disparity range (rounded up to a multiple of 16), 5x5 blocks."""
    num = int(math.ceil(rig.max_disparity_px / 16.0) * 16)
    block = 5
    return cv2.StereoSGBM.create(
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
    """Measure every view of ``n_scenes`` seeded scenes (:func:`scene_views`).

    Args:
        n_scenes: Scenes generated, cycling the standard families.
        seed: Seed of the scenes, the bookshelf views and (offset by 12345) the pixel noise.
        noise_sigma: Pixel noise, grey levels.
        sgbm: Also run and measure OpenCV's StereoSGBM on each pair.
        repeats: Runs of the stereo stages per view whose times are the median.
    """
    rig = StereoRig()
    rng = np.random.default_rng(seed + 12345)
    matcher = make_sgbm(rig) if sgbm else None
    results: list[ViewResult] = []
    renderer: StereoRenderer | None = None
    try:
        for view in scene_views(n_scenes, seed):
            if renderer is None:
                renderer = StereoRenderer(rig, view.scene)
            elif renderer.scene is not view.scene:
                renderer.set_scene(view.scene)
            results.append(
                evaluate_view(
                    renderer, view, rig, rng, noise_sigma=noise_sigma, sgbm=matcher, repeats=repeats
                )
            )
    finally:
        if renderer is not None:
            renderer.close()
    return results


def _stat(fn: Callable[[NDArray[Any]], Any], x: NDArray[Any]) -> float:
    """``fn(x)`` as a float, NaN for an empty ``x``."""
    return float(fn(x)) if x.size else float("nan")


def summarise(results: Sequence[ViewResult]) -> dict[str, float]:
    """The flat dict of figures defined in the module docstring."""

    def cat(name: str) -> FloatArray:
        return np.array([x for r in results for x in getattr(r, name)], dtype=np.float64)

    def med(name: str) -> float:
        return float(np.median([getattr(r.times, name) for r in results]))

    certain = cat("certain_err_px")
    amb = cat("ambiguous_has_true")
    amb_av = cat("ambiguous_has_true_available")
    z = cat("outline_z")
    zc = cat("outline_z_correct")
    nees = cat("nees")
    nc = cat("nees_correct")
    total = [r.times.extract_ms + r.times.match_ms + r.times.triangulate_ms for r in results]
    total_arr = np.array(total)
    sgbm_arr = np.array([r.times.sgbm_ms for r in results])
    return {
        "stereo_views_count": float(len(results)),
        # speed
        "render_stereo_median_ms": med("render_ms"),
        "stereo_extract_median_ms": med("extract_ms"),
        "stereo_match_median_ms": med("match_ms"),
        "stereo_triangulate_median_ms": med("triangulate_ms"),
        "stereo_total_median_ms": float(np.median(total)),
        "sgbm_median_ms": med("sgbm_ms"),
        "stereo_total_over_sgbm_ratio": _stat(np.median, total_arr / sgbm_arr)
        if np.all(sgbm_arr > 0)
        else float("nan"),
        # accuracy of the certain matches, against SGBM
        "stereo_depth_abs_err_median_m": _stat(np.median, cat("stereo_depth_err_m")),
        "sgbm_depth_abs_err_median_m": _stat(np.median, cat("sgbm_depth_err_m")),
        "stereo_disparity_abs_err_median_px": _stat(np.median, certain),
        "stereo_certain_matches_count": float(certain.size),
        "stereo_certain_within_1px_fraction": _stat(np.mean, certain <= 1.0),
        # ambiguity
        "stereo_ambiguous_left_segments_count": float(amb.size),
        "stereo_ambiguous_true_included_fraction": _stat(np.mean, amb),
        "stereo_ambiguous_true_available_count": float(amb_av.size),
        "stereo_ambiguous_true_included_when_available_fraction": _stat(np.mean, amb_av),
        "stereo_ambiguous_no_true_candidate_count": float(
            sum(r.n_ambiguous_no_true_candidate for r in results)
        ),
        "stereo_ambiguous_segments_count": float(sum(r.n_ambiguous_segments for r in results)),
        "stereo_ambiguous_segments_bookshelf_count": float(
            sum(r.n_ambiguous_segments for r in results if r.bookshelf_view)
        ),
        # calibration of the floor covariances
        "stereo_outline_endpoints_count": float(z.size),
        "stereo_outline_within_1p96_fraction": _stat(np.mean, np.abs(z) <= 1.96),
        "stereo_outline_correct_within_1p96_fraction": _stat(np.mean, np.abs(zc) <= 1.96),
        "stereo_nees_correct_endpoints_count": float(nc.size),
        "stereo_nees_mean_correct_matches": _stat(np.mean, nc),
        "stereo_nees_median_correct_matches": _stat(np.median, nc),
        "stereo_nees_within_5p99_correct_fraction": _stat(np.mean, nc <= 5.991),
        "stereo_nees_endpoints_count": float(nees.size),
        "stereo_nees_mean": _stat(np.mean, nees),
    }
