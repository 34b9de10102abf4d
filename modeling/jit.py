"""Numba compilation on first use: the one place the project's compiled loops are made.

Public, so that every package compiles its loops the same way: the loops of :mod:`modeling` (in
the private ``_kernels`` of :mod:`modeling.stereo`, :mod:`modeling.model` and
:mod:`modeling.memory`), the surrogate's and the env's pixel-noise lookup
(:mod:`stereo_nav_env.perception.noise`).

``import modeling`` does not import Numba (it costs about half a second); each loop is compiled,
or loaded from Numba's on-disk cache (next to the source), the first time it is called, with the
interpreter lock released while it runs, and NumPy's floating-point semantics (``error_model
"numpy"``: a division by zero gives an infinity or a NaN, as in the NumPy expressions the loops
replace, instead of raising ``ZeroDivisionError``).

A loop may call scalar helpers of its own module marked with :func:`compiled_helper`: when the
first loop of a module is compiled, its helpers are compiled too and replace the plain functions
in the module's namespace (they stay callable from Python, with the same results).
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

_HELPER = "_compiled_helper"
_OPTIONS: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
_COMPILING = threading.RLock()  # one thread makes the dispatchers (and replaces the helpers)


def compiled_helper(fn: F) -> F:
    """Mark ``fn`` (a module-level function Numba can compile) as a helper of compiled loops."""
    setattr(fn, _HELPER, True)
    return fn


def _compile_helpers(namespace: dict[str, Any]) -> None:
    import numba

    for name, obj in list(namespace.items()):
        if getattr(obj, _HELPER, False) and not isinstance(obj, numba.core.dispatcher.Dispatcher):
            namespace[name] = numba.njit(**_OPTIONS)(obj)


def compiled_on_first_call(fn: F) -> F:
    """``fn`` (a module-level function Numba can compile), compiled when first called (by one
    thread: another thread calling it meanwhile waits for that compilation)."""
    compiled: Callable[..., Any] | None = None

    @functools.wraps(fn)
    def call(*args: Any) -> Any:
        nonlocal compiled
        if compiled is None:
            with _COMPILING:
                if compiled is None:
                    import numba

                    _compile_helpers(fn.__globals__)
                    compiled = numba.njit(**_OPTIONS)(fn)
        return compiled(*args)

    return call  # type: ignore[return-value]
