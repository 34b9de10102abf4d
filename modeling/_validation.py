"""Private validators (return the checked value or raise ``ValueError`` naming the argument) and
the options of a stage, read from its signature."""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def finite_array(value: ArrayLike, name: str, shape: tuple[int | None, ...]) -> FloatArray:
    """``value`` as a float64 array of ``shape`` (``None`` = any length), all finite."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array, got {type(value).__name__}") from exc
    if arr.ndim != len(shape) or any(
        want is not None and have != want for have, want in zip(arr.shape, shape, strict=True)
    ):
        pretty = tuple("n" if s is None else s for s in shape)
        raise ValueError(f"{name} must have shape {pretty}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def covariance(
    value: ArrayLike, name: str, *, rtol: float = 1e-6, atol: float = 1e-12
) -> FloatArray:
    """A symmetric positive-definite 2x2 (or stack of (..., 2, 2)) covariance."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (2, 2):
        raise ValueError(f"{name} must have shape (..., 2, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    sym = np.swapaxes(arr, -1, -2)
    scale = np.maximum(np.abs(arr).max(axis=(-1, -2), keepdims=True), atol)
    if not np.all(np.abs(arr - sym) <= rtol * scale + atol):
        raise ValueError(f"{name} must be symmetric")
    a, b, d = arr[..., 0, 0], arr[..., 0, 1], arr[..., 1, 1]
    if not np.all((a > 0) & (a * d - b * b > 0)):
        raise ValueError(f"{name} must be positive definite")
    return 0.5 * (arr + sym)


def probabilities(value: ArrayLike, name: str, *, atol: float = 1e-6) -> FloatArray:
    """A 1-D array of probabilities in [0, 1] that sums to 1."""
    arr = finite_array(value, name, (None,))
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty")
    if np.any(arr < 0) or np.any(arr > 1):
        raise ValueError(f"{name} must lie in [0, 1], got {arr.tolist()}")
    if abs(arr.sum() - 1.0) > atol:
        raise ValueError(f"{name} must sum to 1, got {arr.sum():.6g}")
    return arr


def positive(value: float, name: str, *, allow_zero: bool = False) -> float:
    """A finite positive (or non-negative) float.

    Plain Python arithmetic (no numpy scalar): the stages check their options on every call, and
    the env calls them every step."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
    return x


def keyword_options(fn: Callable[..., Any]) -> dict[str, Any]:
    """``fn``'s keyword-only parameters (a stage's options) with their defaults, in order."""
    params = inspect.signature(fn).parameters.values()
    return {p.name: p.default for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY}
