"""``aion convert`` without ``--tz`` for a dataset recorded in a known place says its zone and
how to build a map whose hours are local. The ATC files' first time, 1351038020, is 00:20
UTC = 09:20 in Osaka (../shared/data/README.md: 09:00-21:00 local): a map built as the note
says observed 09:00-10:00, one built as before (no note, UTC) 00:00-01:00. (Before: nothing
said so unless --tz was given, and the README's own example built an ATC map in UTC hours.)"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

from aion_cli.engine.time_text import format_ns
from aion_cli.errors import path_word
from aion_cli.timeparse import resolve_zone, to_ns
from tests.cli.conftest import run, run_json

ATC = "1351038020.0,1,0.0,0.0,1.0,0.0\n1351038021.0,1,1.0,0.0,1.0,0.0\n"


def test_atc_without_tz_names_osaka_and_the_build_that_gives_local_hours(tmp_path: Path) -> None:
    src = tmp_path / "atc.csv"
    src.write_text(ATC)
    log = tmp_path / "atc.mcap"
    result = run("convert", src, "--layout", "atc", "-o", log)
    assert result.exit_code == 0, result.stderr
    command = f"aion build {path_word(log)} --tz Asia/Tokyo"
    assert "recorded in Osaka (Asia/Tokyo)" in result.stderr
    assert command in result.stderr
    local = run_json("build", log, "-o", tmp_path / "l.aion", "--tz", "Asia/Tokyo",
                     "--format", "json", "-q")
    assert local["hours_observed"] == "weekdays 09:00-10:00; weekends none (Asia/Tokyo)"
    utc = run_json("build", log, "-o", tmp_path / "u.aion", "--format", "json", "-q")
    assert utc["hours_observed"] == "weekdays 00:00-01:00; weekends none (UTC)"


def test_a_start_without_tz_says_it_was_read_in_utc(tmp_path: Path) -> None:
    src = tmp_path / "thor.csv"
    src.write_text("0.0,1,0.0,0.0,1.0,0.0\n1.0,1,1.0,0.0,1.0,0.0\n")
    result = run("convert", src, "--layout", "thor", "--start", "2017-06-01 10:00",
                 "-o", tmp_path / "t.mcap")
    assert result.exit_code == 0, result.stderr
    assert "recorded in Örebro (Europe/Stockholm): --start was read in UTC" in result.stderr
    zoned = run("convert", src, "--layout", "thor", "--start", "2017-06-01 10:00",
                "--tz", "Europe/Stockholm", "-o", tmp_path / "z.mcap")
    assert "recorded in" not in zoned.stderr


def test_eth_has_no_home_zone_note(tmp_path: Path) -> None:
    src = tmp_path / "eth.txt"
    src.write_text("0 1 0.0 0.0\n10 1 0.4 0.0\n")
    result = run("convert", src, "--layout", "eth", "-o", tmp_path / "e.mcap")
    assert result.exit_code == 0, result.stderr
    assert "recorded in" not in result.stderr


def test_the_build_of_a_converted_log_says_convert_wrote_its_zone(tmp_path: Path) -> None:
    """A log made by ``aion convert --tz`` declares its zone; the build's note on it named
    only ``aion simulate --tz`` as its writer, a command the user never ran."""
    src = tmp_path / "ucy.txt"
    src.write_text("0 1 0.0 0.0\n10 1 0.4 0.0\n")
    log = tmp_path / "ucy.mcap"
    converted = run("convert", src, "--layout", "ucy", "--start", "2026-01-05 12:00",
                    "--tz", "Europe/Nicosia", "-o", log)
    assert converted.exit_code == 0, converted.stderr
    built = run_json("build", log, "-o", tmp_path / "u.aion", "--format", "json", "-q")
    (note,) = [n for n in built["notes"] if "declares the time zone Europe/Nicosia" in n]
    assert "convert --tz" in note


def test_observed_spans_without_tz_are_said_to_be_read_in_utc(tmp_path: Path) -> None:
    """ATC's opening hours typed as --observed without --tz are UTC hours, 09:00-21:00 UTC =
    18:00-06:00 in Osaka: the note named the zone but not that the span was read in UTC, as it
    does for --start and --date. An ETH / UCY --start without --tz (no home zone) was read in
    UTC without a word."""
    src = tmp_path / "atc.csv"
    src.write_text(ATC)
    result = run("convert", src, "--layout", "atc", "--observed",
                 "2012-10-24 00:00..2012-10-24 12:00", "-o", tmp_path / "a.mcap")
    assert result.exit_code == 0, result.stderr
    assert "recorded in Osaka (Asia/Tokyo): --observed was read in UTC (give --tz)" \
        in result.stderr
    eth = tmp_path / "eth.txt"
    eth.write_text("0 1 0.0 0.0\n10 1 0.4 0.0\n")
    started = run("convert", eth, "--layout", "ucy", "--start", "2026-01-05 12:00",
                  "-o", tmp_path / "u.mcap")
    assert started.exit_code == 0, started.stderr
    assert "ucy: --start was read in UTC (give --tz)" in started.stderr
    zoned = run("convert", eth, "--layout", "ucy", "--start", "2026-01-05 12:00",
                "--tz", "Europe/Nicosia", "-o", tmp_path / "z.mcap")
    assert "read in UTC" not in zoned.stderr


@pytest.mark.parametrize(
    ("layout", "option", "wall", "said"),
    [  # Berlin's clocks skip 02:00-03:00 on 2026-03-29 and repeat it on 2026-10-25
        ("thor", "--start", "2026-03-29 02:30", "does not exist in Europe/Berlin"),
        ("eth", "--start", "2026-10-25 02:30", "happens twice in Europe/Berlin"),
        ("edinburgh", "--date", "2026-10-25 02:30", "happens twice in Europe/Berlin"),
    ],
)
def test_a_start_a_clock_change_skips_or_repeats_says_the_instant_taken(
    tmp_path: Path, layout: str, option: str, wall: str, said: str
) -> None:
    """``--start`` / ``--date`` in a wall-clock time the zone's clock change skips or repeats
    was read as ``--time`` reads it (PEP 495's fold=0) without the note ``--time`` gives, so a
    THÖR run started at "02:30" began at 03:30 summer time in silence. The instant expected is
    zoneinfo's, and the log starts at it."""
    rows = {
        "thor": "0.0,1,0.0,0.0,1.0,0.0\n1.0,1,1.0,0.0,1.0,0.0\n",
        "eth": "0 1 0.0 0.0\n10 1 0.4 0.0\n",
        "edinburgh": "TRACK.R1=[[100 100 0];[110 100 9];[120 100 18]];\n",
    }[layout]
    src = tmp_path / "tracks.txt"
    src.write_text(rows)
    log = tmp_path / "t.mcap"
    result = run("convert", src, "--layout", layout, option, wall, "--tz", "Europe/Berlin",
                 "-o", log)
    assert result.exit_code == 0, result.stderr
    # PEP 495's fold=0: the offset before the change (a skipped time lands an hour later)
    instant = to_ns(datetime.fromisoformat(wall).replace(tzinfo=ZoneInfo("Europe/Berlin")))
    read_as = format_ns(instant, resolve_zone("Europe/Berlin"))
    assert f"{option} {wall} {said}" in result.stderr
    assert f"read as {'the first, ' if 'twice' in said else ''}{read_as}" in result.stderr
    info = run_json("info", log, "--format", "json")
    assert info["start_ns"] == instant
    plain = run("convert", src, "--layout", layout, option, "2026-07-01 02:30", "--tz",
                "Europe/Berlin", "-o", tmp_path / "p.mcap")
    assert plain.exit_code == 0, plain.stderr
    assert "clock change" not in plain.stderr
