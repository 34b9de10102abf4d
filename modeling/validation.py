"""The project's validators: each returns the checked value or raises ``ValueError`` naming it.

Array validators (:func:`finite_array`, :func:`covariance`, :func:`probabilities`), scalar ones
(:func:`positive`, :func:`number`, :func:`integer`, :func:`boolean`), the two helpers that
turn keyword arguments into frozen option dataclasses (:func:`with_overrides` for one stage's
options, :func:`from_flat` for a tree of nested configurations) and :func:`reject_unknown`, the
error of an unknown option name (with a "did you mean" of the close known names). Every layer uses
these; none writes its own.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import json
import math
import typing
from collections.abc import Hashable, Iterable, Mapping
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from modeling.types import FloatArray

T = TypeVar("T")


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


def probabilities(
    value: ArrayLike, name: str, *, atol: float = 1e-6, at_most_one: bool = False
) -> FloatArray:
    """A 1-D array of probabilities in [0, 1] that sums to 1 (``at_most_one``: to at most 1,
    the rest being the mass of an outcome not listed)."""
    arr = finite_array(value, name, (None,))
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty")
    if np.any(arr < 0) or np.any(arr > 1):
        raise ValueError(f"{name} must lie in [0, 1], got {arr.tolist()}")
    total = float(arr.sum())
    if at_most_one:
        if total > 1.0 + atol:
            raise ValueError(f"{name} must sum to at most 1, got {total:.6g}")
    elif abs(total - 1.0) > atol:
        raise ValueError(f"{name} must sum to 1, got {total:.6g}")
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


def number(
    value: Any,
    name: str,
    *,
    low: float | None = None,
    high: float | None = None,
    strict: bool = True,
) -> float:
    """A finite real number (not a bool), optionally bounded: ``low < value < high`` when
    ``strict``, else ``low <= value <= high``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    relation = ">" if strict else ">="
    if low is not None and (value <= low if strict else value < low):
        raise ValueError(f"{name} must be {relation} {low}, got {value!r}")
    relation = "<" if strict else "<="
    if high is not None and (value >= high if strict else value > high):
        raise ValueError(f"{name} must be {relation} {high}, got {value!r}")
    return float(value)


def integer(value: Any, name: str, *, low: int | None = None) -> int:
    """An ``int`` (not a bool), at least ``low`` when given."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if low is not None and value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def instance(value: Any, cls: type[Any], name: str) -> None:
    """Nothing if ``value`` is a ``cls``; else a ``ValueError`` naming ``name`` and both types."""
    if not isinstance(value, cls):
        raise ValueError(f"{name} must be a {cls.__name__}, got {type(value).__name__}")


def boolean(value: Any, name: str) -> bool:
    """``True`` or ``False`` (nothing else)."""
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return value


def reject_unknown(given: Iterable[Any], known: Iterable[str], what: str = "") -> None:
    """Nothing if every name in ``given`` is in ``known``; else a ``ValueError`` naming them.

    The message names the unknown names, the closest known name of each that has one
    (:func:`difflib.get_close_matches`, default cutoff), and all the known names, e.g.
    ``unknown StereoNav option(s) ['robot_widht_m'] (did you mean 'robot_width_m'?); known:
    [...]``. ``what`` qualifies "option(s)" (a class or function name; empty: none).
    """
    known = set(known)
    unknown = sorted(set(given) - known, key=str)
    if not unknown:
        return
    names = sorted(known)
    close = {
        key: match[0]
        for key in unknown
        if isinstance(key, str) and (match := difflib.get_close_matches(key, names, n=1))
    }
    if len(unknown) == 1 and close:
        hint = f" (did you mean {next(iter(close.values()))!r}?)"
    elif close:
        hint = " (did you mean " + ", ".join(f"{m!r} for {k!r}" for k, m in close.items()) + "?)"
    else:
        hint = ""
    label = f"{what} option(s)" if what else "option(s)"
    raise ValueError(f"unknown {label} {unknown}{hint}; known: {names}")


def settings_of(words: Iterable[str]) -> dict[str, Any]:
    """``{name: value}`` of ``NAME=VALUE`` words (command-line settings of a config class),
    each value read as JSON (a number, ``true``) or else kept as a string.

    Raises:
        ValueError: A word is not ``NAME=VALUE`` (the word is named).
    """
    out: dict[str, Any] = {}
    for word in words:
        name, sep, text = word.partition("=")
        if not sep or not name:
            raise ValueError(f"a setting must read NAME=VALUE, got {word!r}")
        try:
            out[name] = json.loads(text)
        except json.JSONDecodeError:
            out[name] = text
    return out


def field_names(cls: type[Any]) -> tuple[str, ...]:
    """The field names of the dataclass ``cls``, in order."""
    return tuple(f.name for f in dataclasses.fields(cls))


def with_overrides(options: T | None, cls: type[T], overrides: Mapping[str, Any]) -> T:
    """``options`` (``cls()`` when ``None``) with the fields named in ``overrides`` replaced.

    The stages call this on every call, with the same few arguments: a result is kept and given
    again for equal ``(options, overrides)``, keyed with each override's type (``1`` and ``1.0``
    are not one key, so a field's own check still sees what was passed). The options are frozen,
    so sharing them is safe; unhashable arguments are made afresh.

    Raises:
        ValueError: ``options`` is not a ``cls``, or a key of ``overrides`` is not a field of
            ``cls`` (the unknown keys and the known ones are named).
    """
    try:
        key = tuple(sorted((k, type(v), v) for k, v in overrides.items()))
        return typing.cast(T, _kept(options, typing.cast(Hashable, cls), key))
    except TypeError:  # unhashable options or values (an array, a list)
        return _with_overrides(options, cls, overrides)


@functools.lru_cache(maxsize=256)
def _kept(options: Any, cls: type[Any], key: tuple[tuple[str, type, Any], ...]) -> Any:
    """:func:`_with_overrides` of hashable arguments, kept (``key``: the sorted overrides)."""
    return _with_overrides(options, cls, {name: value for name, _, value in key})


def _with_overrides(options: T | None, cls: type[T], overrides: Mapping[str, Any]) -> T:
    """:func:`with_overrides`, made afresh."""
    base = cls() if options is None else options
    if not isinstance(base, cls):
        raise ValueError(f"options must be a {cls.__name__}, got {type(options).__name__}")
    if not overrides:
        return base
    reject_unknown(overrides, field_names(cls), cls.__name__)
    return dataclasses.replace(base, **overrides)  # type: ignore[type-var]


def _nested(cls: type[Any]) -> dict[str, type[Any]]:
    """The fields of dataclass ``cls`` whose type is itself a dataclass, by name."""
    hints = typing.get_type_hints(cls)
    return {
        f.name: hints[f.name]
        for f in dataclasses.fields(cls)
        if isinstance(hints.get(f.name), type) and dataclasses.is_dataclass(hints[f.name])
    }


def _leaves(cls: type[Any]) -> list[str]:
    """The names of every non-dataclass field in the tree of dataclass ``cls``."""
    nested = _nested(cls)
    out: list[str] = []
    for f in dataclasses.fields(cls):
        out.extend(_leaves(nested[f.name]) if f.name in nested else [f.name])
    return out


def from_flat(cls: type[T], kwargs: Mapping[str, Any], *, what: str | None = None) -> T:
    """A configuration ``cls`` (a dataclass whose fields may be dataclasses) from flat keywords.

    Each key is either the name of a leaf field anywhere in the tree (leaf names are unique across
    it) or the name of a nested-dataclass field, whose value is then an instance or a dict of its
    fields (flat keys override it). Values are validated by the dataclasses themselves.

    Raises:
        ValueError: an unknown key (named, with the closest known one and all the known ones,
            :func:`reject_unknown`), or a nested value that is neither an instance nor a dict.
    """
    label = what or cls.__name__
    nested = _nested(cls)
    owner = {leaf: key for key, sub in nested.items() for leaf in _leaves(sub)}
    own = set(field_names(cls)) - set(nested)
    reject_unknown(kwargs, own | set(nested) | set(owner), label)
    top: dict[str, Any] = {}
    parts: dict[str, dict[str, Any]] = {key: {} for key in nested}
    whole: dict[str, Any] = {}
    for key, value in kwargs.items():
        if key in nested:
            whole[key] = value
        elif key in own:
            top[key] = value
        else:
            parts[owner[key]][key] = value
    for key, sub in nested.items():
        if key not in whole and not parts[key]:
            continue
        value = whole.get(key)
        if value is None:
            base: dict[str, Any] = {}
        elif isinstance(value, sub):
            base = {f.name: getattr(value, f.name) for f in dataclasses.fields(sub)}
        elif isinstance(value, Mapping):
            base = dict(value)
        else:
            got = type(value).__name__
            raise ValueError(f"{key} must be a {sub.__name__} or a dict, got {got}")
        top[key] = from_flat(sub, {**base, **parts[key]}, what=f"{label}.{key}")
    return cls(**top)
