"""Times typed with more than 6 decimals: aion's times are int64 nanoseconds, so every option
that takes a time (``timeparse.parse_time``) keeps the 7th to 9th decimals exactly; before,
``2017-05-24T10:00:00.123456789Z`` was read as ...123456000 without a word
(``datetime.fromisoformat`` cuts to the microsecond). A digit past the 9th, which no int64
nanosecond holds, is an error rather than cut.

Expected values: 2017-05-24T10:00:00Z is 1495620000 s (``date -u -d @1495620000``)."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from aion_cli.timeparse import TimeFormatError, parse_time, resolve_zone
from tests.cli.conftest import Office, assert_one_line_error, run, run_json

S = 1_000_000_000
T0 = 1_495_620_000 * S  # 2017-05-24T10:00:00Z
UTCZ = resolve_zone("UTC")
BERLIN = resolve_zone("Europe/Berlin")  # UTC+2 in May
NOW = datetime(2017, 5, 24, 6, 0, tzinfo=UTC)


@pytest.mark.parametrize(
    ("text", "zone", "expected"),
    [
        ("2017-05-24T10:00:00.123456789Z", BERLIN, T0 + 123_456_789),
        ("2017-05-24T10:00:00.1234567Z", BERLIN, T0 + 123_456_700),
        ("2017-05-24T12:00:00.000000001+02:00", UTCZ, T0 + 1),
        ("2017-05-24 12:00:00,987654321", BERLIN, T0 + 987_654_321),  # ISO's decimal comma
        ("2017-05-24 10:00:00.123456789 UTC", BERLIN, T0 + 123_456_789),
        ("2017-05-24T10:00:00.1234567890000Z", BERLIN, T0 + 123_456_789),  # zeros lose nothing
        ("12:00:00.999999999", BERLIN, T0 + 999_999_999),  # today, NOW's day
        ("today 12:00:00.000000500", BERLIN, T0 + 500),
        ("1495620000.123456789", BERLIN, T0 + 123_456_789),  # UNIX seconds
        ("@1495620000.000000001", BERLIN, T0 + 1),
        ("2017-05-24T10:00:00.123456Z", BERLIN, T0 + 123_456_000),  # as before
    ],
)
def test_decimals_past_the_microsecond_are_kept(text: str, zone: object, expected: int) -> None:
    assert parse_time(text, zone, NOW) == expected  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "decimals"),
    [
        ("2017-05-24T10:00:00.1234567891Z", 10),
        ("10:00:00.0000000001", 10),
        ("@1495620000.1234567891", 10),
        ("1495620000.000000000001", 12),
        ("@1.000000000000000000000000000001", 30),  # past Decimal's 28 digits too
    ],
)
def test_a_decimal_past_the_nanosecond_is_refused_not_cut(text: str, decimals: int) -> None:
    with pytest.raises(TimeFormatError) as caught:
        parse_time(text, UTCZ, NOW)
    assert caught.value.message == (
        f"the time {text!r} has {decimals} decimals: aion's times are whole nanoseconds"
    )
    assert caught.value.hint == "give at most 9 decimals of a second"


def test_predict_time_keeps_the_nanoseconds(office: Office) -> None:
    """``aion predict --time`` with 9 and 7 decimals: ``time_ns`` is the instant typed."""
    base = run_json("predict", office.map, "--time", "2026-11-23T08:30:00Z", "--format", "json")
    for typed, extra in (("123456789", 123_456_789), ("1234567", 123_456_700)):
        doc = run_json(
            "predict", office.map, "--time", f"2026-11-23T08:30:00.{typed}Z", "--format", "json"
        )
        assert doc["time_ns"] == base["time_ns"] + extra
    unix = run_json("predict", office.map, "--time", f"{base['time_ns'] // S}.000000007",
                    "--format", "json")  # fmt: skip
    assert unix["time_ns"] == base["time_ns"] + 7


def test_predict_refuses_a_time_past_the_nanosecond(office: Office) -> None:
    result = run("predict", office.map, "--time", "2026-11-23T08:30:00.1234567891Z")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "has 10 decimals: aion's times are whole nanoseconds")
