"""Numba compilation on first use: the one place the project's compiled loops are made.

``import modeling`` does not import Numba (it costs about half a second); each loop is compiled,
or loaded from Numba's on-disk cache (next to the source), the first time it is called, with the
interpreter lock released while it runs.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


def compiled_on_first_call(fn: F) -> F:
    """``fn`` (a module-level function Numba can compile), compiled when first called."""
    compiled: Callable[..., Any] | None = None

    @functools.wraps(fn)
    def call(*args: Any) -> Any:
        nonlocal compiled
        if compiled is None:
            import numba

            compiled = numba.njit(cache=True, nogil=True)(fn)
        return compiled(*args)

    return call  # type: ignore[return-value]
