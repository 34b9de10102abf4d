"""Numba compilation on first call, for the env's one compiled loop (the pixel-noise lookup).

``import stereo_nav_env`` does not import Numba; the loop is compiled, or loaded from Numba's
on-disk cache, the first time it is called. With ``NUMBA_DISABLE_JIT=1`` it runs as plain Python.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

_COMPILING = threading.Lock()


def compiled_on_first_call(fn: F) -> F:
    """``fn`` (a module-level function Numba can compile in nopython mode), compiled when first
    called."""
    compiled: Callable[..., Any] | None = None

    @functools.wraps(fn)
    def call(*args: Any) -> Any:
        nonlocal compiled
        if compiled is None:
            with _COMPILING:
                if compiled is None:
                    import numba

                    compiled = numba.njit(cache=True, nogil=True)(fn)
        return compiled(*args)

    return call  # type: ignore[return-value]
