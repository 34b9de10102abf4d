"""Situations as plain, comparable lists: every field, arrays as bytes (exact equality tests)."""

from __future__ import annotations

import numpy as np

from modeling.model.records import Situation


def _fields(record: object) -> tuple[object, ...]:
    values = (getattr(record, f) for f in record.__dataclass_fields__)  # type: ignore[attr-defined]
    return tuple(v.tobytes() if isinstance(v, np.ndarray) else v for v in values)


def situation_record(s: Situation) -> list[object]:
    """Every field of a situation's obstacles, critical regions and passages, arrays as bytes."""
    return [
        s.probability,
        s.choice,
        [_fields(o) for o in s.obstacles],
        [_fields(r) for r in s.critical_regions],
        [_fields(p) for p in s.passages],
    ]
