"""The layering of docs/DESIGN.md, checked on the source: the engine is numpy/scipy only,
only the CLI knows click and rich, and nothing imports a top-level ``formats`` (the package is
installed as ``aion_cli.formats`` only). Imports are read with ``ast`` from every module, the
ones inside functions included."""

from __future__ import annotations

import ast
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "aion_cli"
STDLIB = set(sys.stdlib_module_names)


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def _modules(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_engine_uses_numpy_scipy_and_itself_only() -> None:
    allowed_roots = {"numpy", "scipy", "aion_cli"}
    bad = []
    for path in _modules(PACKAGE / "engine"):
        for name in _imports(path):
            root = name.split(".")[0]
            if root in STDLIB or root == "__future__":
                continue
            inside = name.startswith(("aion_cli.engine", "aion_cli.errors"))
            if root not in allowed_roots or (root == "aion_cli" and not inside):
                bad.append(f"{path.relative_to(REPO)} imports {name}")
    assert bad == []


def test_only_the_cli_knows_click_and_rich() -> None:
    bad = []
    for folder in (PACKAGE, REPO / "formats"):
        for path in _modules(folder):
            rel = path.relative_to(REPO)
            if rel.parts[:2] == ("aion_cli", "cli") or rel.parts[:2] == ("aion_cli", "formats"):
                continue
            for name in _imports(path):
                if name.split(".")[0] in ("click", "rich"):
                    bad.append(f"{rel} imports {name}")
    assert bad == []


def test_the_library_does_not_import_the_command_line() -> None:
    """Only ``aion_cli.cli`` (and ``python -m aion_cli``) may import ``aion_cli.cli``: the
    library layer and ``formats`` work without click and rich."""
    bad = []
    for folder in (PACKAGE, REPO / "formats"):
        for path in _modules(folder):
            rel = path.relative_to(REPO)
            if rel.parts[:2] in {("aion_cli", "cli"), ("aion_cli", "formats")}:
                continue
            if rel == Path("aion_cli/__main__.py"):
                continue
            bad.extend(
                f"{rel} imports {name}"
                for name in _imports(path)
                if name == "aion_cli.cli" or name.startswith("aion_cli.cli.")
            )
    assert bad == []


def test_nothing_imports_a_top_level_formats_package() -> None:
    bad = []
    for folder in (PACKAGE, REPO / "formats", REPO / "tests", REPO / "benchmarks"):
        for path in _modules(folder):
            if path.is_relative_to(PACKAGE / "formats"):
                continue  # the same files as formats/
            bad.extend(
                f"{path.relative_to(REPO)} imports {name}"
                for name in _imports(path)
                if name == "formats" or name.startswith("formats.")
            )
    assert bad == []


def test_the_wheel_holds_no_top_level_package_but_aion_cli() -> None:
    """The packages setuptools finds with pyproject's own rules (what ``pip install .``
    installs): ``aion_cli`` and its subpackages, ``aion_cli.formats`` among them, and no
    top-level ``formats``."""
    from setuptools import find_packages

    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    find = config["tool"]["setuptools"]["packages"]["find"]
    packages = find_packages(where=str(REPO), include=find["include"])
    assert packages
    assert {p.split(".")[0] for p in packages} == {"aion_cli"}
    assert "aion_cli.formats" in packages
    assert "aion_cli.formats.detections" in packages


def test_loading_a_map_imports_no_slow_scipy_module() -> None:
    """Every query command loads a map first: scipy.special (with its array-API layer, about
    half a second) and scipy.spatial are imported only by the functions that use them."""
    import subprocess

    code = (
        "import sys; import aion_cli.mapquery, aion_cli.engine.state, aion_cli.engine.query, "
        "aion_cli.cli.main; "
        "print(sorted(m for m in ('scipy.special', 'scipy.spatial', 'scipy.stats') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "[]"
