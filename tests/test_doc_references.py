"""The documents name what exists: every repository path and dotted module the docs give is
there, every ``name.py`` of docs/CONTRACTS.md and docs/DESIGN.md is a module of the package,
and every test docs/ROBUSTNESS.md names (a test function, a parametrised case) is defined."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOCS = [
    "README.md",
    "formats/MAPFILE.md",
    "docs/API.md",
    "docs/CONTRACTS.md",
    "docs/DESIGN.md",
    "docs/ROBUSTNESS.md",
    "docs/SCALING.md",
    "docs/FORECAST.md",
]
PACKAGES = ("aion_cli", "formats")


def _text(doc: str) -> str:
    return (REPO / doc).read_text()


def test_every_path_the_documents_name_exists() -> None:
    missing = []
    for doc in DOCS:
        pattern = r"[`(\s]((?:aion_cli|formats|tests|benchmarks|samples|docs)/[\w./-]+)"
        for found in re.findall(pattern, _text(doc)):
            path = found.rstrip(".,:)`")
            if not (REPO / path).exists():
                missing.append(f"{doc}: {path}")
    assert not missing, missing


def test_every_dotted_module_the_documents_name_exists() -> None:
    missing = []
    for doc in DOCS:
        for dotted in set(re.findall(r"\b((?:aion_cli|formats)(?:\.\w+)+)", _text(doc))):
            parts = dotted.split(".")
            if parts[0] == "aion_cli" and len(parts) > 1 and parts[1] == "formats":
                parts = parts[1:]  # aion_cli.formats is the formats folder
            if len(parts) == 1:
                continue  # the formats folder itself
            init = (REPO / parts[0] / "__init__.py").read_text()
            found = any(
                (REPO / Path(*parts[:i])).with_suffix(".py").exists()
                or (REPO / Path(*parts[:i])).is_dir()
                for i in range(len(parts), 1, -1)
            ) or bool(re.search(rf"\b{parts[1]}\b", init))  # a name the package exports
            if not found:
                missing.append(f"{doc}: {dotted}")
    assert not missing, missing


def test_every_module_file_of_the_contracts_and_the_design_exists() -> None:
    modules = {p.name for package in PACKAGES for p in (REPO / package).rglob("*.py")}
    missing = [
        f"{doc}: {name}"
        for doc in ("docs/CONTRACTS.md", "docs/DESIGN.md")
        for name in re.findall(r"`(?:[\w/]+/)?(\w+\.py)`", _text(doc))
        if name not in modules
    ]
    assert not missing, missing


def test_every_test_robustness_names_is_defined() -> None:
    text = _text("docs/ROBUSTNESS.md")
    sources = "\n".join(p.read_text() for p in (REPO / "tests").rglob("*.py"))
    names = set(re.findall(r"\b(test_\w+)\b", text))
    files = {p.stem for p in (REPO / "tests").rglob("test_*.py")}
    undefined = sorted(
        n for n in names if n not in files and not re.search(rf"def {n}\b", sources)
    )
    assert not undefined, f"docs/ROBUSTNESS.md names tests that do not exist: {undefined}"
    cases = set(re.findall(r"`(?:[\w/]+\.py::\w+|\.\.\.)\[([^\]`]+)\]`", text))
    assert len(cases) > 10
    unknown = sorted(c for c in cases if f'"{c}"' not in sources and f"'{c}'" not in sources)
    assert not unknown, f"docs/ROBUSTNESS.md names parametrised cases that do not exist: {unknown}"
