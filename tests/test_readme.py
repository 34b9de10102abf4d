"""Every Python block of the README runs as written, each in a fresh interpreter, and prints no
warning that the project's own ids or code cause (a new user's first hour)."""

from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


def test_the_readme_has_its_python_examples() -> None:
    assert len(BLOCKS) >= 3  # the minimal example, the configuration, training


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs_as_written(index: int, tmp_path: pathlib.Path) -> None:
    env = os.environ | {"PYOPENGL_PLATFORM": "egl"}
    done = subprocess.run(
        [sys.executable, "-c", BLOCKS[index]],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "out of date" not in done.stderr, done.stderr[-3000:]
    assert not re.search(r"(stereo_nav_env|modeling|agents)/\S+\.py:\d+: \w*Warning", done.stderr)
