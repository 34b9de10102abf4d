"""Reliability across processes: spawned workers reproduce a rollout, soak phases leak nothing."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys

from agents.evaluation.soak import create_close_cycles, random_steps, rollout_digest


def test_two_spawned_processes_give_the_same_200_step_rollout() -> None:
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        first, second = pool.starmap(rollout_digest, [(7, 200), (7, 200)])
    assert first == second
    assert first != rollout_digest(8, 20), "the digest depends on the seed"


def test_short_soak_phases_finish_without_descriptor_growth() -> None:
    steps = random_steps(60, seed=3)
    cycles = create_close_cycles(6, seed=3)
    for result in (steps, cycles):
        assert result.finished
        assert result.fd_growth <= 0, result
        assert result.step_median_ms > 0.0
    assert steps.iterations == 60 and cycles.iterations == 6


FORKED_VECTOR_ENV = """
import gymnasium as gym
import stereo_nav_env
kw = dict(width_px=64, height_px=48, focal_px=52.0)
env = gym.make("StereoNav-v0", **kw)
env.reset(seed=0)  # the parent renders: it now holds an OpenGL context
env.close()
vec = gym.vector.AsyncVectorEnv([lambda: gym.make("StereoNav-v0", **kw)] * 2, context="fork")
try:
    vec.reset(seed=0)
except RuntimeError as exc:
    print("REFUSED:", exc)
else:
    print("RENDERED")
"""


def test_a_forked_vector_env_after_rendering_raises_instead_of_hanging() -> None:
    env = {**os.environ, "PYOPENGL_PLATFORM": "egl"}
    done = subprocess.run(
        [sys.executable, "-c", FORKED_VECTOR_ENV],
        capture_output=True,
        text=True,
        timeout=300,  # a hang fails the test here instead of blocking the suite
        env=env,
        check=False,
    )
    assert "REFUSED:" in done.stdout, done.stdout + done.stderr
    assert "context='spawn'" in done.stdout
