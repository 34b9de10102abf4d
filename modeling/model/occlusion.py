"""Occlusion (paper section 4.1): the floor hidden behind the obstacles.

"The area behind the obstacles is determined as an occluded area": the occluders are the
obstacles of the model's most probable situation (:func:`occluders_of`), each drawn as its
skeleton, its segments and the impassable links that join them (``Obstacle.lines``): an obstacle
of vertical edges only (floor points, a box seen by its corners) or of a candidate chosen in that
situation occludes what lies behind it, not only one of long unambiguous segments. The skeleton,
not the convex hull (``Obstacle.polygon``): for a non-convex cluster (a room corner seen from
inside) the hull's closing edge crosses visible floor. One situation, not the area occluded in
every situation or a weighted one: the most probable one is what the planners and the raster use
first, and one sweep keeps the cost of a model flat in the number of situations.

Within the field-of-view wedge of radius ``max_range_m``, an angular sweep of rays finds the
nearest occluder along each ray (:func:`nearest_hits`), and each run of consecutive blocked rays
gives one shadow polygon (:func:`shadow_rings`). It is computed once per model and treated as
free space by the planners. The rays of each segment's span (:func:`ray_spans`), the nearest hits
and the rings are compiled loops (:mod:`modeling.model._kernels.sweep`), each beside its readable
NumPy reference (``*_reference``, equal to the last bit; a test compares them).

Frames: world, metres; angles radians.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import shapely

from modeling.geometry import wrap_angle
from modeling.model._kernels import sweep as _kernel
from modeling.model._kernels.sweep import RaysAndSegments, RaySweep, Rings
from modeling.model.records import Situation
from modeling.observation import FloorObservation
from modeling.types import FloatArray

__all__ = [
    "RaySweep",
    "RaysAndSegments",
    "Rings",
    "nearest_hits",
    "nearest_hits_reference",
    "occluded_area",
    "occluded_polygons",
    "occluders_of",
    "polygons_of",
    "ray_hits",
    "ray_spans",
    "ray_spans_reference",
    "shadow_rings",
    "shadow_rings_reference",
]


# The empty result of ``occluded_area`` (shapely geometries are immutable: one can be shared, and
# building it costs more than the rest of a small occlusion sweep).
_EMPTY_POLYGON = shapely.Polygon()


def occluded_area(obs: FloorObservation, ends: FloatArray, n_rays: int = 361) -> Any:
    """The area behind segments ``ends`` (n, 2, 2) seen from the viewpoint, within FOV and range.

    An angular sweep: ``n_rays`` rays across the field of view find the nearest segment (mean
    geometry); each run of consecutive rays that hit something within ``max_range_m`` gives one
    occluded polygon, from the hit points out to the range (angular resolution
    ``fov / (n_rays - 1)``, 0.18 deg by default). Only the rays within a segment's angular span
    are intersected with it.

    Args:
        obs: The observation (its viewpoint, field of view and range).
        ends: (n, 2, 2) the occluding segments' endpoint means, world frame, metres.
        n_rays: Number of rays across the field of view.

    Returns:
        A shapely (Multi)Polygon, possibly empty; world frame, metres.
    """
    if ends.shape[0] == 0:
        return _EMPTY_POLYGON
    sweep = ray_hits(obs, ends, n_rays)
    if not (sweep.hit < sweep.max_range).any():
        return _EMPTY_POLYGON
    # Runs of consecutive blocked rays -> polygons (the wedge minus the star polygon of the ray
    # hits), all rings in one vectorised call (shapely closes each ring, as Polygon(shell) does).
    rings = shadow_rings(sweep)
    n_rings = rings.sizes.shape[0]  # >= 1: some ray is blocked
    polys = shapely.polygons(
        shapely.linearrings(rings.vertices, indices=np.repeat(np.arange(n_rings), rings.sizes))
    )
    return polys[0] if n_rings == 1 else shapely.multipolygons(polys)


def occluded_polygons(
    obs: FloorObservation, ends: FloatArray, n_rays: int = 361
) -> tuple[FloatArray, ...]:
    """The polygons of :func:`occluded_area` with an area (above 1e-9 m^2), each its exterior
    ring (m, 2), not closed, read-only: what :func:`polygons_of` gives of that geometry, taken
    from the sweep's rings directly (no shapely geometry is made: about 0.09 ms a model).

    The ring areas are the shoelace sums; a ring whose area lies within a factor 1000 of the
    threshold is measured by GEOS, as :func:`polygons_of` measures it.
    """
    if ends.shape[0] == 0:
        return ()
    sweep = ray_hits(obs, ends, n_rays)
    if not (sweep.hit < sweep.max_range).any():
        return ()
    rings = shadow_rings(sweep)
    v, sizes = rings.vertices, rings.sizes
    starts = np.cumsum(sizes) - sizes
    after = np.arange(1, v.shape[0] + 1)  # each vertex's successor in its ring
    after[starts + sizes - 1] = starts
    cross = v[:, 0] * v[after, 1] - v[after, 0] * v[:, 1]
    areas = 0.5 * np.abs(np.add.reduceat(cross, starts))
    v.setflags(write=False)
    out = []
    for s0, n, area in zip(starts.tolist(), sizes.tolist(), areas.tolist(), strict=True):
        ring = v[s0 : s0 + n]
        if area <= 1e-6:  # near the threshold: GEOS's own measure decides
            area = float(shapely.area(shapely.Polygon(ring)))
        if area > 1e-9:
            out.append(ring)
    return tuple(out)


def ray_hits(obs: FloorObservation, ends: FloatArray, n_rays: int) -> RaySweep:
    """The ``n_rays`` rays across the field of view of ``obs`` and the nearest of the segments
    ``ends`` (n, 2, 2; world metres) each meets (``hit`` ``inf``: none; section 4.1).

    Only the rays within a segment's angular span (the arc it subtends, < pi, relative to the
    heading) are intersected with it (:func:`nearest_hits`).
    """
    vp = np.asarray(obs.viewpoint[:2], dtype=np.float64)
    heading = float(obs.viewpoint[2])
    half = 0.5 * float(obs.fov_rad)
    ang = heading + _ray_offsets(half, n_rays)
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # (B, 2)
    hit = np.full(n_rays, np.inf)
    if ends.shape[0]:
        p = ends[:, 0] - vp
        e = ends[:, 1] - ends[:, 0]
        a0 = wrap_angle(np.arctan2(p[:, 1], p[:, 0]) - heading)
        a1 = wrap_angle(np.arctan2(p[:, 1] + e[:, 1], p[:, 0] + e[:, 0]) - heading)
        k0, count = ray_spans(np.minimum(a0, a1), np.maximum(a0, a1), half, n_rays)
        hit = nearest_hits(RaysAndSegments(u=u, p=p, e=e, k0=k0, n_rays=count))
    return RaySweep(origin=vp, u=u, hit=hit, max_range=float(obs.max_range_m))


def ray_spans(
    lo: FloatArray, hi: FloatArray, half: float, n_rays: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(k0, count)``: the first ray and the number of rays of the sweep (``n_rays`` over
    ``[-half, half]`` about the heading) within each segment's angular span ``[lo, hi]``
    (radians relative to the heading); none for an arc of pi or more, whose shorter arc passes
    behind the viewpoint (:func:`ray_spans_reference`, compiled; a test holds the two equal)."""
    spans: tuple[np.ndarray, np.ndarray] = _kernel.ray_spans(lo, hi, float(half), int(n_rays))
    return spans


def ray_spans_reference(
    lo: FloatArray, hi: FloatArray, half: float, n_rays: int
) -> tuple[np.ndarray, np.ndarray]:
    """The readable reference of :func:`ray_spans`, in NumPy (``k0`` is 0 where ``count``
    is)."""
    step = 2.0 * half / (n_rays - 1)
    ok = hi - lo < np.pi  # a segment whose shorter arc passes behind the viewpoint: not in FOV
    with np.errstate(invalid="ignore"):  # NaN spans are not ok
        k0 = np.clip(np.ceil((lo + half) / step - 1e-9), 0, n_rays).astype(np.int64)
        k1 = np.clip(np.floor((hi + half) / step + 1e-9), -1, n_rays - 1).astype(np.int64)
    count = np.where(ok, np.maximum(k1 - k0 + 1, 0), 0)
    return np.where(ok, k0, 0), count


def occluders_of(situation: Situation) -> FloatArray:
    """(n, 2, 2) the occluding lines of ``situation``: its obstacles' skeletons (segments, then
    impassable links), world frame, metres."""
    lines = [o.lines for o in situation.obstacles]
    return np.concatenate(lines) if lines else np.zeros((0, 2, 2))


def nearest_hits(rays: RaysAndSegments) -> FloatArray:
    """Distance along each ray to the nearest segment it crosses (``inf``: none; section 4.1,
    occlusion): :func:`nearest_hits_reference`, compiled (one pass over the (segment, ray)
    pairs instead of a dozen array operations; a test holds the two equal)."""
    hits: FloatArray = _kernel.nearest_hits(rays)
    return hits


def nearest_hits_reference(rays: RaysAndSegments) -> FloatArray:
    """The readable reference of :func:`nearest_hits`, in NumPy: the distance along each ray
    to the nearest segment it crosses (``inf``: none; section 4.1, occlusion).

    Ray ``k`` (direction ``u_k``) meets segment ``p + s e`` at ``r u_k = p + s e``; the hit
    counts when ``s`` is in [0, 1] (1e-9 slack) and ``r > 1e-9``, rays parallel to the segment
    (``|u_k x e| <= 1e-15``) excepted. Only the rays ``k0 .. k0 + n_rays - 1`` of each segment
    are tried.

    Returns:
        (B,) the smallest such ``r`` of each ray.
    """
    count = rays.n_rays
    seg = np.repeat(np.arange(rays.p.shape[0]), count)  # (segment, ray) pairs to try
    ray = rays.k0[seg] + np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    ux, uy = rays.u[ray, 0], rays.u[ray, 1]
    px, py, ex, ey = rays.p[seg, 0], rays.p[seg, 1], rays.e[seg, 0], rays.e[seg, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = ux * ey - uy * ex
        r = (px * ey - py * ex) / denom
        s = (px * uy - py * ux) / denom
    hit = (np.abs(denom) > 1e-15) & (s >= -1e-9) & (s <= 1.0 + 1e-9) & (r > 1e-9)
    out = np.full(rays.u.shape[0], np.inf)
    np.minimum.at(out, ray[hit], r[hit])
    return out


def shadow_rings(sweep: RaySweep) -> Rings:
    """The occluded polygons of a ray sweep (section 4.1, occlusion): one ring per run of
    consecutive blocked rays (:func:`shadow_rings_reference`, compiled; a test holds the two
    equal)."""
    rings: Rings = _kernel.shadow_rings(sweep)
    return rings


def shadow_rings_reference(sweep: RaySweep) -> Rings:
    """The readable reference of :func:`shadow_rings`, in NumPy: the occluded polygons of a
    ray sweep (section 4.1, occlusion).

    A ray is blocked when its hit is nearer than ``max_range``. Each run of consecutive blocked
    rays gives one ring: the hit points of its rays, then back along the range arc, which reaches
    one ray beyond each end of the run (the shadow's edge lies between a blocked and a free ray).
    """
    u, hit, n = sweep.u, sweep.hit, sweep.hit.shape[0]
    blocked = hit < sweep.max_range
    edges = np.diff(np.concatenate(([0], blocked.astype(np.int8), [0])))
    run_lo = np.flatnonzero(edges == 1)
    run_hi = np.flatnonzero(edges == -1)  # exclusive
    far = sweep.origin + sweep.max_range * u
    rings = [
        np.vstack(
            [sweep.origin + hit[s0:s1, None] * u[s0:s1], far[max(s0 - 1, 0) : min(s1 + 1, n)][::-1]]
        )
        for s0, s1 in zip(run_lo.tolist(), run_hi.tolist(), strict=True)
    ]
    sizes = np.array([r.shape[0] for r in rings], dtype=np.int64)
    vertices = np.concatenate(rings) if rings else np.zeros((0, 2))
    return Rings(vertices=vertices, sizes=sizes)


@functools.lru_cache(maxsize=16)
def _ray_offsets(half: float, n_rays: int) -> FloatArray:
    """(n_rays,) ray angles relative to the heading, read-only (cached: the field of view of a
    camera does not change between observations)."""
    out = np.linspace(-half, half, n_rays)
    out.setflags(write=False)
    return out


def polygons_of(geom: Any) -> tuple[FloatArray, ...]:
    """Exterior rings (m, 2), not closed, of the polygons of ``geom`` with an area."""
    if geom is None or shapely.is_empty(geom):
        return ()
    parts = getattr(geom, "geoms", [geom])
    out = []
    for g in parts:
        if g.geom_type == "Polygon" and not g.is_empty and g.area > 1e-9:
            ring = np.asarray(g.exterior.coords, dtype=np.float64)[:-1]
            ring.setflags(write=False)
            out.append(ring)
    return tuple(out)
