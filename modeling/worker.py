"""This process's one worker thread, for work that runs beside the calling thread.

Used where the work releases the interpreter lock, so the two threads run on two cores at once:
OpenCV's line detector on the right image while the left one is detected
(:func:`modeling.stereo.segments.extract_segment_pair`, 0.9-2.8 ms per env step), and the env's
pixel noise drawn while the pair renders (:mod:`stereo_nav_env.env`, about 0.4 ms per step). Public
so that both packages share the one thread. Made on first use and made again in a forked child
(where the parent's thread does not exist); callers never wait for the worker from inside it.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["worker"]

_WORKER: tuple[int, ThreadPoolExecutor] | None = None
_LOCK = threading.Lock()


def worker() -> ThreadPoolExecutor:
    """The worker thread of this process (a one-thread executor)."""
    global _WORKER
    pid = os.getpid()
    with _LOCK:
        if _WORKER is None or _WORKER[0] != pid:
            _WORKER = (pid, ThreadPoolExecutor(1, thread_name_prefix="modeling"))
        return _WORKER[1]
