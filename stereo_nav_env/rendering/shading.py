"""The renderer's baked shading: the colour of every surface a ray can meet, without pyrender.

:mod:`stereo_nav_env.rendering.renderer` draws flat, pre-shaded faces: a part's vertical face has
its base colour times the shade of the face's orientation (:func:`face_shade`), its top
``TOP_SHADE`` and its bottom ``BOTTOM_SHADE`` times the colour; the floor is ``FLOOR_COLOR`` (the
scene's bounds plus a margin), and whatever no surface covers is ``BACKGROUND_COLOR``. The surrogate
perception (:mod:`stereo_nav_env.perception.surrogate.photometry`) reads the same values to know the
grey levels beside each edge, so this module imports nothing heavy.

Colours are RGB in [0, 1]; :func:`grey_levels` gives the grey level the pipeline sees.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BACKGROUND_COLOR",
    "BOTTOM_SHADE",
    "FLOOR_COLOR",
    "FLOOR_MARGIN_M",
    "SIDE_SHADES",
    "TOP_SHADE",
    "face_shade",
    "face_shades",
    "grey_levels",
]

FLOOR_COLOR = (0.40, 0.40, 0.42)
BACKGROUND_COLOR = (0.62, 0.70, 0.80)
TOP_SHADE = 1.0
BOTTOM_SHADE = 0.45
SIDE_SHADES = (0.92, 0.74, 0.58, 0.84)  # outward normal nearest world +x, +y, -x, -y
FLOOR_MARGIN_M = 0.5
"""How far the rendered floor extends beyond the scene's bounds, metres."""


def face_shade(normal_xy: NDArray[np.float64]) -> float:
    """Shade factor of a vertical face from its outward normal (2,) in the world floor plane.

    The four quadrants around world +x, +y, -x, -y get distinct factors, so two faces at right
    angles (adjacent sides of a box) never share a shade.
    """
    phi = math.atan2(float(normal_xy[1]), float(normal_xy[0]))
    quadrant = math.floor((phi + math.pi / 4) / (math.pi / 2)) % 4
    return SIDE_SHADES[quadrant]


def face_shades(normals_xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`face_shade` of many outward normals (..., 2) at once: (...,) shade factors."""
    phi = np.arctan2(normals_xy[..., 1], normals_xy[..., 0])
    quadrant = np.floor((phi + math.pi / 4) / (math.pi / 2)).astype(np.int64) % 4
    out: NDArray[np.float64] = np.asarray(SIDE_SHADES)[quadrant]
    return out


def grey_levels(colors: NDArray[np.float64]) -> NDArray[np.float64]:
    """The grey levels (...,) of RGB colours (..., 3) in [0, 1] as the pipeline sees them: the
    renderer's uint8 colour (rounded, clipped), then OpenCV's RGB to grey conversion."""
    rgb = np.clip(np.round(np.asarray(colors, dtype=np.float64) * 255.0), 0, 255).astype(np.uint8)
    flat = rgb.reshape(1, -1, 3)
    grey = cv2.cvtColor(np.ascontiguousarray(flat), cv2.COLOR_RGB2GRAY)
    out: NDArray[np.float64] = grey.reshape(rgb.shape[:-1]).astype(np.float64)
    return out
