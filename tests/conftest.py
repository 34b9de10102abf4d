"""Fixtures shared by the whole suite: the default rig, the default scene and one renderer."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from modeling.rig import StereoRig


@pytest.fixture(scope="session")
def rig() -> StereoRig:
    """The project's default rig: 320x240, focal 260 px, baseline 0.12 m."""
    return StereoRig()


@pytest.fixture(scope="session")
def default_scene():  # -> stereo_nav_env.scenes.Scene
    """The bundled ``default`` map."""
    from stereo_nav_env.scenes import load_scenario

    return load_scenario("default")


@pytest.fixture(scope="session")
def default_renderer(rig, default_scene) -> Iterator:  # -> StereoRenderer
    """One session-wide renderer of the default scene (its OpenGL context is made once)."""
    from stereo_nav_env.render import StereoRenderer

    renderer = StereoRenderer(rig, default_scene)
    yield renderer
    renderer.close()
