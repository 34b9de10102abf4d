"""Synthetic rectified stereo pairs of fronto-parallel rectangles (no renderer needed).

A rectangle is ``(x0_m, x1_m, y0_m, y1_m, z_m, grey)`` in the LEFT camera frame (x right, y down,
z forward). Images are drawn far to near with ``ss``-times horizontal supersampling, so an edge's
column is known to a small fraction of a pixel: a vertical edge at ``X`` and depth ``Z`` lies at
``u = f X / Z + cx`` in the left image and at ``u - f b / Z`` in the right one.
"""

from __future__ import annotations

import numpy as np

from modeling.stereo.rig import StereoRig

Rect = tuple[float, float, float, float, float, float]


def render_pair(
    rig: StereoRig,
    rects: list[Rect],
    *,
    background: float = 90.0,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
    ss: int = 8,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(left, right, depth_left)``: uint8 (H, W) images and the left depth map (inf = none)."""
    H, W = rig.height_px, rig.width_px
    us = (np.arange(W * ss) + 0.5) / ss - 0.5  # sub-sample columns
    vv = np.arange(H)
    out = []
    depth = np.full((H, W), np.inf)
    for shift in (0.0, rig.baseline_m):
        img = np.full((H, W * ss), background, dtype=np.float64)
        for x0, x1, y0, y1, z, grey in sorted(rects, key=lambda r: -r[4]):
            ua = rig.focal_px * (x0 - shift) / z + rig.cx_px
            ub = rig.focal_px * (x1 - shift) / z + rig.cx_px
            va = rig.focal_px * y0 / z + rig.cy_px
            vb = rig.focal_px * y1 / z + rig.cy_px
            cols = (us >= ua) & (us < ub)
            rows = (vv >= va) & (vv < vb)
            img[np.ix_(rows, cols)] = grey
            if shift == 0.0:
                pc = (np.arange(W) >= ua) & (np.arange(W) < ub)
                m = np.ix_(rows, pc)
                depth[m] = np.minimum(depth[m], z)
        img = img.reshape(H, W, ss).mean(axis=2)
        if noise > 0:
            assert rng is not None
            img = img + rng.normal(0.0, noise, img.shape)
        out.append(np.clip(np.rint(img), 0, 255).astype(np.uint8))
    return out[0], out[1], depth
