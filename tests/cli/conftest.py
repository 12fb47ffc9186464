"""Fixtures of the CLI tests: the office log (tests/cli/logdata.py) and maps built from it.

The expensive artefacts (logs, maps) are built once per session in a temporary folder; tests
that modify files copy them first.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result

from aion_cli.cli.main import cli
from tests.cli.logdata import Expected, write_office_log

SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"

AION = Path(sys.executable).with_name("aion")


@dataclass(frozen=True)
class Office:
    """The office log and the map built from it."""

    log: Path
    expected: Expected
    map: Path
    build: dict[str, Any]


def run(*args: str | Path) -> Result:
    """Invoke the CLI in-process (click's runner; stdout and stderr kept apart)."""
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def run_json(*args: str | Path) -> Any:
    """Invoke the CLI and parse its stdout as JSON (asserting success)."""
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def build_office_days(folder: Path, days: int = 3) -> Path:
    """A map of ``days`` daily copies of the office log (``folder/day{k}.mcap``, each a day
    after the one before), built into ``folder/three.aion``: the middle days are scored
    against the ones before them, the last stays pending."""
    logs = []
    for day in range(days):
        logs.append(folder / f"day{day}.mcap")
        write_office_log(logs[-1], shift_s=86400 * day)
    out = folder / "three.aion"
    run_json("build", *logs, "-o", out, "--format", "json")
    return out


def kept_figures(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The list every figure :func:`~aion_cli.pictures.render.save_png` saves from now on is
    appended to (saved as before), for tests that read what a picture draws."""
    import aion_cli.pictures.render as render

    figures: list[Any] = []
    saved = render.save_png

    def keep(fig: Any, out: Path, option: str = "-o") -> Path:
        figures.append(fig)
        return saved(fig, out, option)

    monkeypatch.setattr(render, "save_png", keep)
    return figures


def figure_texts(monkeypatch: pytest.MonkeyPatch, *args: str | Path) -> list[str]:
    """Run the command (it must succeed) and return the text of every artist of each figure it
    saves as a PNG (titles, legend, caption), whitespace collapsed, in the order saved: what a
    reader of the pictures sees written on them."""
    from matplotlib.text import Text

    figures = kept_figures(monkeypatch)
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    return [" ".join(" ".join(t.get_text() for t in f.findobj(Text)).split()) for f in figures]


def run_process(*args: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the installed ``aion`` console script in a subprocess."""
    env = {**os.environ, "TZ": "UTC", "COLUMNS": "200"}
    return subprocess.run(
        [str(AION), *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=120,
        check=False,
    )


def map_cells(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell centres (x, y), detections per direction bin, undirected detections of a map."""
    from aion_cli.mapquery import load_map

    entries = load_map(path).state.entries
    rows = entries.cell_rows()
    return entries.xyz[rows, :2], entries.counts[rows], entries.nodir[rows]


def assert_one_line_error(stderr: str, *fragments: str) -> None:
    """``error: ...`` on the first line, at most a ``hint:`` after it, no traceback."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1, stderr
    assert "Traceback" not in stderr, stderr
    assert all(line.startswith(("error: ", "hint: ")) for line in lines), stderr
    for fragment in fragments:
        assert fragment in errors[0], (fragment, stderr)


def warning_lines(stderr: str) -> list[str]:
    """The ``warning: ...`` lines of ``stderr`` (a bare "warning" may be in a path the output
    names, such as pytest's folder for a test with "warning" in its name)."""
    return [line for line in stderr.splitlines() if line.startswith("warning:")]


@pytest.fixture(scope="session")
def office(tmp_path_factory: pytest.TempPathFactory) -> Office:
    folder = tmp_path_factory.mktemp("office")
    log = folder / "office.mcap"
    expected = write_office_log(log)
    out = folder / "office.aion"
    build = run_json("build", log, "-o", out, "--format", "json")
    return Office(log, expected, out, build)


@pytest.fixture(autouse=True)
def _utc(monkeypatch: pytest.MonkeyPatch) -> None:
    """Times without a zone are read in UTC unless a test says otherwise."""
    monkeypatch.setenv("TZ", "UTC")


@pytest.fixture(scope="session")
def sample_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A map of the bundled sample (five workdays of the office, named rooms, a mesh, varied
    flows and entropies), built once."""
    out = tmp_path_factory.mktemp("sample") / "office.aion"
    result = run("build", SAMPLE, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    return out
