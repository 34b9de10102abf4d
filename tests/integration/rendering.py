"""Rendering a test scene to a noisy grey stereo pair (shared by the integration tests)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from modeling.stereo.pipeline import to_gray
from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import Scene


def noisy_grey_pair(
    scene: Scene, rig: StereoRig, head: HeadPose, noise_std: float = 2.0
) -> list[NDArray[np.uint8]]:
    """The pair of ``scene`` seen from ``head``, grey, with seeded Gaussian pixel noise
    (``noise_std`` grey levels, generator seed 0); skips the test where nothing renders."""
    renderer = StereoRenderer(rig, scene)
    try:
        left, right = renderer.render_stereo(head)
    except RuntimeError as exc:  # pragma: no cover - no OpenGL on this machine
        pytest.skip(f"rendering unavailable: {exc}")
    finally:
        renderer.close()
    rng = np.random.default_rng(0)
    grey = []
    for image in (left, right):
        g = to_gray(image).astype(np.float64) + rng.normal(0.0, noise_std, image.shape[:2])
        grey.append(np.clip(np.rint(g), 0, 255).astype(np.uint8))
    return grey
