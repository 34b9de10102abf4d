"""Printing and saving the benchmarks' figures (shared by ``benchmark.py`` and ``bench_*.py``)."""

from __future__ import annotations

import json
import pathlib


def print_figures(figures: dict[str, float]) -> None:
    """One line per figure: its name, then its value to four significant digits."""
    for name, value in figures.items():
        print(f"  {name:<48s} {value:12.4g}")


def write_figures(figures: dict[str, object], path: pathlib.Path | None) -> None:
    """Write ``figures`` to ``path`` as a flat, sorted JSON object (nothing if ``path`` is None)."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
