"""Reliability across processes: spawned workers reproduce a rollout, soak phases leak nothing."""

from __future__ import annotations

import multiprocessing

from stereo_nav_env.soak import create_close_cycles, random_steps, rollout_digest


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
