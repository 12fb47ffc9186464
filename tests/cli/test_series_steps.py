"""The times of a series (``predict``/``export --from --to --step``, ``plan --leave``, the
API's ``predict_series``) across the daylight-saving changes of Europe/Berlin in 2026: a step
in days or weeks keeps the wall-clock time, one in hours is elapsed time, and ``--to`` is a
time of the series when it falls on a step.

Known answers: Berlin is UTC+01:00 until 2026-03-29 02:00, when the clocks jump to 03:00
(UTC+02:00), and back from 03:00 to 02:00 (UTC+01:00) on 2026-10-25. Every expected instant
below is written as a UTC time (``_utc``), independently of aion's zone arithmetic.
"""

from __future__ import annotations

import itertools
from datetime import UTC, datetime
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

import aion_cli as aion
from aion_cli.api import Map
from aion_cli.engine.time_text import format_ns
from aion_cli.time_steps import Step, parse_step
from aion_cli.timeparse import TimeFormatError, resolve_zone, to_ns
from tests.cli.conftest import Office, run, run_json
from tests.engine.temporal_data import DAY, HOUR, corridor

BERLIN = "Europe/Berlin"


def _utc(text: str) -> int:
    """``"2026-03-29 10:00"`` read as UTC -> ns since the epoch."""
    moment = datetime.fromisoformat(text).replace(tzinfo=UTC)
    return int(moment.timestamp()) * 10**9


@pytest.fixture(scope="module")
def berlin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small map whose zone is Europe/Berlin (``aion build --tz Europe/Berlin``)."""
    mapper = corridor(2, lambda day, hour: 4.0, cells=(2.0, 1.0))
    path = tmp_path_factory.mktemp("berlin") / "berlin.aion"
    Map.from_state(mapper.state, timezone=BERLIN).save(path)
    return path


def _series(map_path: Path, start: str, end: str, step: str) -> tuple[list[str], list[int]]:
    doc = run_json(
        "predict", map_path, "--from", start, "--to", end, "--step", step, "--top", "1",
        "--format", "json",
    )
    assert doc["zone"] == BERLIN  # the map's zone: no --tz given
    return doc["times"], doc["times_ns"]


def test_a_daily_step_keeps_noon_across_the_spring_change_and_includes_the_end(
    berlin: Path,
) -> None:
    times, times_ns = _series(berlin, "2026-03-27 12:00", "2026-03-31 12:00", "1d")
    assert times == [
        "2026-03-27 12:00:00+01:00",
        "2026-03-28 12:00:00+01:00",
        "2026-03-29 12:00:00+02:00",
        "2026-03-30 12:00:00+02:00",
        "2026-03-31 12:00:00+02:00",  # --to, on a step: included (it was missing)
    ]
    assert times_ns == [
        _utc("2026-03-27 11:00"),
        _utc("2026-03-28 11:00"),
        _utc("2026-03-29 10:00"),  # 23 hours after the day before
        _utc("2026-03-30 10:00"),
        _utc("2026-03-31 10:00"),
    ]


def test_a_daily_step_keeps_noon_across_the_autumn_change(berlin: Path) -> None:
    times, times_ns = _series(berlin, "2026-10-23 12:00", "2026-10-27 12:00", "1d")
    assert times == [
        "2026-10-23 12:00:00+02:00",
        "2026-10-24 12:00:00+02:00",
        "2026-10-25 12:00:00+01:00",
        "2026-10-26 12:00:00+01:00",
        "2026-10-27 12:00:00+01:00",
    ]
    assert [b - a for a, b in itertools.pairwise(times_ns)] == [
        DAY, DAY + HOUR, DAY, DAY  # the day of the change has 25 hours
    ]


def test_a_weekly_step_keeps_nine_oclock(berlin: Path) -> None:
    times, _ = _series(berlin, "2026-03-20 09:00", "2026-04-03 09:00", "1w")
    assert times == [
        "2026-03-20 09:00:00+01:00",
        "2026-03-27 09:00:00+01:00",
        "2026-04-03 09:00:00+02:00",  # was 10:00, and the end was dropped
    ]


def test_hours_stay_elapsed_time(berlin: Path) -> None:
    times, _ = _series(berlin, "2026-03-27 12:00", "2026-03-31 12:00", "24h")
    assert times == [  # 24 elapsed hours: 13:00 after the change, and --to is off the steps
        "2026-03-27 12:00:00+01:00",
        "2026-03-28 12:00:00+01:00",
        "2026-03-29 13:00:00+02:00",
        "2026-03-30 13:00:00+02:00",
    ]
    times, times_ns = _series(berlin, "2026-10-25 01:00", "2026-10-25 04:00", "1h")
    assert times == [  # the repeated hour twice, an hour apart
        "2026-10-25 01:00:00+02:00",
        "2026-10-25 02:00:00+02:00",
        "2026-10-25 02:00:00+01:00",
        "2026-10-25 03:00:00+01:00",
        "2026-10-25 04:00:00+01:00",
    ]
    assert times_ns == [_utc("2026-10-24 23:00") + k * HOUR for k in range(5)]


def test_a_day_and_hours_step_is_a_calendar_day_then_elapsed_hours(berlin: Path) -> None:
    times, _ = _series(berlin, "2026-03-28 12:00", "2026-03-31 12:00", "1d12h")
    assert times == [
        "2026-03-28 12:00:00+01:00",
        "2026-03-30 00:00:00+02:00",  # 2026-03-29 12:00, then 12 hours
        "2026-03-31 12:00:00+02:00",
    ]


def test_wall_clock_times_the_changes_skip_or_repeat(berlin: Path) -> None:
    times, times_ns = _series(berlin, "2026-03-28 02:30", "2026-03-30 02:30", "1d")
    assert times == [
        "2026-03-28 02:30:00+01:00",
        "2026-03-29 03:30:00+02:00",  # 02:30 does not exist: as late as the clocks jump
        "2026-03-30 02:30:00+02:00",  # and the next day is 02:30 again
    ]
    single = run_json("predict", berlin, "--time", "2026-03-29 02:30", "--top", "1",
                      "--format", "json")
    assert times_ns[1] == single["time_ns"] == _utc("2026-03-29 01:30")  # as --time reads it
    times, _ = _series(berlin, "2026-10-24 02:30", "2026-10-26 02:30", "1d")
    assert times == [
        "2026-10-24 02:30:00+02:00",
        "2026-10-25 02:30:00+02:00",  # 02:30 happens twice: the first one
        "2026-10-26 02:30:00+01:00",
    ]
    times, _ = _series(berlin, "2026-10-25 02:30+01:00", "2026-10-27 03:00", "1d")
    assert times == [
        "2026-10-25 02:30:00+01:00",  # the start as given (the second 02:30)
        "2026-10-26 02:30:00+01:00",
        "2026-10-27 02:30:00+01:00",
    ]


def test_the_api_series_equals_the_cli_across_the_change(berlin: Path) -> None:
    m = aion.Map.load(berlin)
    days = m.predict_series("2026-03-27 12:00", "2026-03-31 12:00", "1d", top=1)
    _, cli_ns = _series(berlin, "2026-03-27 12:00", "2026-03-31 12:00", "1d")
    assert days.times_ns == cli_ns
    assert days.times[-1] == "2026-03-31 12:00:00+02:00"
    seconds = m.predict_series("2026-03-27 12:00", "2026-03-31 12:00", 86400.0, top=1)
    assert seconds.times_ns == [_utc("2026-03-27 11:00") + k * DAY for k in range(4)]


def test_plan_departures_every_day_keep_the_wall_clock_time(office: Office) -> None:
    doc = run_json(
        "plan", office.map, "--from", "p0", "--to", "p4", "--tz", BERLIN, "--leave",
        "2026-03-27 12:00..2026-03-31 12:00", "--step", "1d", "--format", "json",
    )
    assert [row["depart"] for row in doc["departures"]] == [
        f"2026-03-{d} 12:00:00{'+01:00' if d < 29 else '+02:00'}" for d in range(27, 32)
    ]
    m = aion.Map.load(office.map)
    plan = m.plan("p0", "p4", tz=BERLIN, leave=("2026-03-27 12:00", "2026-03-31 12:00"),
                  step="1d")
    assert [row["depart_ns"] for row in plan.departures] == [
        row["depart_ns"] for row in doc["departures"]
    ]


def test_an_export_series_every_day_names_its_folders_by_the_same_local_noon(
    office: Office, tmp_path: Path
) -> None:
    out = tmp_path / "series"
    done = run(
        "export", office.map, "--tz", BERLIN, "--from", "2026-10-23 12:00", "--to",
        "2026-10-27 12:00", "--step", "1d", "-o", out,
    )
    assert done.exit_code == 0, done.stderr
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == [
        "20261023T100000Z",
        "20261024T100000Z",
        "20261025T110000Z",
        "20261026T110000Z",
        "20261027T110000Z",
    ]


@pytest.mark.parametrize(
    ("text", "step"),
    [
        ("1d", Step(1, 0)),
        ("2d", Step(2, 0)),
        ("1w", Step(7, 0)),
        ("1w2d", Step(9, 0)),
        ("24h", Step(0, DAY)),
        ("1d12h", Step(1, 12 * HOUR)),
        ("1.5d", Step(1, 12 * HOUR)),
        ("0.5d", Step(0, 12 * HOUR)),
        ("90m", Step(0, 90 * 60 * 10**9)),
        ("600", Step(0, 600 * 10**9)),
        (86400.0, Step(0, DAY)),
    ],
)
def test_which_steps_are_calendar_days(text: str | float, step: Step) -> None:
    assert parse_step(text) == step


def test_a_signed_step_is_read_or_refused_as_a_length() -> None:
    """A step is a length: "+1h" is 1h (it had been "cannot read the step"), and "-1h" is
    refused naming its sign (it had been "cannot read the step '-1h'", as for a typo), on
    the command line and in the API alike; a number of seconds below 1 still says so."""
    assert parse_step("+1h") == parse_step("1h") == Step(0, HOUR)
    assert parse_step(" + 1d") == Step(1, 0)
    for text, option in (("-1h", "--step"), (" -30m", "--step"), ("-1d", "step")):
        with pytest.raises(TimeFormatError) as caught:
            parse_step(text, option)
        assert caught.value.message == (
            f"{option} {text!r} has a minus sign: a step is a length, and a series runs "
            "forward from its start"
        )
    with pytest.raises(TimeFormatError, match="at least 1 s"):
        parse_step(-3600.0, "step")


def test_a_repeated_hour_is_labelled_by_its_offset() -> None:
    """London, 2026-10-25: 01:00 and 01:30 come twice (BST, then GMT). Rows and panel titles
    of the same wall time had read alike; they now carry the offset, the others stay bare."""
    from aion_cli.cli.predict_series import short_labels
    from aion_cli.pictures.render import _panel_titles
    from aion_cli.timeparse import parse_time, resolve_zone

    zone = resolve_zone("Europe/London")
    start = parse_time("2026-10-25T00:00Z", zone)
    times = [start + k * 1800 * 10**9 for k in range(6)]
    expected = ["01:00 +01:00", "01:30 +01:00", "01:00 +00:00", "01:30 +00:00", "02:00", "02:30"]
    assert short_labels(times, zone) == expected
    assert _panel_titles(times, zone) == expected


def test_an_end_before_a_start_the_spring_change_moved_says_how_both_were_read(
    berlin: Path,
) -> None:
    """``--from 02:30 --to 03:10`` on the spring change: 02:30 does not exist and is read as
    03:30 summer time (01:30 UTC), after the end, 03:10 summer time (01:10 UTC). The error
    said only "--to is before --from"; it now shows both times as read and names the clock
    change. An end before its start elsewhere names no change."""
    result = run(
        "predict", berlin, "--from", "2026-03-29 02:30", "--to", "2026-03-29 03:10",
        "--step", "10m",
    )
    assert result.exit_code == 2, result.stderr
    first = result.stderr.splitlines()[0]
    start = datetime.fromtimestamp(_utc("2026-03-29 01:30") // 10**9, UTC).astimezone(
        ZoneInfo(BERLIN)
    )
    end = datetime.fromtimestamp(_utc("2026-03-29 01:10") // 10**9, UTC).astimezone(
        ZoneInfo(BERLIN)
    )
    assert first == (
        f"error: --to is before --from (read as {start.isoformat(sep=' ')} .. "
        f"{end.isoformat(sep=' ')}: a clock change skips or repeats an hour there)"
    )
    plain = run(
        "predict", berlin, "--from", "2026-03-20 02:30", "--to", "2026-03-20 01:10",
        "--step", "10m",
    )
    assert plain.exit_code == 2, plain.stderr
    assert plain.stderr.splitlines()[0] == (
        "error: --to is before --from (read as 2026-03-20 02:30:00+01:00 .. "
        "2026-03-20 01:10:00+01:00)"
    )


def test_a_daily_series_from_a_skipped_time_keeps_the_time_typed_on_the_other_days(
    berlin: Path, office: Office
) -> None:
    """``--from "2026-03-29 02:30" --step 1d``: 02:30 does not exist that day and is read as
    03:30 summer time (01:30 UTC), as --time reads it; the next days are 02:30 again (00:30
    UTC), as for a series that starts the day before. They had been 03:30 on every day, and
    the ``--to`` of 02:30 on 03-31, no longer on a step, was left out."""
    expected = [_utc("2026-03-29 01:30"), _utc("2026-03-30 00:30"), _utc("2026-03-31 00:30")]
    times, times_ns = _series(berlin, "2026-03-29 02:30", "2026-03-31 02:30", "1d")
    assert times_ns == expected
    assert times[1:] == ["2026-03-30 02:30:00+02:00", "2026-03-31 02:30:00+02:00"]
    _, from_before = _series(berlin, "2026-03-28 02:30", "2026-03-31 02:30", "1d")
    assert from_before[1:] == expected  # the same days, whichever day the series starts
    m = aion.Map.load(berlin)
    assert m.predict_series("2026-03-29 02:30", "2026-03-31 02:30", "1d", top=1).times_ns == (
        expected
    )
    doc = run_json(
        "plan", office.map, "--from", "p0", "--to", "p4", "--tz", BERLIN, "--leave",
        "2026-03-29 02:30..2026-03-31 02:30", "--step", "1d", "--format", "json",
    )
    assert [row["depart_ns"] for row in doc["departures"]] == expected
    plan = aion.Map.load(office.map).plan(
        "p0", "p4", tz=BERLIN, leave=("2026-03-29 02:30", "2026-03-31 02:30"), step="1d"
    )
    assert [row["depart_ns"] for row in plan.departures] == expected
    _, named = _series(berlin, "2026-03-29 02:30 Europe/Berlin", "2026-03-31 02:30", "1d")
    assert named == expected  # the map's zone named in the time: the same days
    # typed as the instant it is (summer time, its own offset): 03:30 every day
    _, given = _series(berlin, "2026-03-29 03:30+02:00", "2026-03-30 03:30", "1d")
    assert given == [_utc("2026-03-29 01:30"), _utc("2026-03-30 01:30")]


def test_a_naive_datetime_start_in_a_skipped_hour_keeps_its_time_as_a_string_does(
    berlin: Path, office: Office
) -> None:
    """``Map.predict_series(datetime(2026, 3, 29, 2, 30), ...)`` (a naive datetime: a wall
    clock of the map's zone, as a string without an offset is) gave 03:30 on every day, and
    left out the end of 02:30 on 03-31, after the string form was fixed; it gives the string's
    times now. An aware datetime names one instant and keeps its wall clock, as before."""
    expected = [_utc("2026-03-29 01:30"), _utc("2026-03-30 00:30"), _utc("2026-03-31 00:30")]
    m = aion.Map.load(berlin)
    naive = m.predict_series(datetime(2026, 3, 29, 2, 30), datetime(2026, 3, 31, 2, 30), "1d",
                             top=1)
    assert naive.times_ns == expected
    summer = datetime(2026, 3, 29, 3, 30, tzinfo=ZoneInfo(BERLIN))
    aware = m.predict_series(summer, datetime(2026, 3, 30, 3, 30), "1d", top=1)
    assert aware.times_ns == [_utc("2026-03-29 01:30"), _utc("2026-03-30 01:30")]
    plan = aion.Map.load(office.map).plan(
        "p0", "p4", tz=BERLIN, leave=(datetime(2026, 3, 29, 2, 30), datetime(2026, 3, 31, 2, 30)),
        step="1d",
    )
    assert [row["depart_ns"] for row in plan.departures] == expected


def test_plan_leave_from_a_skipped_or_repeated_time_says_the_instant_taken(
    office: Office,
) -> None:
    """``plan --leave`` from a wall-clock time Berlin's clock change skips or repeats was read
    as ``--time`` reads it (the first departure at 03:30 summer time for "02:30" on 03-29)
    without the note that ``--time`` and ``predict --from`` give (nor had ``Map.plan(leave=)``
    the note ``Map.predict_series`` has); the first departure and the instant named are
    zoneinfo's."""
    berlin = ZoneInfo(BERLIN)
    for wall, said in (("2026-03-29 02:30", "does not exist"),
                       ("2026-10-25 02:30", "happens twice")):
        result = run("plan", office.map, "--from", "p0", "--to", "p4", "--tz", BERLIN,
                     "--leave", f"{wall}..{wall[:11]}04:00", "--step", "30m")
        assert result.exit_code == 0, result.stderr
        first = to_ns(datetime.fromisoformat(wall).replace(tzinfo=berlin))  # fold=0
        read_as = format_ns(first, resolve_zone(BERLIN))
        assert f"--leave {wall} {said} in {BERLIN} (a clock change " in result.stderr
        assert f"read as {'the first, ' if 'twice' in said else ''}{read_as}" in result.stderr
        doc = run_json("plan", office.map, "--from", "p0", "--to", "p4", "--tz", BERLIN,
                       "--leave", f"{wall}..{wall[:11]}04:00", "--step", "30m",
                       "--format", "json")
        assert doc["departures"][0]["depart_ns"] == first
        api = aion.Map.load(office.map).plan("p0", "p4", tz=BERLIN, step="30m",
                                             leave=(wall, f"{wall[:11]}04:00"))
        assert api.departures[0]["depart_ns"] == first
        assert api.notes[0].startswith(f"{wall} {said} in {BERLIN} (a clock change ")
    plain = run("plan", office.map, "--from", "p0", "--to", "p4", "--tz", BERLIN,
                "--leave", "2026-07-01 02:30..2026-07-01 04:00", "--step", "30m")
    assert plain.exit_code == 0, plain.stderr
    assert "clock change" not in plain.stderr
