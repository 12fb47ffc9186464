"""Unit tests of the time and time-zone parser behind every ``--time`` / ``--tz`` option."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta, timezone

import pytest

from aion_cli.engine.time_text import Zone, format_ns
from aion_cli.errors import InputError
from aion_cli.timeparse import TimeFormatError, local_zone, parse_time, resolve_zone, to_ns

BERLIN = resolve_zone("Europe/Berlin")
UTCZ = resolve_zone("UTC")
# A fixed "now": Sunday 2026-11-22 10:15:00 UTC (11:15 in Berlin, CET = UTC+1).
NOW = datetime(2026, 11, 22, 10, 15, 0, tzinfo=UTC)
S = 1_000_000_000


def ns(*args: int, tz: timezone | None = None) -> int:
    return to_ns(datetime(*args, tzinfo=tz or UTC))


def test_iso_naive_uses_the_given_zone() -> None:
    # 08:30 in Berlin in November (CET, UTC+1) is 07:30 UTC.
    assert parse_time("2026-11-23 08:30", BERLIN, NOW) == ns(2026, 11, 23, 7, 30)
    assert parse_time("2026-11-23 08:30", UTCZ, NOW) == ns(2026, 11, 23, 8, 30)


def test_iso_with_offset_ignores_the_given_zone() -> None:
    expected = ns(2026, 11, 23, 7, 30)
    assert parse_time("2026-11-23T08:30:00+01:00", UTCZ, NOW) == expected
    assert parse_time("2026-11-23T07:30:00Z", BERLIN, NOW) == expected
    assert parse_time("2026-11-23t07:30z", BERLIN, NOW) == expected


def test_an_offset_and_a_zone_after_it_must_agree() -> None:
    """``2026-03-29T08:00Z Europe/Berlin`` was read as 08:00Z, the zone silently ignored:
    an offset and a zone that disagree at the instant are refused, naming both; where they
    agree (Berlin is +02:00 after the spring change) the time is read."""
    from zoneinfo import ZoneInfo

    berlin = ZoneInfo("Europe/Berlin")
    summer = datetime(2026, 3, 29, 8, 0, tzinfo=berlin)  # after the change at 01:00 UTC
    assert summer.utcoffset() == timedelta(hours=2)
    assert parse_time("2026-03-29T08:00+02:00 Europe/Berlin", UTCZ, NOW) == to_ns(summer)
    assert parse_time("2026-11-23T07:30Z UTC", BERLIN, NOW) == ns(2026, 11, 23, 7, 30)
    for text, mark in (
        ("2026-03-29T08:00Z Europe/Berlin", "Z"),
        ("2026-03-29T08:00+01:00 Europe/Berlin", "+01:00"),
        ("2026-11-23T08:30:00.5-05 UTC", "-05"),
    ):
        with pytest.raises(TimeFormatError, match="names two zones that disagree") as info:
            parse_time(text, UTCZ, NOW)
        assert f"its offset {mark} and" in str(info.value)
        assert info.value.hint == "give the offset or the zone, not both"
    # a date alone ends in digits after a dash, which is no offset
    assert parse_time("2026-11-23 Europe/Berlin", UTCZ, NOW) == ns(2026, 11, 22, 23)


def test_iso_date_only_is_midnight_and_summer_time_is_respected() -> None:
    assert parse_time("2026-11-23", UTCZ, NOW) == ns(2026, 11, 23)
    # July in Berlin is CEST = UTC+2.
    assert parse_time("2026-07-01 12:00", BERLIN, NOW) == ns(2026, 7, 1, 10, 0)


def test_iso_fractional_seconds_are_exact() -> None:
    assert parse_time("2026-11-23T07:30:00.000250Z", UTCZ, NOW) == ns(2026, 11, 23, 7, 30) + 250_000


def test_unix_seconds_and_nanoseconds() -> None:
    assert parse_time("1795420200", BERLIN, NOW) == 1795420200 * S
    assert parse_time("@1795420200.5", BERLIN, NOW) == 1795420200 * S + S // 2
    assert parse_time("1795420200123456789ns", BERLIN, NOW) == 1795420200123456789


def test_unix_nanoseconds_without_unit_are_refused_with_a_hint() -> None:
    with pytest.raises(TimeFormatError) as info:
        parse_time("1795420200123456789", UTCZ, NOW)
    assert "ns" in (info.value.hint or "")


@pytest.mark.parametrize(
    ("text", "offset_s"),
    [
        ("now", 0),
        ("+2h", 7200),
        ("-30m", -1800),
        ("+1d12h", 36 * 3600),
        ("now+90s", 90),
        ("now - 1w", -7 * 86400),
        ("+1.5h", 5400),
        ("-30s", -30),
        ("+10min", 600),
    ],
)
def test_relative_forms(text: str, offset_s: int) -> None:
    assert parse_time(text, BERLIN, NOW) == to_ns(NOW) + offset_s * S


def test_day_words_with_clock_use_the_zone_calendar() -> None:
    # "tomorrow 12:00" in Berlin: Monday 2026-11-23 12:00 CET = 11:00 UTC.
    assert parse_time("tomorrow 12:00", BERLIN, NOW) == ns(2026, 11, 23, 11, 0)
    assert parse_time("Today 17:00:30", UTCZ, NOW) == ns(2026, 11, 22, 17, 0, 30)
    assert parse_time("yesterday 08:15", UTCZ, NOW) == ns(2026, 11, 21, 8, 15)


def test_day_words_alone_follow_gnu_date() -> None:
    assert parse_time("tomorrow", UTCZ, NOW) == to_ns(NOW + timedelta(days=1))
    assert parse_time("today", UTCZ, NOW) == to_ns(NOW)


def test_weekdays_are_the_next_occurrence_today_included() -> None:
    # NOW is a Sunday.
    assert parse_time("monday 08:30", UTCZ, NOW) == ns(2026, 11, 23, 8, 30)
    assert parse_time("sun 09:00", UTCZ, NOW) == ns(2026, 11, 22, 9, 0)
    assert parse_time("saturday", UTCZ, NOW) == ns(2026, 11, 28)


def test_bare_clock_is_today() -> None:
    assert parse_time("08:30", UTCZ, NOW) == ns(2026, 11, 22, 8, 30)
    # Near midnight the zone decides which day "today" is: 23:30 UTC is already the next
    # day in Berlin.
    late = datetime(2026, 11, 22, 23, 30, tzinfo=UTC)
    assert parse_time("08:00", BERLIN, late) == ns(2026, 11, 23, 7, 0)


def test_twelve_hour_clocks_wherever_a_clock_goes() -> None:
    assert parse_time("9am", UTCZ, NOW) == ns(2026, 11, 22, 9, 0)
    assert parse_time("9:30 PM", UTCZ, NOW) == ns(2026, 11, 22, 21, 30)
    assert parse_time("12am", UTCZ, NOW) == ns(2026, 11, 22, 0, 0)  # midnight
    assert parse_time("12:15pm", UTCZ, NOW) == ns(2026, 11, 22, 12, 15)  # noon
    assert parse_time("tomorrow 9am", BERLIN, NOW) == ns(2026, 11, 23, 8, 0)
    assert parse_time("friday 5:45:10pm", UTCZ, NOW) == ns(2026, 11, 27, 17, 45, 10)
    assert parse_time("tomorrow 9am UTC", BERLIN, NOW) == ns(2026, 11, 23, 9, 0)


def test_a_date_with_a_twelve_hour_clock() -> None:
    """``2026-03-29 9am`` was 'cannot read the time' (the 12-hour form went with day words
    only); in Berlin it is 9:00 summer time that day, as zoneinfo has it."""
    from zoneinfo import ZoneInfo

    nine = datetime(2026, 3, 29, 9, tzinfo=ZoneInfo("Europe/Berlin"))
    assert parse_time("2026-03-29 9am", BERLIN, NOW) == to_ns(nine)
    assert parse_time("2026-03-29T9:30 PM", BERLIN, NOW) == ns(2026, 3, 29, 19, 30)
    assert parse_time("2028-02-29 12am UTC", BERLIN, NOW) == ns(2028, 2, 29, 0, 0)
    with pytest.raises(TimeFormatError, match="day is out of range"):
        parse_time("2027-02-29 9am", BERLIN, NOW)


@pytest.mark.parametrize("word", ["PST", "CEST", "Narnia", "local"])
def test_a_time_followed_by_a_word_no_zone_has_names_it_as_the_zone(word: str) -> None:
    """``08:30 PST`` said 'cannot read the time' with the forms of a time, which it has."""
    with pytest.raises(TimeFormatError) as info:
        parse_time(f"2026-11-23 08:30 {word}", UTCZ, NOW)
    assert info.value.message == f"unknown time zone {word!r} in the time '2026-11-23 08:30 {word}'"
    assert ("--tz local" if word == "local" else "IANA") in str(info.value.hint)
    for text in ("garbage words", "2026-11-23 08:30 Europe/Berlin UTC", "tomorrow pm"):
        with pytest.raises(TimeFormatError, match="cannot read the time"):
            parse_time(text, UTCZ, NOW)


@pytest.mark.parametrize(
    "text",
    [
        "",
        "   ",
        "yesterday-ish",
        "2026-13-01",
        "25:00",
        "tomorrow 12:99",
        "+2 parsecs",
        "soon",
        "13pm",
        "0am",
        "tomorrow 9",
        "tomorrow noonish",
    ],
)
def test_bad_times_raise_an_input_error_with_the_accepted_forms(text: str) -> None:
    with pytest.raises(TimeFormatError) as info:
        parse_time(text, UTCZ, NOW)
    assert isinstance(info.value, InputError)
    assert info.value.hint


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("2026-02-30 12:00", "day is out of range for month"),
        ("2026-13-01", "month must be in 1..12"),
        ("2026-01-12 25:00", "hour must be in 0..23"),
    ],
)
def test_a_date_of_the_right_form_says_which_field_is_wrong(text: str, reason: str) -> None:
    with pytest.raises(TimeFormatError, match=f"invalid date or time '{text}': {reason}"):
        parse_time(text, UTCZ, NOW)


def test_zones_by_name_offset_and_local(monkeypatch: pytest.MonkeyPatch) -> None:
    assert resolve_zone("UTC").name == "UTC"
    plus_one = resolve_zone("+01:00")
    assert plus_one.name == "UTC+01:00"
    assert parse_time("2026-11-23 08:30", plus_one, NOW) == ns(2026, 11, 23, 7, 30)
    minus = resolve_zone("UTC-0530")
    assert parse_time("2026-11-23 00:00", minus, NOW) == ns(2026, 11, 23, 5, 30)
    monkeypatch.setenv("TZ", "America/New_York")
    assert local_zone().name == "America/New_York"
    assert resolve_zone(None).name == "America/New_York"
    assert resolve_zone("local").name == "America/New_York"


@pytest.mark.parametrize("name", ["Mars/Olympus", "+25:00", "../../etc"])
def test_unknown_zone_is_an_input_error(name: str) -> None:
    with pytest.raises(TimeFormatError):
        resolve_zone(name)


@pytest.mark.parametrize("name", ["europe/berlin", "EUROPE/BERLIN", "Europe/berlin"])
def test_an_iana_name_in_another_case_is_that_zone(name: str) -> None:
    """``--tz europe/berlin`` (as typed, or as a map written on a machine whose file system
    ignores case records it) is Europe/Berlin, shown so; it was 'unknown time zone'."""
    from zoneinfo import ZoneInfo

    zone = resolve_zone(name)
    assert zone.name == "Europe/Berlin"
    summer = datetime(2026, 7, 1, 8, 30, tzinfo=ZoneInfo("Europe/Berlin"))
    assert parse_time("2026-07-01 08:30", zone, NOW) == to_ns(summer)
    assert parse_time(f"2026-07-01 08:30 {name}", UTCZ, NOW) == to_ns(summer)


def test_the_calendar_of_a_zone_named_in_another_case_is_that_zones() -> None:
    import numpy as np

    from aion_cli.engine.temporal.calendar import Calendar

    times = np.array([ns(2026, 3, 28, 7, 30), ns(2026, 3, 30, 6, 30)], dtype=np.int64)
    # 08:30 local on both sides of the spring change: the same hour of the day, bin 8
    assert Calendar("europe/berlin", "day").profile_bin(times).tolist() == [8, 8]


@pytest.mark.parametrize(("name", "meant"), [("Europe/Berln", "Europe/Berlin"),
                                             ("asia/tokio", "Asia/Tokyo")])
def test_a_misspelt_zone_names_the_zone_meant(name: str, meant: str) -> None:
    with pytest.raises(TimeFormatError, match="unknown time zone") as caught:
        resolve_zone(name)
    assert f'did you mean "{meant}"?' in str(caught.value.hint)
    with pytest.raises(TimeFormatError) as caught:
        resolve_zone("Mars/Olympus")
    assert "did you mean" not in str(caught.value.hint)


def test_format_round_trip() -> None:
    t = parse_time("2026-11-23 08:30", BERLIN, NOW)
    assert format_ns(t, BERLIN) == "2026-11-23 08:30:00+01:00"
    assert format_ns(t, Zone(UTC, "UTC")) == "2026-11-23 07:30:00+00:00"


def test_one_digit_hour_and_a_trailing_zone_name() -> None:
    assert parse_time("2026-11-23 8:30", UTCZ, NOW) == ns(2026, 11, 23, 8, 30)
    assert parse_time("2026-11-23 08:30 Europe/Berlin", UTCZ, NOW) == ns(2026, 11, 23, 7, 30)
    assert parse_time("tomorrow 12:00 UTC", BERLIN, NOW) == ns(2026, 11, 23, 12, 0)
    with pytest.raises(TimeFormatError):
        parse_time("2026-11-23 08:30 Mars/Olympus", UTCZ, NOW)
    # every zone form --tz takes (README: "any form followed by a zone name")
    assert parse_time("2026-11-23 08:30 UTC+05:30", UTCZ, NOW) == ns(2026, 11, 23, 3, 0)
    assert parse_time("2026-11-23 08:30 CET", UTCZ, NOW) == ns(2026, 11, 23, 7, 30)
    assert parse_time("2026-11-23 08:30 EST5EDT", UTCZ, NOW) == ns(2026, 11, 23, 13, 30)
    # a last word that is no zone is part of the time
    assert parse_time("9:30 pm", UTCZ, NOW) == parse_time("21:30", UTCZ, NOW)
    with pytest.raises(TimeFormatError):
        parse_time("2026-11-23 08:30 Narnia", UTCZ, NOW)


def test_an_offset_reads_as_iso_writes_it_seconds_included() -> None:
    """A series label or title once cut ``isoformat()`` to its last six characters, which
    for an offset of seconds (Monrovia until 1972, -00:44:30) read ``44:30``."""
    from zoneinfo import ZoneInfo

    from aion_cli.engine.time_text import offset_text

    for zone, moment in (
        ("Africa/Monrovia", datetime(1960, 1, 1)),
        ("Europe/Berlin", datetime(2026, 7, 1)),
        ("America/St_Johns", datetime(2026, 1, 1)),
        ("UTC", datetime(2026, 1, 1)),
    ):
        aware = moment.replace(tzinfo=ZoneInfo(zone))
        assert offset_text(aware) == aware.isoformat()[len("2026-01-01T00:00:00"):], zone


def test_eight_digits_that_are_a_date_are_refused_naming_both_readings() -> None:
    """``20261123`` had been read as UNIX seconds, 1970-08-23 12:05:23 UTC, without a word
    (``20261123T0830`` is read as 2026-11-23 08:30); it is now an error naming both readings.
    ``@`` says UNIX seconds; eight digits that are no date stay UNIX seconds."""
    with pytest.raises(TimeFormatError) as info:
        parse_time("20261123", BERLIN, NOW)
    assert "2026-11-23" in info.value.message
    assert "1970-08-23 12:05:23+00:00" in info.value.message  # 20261123 s = 234 d 12:05:23
    assert '"@20261123"' in (info.value.hint or "")
    assert parse_time("@20261123", BERLIN, NOW) == 20261123 * S
    assert parse_time("20260231", BERLIN, NOW) == 20260231 * S  # February has no 31st
    assert parse_time("20261123T0830", UTCZ, NOW) == ns(2026, 11, 23, 8, 30)


@pytest.mark.parametrize(("text", "stamp"), [("-5", "23:59:55"), ("-90.5", "23:58:29")])
def test_a_negative_number_without_a_unit_is_refused_naming_the_relative_forms(
    text: str, stamp: str
) -> None:
    """``--time -5`` was read as UNIX seconds, 1969-12-31 23:59:55 UTC, and predicted for
    1969 (only a note said it lay 56 years before the map), where "-5h" or "-5m" (a time
    before now, as ``-30m`` is) lacked its unit. ``@-5`` still says UNIX seconds, and
    ``-5s`` is five seconds ago."""
    with pytest.raises(TimeFormatError) as info:
        parse_time(text, BERLIN, NOW)
    assert f"reads as UNIX seconds before 1970 (1969-12-31 {stamp}+00:00)" in info.value.message
    assert f'"{text}h", "{text}m" or "{text}s"' in (info.value.hint or "")
    assert f'"@{text}"' in (info.value.hint or "")
    seconds = float(text)
    assert parse_time(f"@{text}", BERLIN, NOW) == round(seconds * S)
    assert parse_time(f"{text}s", BERLIN, NOW) == to_ns(NOW) + round(seconds * S)
    assert parse_time("0", BERLIN, NOW) == 0


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        # "now" is Sunday 2026-11-22 10:15 UTC, 11:15 at UTC+01:00, 05:15 at UTC-05:00
        ("08:30 +01:00", ns(2026, 11, 22, 7, 30)),
        ("tomorrow 12:00 +01:00", ns(2026, 11, 23, 11, 0)),
        ("monday 08:30 -05:00", ns(2026, 11, 23, 13, 30)),
        ("9am -05", ns(2026, 11, 22, 14, 0)),
        ("2026-11-23 9am +0100", ns(2026, 11, 23, 8, 0)),
        ("2026-11-23 08:30 +01:00", ns(2026, 11, 23, 7, 30)),  # ISO: as before
    ],
)
def test_a_time_followed_by_an_offset_alone_is_read_at_that_offset(
    text: str, expected: int
) -> None:
    """``--tz +01:00`` is a zone, and the README reads any time followed by a zone in it;
    ``08:30 +01:00`` and ``tomorrow 12:00 +01:00`` had been errors ("cannot read the time")
    where ``08:30 UTC+01:00`` and ``2026-11-23 08:30 +01:00`` were read."""
    assert parse_time(text, BERLIN, NOW) == expected


def test_an_offset_alone_that_disagrees_with_the_times_own_is_refused() -> None:
    with pytest.raises(TimeFormatError, match="two zones that disagree"):
        parse_time("2026-11-23T08:30+02:00 +01:00", BERLIN, NOW)
    for text in ("now -12", "+2h -05"):  # a number after "now": no zone, an error as before
        with pytest.raises(TimeFormatError, match="cannot read the time"):
            parse_time(text, BERLIN, NOW)


@pytest.mark.parametrize(("unit", "scale"), [("milliseconds", 10**3), ("microseconds", 10**6)])
def test_a_time_in_milliseconds_is_refused_with_a_hint_that_reads_it_so(
    unit: str, scale: int
) -> None:
    """``--time 1795422600000`` (JavaScript's ``Date.now()``, milliseconds) was refused with
    the hint "append 'ns' for nanoseconds", which reads it as 1970-01-01 00:29:55 UTC; the
    hint names the unit it is in and the two forms of that time, each read back as it."""
    expected = ns(2026, 11, 23, 8, 30)
    text = str(expected // S * scale)
    with pytest.raises(TimeFormatError) as info:
        parse_time(text, UTCZ, NOW)
    hint = info.value.hint or ""
    assert f"as UNIX {unit} it is {expected // S} seconds" in hint, hint
    assert parse_time(str(expected // S), UTCZ, NOW) == expected
    assert f"{expected}ns" in hint, hint
    with pytest.raises(TimeFormatError) as whole_ns:  # nanoseconds without their unit
        parse_time(str(expected), UTCZ, NOW)
    assert f"append 'ns': {expected}ns" in (whole_ns.value.hint or "")


def test_every_day_word_read_is_among_the_forms_help_and_readme_list() -> None:
    """``--time yesterday 08:30`` was read but neither ``--help`` nor the README listed
    yesterday (nor today): each day word the parser reads is now among their forms, and
    the form they give reads as that day."""
    from pathlib import Path

    from aion_cli.cli.common import TIME_HELP
    from aion_cli.timeparse import DAY_SHIFTS

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    forms = readme.split("Times: ISO 8601", 1)[1][:300]  # the README's list of forms
    for word, shift in DAY_SHIFTS.items():
        (given,) = re.findall(rf'"({word} [0-9:]+)"', TIME_HELP)
        assert f"`{given}`" in forms
        clock = datetime.strptime(given.split()[1], "%H:%M").time()
        expected = datetime.combine(NOW.date() + timedelta(days=shift), clock, UTC)
        assert parse_time(given, UTCZ, NOW) == to_ns(expected)
