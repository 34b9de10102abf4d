"""Fixtures shared by the whole suite: default rig, scene and renderer, a small map and a tiny
imitation run."""

from __future__ import annotations

import json
import os
import pathlib
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, settings

from modeling.stereo.rig import StereoRig

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

# Hypothesis profiles: "ci" (the default: deterministic, 100 examples per property) and
# "soak" (10,000 examples: ``make fuzz``). Tests with explicit @settings keep their own counts.
_QUIET = [HealthCheck.too_slow, HealthCheck.data_too_large]
settings.register_profile(
    "ci",
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=_QUIET,
)
settings.register_profile(
    "soak",
    max_examples=10_000,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=_QUIET,
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def rig() -> StereoRig:
    """The project's default rig: 320x240, focal 260 px, baseline 0.12 m."""
    return StereoRig()


@pytest.fixture(scope="session")
def default_scene():  # -> stereo_nav_env.sim.scenes.Scene
    """The bundled ``default`` map."""
    from stereo_nav_env.sim.scenes import load_scenario

    return load_scenario("default")


@pytest.fixture(scope="session")
def default_renderer(rig, default_scene) -> Iterator:  # -> StereoRenderer
    """One session-wide renderer of the default scene (its OpenGL context is made once)."""
    from stereo_nav_env.rendering.renderer import StereoRenderer

    renderer = StereoRenderer(rig, default_scene)
    yield renderer
    renderer.close()


SMALL_MAP = {
    "format": "stereo-nav-map/1",
    "name": "small_box",
    "bounds": [0.0, 0.0, 5.0, 3.0],
    "start": [0.8, 1.5, 0.0],
    "goal": [4.2, 1.5],
    "obstacles": [
        {"kind": "wall", "rect": {"center": [2.5, 0.05], "size": [5.0, 0.1], "yaw_deg": 0}},
        {"kind": "wall", "rect": {"center": [2.5, 2.95], "size": [5.0, 0.1], "yaw_deg": 0}},
        {"kind": "wall", "rect": {"center": [0.05, 1.5], "size": [2.8, 0.1], "yaw_deg": 90}},
        {"kind": "wall", "rect": {"center": [4.95, 1.5], "size": [2.8, 0.1], "yaw_deg": 90}},
        {"kind": "box", "rect": {"center": [2.5, 1.35], "size": [0.6, 0.6], "yaw_deg": 0}},
    ],
}


@pytest.fixture(scope="session")
def small_map(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A 5 m x 3 m room with one box between the start and the goal (JSON map path)."""
    path = tmp_path_factory.mktemp("maps") / "small_box.json"
    path.write_text(json.dumps(SMALL_MAP))
    return path


@pytest.fixture(scope="session")
def imitation_run(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A ``train.py --teacher planner`` output folder of a tiny imitation policy (120 planner
    steps on ``open``, a 16 px map at 0.5 m, width 32): ``policy.pt``, ``record.json``, ..."""
    from agents.learning.egomap import EgoMapConfig
    from agents.learning.imitation import ImitationConfig, train_imitation

    out = tmp_path_factory.mktemp("imitation")
    cfg = ImitationConfig(
        out_dir=out,
        n_envs=1,
        demo_steps=120,
        rounds=0,
        epochs=1,
        width=32,
        families=("open",),
        weights=(1.0,),
        egomap=EgoMapConfig(size_px=16, cell_m=0.5),
        progress=False,
    )
    train_imitation(cfg)
    return out
