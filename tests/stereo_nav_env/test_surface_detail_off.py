"""With ``surface_detail`` off, the world is main's plain world, bit for bit (issue 42).

The digests below were computed on main before surface detail existed (commit 9b9c767, the
branch point), by the same code: the scene mesh the renderer draws (plain arithmetic, the same
on any machine) and 20 surrogate steps of seeded random actions (observations and rewards). A
rendered pair and the stereo's observations depend on the machine's rasteriser and compiled
kernels, so they are compared within the run instead: the world with the switch off renders
and observes exactly as the detailed world with its detail taken away.
"""

from __future__ import annotations

import hashlib

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)
from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.rendering.renderer import StereoRenderer, build_scene_mesh
from stereo_nav_env.sim.scenes import load_scenario, map_io, plain_surfaces

MAIN = {
    "mesh": "06f60ecc3c302ee6",
    "surrogate": "df84c325dc109055",
}


def _digest(*arrays: np.ndarray) -> str:
    d = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        d.update(str(a.dtype).encode())
        d.update(str(a.shape).encode())
        d.update(a.tobytes())
    return d.hexdigest()[:16]


def _rollout(steps: int, **kwargs: object) -> str:
    env = gym.make("StereoNav-v1", surface_detail=False, **kwargs)
    obs, _ = env.reset(seed=11)
    rng = np.random.default_rng(3)
    d = hashlib.sha256()
    for _ in range(steps):
        for key in sorted(obs):
            d.update(np.ascontiguousarray(obs[key]).tobytes())
        obs, reward, *_ = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
        d.update(np.float64(reward).tobytes())
    env.close()
    return d.hexdigest()[:16]


def test_plain_scene_mesh_is_mains() -> None:
    scene = load_scenario("office", 5, surface_detail=False)
    assert not any(ob.detail for ob in scene.obstacles)
    mesh = build_scene_mesh(scene)
    assert _digest(mesh.vertices, mesh.faces, mesh.visual.face_colors) == MAIN["mesh"]


def test_plain_rendered_pair_is_the_detailed_one_without_detail(rig: StereoRig) -> None:
    detailed = load_scenario("office", 5, surface_detail=True)
    assert any(ob.detail for ob in detailed.obstacles)
    x, y, heading = detailed.start
    head = HeadPose(x_m=x, y_m=y, heading_rad=heading, height_m=0.8)
    pairs = []
    for scene in (load_scenario("office", 5), plain_surfaces(detailed), detailed):
        renderer = StereoRenderer(rig, scene)
        pairs.append(renderer.render_stereo(head))
        renderer.close()
    off, stripped, on = pairs
    for a, b in zip(off, stripped, strict=True):
        np.testing.assert_array_equal(a, b)
    assert any(np.any(a != b) for a, b in zip(off, on, strict=True))


def test_plain_surrogate_observations_are_mains() -> None:
    assert _rollout(20, scenario="office", perception="surrogate") == MAIN["surrogate"]


def test_plain_stereo_observations_ignore_the_detail_generator(monkeypatch) -> None:
    """With the switch off, stereo episodes on generated and listed scenes never draw detail
    (the generator raises if called)."""

    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("surface detail drawn with surface_detail=False")

    monkeypatch.setattr(map_io, "add_surface_detail", forbidden)
    for scenario in ("cluttered", "office"):
        assert len(_rollout(3, scenario=scenario)) == 16


def test_the_default_is_plain() -> None:
    env = gym.make("StereoNav-v1", scenario="office")
    env.reset(seed=5)
    assert env.unwrapped.config.surface_detail is False
    assert not any(ob.detail for ob in env.unwrapped.scene.obstacles)
    env.close()
