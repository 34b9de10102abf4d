"""Printing, saving and reporting the benchmarks' figures (shared by ``benchmark.py`` and
``bench_*.py``): a table on stdout, flat JSON, and the Markdown of ``docs/benchmarks.md`` and of
the README's benchmark table."""

from __future__ import annotations

import json
import os
import pathlib
import platform
import re
from collections.abc import Mapping

README_START = "<!-- benchmark:start -->"
README_END = "<!-- benchmark:end -->"


def print_figures(figures: Mapping[str, float]) -> None:
    """One line per figure: its name, then its value to four significant digits."""
    for name, value in figures.items():
        print(f"  {name:<48s} {value:12.4g}")


def write_figures(figures: Mapping[str, object], path: pathlib.Path | None) -> None:
    """Write ``figures`` to ``path`` as a flat, sorted JSON object (nothing if ``path`` is None)."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")


def cpu_model() -> str:
    """The CPU's model name (from ``/proc/cpuinfo`` where there is one)."""
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_description() -> str:
    """One line naming the machine: CPU model, cores, operating system, Python, OpenGL platform."""
    return (
        f"{cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()} "
        f"({platform.machine()}), Python {platform.python_version()}, "
        f"rendering through PYOPENGL_PLATFORM={os.environ.get('PYOPENGL_PLATFORM', 'default')}"
    )


def docstring_markdown(doc: str | None) -> str:
    """A module docstring, less its first line, as Markdown.

    Indented lines (command lines) become fenced code blocks; reST roles and ````x```` become
    ```x```.
    """
    out: list[str] = []
    code = False
    for line in (doc or "").splitlines()[1:]:
        indented = line.startswith("    ") and line.strip() != ""
        if indented != code:
            out.append("```bash" if indented else "```")
            code = indented
        if indented:
            out.append(line[4:])
        else:
            out.append(re.sub(r":\w+:`~?([^`]+)`", r"`\1`", line).replace("``", "`"))
    if code:
        out.append("```")
    return "\n".join(out).strip() + "\n"


def format_value(value: float) -> str:
    """A figure to four significant digits (integers as integers)."""
    if float(value).is_integer() and abs(value) < 1e6:
        return str(int(value))
    return f"{value:.4g}"


def figures_table(figures: Mapping[str, float]) -> str:
    """A two-column Markdown table of named figures."""
    rows = [f"| `{name}` | {format_value(value)} |" for name, value in figures.items()]
    return "\n".join(["| figure | value |", "|---|---|", *rows]) + "\n"


def summary_table(rows: list[tuple[str, str, str]], figures: Mapping[str, float]) -> str:
    """The short table: ``(label, figure name, unit)`` rows whose figure was measured."""
    lines = ["| figure | value |", "|---|---|"]
    for label, name, unit in rows:
        if name in figures:
            lines.append(f"| {label} | {format_value(figures[name])}{unit} |")
    return "\n".join(lines) + "\n"


def paste_into(path: pathlib.Path, block: str) -> None:
    """Replace what lies between :data:`README_START` and :data:`README_END` in ``path``."""
    text = path.read_text()
    start, end = text.find(README_START), text.find(README_END)
    if start < 0 or end < start:
        raise ValueError(f"{path}: no {README_START} ... {README_END} block to fill")
    head = text[: start + len(README_START)]
    path.write_text(f"{head}\n{block.rstrip()}\n{text[end:]}")
