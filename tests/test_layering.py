"""The layering of ARCHITECTURE.md: imports go modeling <- stereo_nav_env <- agents <- scripts."""

from __future__ import annotations

import ast
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

FORBIDDEN = {
    "modeling": {
        "gymnasium",
        "pymunk",
        "pyrender",
        "trimesh",
        "torch",
        "stable_baselines3",
        "stereo_nav_env",
        "agents",
        "OpenGL",
    },
    "stereo_nav_env": {"torch", "stable_baselines3", "agents"},
    "agents": set(),
}
ONLY_IMPORTER = {"pymunk": "stereo_nav_env/world.py", "pyrender": "stereo_nav_env/render.py"}


def _imported_roots(path: pathlib.Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    roots: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_imports_only_lower_layers(package: str) -> None:
    bad = {
        str(path.relative_to(ROOT)): sorted(_imported_roots(path) & FORBIDDEN[package])
        for path in (ROOT / package).rglob("*.py")
    }
    assert {k: v for k, v in bad.items() if v} == {}


@pytest.mark.parametrize(("module", "owner"), sorted(ONLY_IMPORTER.items()))
def test_single_importer_of_heavy_dependencies(module: str, owner: str) -> None:
    importers = sorted(
        str(path.relative_to(ROOT))
        for package in ("modeling", "stereo_nav_env", "agents")
        for path in (ROOT / package).rglob("*.py")
        if module in _imported_roots(path)
    )
    assert importers == [owner]


def test_importing_modeling_pulls_in_no_simulator() -> None:
    code = (
        "import sys, modeling\n"
        "from modeling import *\n"
        "heavy = {'gymnasium', 'pymunk', 'pyrender', 'torch', 'trimesh'} & set(sys.modules)\n"
        "print(sorted(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
