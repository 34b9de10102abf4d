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


def _import_targets(path: pathlib.Path) -> list[tuple[str, list[str]]]:
    """``(module, names)`` of each absolute import in ``path`` (``import a.b``: no names)."""
    targets: list[tuple[str, list[str]]] = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets += [(alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            targets.append((node.module, [alias.name for alias in node.names]))
    return targets


def _imported_roots(path: pathlib.Path) -> set[str]:
    return {module.split(".")[0] for module, _ in _import_targets(path)}


def _private_imports(path: pathlib.Path, own: str) -> list[str]:
    """The imports in ``path`` of a private module or name of a project package but ``own``.

    Private: a dotted component or an imported name that starts with ``_`` (``modeling._compiled``,
    ``from modeling.model.build import _helper``); dunder names such as ``__version__`` are not.
    """

    def private(name: str) -> bool:
        return name.startswith("_") and not name.endswith("__")

    found: list[str] = []
    for module, names in _import_targets(path):
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


SUBPACKAGE_FORBIDDEN = {
    "modeling/stereo": ("modeling.model", "modeling.memory"),
    "modeling/model": ("modeling.stereo", "modeling.memory"),
    "modeling/memory": ("modeling.stereo",),
    "stereo_nav_env/sim": (
        "stereo_nav_env.perception",
        "stereo_nav_env.observation",
        "stereo_nav_env.rendering",
        "stereo_nav_env.env",
    ),
    "stereo_nav_env/rendering": ("stereo_nav_env.perception", "stereo_nav_env.observation"),
    "stereo_nav_env/observation": ("stereo_nav_env.perception", "stereo_nav_env.sim"),
    "stereo_nav_env/perception": ("stereo_nav_env.observation", "stereo_nav_env.env"),
    "agents/planning": ("agents.learning", "agents.evaluation"),
}
"""What each subpackage may not import (docs/architecture.md): stereo/ and model/ meet only at
the floor observation, the simulator knows nothing of what perceives or draws it, and so on."""


def _imported_modules(path: pathlib.Path) -> set[str]:
    """The modules ``path`` imports, and ``module.name`` of each name it imports from one (a
    ``from modeling import model`` imports the module ``modeling.model``)."""
    return {
        dotted
        for module, names in _import_targets(path)
        for dotted in (module, *(f"{module}.{name}" for name in names))
    }


@pytest.mark.parametrize(("folder", "forbidden"), sorted(SUBPACKAGE_FORBIDDEN.items()))
def test_subpackages_import_only_what_their_layer_allows(
    folder: str, forbidden: tuple[str, ...]
) -> None:
    bad = {
        str(path.relative_to(ROOT)): sorted(
            m
            for m in _imported_modules(path)
            if any(m == f or m.startswith(f + ".") for f in forbidden)
        )
        for path in (ROOT / folder).rglob("*.py")
    }
    assert {k: v for k, v in bad.items() if v} == {}


def _module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_private_modules_are_imported_only_inside_their_own_subpackage() -> None:
    """``X._kernels`` (or any ``X._private`` module) is imported only by modules of ``X``."""
    bad = []
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            importer = _module_name(path)
            for module, _ in _import_targets(path):
                parts = module.split(".")
                if parts[0] not in PACKAGES:
                    continue
                private = [
                    i for i, p in enumerate(parts) if p.startswith("_") and not p.endswith("__")
                ]
                if not private:
                    continue
                owner = ".".join(parts[: private[0]])
                if importer != owner and not importer.startswith(owner + "."):
                    bad.append(f"{importer} imports {module}")
    assert bad == []


def _package_dirs() -> list[pathlib.Path]:
    return sorted(
        d
        for package in PACKAGES
        for d in [ROOT / package, *(ROOT / package).rglob("*")]
        if d.is_dir() and (d / "__init__.py").exists()
    )


@pytest.mark.parametrize("folder", [str(d.relative_to(ROOT)) for d in _package_dirs()])
def test_each_package_folder_holds_at_most_12_modules_and_says_what_it_owns(folder: str) -> None:
    directory = ROOT / folder
    modules = sorted(p.stem for p in directory.glob("*.py") if p.name != "__init__.py")
    assert len(modules) <= 12, modules
    doc = ast.get_docstring(ast.parse((directory / "__init__.py").read_text())) or ""
    assert doc, f"{folder}/__init__.py has no docstring"
    if directory.name.startswith("_"):
        return  # a private subpackage: its docstring says whose loops it holds
    public = [m for m in modules if not m.startswith("_")]
    subpackages = [d.name for d in directory.iterdir() if (d / "__init__.py").exists()]
    unnamed = [m for m in public + subpackages if not m.startswith("_") and m not in doc]
    assert unnamed == [], f"{folder}/__init__.py does not name {unnamed}"


def test_no_function_takes_more_than_8_positional_arguments() -> None:
    bad = []
    for folder in (*PACKAGES, "scripts"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    args = [
                        a.arg
                        for a in (*node.args.posonlyargs, *node.args.args)
                        if a.arg not in ("self", "cls")
                    ]
                    if len(args) > 8:
                        bad.append(f"{path.relative_to(ROOT)}:{node.name} ({len(args)})")
    assert bad == []
