"""The package is typed (``py.typed``): the documents' Python examples, as a user's script,
pass ``mypy --strict``. Before, ``built.report.detections_used`` was an error (``Map.report``
was typed as any of the build, merge and compact reports or None, whatever made the map) and
so was ``p.distance_only.cost`` (``Plan | None``, though a plan always has one)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

# a user's helpers typed with the bare class: every kind of map is one
HELPERS = '''
import aion_cli as aion


def busiest(m: aion.Map) -> str:
    return str(m.predict(historical=True).records()[0]["id"])


def every_kind(paths: list[str]) -> list[str]:
    return [
        busiest(aion.Map.load(paths[0])),
        busiest(aion.build(paths, output="x.aion")),
        busiest(aion.merge(paths, "y.aion")),
        busiest(aion.compact(paths[0], "z.aion")),
    ]
'''


def _python_blocks(name: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (REPO / name).read_text(), flags=re.S)


def test_the_documented_examples_pass_mypy_strict(tmp_path: Path) -> None:
    api = pytest.importorskip("mypy.api")
    readme = next(b for b in _python_blocks("README.md") if "import aion_cli" in b)
    scripts = [*_python_blocks("docs/API.md"), readme, HELPERS]
    files = []
    for k, text in enumerate(scripts):
        files.append(tmp_path / f"script{k}.py")
        files[-1].write_text(text)
    # the package as a user's mypy sees an installed one: its own modules not reported
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\nmypy_path = {REPO}\n[mypy-aion_cli.*]\nfollow_imports = silent\n")
    out, err, status = api.run(
        ["--strict", "--config-file", str(config), "--cache-dir", str(tmp_path / "cache"),
         *map(str, files)]
    )
    assert status == 0, out + err
