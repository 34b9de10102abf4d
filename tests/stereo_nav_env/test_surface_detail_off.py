"""With ``surface_detail`` off, the world is main's plain world, bit for bit (issue 42).

The digests below were computed on main before surface detail existed (commit 9b9c767, the
branch point), by the same code: the scene mesh the renderer draws (machine-independent), a
rendered pair (Mesa's llvmpipe through EGL, the project's headless renderer), 20 surrogate
steps and 6 stereo steps of seeded random actions (observations and rewards).
"""

from __future__ import annotations

import hashlib

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.rendering.renderer import build_scene_mesh
from stereo_nav_env.sim.scenes import load_scenario

MAIN = {
    "mesh": "06f60ecc3c302ee6",
    "pair": "f7e06c809d75d003",
    "surrogate": "df84c325dc109055",
    "stereo": "53ce425564219260",
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


def test_plain_rendered_pair_is_mains() -> None:
    env = gym.make("StereoNav-v1", scenario="office", surface_detail=False)
    env.reset(seed=5)
    left, right = env.unwrapped.render_stereo()
    env.close()
    assert _digest(left, right) == MAIN["pair"]


def test_plain_surrogate_observations_are_mains() -> None:
    assert _rollout(20, scenario="office", perception="surrogate") == MAIN["surrogate"]


def test_plain_stereo_observations_are_mains() -> None:
    assert _rollout(6, scenario="cluttered") == MAIN["stereo"]


def test_the_default_is_plain() -> None:
    env = gym.make("StereoNav-v1", scenario="office")
    env.reset(seed=5)
    assert env.unwrapped.config.surface_detail is False
    assert not any(ob.detail for ob in env.unwrapped.scene.obstacles)
    env.close()
