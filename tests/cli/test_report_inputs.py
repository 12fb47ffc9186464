"""``aion report`` says where a map came from as ``aion info`` says it: its logs named by path
where two share a file name."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from tests.cli.conftest import run
from tests.cli.logdata import write_office_log
from tests.cli.test_report import _parse

DAY_S = 86_400


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two robots' logs of two days, both saved as run.mcap (in robot1/ and robot2/)."""
    folder = tmp_path_factory.mktemp("runs")
    logs = []
    for k, robot in enumerate(("robot1", "robot2")):
        (folder / robot).mkdir()
        log = folder / robot / "run.mcap"
        write_office_log(log, shift_s=k * DAY_S)
        logs.append(log)
    return logs[0], logs[1]


def _sha12(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:12]


def test_logs_that_share_a_file_name_are_named_by_path(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """Both rows read 'run.mcap' (which was which?); aion info names them by path."""
    out = tmp_path / "both.aion"
    assert run("build", *two_runs, "-o", out, "-q").exit_code == 0
    assert run("report", out, "-o", tmp_path / "report", "-q").exit_code == 0
    rows = _parse(tmp_path / "report" / "index.html").tables["inputs"]
    assert [(name, sha) for name, _size, sha in rows] == [
        (str(log.resolve()), _sha12(log)) for log in two_runs
    ]


def test_a_merged_query_only_map_says_how_it_was_made(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """The page of a compacted merged map said neither: no maps merged, nothing of its being
    query-only (the copy a robot gets), where aion info shows both."""
    parts = []
    for k, log in enumerate(two_runs):
        part = tmp_path / f"robot{k + 1}.aion"
        assert run("build", log, "-o", part, "-q").exit_code == 0
        parts.append(part)
    fleet, small = tmp_path / "fleet.aion", tmp_path / "fleet-robot.aion"
    assert run("merge", *parts, "-o", fleet, "-q").exit_code == 0
    assert run("compact", fleet, "-o", small, "-q").exit_code == 0
    assert run("report", small, "-o", tmp_path / "report", "-q").exit_code == 0
    page = _parse(tmp_path / "report" / "index.html")
    facts = dict(page.tables["facts"])
    assert facts["merged from"].startswith("2 maps by aion merge (")
    assert facts["query only"].startswith("made from fleet.aion by aion compact")
    assert [(name, sha) for name, _size, sha in page.tables["merged"]] == [
        (part.name, _sha12(part)) for part in parts
    ]
    info = run("info", small).stdout
    assert facts["merged from"] in info
    assert facts["query only"] in info
