"""``aion convert --observed`` of UNIX times names no time zone: the note no longer says they
were read in UTC, while clock times still are."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run
from tests.shared_data import real


def test_unix_observed_spans_are_not_said_to_be_read_in_utc(tmp_path: Path) -> None:
    """Before: README's ``--observed 1351036800..1351040400`` got "--observed was read in UTC
    (give --tz)", though a UNIX time is the same instant in every zone."""
    csv = real("atc", "atc-1024-9_test.csv")
    spans = {"unix": "1351036800..1351040400", "clock": "2012-10-24 00:00..2012-10-24 01:00"}
    said = _notes(tmp_path, csv, "atc", "--observed", spans)
    for text in said.values():  # both still name the dataset's zone and the build for it
        assert "atc: the dataset was recorded in Osaka (Asia/Tokyo):" in text
    assert "--observed was read in UTC" not in said["unix"]
    assert "--observed was read in UTC (give --tz)" in said["clock"]


def test_a_start_that_names_an_instant_is_not_said_to_be_read_in_utc(tmp_path: Path) -> None:
    """``--start 1767614400`` (UNIX), ``--start now`` or a time with its offset or zone got
    "--start was read in UTC (give --tz)", and the advice to convert again with --tz, which
    would not move them; a wall-clock ``--start`` still gets it, as does an ``--observed``
    span whose end is a clock time."""
    csv = real("thor", "thor1-exp-1-run-2.csv")
    starts = {
        "unix": "1767614400",
        "now": "now",
        "offset": "2026-01-05T13:00+01:00",
        "zone": "2026-01-05 13:00 Europe/Stockholm",
        "clock": "2026-01-05 12:00",
    }
    said = _notes(tmp_path, csv, "thor", "--start", starts)
    for kind, text in said.items():
        assert "thor: the dataset was recorded in Örebro (Europe/Stockholm):" in text, kind
        assert ("--start was read in UTC (give --tz)" in text) == (kind == "clock"), text
    csv = real("atc", "atc-1024-9_test.csv")
    out = run("convert", csv, "--layout", "atc", "-o", tmp_path / "end.mcap",
              "--observed", "1351036800..2012-10-24 01:00")  # fmt: skip
    assert out.exit_code == 0, out.stderr
    assert "--observed was read in UTC (give --tz)" in " ".join(out.output.split())


def _notes(
    tmp_path: Path, csv: Path, layout: str, flag: str, values: dict[str, str]
) -> dict[str, str]:
    """What ``aion convert`` says (whitespace joined) for each of ``values`` given to ``flag``."""
    said = {}
    for kind, value in values.items():
        out = run("convert", csv, "--layout", layout, "-o", tmp_path / f"{kind}.mcap", flag, value)
        assert out.exit_code == 0, out.stderr
        said[kind] = " ".join(out.output.split())
    return said
