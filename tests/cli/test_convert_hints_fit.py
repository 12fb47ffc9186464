"""``aion convert``'s zone notes fit the case: a THÖR file converted without ``--start`` lies
in 1970, where no zone gives its hours a meaning, so the note asks for ``--start`` (naming
Örebro's zone for ``--tz``), not for ``aion build --tz Europe/Stockholm``; a ``--start`` or
``--date`` read in UTC is mended by converting again with ``--tz``, not by the build's
``--tz`` alone. And README's Lincoln example (the shared 2017-06-09.txt's rows without its
header, which declares four days) observes what ``aion evaluate lincoln`` takes for that day."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tests.cli.conftest import run, run_json
from tests.shared_data import SHARED_DATA, needs

THOR = "0.0,1,0.0,0.0,1.0,0.0\n1.0,1,1.0,0.0,1.0,0.0\n"
README = Path(__file__).resolve().parents[2] / "README.md"
LINCOLN = SHARED_DATA / "lincoln" / "2017-06-09.txt"


def _said(text: str) -> str:
    return " ".join(text.split())


def test_thor_without_start_asks_for_start_not_for_a_build_zone(tmp_path: Path) -> None:
    src = tmp_path / "thor.csv"
    src.write_text(THOR)
    result = run("convert", src, "--layout", "thor", "-o", tmp_path / "t.mcap")
    assert result.exit_code == 0, result.stderr
    said = _said(result.stderr)
    assert "written from 1970-01-01 00:00 UTC; give --start for when it was recorded" in said
    assert '--start "YYYY-MM-DD HH:MM" --tz Europe/Stockholm' in said
    assert "aion build" not in said


def test_eth_without_start_gets_the_start_note_alone(tmp_path: Path) -> None:
    src = tmp_path / "eth.txt"
    src.write_text("0 1 0.0 0.0\n10 1 0.4 0.0\n")
    result = run("convert", src, "--layout", "eth", "-o", tmp_path / "e.mcap")
    assert result.exit_code == 0, result.stderr
    said = _said(result.stderr)
    assert "eth: the file's times count from 0" in said
    assert "--tz" not in said  # recorded in several places: no zone to name


def test_a_start_read_in_utc_is_mended_by_converting_with_tz(tmp_path: Path) -> None:
    src = tmp_path / "thor.csv"
    src.write_text(THOR)
    log = tmp_path / "t.mcap"
    result = run("convert", src, "--layout", "thor", "--start", "2019-05-10 10:00", "-o", log)
    assert result.exit_code == 0, result.stderr
    said = _said(result.stderr)
    assert ("thor: the dataset was recorded in Örebro (Europe/Stockholm): --start was read in "
            "UTC (give --tz): if it is Örebro's clock, convert again with --tz "
            "Europe/Stockholm") in said
    assert f"if it is UTC, aion build {log} --tz Europe/Stockholm" in said


def test_atc_of_unix_times_still_gets_the_build_zone(tmp_path: Path) -> None:
    src = tmp_path / "atc.csv"
    src.write_text("1351038020.0,1,0.0,0.0,1.0,0.0\n1351038021.0,1,1.0,0.0,1.0,0.0\n")
    log = tmp_path / "a.mcap"
    result = run("convert", src, "--layout", "atc", "-o", log)
    assert result.exit_code == 0, result.stderr
    said = _said(result.stderr)
    assert "recorded in Osaka (Asia/Tokyo): aion build takes" in said
    assert f"aion build {log} --tz Asia/Tokyo" in said
    assert "convert again" not in said  # no time was typed


@needs(LINCOLN, "the Lincoln corridor data")
def test_readmes_lincoln_example_observes_the_evaluated_session(tmp_path: Path) -> None:
    """The README converts the rows of 2017-06-09.txt without its header line (``tail -n
    +4``): the map observes the 55 windows of 10 min of the day's one session (detections
    09:13:47-18:13:45 UTC, no gap over an hour), which ``aion evaluate lincoln`` takes as the
    test day's observed spans; the whole file observes the header's 96 hours."""
    from aion_cli.evaluation.lincoln import SESSION_GAP_NS, load_days, observed_windows

    text = README.read_text()
    assert "tail -n +4 2017-06-09.txt > 2017-06-09-rows.txt" in text
    assert re.search(r"aion convert 2017-06-09-rows\.txt --layout lincoln --tz Europe/London", text)
    rows = tmp_path / "2017-06-09-rows.txt"
    rows.write_text("".join(LINCOLN.read_text().splitlines(keepends=True)[3:]))  # tail -n +4
    log = tmp_path / "corridor.mcap"
    converted = run("convert", rows, "--layout", "lincoln", "--tz", "Europe/London", "-o", log)
    assert converted.exit_code == 0, converted.stderr
    assert "declares recording" not in converted.stderr
    run_json("build", log, "--derive-graph", "-o", tmp_path / "c.aion", "--format", "json", "-q")
    info = run_json("info", tmp_path / "c.aion", "--format", "json")
    day = load_days(LINCOLN.parent)["2017-06-09"]
    assert len(day.spans) == 1
    assert SESSION_GAP_NS == 3600 * 10**9
    windows = observed_windows(day.spans, 600 * 10**9)
    assert len(windows) == 55 == info["counts"]["recording_windows"]
    first, last = int(np.min(day.batch.t_ns)), int(np.max(day.batch.t_ns))
    assert (first, last) == (1496999627 * 10**9, 1497032025 * 10**9)
    assert info["time_span"] == {"start_ns": first, "end_ns": last}
    assert info["timezone"] == "Europe/London"
