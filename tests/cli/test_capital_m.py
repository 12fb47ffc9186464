"""A length with a capital ``M`` (``1M``, ``now-1M``) is refused: aion's durations ignore case,
so it would silently be a minute where the writer most likely meant a month (found by stop
70's API pass). Lower-case minutes, and the capital M of clocks and zones (``1 PM``,
``MST``), read as before."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from aion_cli.graph_schedule import parse_period_ns
from aion_cli.time_steps import parse_step
from aion_cli.timeparse import TimeFormatError, parse_time, resolve_zone

UTCZ = resolve_zone("UTC")
NOW = datetime(2026, 1, 9, 12, 0, tzinfo=UTC)
NOW_NS = int(NOW.timestamp()) * 10**9


@pytest.mark.parametrize("text", ["1M", "30 M", "1h30M", "+1M"])
def test_a_step_or_period_with_a_capital_m_is_refused_naming_months(text: str) -> None:
    for parse in (lambda: parse_step(text, "--step"), lambda: parse_period_ns(text)):
        with pytest.raises(TimeFormatError, match="capital M") as caught:
            parse()
        assert "30d" in caught.value.hint


def test_minutes_in_lower_case_read_as_before() -> None:
    assert parse_step("1m", "--step").exact_ns == 60 * 10**9
    assert parse_step("1h30m", "--step").exact_ns == 5400 * 10**9
    assert parse_period_ns("1m") == 60 * 10**9
    assert parse_time("now-1m", UTCZ, NOW) == NOW_NS - 60 * 10**9


def test_a_relative_time_with_a_capital_m_is_refused() -> None:
    with pytest.raises(TimeFormatError, match="capital M in 'now-1M'"):
        parse_time("now-1M", UTCZ, NOW)


def test_clocks_and_zones_with_a_capital_m_are_times() -> None:
    one_pm = int(datetime(2026, 1, 9, 13, 0, tzinfo=UTC).timestamp()) * 10**9
    assert parse_time("2026-01-09 1PM", UTCZ, NOW) == one_pm
    assert parse_time("2026-01-09 13:00 UTC", UTCZ, NOW) == one_pm
    assert parse_time("2026-01-09 06:00 MST", UTCZ, NOW) == one_pm  # MST: UTC-7 all year
