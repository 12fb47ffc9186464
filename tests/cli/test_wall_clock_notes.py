"""A wall-clock time a clock change skips or repeats is read as PEP 495's ``fold=0`` has it
(README: as late as the clocks jump; the first of a repeated hour), which the commands did
not say: ``--time "2026-03-29 02:30"`` in Europe/Berlin printed ``time: 2026-03-29
03:30:00+02:00`` with no word on why, ``"2026-10-25 02:30"`` no word that there is a second
02:30. Now a note says which instant was taken (and the other one). Expected instants are
computed here with zoneinfo, independently of aion's parser."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

from aion_cli.api import Map
from aion_cli.engine.time_text import format_ns
from aion_cli.timeparse import parse_time, resolve_zone, to_ns
from aion_cli.wall_clock import clock_change_note
from tests.cli.conftest import run, run_json
from tests.engine.temporal_data import corridor

NOW = datetime(2026, 6, 1, 12, 0, tzinfo=UTC)


@pytest.mark.parametrize(
    ("name", "wall"),
    [
        ("Europe/Berlin", datetime(2026, 3, 29, 2, 30)),
        ("America/New_York", datetime(2026, 3, 8, 2, 15)),
    ],
)
def test_a_skipped_time_names_the_instant_it_was_read_as(name: str, wall: datetime) -> None:
    zone = resolve_zone(name)
    text = wall.isoformat(sep=" ", timespec="minutes")
    t = parse_time(text, zone, NOW)
    # fold=0 of a skipped time takes the offset before the change: an hour later on the wall
    assert t == to_ns(wall.replace(tzinfo=ZoneInfo(name), fold=0))
    note = clock_change_note(text, zone, t, NOW)
    assert note == (
        f"{text} does not exist in {name} (a clock change skips it): read as "
        f"{format_ns(t, zone)}, as late as the clocks jump"
    )


@pytest.mark.parametrize(
    ("name", "wall"),
    [
        ("Europe/Berlin", datetime(2026, 10, 25, 2, 30)),
        ("America/New_York", datetime(2026, 11, 1, 1, 45)),
    ],
)
def test_a_repeated_time_names_both_instants(name: str, wall: datetime) -> None:
    zone = resolve_zone(name)
    text = wall.isoformat(sep=" ", timespec="minutes")
    first = to_ns(wall.replace(tzinfo=ZoneInfo(name), fold=0))
    second = to_ns(wall.replace(tzinfo=ZoneInfo(name), fold=1))
    assert second - first == 3600 * 10**9
    t = parse_time(text, zone, NOW)
    assert t == first
    assert clock_change_note(text, zone, t, NOW) == (
        f"{text} happens twice in {name} (a clock change repeats it): read as the first, "
        f"{format_ns(first, zone)}; the second is {format_ns(second, zone)}"
    )


@pytest.mark.parametrize(
    "text",
    [
        "2026-10-25T02:30+01:00",  # its own offset: one instant
        "2026-10-25 02:30 UTC",  # UTC repeats nothing
        "1792888200",  # UNIX seconds
        "2026-10-25 03:30",  # beside the change, but once
        "2026-03-29 03:30",
        "2026-07-01 02:30",  # far from any change
    ],
)
def test_no_note_for_a_time_read_one_way(text: str) -> None:
    zone = resolve_zone("Europe/Berlin")
    assert clock_change_note(text, zone, parse_time(text, zone, NOW), NOW) is None


def test_predict_says_how_it_read_a_time_the_spring_change_skips(tmp_path: Path) -> None:
    path = tmp_path / "berlin.aion"
    Map.from_state(corridor(2, lambda day, hour: 4.0).state, timezone="Europe/Berlin").save(path)
    result = run("predict", path, "--time", "2026-03-29 02:30", "--top", "1")
    assert result.exit_code == 0, result.stderr
    assert "time: 2026-03-29 03:30:00+02:00 (Europe/Berlin)" in result.stderr
    assert "2026-03-29 02:30 does not exist in Europe/Berlin" in result.stderr
    plain = run("predict", path, "--time", "2026-03-29 04:30", "--top", "1")
    assert plain.exit_code == 0, plain.stderr
    assert "does not exist" not in plain.stderr


def test_a_naive_datetime_of_a_clock_change_is_noted_as_its_string_is(tmp_path: Path) -> None:
    """The Python API reads a naive ``datetime`` (or ``numpy.datetime64``) as the wall-clock
    time a string without an offset is, but only the string's table said which instant a
    skipped or repeated one was read as: ``m.predict(datetime(2026, 3, 29, 2, 30))`` in
    Berlin answered at 03:30 summer time without a word. Now its notes say it as the
    command's stderr does (with the ``fold`` that gives the other instant), instants
    computed here with zoneinfo."""
    import numpy as np

    path = tmp_path / "berlin.aion"
    Map.from_state(corridor(2, lambda day, hour: 4.0).state, timezone="Europe/Berlin").save(path)
    m = Map.load(path)
    berlin = ZoneInfo("Europe/Berlin")
    said = run("predict", path, "--time", "2026-03-29 02:30", "--top", "1").stderr
    cli_note = next(line for line in said.splitlines() if "does not exist" in line)
    for given in (datetime(2026, 3, 29, 2, 30), np.datetime64("2026-03-29T02:30")):
        table = m.predict(given, top=1)
        assert table.time_ns == to_ns(datetime(2026, 3, 29, 2, 30, tzinfo=berlin))
        assert table.notes[0] == cli_note  # as late as the clocks jump
    early = m.predict(datetime(2026, 3, 29, 2, 30, fold=1), top=1)
    assert early.time_ns == to_ns(datetime(2026, 3, 29, 2, 30, fold=1, tzinfo=berlin))
    assert early.notes[0].endswith(f"read as {early.time}, as early as the clocks jump (fold=1)")
    first = datetime(2026, 10, 25, 2, 30, tzinfo=berlin)
    second = first.replace(fold=1)
    zone = resolve_zone("Europe/Berlin")
    later = m.predict(datetime(2026, 10, 25, 2, 30, fold=1), top=1)
    assert later.time_ns == to_ns(second)
    assert later.notes[0] == (
        "2026-10-25 02:30 happens twice in Europe/Berlin (a clock change repeats it): read as "
        f"the second, {format_ns(to_ns(second), zone)}; the first is "
        f"{format_ns(to_ns(first), zone)} (fold=0)"
    )
    aware = m.predict(datetime(2026, 3, 29, 1, 30, tzinfo=UTC), top=1)  # one instant
    assert not any("clock change" in n for n in aware.notes)


def test_a_repeated_datetime64_is_not_told_to_use_a_fold_it_lacks() -> None:
    """A ``numpy.datetime64`` at a repeated wall-clock time is read as the first instant (it
    has no fold); its note ended "(fold=1)", which no ``datetime64`` can be given. It now says
    that a ``datetime`` with ``fold=1`` names the second, and that one does."""
    import numpy as np

    m = Map.from_state(corridor(2, lambda day, hour: 4.0).state, timezone="Europe/Berlin")
    berlin, zone = ZoneInfo("Europe/Berlin"), resolve_zone("Europe/Berlin")
    first = datetime(2026, 10, 25, 2, 30, tzinfo=berlin)
    second = first.replace(fold=1)
    table = m.predict(np.datetime64("2026-10-25T02:30"), top=1)
    assert table.time_ns == to_ns(first)
    assert table.notes[0] == (
        "2026-10-25 02:30 happens twice in Europe/Berlin (a clock change repeats it): read as "
        f"the first, {format_ns(to_ns(first), zone)}; the second is "
        f"{format_ns(to_ns(second), zone)} (a datetime64 has no fold: a datetime with fold=1 "
        "names it)"
    )
    assert m.predict(datetime(2026, 10, 25, 2, 30, fold=1), top=1).time_ns == to_ns(second)


def test_an_observed_start_a_clock_change_skips_says_the_instant_taken(tmp_path: Path) -> None:
    """``--observed "2026-03-29 02:30..05:00"`` in Europe/Berlin starts at a time the spring
    change skips: convert, build and evaluate holdout read it as --time does (03:30 summer
    time) without the note --time gives. Each says it now; the span the log records starts
    at zoneinfo's instant, and a span from 04:00 gets no note."""
    src = tmp_path / "thor.csv"
    src.write_text("0.0,1,0.0,0.0,1.0,0.0\n1.0,1,1.0,0.0,1.0,0.0\n")
    zone = resolve_zone("Europe/Berlin")
    instant = to_ns(datetime(2026, 3, 29, 2, 30, tzinfo=ZoneInfo("Europe/Berlin")))  # fold=0
    said = (
        "--observed 2026-03-29 02:30 does not exist in Europe/Berlin (a clock change skips "
        f"it): read as {format_ns(instant, zone)}"
    )
    span = "2026-03-29 02:30..2026-03-29 05:00"
    log = tmp_path / "t.mcap"
    converted = run("convert", src, "--layout", "thor", "--start", "2026-03-29 04:00",
                    "--tz", "Europe/Berlin", "--observed", span, "-o", log)
    assert converted.exit_code == 0, converted.stderr
    assert said in converted.stderr
    info = run_json("info", log, "--format", "json")
    (spans,) = info["observed_spans"].values()
    assert spans[0]["start_ns"] == instant
    built = run_json("build", log, "-o", tmp_path / "t.aion", "--observed", span,
                     "--format", "json", "-q")
    assert [n for n in built["notes"] if n.startswith(said)]
    held = run("evaluate", "holdout", tmp_path / "t.aion", log, "--observed", span)
    assert held.exit_code == 0, held.stderr
    assert said in held.stderr
    # and in the JSON's notes, as build's (the note went to stderr only)
    doc = run_json("evaluate", "holdout", tmp_path / "t.aion", log, "--observed", span,
                   "--format", "json")
    assert [n for n in doc["notes"] if n.startswith(said)]
    plain = run("build", log, "-o", tmp_path / "p.aion", "--observed",
                "2026-03-29 04:00..2026-03-29 05:00")
    assert plain.exit_code == 0, plain.stderr
    assert "clock change" not in plain.stderr
