"""What a level stereo head could see of the true scene: the visibility sweep of the surrogate.

The stereo pipeline (:mod:`modeling`) sees obstacles through the *vertical edges* of their rendered
parts (footprint corners of walls and boxes, table and chair legs, bookshelf sides and dividers)
and, for :func:`modeling.stereo.faces.close_faces`, the *bottom edges* of faces where they meet the
floor. :class:`SceneEdges` lists those of a scene once (every corner of every rendered part, with
its height range, and every footprint side of a part standing on the floor); :func:`visible_edges`
keeps, for one head pose, the ones in the field of view and range, facing the camera and not
occluded, with the part of their height that is seen, where they fall in the left image, and
whether each is an outline (one of its two sides faces the head) or a crease (both do). It also
holds each face's rendered grey level (:mod:`stereo_nav_env.rendering.shading`), for the photometry.

Occlusion (the sweep). The sight line from the head (world ``(x, y)``, height ``Hh``) to a point
of an edge at height ``z`` and floor distance ``D`` runs at height ``Hh + (z - Hh) t`` at the
fraction ``t`` of ``D``. A part (footprint crossed by the line between ``t0`` and ``t1``, heights
``[s0, s1]``) hides the heights ``z = Hh + (s - Hh) / t`` for ``s`` in ``[s0, s1]`` and ``t`` in
``[t0, t1]``: an interval whose ends are among its four corners. Each line is clipped to every
part's footprint (Cyrus-Beck) in one compiled pass (:func:`seen_runs`, :func:`floor_hidden`); their
NumPy references test all footprints at once (:func:`clip_to_parts`: a ``shapely.STRtree``
query, then the vectorised clipping). A corner whose line passes through its own part (a back
corner) is hidden whole. An edge keeps its longest visible run of heights.

Frames and units: world metres, floor plane x-y, z up; image pixels (u right, v down, (0, 0) the
centre of the top-left pixel); camera depth ``Z`` along the optical axis, ``X`` to the right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import BoolArray, FloatArray, IntArray
from stereo_nav_env.perception.surrogate._kernels.visibility import (
    Parts,
    Sight,
    edge_candidates_loop,
    seen_runs_loop,
)
from stereo_nav_env.rendering.shading import (
    BACKGROUND_COLOR,
    BOTTOM_SHADE,
    FLOOR_COLOR,
    FLOOR_MARGIN_M,
    TOP_SHADE,
    face_shades,
    grey_levels,
)
from stereo_nav_env.sim.scenes import DetailKind, Obstacle, ObstacleKind, Scene, outline_sides

__all__ = [
    "PULL_BACK_M",
    "SceneEdges",
    "VisibleEdges",
    "camera_array",
    "camera_xz",
    "clip_to_parts",
    "head_array",
    "in_both_images",
    "parts_of",
    "seen_heights",
    "seen_runs",
    "seen_runs_reference",
    "sight_blocked",
    "sight_of",
    "visible_edges",
    "visible_edges_reference",
]


PULL_BACK_M = 0.005
"""The sight line stops this short of the edge, so that it does not touch the edge's own part."""
_REPEATED_KINDS = (ObstacleKind.BOOKSHELF, ObstacleKind.TABLE, ObstacleKind.CHAIR)
"""Kinds whose identical parts (legs, sides and dividers) repeat the same edge."""


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class SceneEdges:
    """The vertical edges and floor lines of a scene's rendered parts (world frame, metres).

    Attributes:
        polygons: (P,) shapely footprints of the parts.
        tree: STRtree of ``polygons``.
        z_min: (P,) bottom of each part, metres. ``z_max``: (P,) its top.
        corner_xy: (C, 2) floor point of each corner edge. ``corner_z``: (C, 2) its bottom and top.
        corner_part: (C,) the part it belongs to.
        corner_normals: (C, 2, 2) outward unit normals of the part's two sides meeting there.
        corner_group: (C,) edges of one group are the same corner of identical parts of one piece
            of furniture (legs, shelf sides and dividers: the repeated edges); every other edge
            has its own. (What the matcher takes for one another is decided by the grey levels
            beside the edges, :mod:`stereo_nav_env.perception.surrogate.photometry`.)
        corner_plain: (C,) whether the edge is a corner of a wall or a box (a plain prism), not
            of furniture.
        corner_kind: (C,) the kind of its obstacle, an index into ``tuple(ObstacleKind)``.
        side_start: (P, V, 2) each part's corners (the last repeated up to ``V``, the most any
            part has). ``side_normal``: (P, V, 2) the outward unit normal of the side from each.
        line_ends: (L, 2, 2) floor sides of the parts standing on the floor (``z_min`` 0), the
            part's counter-clockwise order. ``line_normal``: (L, 2) outward unit normals.
            ``line_corners``: (L, 2) the corner edges at their two ends. ``line_detail``:
            (L,) whether the line is a stretch of a face between its surface detail's strips
            (after the parts' own sides): a face's bottom edge as the image shows it between
            the strips, the line :func:`modeling.stereo.faces.close_faces` joins two strips'
            edges by (the ground lines leave these out: the face's own side is there).
        side_grey: (P, V) the grey level the renderer gives each side face (padded like
            ``side_start``); ``top_grey``, ``bottom_grey``: (P,) those of the top and bottom
            faces (:mod:`stereo_nav_env.rendering.shading`).
        floor_box: (4,) ``(xmin, ymin, xmax, ymax)`` of the rendered floor, metres.
        floor_grey: The floor's grey level. ``background_grey``: that where no surface is.
    """

    polygons: NDArray[np.object_]
    tree: shapely.STRtree
    z_min: FloatArray
    z_max: FloatArray
    corner_xy: FloatArray
    corner_z: FloatArray
    corner_part: IntArray
    corner_normals: FloatArray
    corner_group: IntArray
    corner_plain: NDArray[np.bool_]
    corner_kind: IntArray
    side_start: FloatArray
    side_normal: FloatArray
    line_ends: FloatArray
    line_normal: FloatArray
    line_corners: IntArray
    line_detail: NDArray[np.bool_]
    side_grey: FloatArray
    top_grey: FloatArray
    bottom_grey: FloatArray
    floor_box: FloatArray
    floor_grey: float
    background_grey: float

    @classmethod
    def of(cls, scene: Scene) -> SceneEdges:
        """The edges of every rendered part of ``scene``'s obstacles."""
        polys: list[shapely.Polygon] = []
        z_min: list[float] = []
        z_max: list[float] = []
        xy: list[FloatArray] = []
        zz, part_of, normals, groups, plain, kinds = [], [], [], [], [], []
        kind_index = {kind: k for k, kind in enumerate(ObstacleKind)}
        ends: list[FloatArray] = []
        line_n: list[FloatArray] = []
        starts: list[FloatArray] = []
        side_n: list[FloatArray] = []
        line_c: list[tuple[int, int]] = []
        side_c: list[FloatArray] = []
        flat_c: list[FloatArray] = []
        keys: dict[tuple[object, ...], int] = {}
        detail_ends: list[FloatArray] = []
        detail_n: list[FloatArray] = []
        detail_c: list[tuple[int, int]] = []
        for o, ob in enumerate(scene.obstacles):
            first_corner = len(xy)
            for part in ob.drawn_parts:
                p = len(polys)
                fp = part.footprint
                polys.append(shapely.Polygon(fp))
                z_min.append(part.z_min_m)
                z_max.append(part.z_max_m)
                side, _, n = outline_sides(fp)
                starts.append(fp)
                side_n.append(n)
                base = np.asarray(part.color, dtype=np.float64)
                side_c.append(face_shades(n)[:, None] * base)
                flat_c.append(np.stack([TOP_SHADE * base, BOTTOM_SHADE * base]))
                dims = tuple(np.round(np.linalg.norm(side, axis=1), 3).tolist())
                for k in range(fp.shape[0]):
                    xy.append(fp[k])
                    zz.append((part.z_min_m, part.z_max_m))
                    part_of.append(p)
                    normals.append((n[k - 1], n[k]))
                    key: tuple[object, ...] = (
                        (o, dims, part.z_min_m, part.z_max_m, k)
                        if ob.kind in _REPEATED_KINDS
                        else (o, p, k)
                    )
                    groups.append(keys.setdefault(key, len(keys)))
                    plain.append(ob.kind not in _REPEATED_KINDS)
                    kinds.append(kind_index[ob.kind])
                if part.z_min_m <= 1e-6:
                    first = len(xy) - fp.shape[0]
                    ends.extend(np.stack([fp, np.roll(fp, -1, axis=0)], axis=1))
                    line_n.extend(n)
                    line_c.extend(
                        (first + k, first + (k + 1) % fp.shape[0]) for k in range(fp.shape[0])
                    )
            if ob.detail:
                _detail_floor_lines(ob, first_corner, detail_ends, detail_n, detail_c)
        line_detail = [False] * len(ends) + [True] * len(detail_ends)
        ends += detail_ends
        line_n += detail_n
        line_c += detail_c
        v_max = max((fp.shape[0] for fp in starts), default=1)

        def padded(rows: list[FloatArray]) -> FloatArray:
            out = np.zeros((len(rows), v_max, rows[0].shape[1] if rows else 2))
            for p, r in enumerate(rows):
                out[p] = np.concatenate([r, np.repeat(r[-1:], v_max - r.shape[0], axis=0)])
            return out

        x0, y0, x1, y1 = scene.bounds
        m = FLOOR_MARGIN_M
        flat = grey_levels(np.array(flat_c).reshape(-1, 2, 3))

        return cls(
            polygons=np.array(polys, dtype=object),
            tree=shapely.STRtree(polys),
            z_min=np.array(z_min),
            z_max=np.array(z_max),
            corner_xy=np.array(xy).reshape(-1, 2),
            corner_z=np.array(zz).reshape(-1, 2),
            corner_part=np.array(part_of, dtype=np.int64),
            corner_normals=np.array(normals).reshape(-1, 2, 2),
            corner_group=np.array(groups, dtype=np.int64),
            corner_plain=np.array(plain, dtype=bool),
            corner_kind=np.array(kinds, dtype=np.int64),
            side_start=padded(starts),
            side_normal=padded(side_n),
            line_ends=np.array(ends).reshape(-1, 2, 2),
            line_normal=np.array(line_n).reshape(-1, 2),
            line_corners=np.array(line_c, dtype=np.int64).reshape(-1, 2),
            line_detail=np.array(line_detail, dtype=bool),
            side_grey=grey_levels(padded(side_c)),
            top_grey=flat[:, 0],
            bottom_grey=flat[:, 1],
            floor_box=np.array([x0 - m, y0 - m, x1 + m, y1 + m]),
            floor_grey=float(grey_levels(np.array(FLOOR_COLOR))),
            background_grey=float(grey_levels(np.array(BACKGROUND_COLOR))),
        )


def _detail_floor_lines(
    ob: Obstacle,
    first_corner: int,
    ends: list[FloatArray],
    normals: list[FloatArray],
    corners: list[tuple[int, int]],
) -> None:
    """Append the floor lines of ``ob``'s faces between its surface detail's strips.

    On each side of the footprint, the strips that stand on the floor (not books) cut the
    side's bottom edge into stretches: from the side's first corner (when the obstacle's first
    part is its footprint's prism) to the first strip's front corner, between each strip's
    right front corner and the next one's left, to the side's last corner. Their ends are corner
    edges (``first_corner`` is the obstacle's first corner index; a part's corners follow its
    footprint, a strip's front corners are its first two).
    """
    fp = ob.footprint
    k = fp.shape[0]
    prism = len(ob.parts) >= 1 and ob.parts[0].footprint.shape == fp.shape
    prism = prism and bool(np.allclose(ob.parts[0].footprint, fp))
    strip_first = first_corner + sum(p.footprint.shape[0] for p in ob.parts)
    starts: list[int] = []
    for part in ob.detail_parts:
        starts.append(strip_first)
        strip_first += part.footprint.shape[0]
    side, _, n = outline_sides(fp)
    for face in range(k):
        on = sorted(
            (f.offset_m, j)
            for j, f in enumerate(ob.detail)
            if f.face == face and f.z_min_m <= 1e-6 and f.kind is not DetailKind.SPINE
        )
        if not on:
            continue
        # (point, corner) along the side: its start, each strip's two front corners, its end
        chain: list[tuple[FloatArray, int]] = []
        for _, j in on:
            c = starts[j]
            strip = ob.detail_parts[j].footprint
            chain += [(strip[0], c), (strip[1], c + 1)]
        if prism:
            e = (face + 1) % k
            chain = [(fp[face], first_corner + face), *chain, (fp[e], first_corner + e)]
        else:
            chain = chain[1:-1]
        along = side[face] / np.linalg.norm(side[face])
        for (a, ca), (b, cb) in zip(chain[0::2], chain[1::2], strict=True):
            if float((b - a) @ along) > 1e-6:
                ends.append(np.stack([a, b]))
                normals.append(n[face])
                corners.append((ca, cb))


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class VisibleEdges:
    """The edges one head pose sees (n of them), arrays of one row each.

    Attributes:
        corner: (n,) index into ``SceneEdges.corner_xy``.
        X, Z: (n,) camera coordinates of the edge, metres (right, depth).
        z_low, z_high: (n,) the seen run of its heights, metres.
        u: (n,) its column in the left image, px. ``v_top``, ``v_bottom``: (n,) rows of the run.
        group: (n,) its group of repeated edges (``SceneEdges.corner_group``).
        crease: (n,) whether both sides meeting at the edge face the head: the edge is seen
            between two faces of its part (a crease, imaged only by their shading step), not as
            an outline against what lies behind it.
    """

    corner: IntArray
    X: FloatArray
    Z: FloatArray
    z_low: FloatArray
    z_high: FloatArray
    u: FloatArray
    v_top: FloatArray
    v_bottom: FloatArray
    group: IntArray
    crease: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.corner.shape[0])


def camera_xz(xy: FloatArray, head: HeadPose) -> tuple[FloatArray, FloatArray]:
    """Camera ``(X, Z)`` (right, depth) of world floor points (n, 2) for a level head."""
    c, s = math.cos(head.heading_rad), math.sin(head.heading_rad)
    dx, dy = xy[..., 0] - head.x_m, xy[..., 1] - head.y_m
    return s * dx - c * dy, c * dx + s * dy


def in_both_images(
    X: FloatArray, Z: FloatArray, rig: StereoRig, margin_px: float
) -> NDArray[np.bool_]:
    """Whether camera points lie in the disparity range and in both images' columns."""
    cx, _ = rig.principal_point_px
    ok = (Z >= rig.min_depth_m) & (Z <= rig.max_depth_m)
    Zs = np.where(ok, Z, 1.0)
    u = cx + rig.focal_px * X / Zs
    u_right = u - rig.fb / Zs
    lo, hi = margin_px - 0.5, rig.width_px - 0.5 - margin_px
    out: NDArray[np.bool_] = ok & (u >= lo) & (u <= hi) & (u_right >= lo) & (u_right <= hi)
    return out


def clip_to_parts(
    edges: SceneEdges, start: FloatArray, stop: FloatArray
) -> tuple[IntArray, IntArray, FloatArray, FloatArray, IntArray]:
    """The parts' footprints crossed by the floor lines from ``start`` to ``stop`` (m, 2) each.

    The STRtree gives the parts whose bounding boxes the lines meet; each line is then clipped to
    each such (convex) footprint (Cyrus-Beck: the line's parameter enters at the largest ``t`` of
    the sides it crosses inwards and leaves at the smallest of those it crosses outwards).

    Returns:
        ``(line, part, t0, t1, side)``: one row per crossing, the fractions of the line (from
        ``start``) between which it is inside the part's footprint, and the side it enters
        through (index into ``SceneEdges.side_start``; -1 where it starts inside).
    """
    lines = shapely.linestrings(np.stack([start, stop], axis=1))
    line, part = edges.tree.query(lines)
    a, n = edges.side_start[part], edges.side_normal[part]  # (k, V, 2)
    origin = start[line]
    step = (stop - start)[line]  # (k, 2)
    num = np.einsum("kvi,kvi->kv", n, a - origin[:, None])
    den = np.einsum("kvi,ki->kv", n, step)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / den
    outside = np.any((den == 0) & (num < 0), axis=1)
    t_in = np.where(den < 0, t, -np.inf)
    side = np.argmax(t_in, axis=1)
    t_enter = t_in[np.arange(side.size), side]
    t0 = np.maximum(t_enter, 0.0)
    t1 = np.minimum(np.where(den > 0, t, np.inf).min(axis=1), 1.0)
    hit = np.flatnonzero(~outside & (t1 > t0))
    side = np.where(t_enter[hit] >= 0.0, side[hit], -1)
    return line[hit], part[hit], t0[hit], t1[hit], side


def sight_blocked(
    edges: SceneEdges, head: HeadPose, targets: FloatArray
) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:
    """The parts crossing the sight lines from the head to floor points ``targets`` (n, 2)
    (:func:`clip_to_parts`; the lines stop ``PULL_BACK_M`` short of the targets).

    Returns:
        ``(line, part, t0, t1)``: one row per crossing, the fractions of the line's floor length
        (from the head to the target) between which it is inside the part's footprint.
    """
    head_xy = np.array([head.x_m, head.y_m])
    d = targets - head_xy
    length = np.hypot(d[:, 0], d[:, 1])
    stop = targets - d * (PULL_BACK_M / np.maximum(length, 1e-9))[:, None]
    line, part, t0, t1, _ = clip_to_parts(edges, np.broadcast_to(head_xy, stop.shape), stop)
    scale = 1.0 - PULL_BACK_M / np.maximum(length[line], 1e-9)
    return line, part, t0 * scale, t1 * scale


def visible_edges_reference(
    edges: SceneEdges, head: HeadPose, rig: StereoRig, *, trim_px: float, min_length_px: float
) -> VisibleEdges:
    """The vertical edges the head sees, each with its longest visible run of heights.

    An edge is seen where it lies in the disparity range and in both images' columns, where one
    of the two sides meeting at it faces the head (an outline; both: a crease), and along the
    heights no part hides (the module docstring) inside the image's rows. Its image run is
    trimmed by ``trim_px`` at both ends (the fit's trimmed rows) and must keep ``min_length_px``
    rows.

    Args:
        edges: The scene's edges.
        head: Pose of the left optical centre (level).
        rig: The stereo rig.
        trim_px: Rows left out at each end of the image run, px.
        min_length_px: Shortest image run kept, px.
    """
    X, Z = camera_xz(edges.corner_xy, head)
    head_xy = np.array([head.x_m, head.y_m])
    to_head = head_xy - edges.corner_xy
    facing = np.einsum("cki,ci->ck", edges.corner_normals, to_head) > 0.0
    cand = np.flatnonzero(in_both_images(X, Z, rig, 1.0) & facing.any(axis=1))
    X, Z = X[cand], Z[cand]
    f, cy, Hh = rig.focal_px, rig.principal_point_px[1], head.height_m
    # the heights inside the image's rows (v = cy + f (Hh - z) / Z), trimmed
    z_img_low = Hh - (rig.height_px - 1.0 - trim_px - cy) * Z / f
    z_img_high = Hh - (trim_px - cy) * Z / f
    low = np.maximum(edges.corner_z[cand, 0], z_img_low)
    high = np.minimum(edges.corner_z[cand, 1], z_img_high)
    crease = facing[cand].all(axis=1)
    return _seen(
        edges,
        head,
        rig,
        cand,
        X=X,
        Z=Z,
        low=low,
        high=high,
        crease=crease,
        min_length_px=min_length_px,
    )


def _seen(
    edges: SceneEdges,
    head: HeadPose,
    rig: StereoRig,
    cand: IntArray,
    *,
    X: FloatArray,
    Z: FloatArray,
    low: FloatArray,
    high: FloatArray,
    crease: BoolArray,
    min_length_px: float,
) -> VisibleEdges:
    """The candidate edges ``cand`` (camera ``X``, ``Z``; heights ``[low, high]`` inside the
    image's rows; ``crease``) cut to their longest unhidden run (:func:`seen_runs`), those whose
    image run keeps ``min_length_px`` rows."""
    f, (cx, cy), Hh = rig.focal_px, rig.principal_point_px, head.height_m
    low, high = seen_runs(edges, head, cand, low, high)
    v_top = cy + f * (Hh - high) / Z
    v_bottom = cy + f * (Hh - low) / Z
    sel = np.flatnonzero(v_bottom - v_top >= min_length_px)
    corner = cand[sel]
    return VisibleEdges(
        corner=corner,
        X=X[sel],
        Z=Z[sel],
        z_low=low[sel],
        z_high=high[sel],
        u=cx + f * X[sel] / Z[sel],
        v_top=v_top[sel],
        v_bottom=v_bottom[sel],
        group=edges.corner_group[corner],
        crease=crease[sel],
    )


def head_array(head: HeadPose) -> FloatArray:
    """``(x, y, height, cos heading, sin heading)`` of ``head``, for the compiled loops."""
    c, s = math.cos(head.heading_rad), math.sin(head.heading_rad)
    return np.array([head.x_m, head.y_m, head.height_m, c, s])


def camera_array(rig: StereoRig) -> FloatArray:
    """``(focal, cx, cy, f b, min depth, max depth, width, height)`` of ``rig``, for the
    compiled loops."""
    (cx, cy), f = rig.principal_point_px, rig.focal_px
    values = (f, cx, cy, rig.fb, rig.min_depth_m, rig.max_depth_m, rig.width_px, rig.height_px)
    return np.array(values, dtype=np.float64)


def sight_of(head: HeadPose) -> Sight:
    """Where the sight lines from ``head`` start and stop (``PULL_BACK_M``), for the compiled
    loops."""
    return Sight(head.x_m, head.y_m, head.height_m, PULL_BACK_M)


def parts_of(edges: SceneEdges) -> Parts:
    """The parts of ``edges`` that hide (footprints and heights), for the compiled loops."""
    return Parts(edges.side_start, edges.side_normal, edges.z_min, edges.z_max)


def visible_edges(
    edges: SceneEdges, head: HeadPose, rig: StereoRig, *, trim_px: float, min_length_px: float
) -> VisibleEdges:
    """:func:`visible_edges_reference` (the one to read, with the arguments) with its candidate
    edges found by one compiled loop (a test holds them equal, bit for bit)."""
    cand, X, Z, low, high, crease = edge_candidates_loop(
        head_array(head),
        camera_array(rig),
        edges.corner_xy,
        edges.corner_normals,
        edges.corner_z,
        float(trim_px),
    )
    return _seen(
        edges,
        head,
        rig,
        cand,
        X=X,
        Z=Z,
        low=low,
        high=high,
        crease=crease,
        min_length_px=min_length_px,
    )


def seen_runs_reference(
    edges: SceneEdges, head: HeadPose, cand: IntArray, low: FloatArray, high: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """:func:`seen_runs` in NumPy: the sight lines clipped to every part at once
    (:func:`sight_blocked`), the hidden interval of each crossing, then per edge its longest run
    outside them (one interval: at once; more: :func:`_longest_run`)."""
    low, high = low.copy(), high.copy()
    Hh = head.height_m
    line, part, t0, t1 = sight_blocked(edges, head, edges.corner_xy[cand])
    own = part == edges.corner_part[cand][line]
    # hidden heights: Hh + (s - Hh) / t over s in [z_min, z_max], t in [t0, t1]
    s = np.stack([edges.z_min[part], edges.z_max[part]], axis=1) - Hh  # (k, 2)
    inv = 1.0 / np.maximum(np.stack([t0, t1], axis=1), 1e-9)  # (k, 2)
    corners = Hh + s[:, :, None] * inv[:, None, :]
    hide_lo = corners.reshape(-1, 4).min(axis=1)
    hide_hi = corners.reshape(-1, 4).max(axis=1)
    hide_lo[own], hide_hi[own] = -np.inf, np.inf
    count = np.bincount(line, minlength=cand.size)
    # one hiding interval (the usual case), at once: the longer of the runs below and above it
    one = np.flatnonzero(count[line] == 1)
    i1, a, b = line[one], hide_lo[one], hide_hi[one]
    below_hi = np.minimum(a, high[i1])
    above_lo = np.maximum(b, low[i1])
    take_below = below_hi - low[i1] >= high[i1] - above_lo
    low[i1], high[i1] = (
        np.where(take_below, low[i1], above_lo),
        np.where(take_below, below_hi, high[i1]),
    )
    order = np.argsort(line, kind="stable")
    starts = np.searchsorted(line[order], np.arange(cand.size + 1))
    for i in np.flatnonzero(count > 1).tolist():
        rows = order[starts[i] : starts[i + 1]]
        low[i], high[i] = _longest_run(
            low[i], high[i], hide_lo[rows].tolist(), hide_hi[rows].tolist()
        )
    return low, high


def seen_runs(
    edges: SceneEdges, head: HeadPose, cand: IntArray, low: FloatArray, high: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The longest run of heights of each edge ``cand`` (indices into ``corner_xy``) within
    ``[low, high]`` that no part hides from the head (the module docstring's sweep); one
    compiled pass over the edges and parts (:func:`seen_runs_reference` is the same in NumPy,
    and a test holds them equal)."""
    return seen_heights(edges, head, edges.corner_xy[cand], edges.corner_part[cand], low, high)


def seen_heights(
    edges: SceneEdges,
    head: HeadPose,
    points: FloatArray,
    own_part: IntArray,
    low: FloatArray,
    high: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The longest run of heights within ``[low, high]`` (n,) of the vertical line through each
    floor point ``points`` (n, 2) of part ``own_part`` (n,) (an index into the parts of
    ``edges``) that no part hides from the head: :func:`seen_runs` for any points on the parts'
    outlines, not only their corners (the sight line stops ``PULL_BACK_M`` short of the point;
    one that crosses the point's own part hides it whole).

    Returns:
        ``(low, high)``: (n,) the longest unhidden run of each point's heights, metres (new
        arrays); ``high <= low`` where none of ``[low, high]`` is seen.
    """
    return seen_runs_loop(
        sight_of(head),
        parts_of(edges),
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(own_part, dtype=np.int64),
        np.asarray(low, dtype=np.float64),
        np.asarray(high, dtype=np.float64),
    )


def _longest_run(
    low: float, high: float, hide_lo: list[float], hide_hi: list[float]
) -> tuple[float, float]:
    """The longest part of ``[low, high]`` outside every ``[hide_lo[k], hide_hi[k]]``
    (``(low, low)`` when nothing is left)."""
    best = (low, low)
    cursor = low
    for a, b in sorted(zip(hide_lo, hide_hi, strict=True)):
        if a > cursor and min(a, high) - cursor > best[1] - best[0]:
            best = (cursor, min(a, high))
        cursor = max(cursor, b)
        if cursor >= high:
            break
    if high - cursor > best[1] - best[0]:
        best = (cursor, high)
    return best
