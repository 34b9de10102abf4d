"""The floor one observation sees free (issue 16; occlusion after paper section 4.1).

What a view sees is its field-of-view wedge of radius ``max_range_m`` up to the nearest segment
along each ray: the same angular sweep as :func:`modeling.model.occlusion.occluded_area`
(:func:`modeling.model.occlusion.ray_hits`), kept as the hit distance per ray. A floor point is
*seen free* when it lies in the wedge, beyond ``near_range_m`` (the floor too close to appear in
the image) and at least ``margin_m`` short of the nearest hit along its ray (so a remembered
segment lying on or just in front of what the view sees is not counted as seen free). The
visible area as a polygon (:meth:`Visibility.polygon`) is the star of the hit points (or the
range).

Frames: world, metres; angles radians.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numpy as np
import shapely

from modeling.geometry import wrap_angle
from modeling.model.occlusion import ray_hits
from modeling.observation import FloorObservation
from modeling.types import FloatArray

__all__ = ["Visibility", "flat_in_image", "visibility"]


class Visibility(NamedTuple):
    """One view's rays and how far each sees.

    Attributes:
        origin: (2,) the viewpoint, world frame, metres.
        heading: Heading of the view, radians.
        half_fov: Half the field of view, radians.
        angles: (B,) ray angles relative to the heading, ascending, radians.
        reach: (B,) distance to the nearest hit of each ray, at most the range, metres.
        near_m: Floor nearer than this is not seen, metres.
    """

    origin: FloatArray
    heading: float
    half_fov: float
    angles: FloatArray
    reach: FloatArray
    near_m: float

    def seen_free(
        self, points: FloatArray, margin_m: float, near_m: FloatArray | None = None
    ) -> np.ndarray:
        """(k,) bool: each of ``points`` (k, 2), world metres, is seen free by this view (in the
        wedge, beyond ``near_m`` (k,) or this view's ``near_m``, at least ``margin_m`` short of
        its ray's hit)."""
        rel = np.asarray(points, dtype=np.float64).reshape(-1, 2) - self.origin
        dist = np.hypot(rel[:, 0], rel[:, 1])
        ang = wrap_angle(np.arctan2(rel[:, 1], rel[:, 0]) - self.heading)
        n = self.angles.shape[0]
        step = 2.0 * self.half_fov / (n - 1)
        k = np.clip(np.rint((ang + self.half_fov) / step), 0, n - 1).astype(np.int64)
        out: np.ndarray = (
            (np.abs(ang) <= self.half_fov)
            & (dist > (self.near_m if near_m is None else near_m))
            & (dist < self.reach[k] - margin_m)
        )
        return out

    def polygon(self) -> Any:
        """The visible area as a shapely Polygon (the star of the rays' reaches, from the near
        arc), world frame; not simplified (the union with the seen floor and one simplification
        of that cost less than simplifying this first)."""
        # Rays that reach farthest, as both neighbours do: on the range arc, where one ray per
        # 3 degrees is enough (a chord of 3 degrees deviates 2.7 mm from an 8 m arc); the star
        # stays simple (the vertices keep their angular order).
        n = self.reach.shape[0]
        stride = max(1, int(math.radians(3.0) / (2.0 * self.half_fov / (n - 1))))
        far_ray = self.reach >= self.reach.max() - 1e-12
        inner = np.zeros(n, dtype=bool)
        inner[1:-1] = far_ray[:-2] & far_ray[1:-1] & far_ray[2:]
        keep = ~inner | (np.arange(n) % stride == 0)
        ang = self.heading + self.angles[keep]
        u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        reach_kept = self.reach[keep]
        if self.near_m > 0.0:  # an annular sector: never touching itself (reach > near)
            reach = np.maximum(reach_kept, self.near_m + 1e-3)
            ring = np.vstack(
                [self.origin + reach[:, None] * u, (self.origin + self.near_m * u)[::-1]]
            )
        else:  # a star polygon around the viewpoint: simple
            ring = np.vstack([self.origin[None, :], self.origin + reach_kept[:, None] * u])
        return shapely.polygons(ring)


@functools.lru_cache(maxsize=16)
def _ray_angles(half: float, n_rays: int) -> FloatArray:
    """(n_rays,) ray angles relative to the heading, ascending, read-only (cached: a camera's
    field of view does not change between views)."""
    out = np.linspace(-half, half, n_rays)
    out.setflags(write=False)
    return out


def visibility(
    observation: FloorObservation, occluders: FloatArray, *, n_rays: int, near_m: float
) -> Visibility:
    """The rays of ``observation`` and the reach of each past the ``occluders``.

    Args:
        observation: The view (viewpoint, field of view, range).
        occluders: (n, 2, 2) endpoint means of the segments that block the view, metres.
        n_rays: Rays across the field of view (>= 2).
        near_m: Floor nearer than this is not seen, metres.
    """
    sweep = ray_hits(observation, occluders, n_rays)
    half = 0.5 * float(observation.fov_rad)
    return Visibility(
        origin=sweep.origin,
        heading=float(observation.viewpoint[2]),
        half_fov=half,
        angles=_ray_angles(half, n_rays),
        reach=np.minimum(sweep.hit, sweep.max_range),
        near_m=near_m,
    )


def flat_in_image(
    vis: Visibility,
    ends: FloatArray,
    heights: FloatArray,
    head_height_m: float,
    min_angle_deg: float,
) -> np.ndarray:
    """(n,) bool: the image of each segment (floor endpoints ``ends`` (n, 2, 2), world metres,
    their 3-D heights ``heights`` (n, 2)) in the view of ``vis``, a level head at
    ``head_height_m``, lies at less than ``min_angle_deg`` to the image rows, so that the segment
    stereo could not match it there (``SegmentOptions.min_angle_deg``).

    A point ``z`` ahead, ``x`` across and ``h`` high images at ``(x / z, (H - h) / z)`` times the
    focal length, which the angle does not depend on: a floor line across the gaze is a row, one
    along it is steep, a vertical edge is a column. A segment with an endpoint not ahead of the
    viewpoint is not flat (no view sees its floor)."""
    n = ends.shape[0]
    if n == 0 or min_angle_deg <= 0.0:
        return np.zeros(n, dtype=bool)
    rel = ends - vis.origin  # (n, 2, 2)
    c, s = math.cos(vis.heading), math.sin(vis.heading)
    z = rel[..., 0] * c + rel[..., 1] * s
    x = rel[..., 1] * c - rel[..., 0] * s
    ahead = np.all(z > 1e-9, axis=1)
    z = np.where(z > 1e-9, z, 1.0)
    du = x[:, 1] / z[:, 1] - x[:, 0] / z[:, 0]
    dv = (head_height_m - heights[:, 1]) / z[:, 1] - (head_height_m - heights[:, 0]) / z[:, 0]
    sin_min = math.sin(math.radians(min_angle_deg))
    out: np.ndarray = ahead & (np.abs(dv) < sin_min * np.hypot(du, dv))
    return out
