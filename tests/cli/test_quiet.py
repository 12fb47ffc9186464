"""``-q`` on the commands that read a map or write a log (predict, plan, export, convert)
and on ``aion evaluate``'s:
nothing on stderr but warnings and errors, the same data on stdout and in the files, and the
quiet lasting for that one command (the test runner, like the API, runs many in a process)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import Office, run, run_json
from tests.cli.logdata import T0
from tests.cli.test_convert import write_tracks

S = 1_000_000_000
AT = "2026-11-24 09:00"


@pytest.mark.parametrize(
    "args",
    [
        ("predict", "{map}", "--time", AT, "--format", "csv"),
        ("predict", "{map}", "--time", AT, "--format", "json"),
        ("predict", "{map}", "--from", "2026-11-23 08:00", "--to", "2026-11-23 10:00",
         "--step", "1h", "--format", "csv"),
        ("plan", "{map}", "--from", "{first}", "--to", "{last}", "--time", AT,
         "--format", "json"),
    ],
)
def test_quiet_keeps_stdout_and_empties_stderr(office: Office, args: tuple[str, ...]) -> None:
    entries = run_json("predict", office.map, "--historical", "--format", "json")["entries"]
    nodes = [str(e["id"]) for e in entries if e["kind"] == "node"]
    filled = [a.format(map=office.map, first=nodes[0], last=nodes[1]) for a in args]
    loud = run(*filled)
    quiet = run(*filled, "-q")
    assert loud.exit_code == quiet.exit_code == 0, loud.stderr
    assert loud.stderr.strip()  # the time line at least: -q has something to drop
    assert quiet.stderr == ""
    assert quiet.stdout == loud.stdout
    # the next command in the same process is loud again
    assert run(*filled).stderr == loud.stderr


def test_quiet_export_writes_the_same_files(office: Office, tmp_path: Path) -> None:
    loud = run("export", office.map, "--time", AT, "-o", tmp_path / "loud")
    quiet = run("export", office.map, "--time", AT, "-o", tmp_path / "quiet", "-q")
    assert loud.exit_code == quiet.exit_code == 0, loud.stderr
    assert "wrote " in loud.stderr
    assert quiet.stderr == ""
    names = sorted(p.name for p in (tmp_path / "loud").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "quiet").iterdir())
    for name in names:
        assert (tmp_path / "loud" / name).read_bytes() == (tmp_path / "quiet" / name).read_bytes()


def test_quiet_convert_keeps_its_warnings(tmp_path: Path) -> None:
    """The summary goes, the warning of a span far from every detection stays."""
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)  # 60 s from T0
    later = T0 // S + 5 * 3600
    result = run("convert", csv, "-o", tmp_path / "obs.mcap", "--observed",
                 f"{later}..{later + 1800}", "-q")
    assert result.exit_code == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines
    assert all(line.startswith(("warning:", " ")) for line in lines)
    assert "lies wholly after the detections" in result.stderr
    assert (tmp_path / "obs.mcap").stat().st_size > 0


def test_errors_stay_under_quiet(office: Office) -> None:
    result = run("predict", office.map, "--time", "yesterday-ish", "-q")
    assert result.exit_code == 2
    assert result.stderr.startswith("error: ")



def test_quiet_build_prints_no_summary_table(office: Office, tmp_path: Path) -> None:
    """``build -q`` shares the option: its summary table and notes stay out, the map is
    written."""
    loud = run("build", office.log, "-o", tmp_path / "loud.aion")
    quiet = run("build", office.log, "-o", tmp_path / "quiet.aion", "-q")
    assert loud.exit_code == quiet.exit_code == 0, loud.stderr
    assert "│" in loud.stderr
    assert quiet.stderr == ""
    assert (tmp_path / "quiet.aion").stat().st_size > 0


def test_quiet_evaluate_keeps_its_result_and_drops_its_summary() -> None:
    """``aion evaluate door``'s summary line (and every evaluate command's progress) goes to
    stderr; ``-q`` drops it and leaves the result on stdout as it was."""
    from tests.shared_data import SHARED_DATA, require

    require(SHARED_DATA / "fremen_door", "the FreMEn door data")
    loud = run("evaluate", "door", "--format", "json")
    quiet = run("evaluate", "door", "--format", "json", "-q")
    assert loud.exit_code == quiet.exit_code == 0, loud.stderr
    assert "FreMEn beats the static mean" in loud.stderr
    assert quiet.stderr == ""
    assert quiet.stdout == loud.stdout
    for command in ("atc", "door", "lincoln", "holdout", "office", "report"):
        assert "--quiet" in run("evaluate", command, "--help").stdout, command
