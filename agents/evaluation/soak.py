"""Soak runs: many steps, many create/close cycles and vector envs, watching for leaks and hangs.

Each phase records the process's resident memory and open file descriptors after a warm-up and
at its end, the step times, and whether it finished before its deadline. ``scripts/soak.py``
(``make soak``) runs the three phases and prints the table; the README's Reliability section
quotes it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import os
import statistics
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)

__all__ = [
    "PhaseResult",
    "create_close_cycles",
    "format_table",
    "make_small_env",
    "open_descriptors",
    "random_steps",
    "resident_mb",
    "rollout_digest",
    "vector_steps",
]

SMALL_CAMERA: dict[str, Any] = {"width_px": 160, "height_px": 120, "focal_px": 130.0}
"""A quarter-size pair (the default field of view) for the create/close and vector phases."""


@dataclass(frozen=True, slots=True, kw_only=True)
class PhaseResult:
    """What one soak phase measured.

    Attributes:
        phase: Its name.
        iterations: Steps or cycles done.
        rss_start_mb: Resident memory after the warm-up, MiB.
        rss_end_mb: Resident memory at the end, MiB.
        fds_start: Open file descriptors after the warm-up.
        fds_end: Open file descriptors at the end.
        step_median_ms: Median time of one iteration, milliseconds.
        step_p99_ms: Its 99th percentile, milliseconds.
        seconds: Wall time of the phase, seconds.
        finished: Whether it ended before its deadline (``False``: it hung).
    """

    phase: str
    iterations: int
    rss_start_mb: float
    rss_end_mb: float
    fds_start: int
    fds_end: int
    step_median_ms: float
    step_p99_ms: float
    seconds: float
    finished: bool

    @property
    def rss_growth_mb(self) -> float:
        """Resident memory growth over the phase, MiB."""
        return self.rss_end_mb - self.rss_start_mb

    @property
    def fd_growth(self) -> int:
        """Open descriptors gained over the phase."""
        return self.fds_end - self.fds_start

    def as_dict(self) -> dict[str, float | int | str | bool]:
        """The fields and the two growths, for JSON."""
        out = dataclasses.asdict(self)
        out["rss_growth_mb"] = self.rss_growth_mb
        out["fd_growth"] = self.fd_growth
        return out


def resident_mb() -> float:
    """This process's resident memory, MiB (Linux: ``/proc/self/statm``)."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def open_descriptors() -> int:
    """How many file descriptors this process has open (Linux: ``/proc/self/fd``)."""
    return len(os.listdir("/proc/self/fd"))


class _Deadline:
    """Set once ``seconds`` have passed; phases check it between iterations."""

    def __init__(self, seconds: float) -> None:
        self._event = threading.Event()
        self._timer = threading.Timer(seconds, self._event.set)
        self._timer.daemon = True

    @property
    def passed(self) -> bool:
        return self._event.is_set()

    @contextmanager
    def running(self) -> Iterator[_Deadline]:
        self._timer.start()
        try:
            yield self
        finally:
            self._timer.cancel()


def _phase(
    name: str,
    iterations: int,
    warmup: int,
    deadline_s: float,
    one: Callable[[int], None],
) -> PhaseResult:
    """Run ``one(i)`` for ``i < iterations`` (the first ``warmup`` untimed), measuring."""
    times: list[float] = []
    t_start = time.perf_counter()
    for i in range(min(warmup, iterations)):
        one(i)
    rss0, fds0 = resident_mb(), open_descriptors()
    done = min(warmup, iterations)
    with _Deadline(deadline_s).running() as deadline:
        for i in range(done, iterations):
            if deadline.passed:
                break
            t0 = time.perf_counter()
            one(i)
            times.append((time.perf_counter() - t0) * 1e3)
            done += 1
    finished = done == iterations
    return PhaseResult(
        phase=name,
        iterations=done,
        rss_start_mb=rss0,
        rss_end_mb=resident_mb(),
        fds_start=fds0,
        fds_end=open_descriptors(),
        step_median_ms=statistics.median(times) if times else 0.0,
        step_p99_ms=float(np.percentile(times, 99)) if times else 0.0,
        seconds=time.perf_counter() - t_start,
        finished=finished,
    )


def random_steps(steps: int, *, seed: int = 0, deadline_s: float = 3600.0) -> PhaseResult:
    """``steps`` random actions in one env whose every reset draws a random scene family."""
    env = gym.make("StereoNav-v0", scenario="random")
    env.action_space.seed(seed)
    env.reset(seed=seed)

    def one(_: int) -> None:
        step = env.step(env.action_space.sample())
        if step[2] or step[3]:  # terminated or truncated
            env.reset()

    try:
        return _phase("random steps", steps, min(200, steps // 10), deadline_s, one)
    finally:
        env.close()


def create_close_cycles(cycles: int, *, seed: int = 0, deadline_s: float = 3600.0) -> PhaseResult:
    """``cycles`` times: make an env, reset, step once, close it."""

    def one(i: int) -> None:
        env = make_small_env()
        try:
            env.reset(seed=seed + i)
            env.step(env.action_space.sample())
        finally:
            env.close()

    return _phase("create/close cycles", cycles, min(20, cycles // 10), deadline_s, one)


def vector_steps(
    rounds: int, *, steps: int = 50, num_envs: int = 2, seed: int = 0, deadline_s: float = 3600.0
) -> PhaseResult:
    """``rounds`` times: an ``AsyncVectorEnv`` of ``num_envs`` spawned workers, ``steps`` steps,
    closed. Each iteration is one round; the memory is the parent's."""

    def one(i: int) -> None:
        fns = [functools.partial(make_small_env) for _ in range(num_envs)]
        vec = gym.vector.AsyncVectorEnv(fns, context="spawn")
        try:
            vec.action_space.seed(seed + i)
            vec.reset(seed=seed + i)
            for _ in range(steps):
                vec.step(vec.action_space.sample())
        finally:
            vec.close()

    return _phase("vector env rounds", rounds, min(1, rounds - 1), deadline_s, one)


def make_small_env() -> gym.Env[Any, Any]:
    """A ``StereoNav-v0`` of random families with the quarter-size pair (picklable by reference,
    so a spawned vector-env worker imports this module and with it the registration)."""
    return gym.make("StereoNav-v0", scenario="random", **SMALL_CAMERA)


def rollout_digest(seed: int, steps: int = 200, *, scenario: str = "random") -> str:
    """SHA-256 of a ``steps``-step rollout: every observation, reward and end flag, in order.

    The actions come from the action space seeded with ``seed``; the env resets with ``seed``
    (and again, unseeded, when an episode ends). Two processes that get the same digest saw the
    same rollout bit for bit.
    """
    env = gym.make("StereoNav-v0", scenario=scenario, **SMALL_CAMERA)
    digest = hashlib.sha256()

    def feed(obs: dict[str, np.ndarray], *extra: float) -> None:
        for key in sorted(obs):
            digest.update(key.encode())
            digest.update(np.ascontiguousarray(obs[key]).tobytes())
        digest.update(np.asarray(extra, dtype=np.float64).tobytes())

    try:
        env.action_space.seed(seed)
        obs, _ = env.reset(seed=seed)
        feed(obs)
        for _ in range(steps):
            obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            feed(obs, float(reward), float(terminated), float(truncated))
            if terminated or truncated:
                obs, _ = env.reset()
                feed(obs)
    finally:
        env.close()
    return digest.hexdigest()


def format_table(results: list[PhaseResult]) -> str:
    """A Markdown table of the phases."""
    rows = [
        "| phase | iterations | RSS growth (MiB) | descriptors | median (ms) | p99 (ms) | "
        "time (s) | finished |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        rows.append(
            f"| {r.phase} | {r.iterations} | {r.rss_growth_mb:+.1f} "
            f"({r.rss_start_mb:.0f} -> {r.rss_end_mb:.0f}) | {r.fds_start} -> {r.fds_end} | "
            f"{r.step_median_ms:.1f} | {r.step_p99_ms:.1f} | {r.seconds:.0f} | "
            f"{'yes' if r.finished else 'NO (hung)'} |"
        )
    return "\n".join(rows)
