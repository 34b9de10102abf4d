"""The layering of ARCHITECTURE.md: imports go modeling <- stereo_nav_env <- agents <- scripts,
``modeling`` stays pure, and no package or script imports another package's private modules or
names."""

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
ONLY_IMPORTER = {
    "pymunk": "stereo_nav_env/sim/world.py",
    "pyrender": "stereo_nav_env/rendering/renderer.py",
}
PACKAGES = ("modeling", "stereo_nav_env", "agents")
"""The project's packages; scripts/ holds programs that import them."""


def _imported_roots(path: pathlib.Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    roots: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


def _private_imports(path: pathlib.Path, own: str) -> list[str]:
    """The imports in ``path`` of a private module or name of a project package but ``own``.

    Private: a dotted component or an imported name that starts with ``_`` (``modeling._compiled``,
    ``from modeling.model.build import _helper``); dunder names such as ``__version__`` are not.
    """

    def private(name: str) -> bool:
        return name.startswith("_") and not name.endswith("__")

    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[str] = []
    for node in ast.walk(tree):
        targets: list[tuple[str, list[str]]]
        if isinstance(node, ast.Import):
            targets = [(alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            targets = [(node.module, [alias.name for alias in node.names])]
        else:
            continue
        for module, names in targets:
            parts = module.split(".")
            if parts[0] not in PACKAGES or parts[0] == own:
                continue
            if any(private(p) for p in parts) or any(private(n) for n in names):
                found.append(f"{module}: {', '.join(names)}" if names else module)
    return found


@pytest.mark.parametrize("folder", [*PACKAGES, "scripts"])
def test_no_private_imports_across_packages(folder: str) -> None:
    bad = {
        str(path.relative_to(ROOT)): _private_imports(path, own=folder)
        for path in (ROOT / folder).rglob("*.py")
    }
    assert {k: v for k, v in bad.items() if v} == {}


def test_private_import_check_names_what_it_finds(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "module.py"
    path.write_text(
        "import modeling._compiled.jit\n"
        "from modeling.model.build import _helper, build_model\n"
        "from modeling import __version__, build_model\n"
        "from stereo_nav_env._x import y\n"
        "from ._local import z\n"
    )
    assert _private_imports(path, own="stereo_nav_env") == [
        "modeling._compiled.jit",
        "modeling.model.build: _helper, build_model",
    ]


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
