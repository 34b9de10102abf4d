"""How a training run uses this machine: freed memory kept, env processes pinned to cores.

**Freed memory.** A CPU update of the policy allocates and frees tens of megabytes per minibatch:
the maps as floats (256 x 7 x 64 x 64 x 4 bytes = 29 MiB), each convolution's output and its
gradient. glibc's ``malloc`` serves blocks that large with ``mmap`` and returns them with
``munmap`` when freed (and trims the heap's free top above a threshold), so the next minibatch
faults the same amount of fresh pages in again, zero-filled by the kernel: a page fault per 4 KiB.
On this project's 2-core machine that was 40-45 % of a PPO update (``FinetuneConfig``'s update of
2,048 samples: 2.72 s with glibc's defaults, 1.47 s with both settings below; the process's peak
memory 954 MB and 992 MB). :func:`keep_freed_memory` raises glibc's ``mmap`` threshold to its
ceiling (32 MiB on 64-bit systems: smaller blocks come from the heap) and its trim threshold to
2 GiB (freed heap memory stays with the process), through ``mallopt``. PyTorch's CPU performance
guide reaches the same end by preloading another allocator (jemalloc or tcmalloc); this needs no
install. The effect lasts for the rest of the process; it changes how fast memory is handed out,
never what is computed. On a C library without glibc's ``mallopt`` (macOS; musl ignores it)
nothing changes.

**Pinned env processes.** Between two steps of a training's env processes the learner acts (and
every rollout it updates); woken again, an env process that the scheduler moves to the other core
starts on cold caches (the likely cause of what was measured below; the migrations themselves
were not counted). When the env processes fill the machine (at least as many as the cores
this process may use), :func:`pinned_maker` puts env ``i`` on core ``i`` modulo their count for
good, and the learner goes where there is room. The fine-tuning stage as ``bench_training.py``
runs it (10,240 steps, 2 env processes, 2 cores), alternating in one run: 232.1, 240.9 and 236.3
steps/s pinned against 208.4, 206.7 and 203.7 not (the envs' steps inside the loop took 27.7-28.6
s against 32.2-33.7 s; stepped alone afterwards, the same envs ran at 364-451 steps/s either
way); as ``bench_training.py`` runs it, 222.4, 229.6 and 257.8 against 217.4, 222.8 and 240.2:
1.09x over both comparisons. With more cores than env processes nothing is pinned: several runs
sharing a large machine would otherwise all pin their first env to the same core.
"""

from __future__ import annotations

import ctypes
import functools
import os
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

M_TRIM_THRESHOLD = -1
"""glibc's ``mallopt`` parameter: the free top of the heap above which ``free`` trims it."""
M_MMAP_THRESHOLD = -3
"""glibc's ``mallopt`` parameter: the request size from which ``malloc`` uses ``mmap``."""
MMAP_THRESHOLD_MAX = 32 * 1024 * 1024
"""glibc's ceiling on ``M_MMAP_THRESHOLD`` on 64-bit systems (``DEFAULT_MMAP_THRESHOLD_MAX``)."""
TRIM_THRESHOLD = 2**31 - 1
"""The trim threshold set: the largest ``int`` (``mallopt`` takes one), 2 GiB."""


def keep_freed_memory() -> bool:
    """Set glibc's ``malloc`` to serve blocks up to 32 MiB from the heap and to keep freed heap
    memory (module docstring). Returns whether both settings took; calling it again is
    harmless."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError):  # no mallopt in this C library
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_MAX)) and bool(
        mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    )


def allowed_cores() -> list[int]:
    """The cores this process may run on, in order (``os.sched_getaffinity``; all of
    ``os.cpu_count()`` where the system has no affinity calls)."""
    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


def pins_envs(n_envs: int) -> bool:
    """Whether :func:`pinned_maker` pins ``n_envs`` env processes: when they are at least as many
    as :func:`allowed_cores` and the system can pin (module docstring)."""
    return n_envs >= len(allowed_cores()) and hasattr(os, "sched_setaffinity")


def pin_to_core(index: int) -> int:
    """Pin this process to core ``index`` modulo :func:`allowed_cores`'s count; returns it."""
    cores = allowed_cores()
    core = cores[index % len(cores)]
    os.sched_setaffinity(0, {core})
    return core


def _pinned_call(index: int, make: Callable[[], T], creator: int) -> T:
    if os.getpid() != creator:  # gymnasium's AsyncVectorEnv makes one env in the caller too
        pin_to_core(index)
    return make()


def pinned_maker(make: Callable[[], T], index: int, n_envs: int) -> Callable[[], T]:
    """The maker of env ``index`` of ``n_envs`` in their subprocesses: ``make`` itself when
    :func:`pins_envs` says no, else a picklable function that first pins the process it runs in
    to core ``index`` (:func:`pin_to_core`), then calls ``make``; called in this process (as
    gymnasium's ``AsyncVectorEnv`` does with its first maker, to read the spaces), it pins
    nothing."""
    if not pins_envs(n_envs):
        return make
    return functools.partial(_pinned_call, index, make, os.getpid())
