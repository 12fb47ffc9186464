"""aion_cli.engine.time_text: the one place a UNIX-ns time becomes a datetime or text. The
expected values are written out by hand (and checked against ``date -u -d @...``)."""

from __future__ import annotations

from datetime import UTC, timedelta, timezone
from zoneinfo import ZoneInfo

from aion_cli.engine.time_text import (
    Zone,
    format_ns,
    from_ns,
    iso_utc,
    on_clock,
    utc_ends,
    utc_of,
    utc_text,
)

S = 10**9
TOKYO = Zone(ZoneInfo("Asia/Tokyo"), "Asia/Tokyo")
T = 1_351_038_020 * S  # 2012-10-24 00:20:20 UTC, 09:20:20 in Tokyo


def test_the_text_forms_of_one_time() -> None:
    t = T + 123_456_789
    assert utc_text(t) == "2012-10-24 00:20:20 UTC"
    assert iso_utc(t) == "2012-10-24T00:20:20.123456Z"  # cut, never rounded up
    assert format_ns(t, TOKYO) == "2012-10-24 09:20:20+09:00"
    assert format_ns(t, TOKYO, millis=True) == "2012-10-24 09:20:20.123+09:00"
    assert format_ns(T + 999_600_000, TOKYO, millis=True) == "2012-10-24 09:20:21.000+09:00"
    assert from_ns(t, TOKYO).isoformat() == "2012-10-24T09:20:20.123456+09:00"


def test_the_last_nanosecond_of_a_day_stays_in_that_day() -> None:
    """Through float seconds ``...23:59:59.999999999`` became the next day."""
    t = 1_700_006_400 * S - 1  # 1 ns before 2023-11-15 00:00:00 UTC
    assert utc_text(t) == "2023-11-14 23:59:59 UTC"
    assert iso_utc(t) == "2023-11-14T23:59:59.999999Z"
    assert utc_of(t) == utc_of(1_700_006_400 * S) - timedelta(microseconds=1)


def test_a_time_before_1970_is_cut_towards_the_earlier_microsecond() -> None:
    assert iso_utc(-1) == "1969-12-31T23:59:59.999999Z"
    assert utc_text(-1) == "1969-12-31 23:59:59 UTC"


def test_a_time_beyond_datetime_is_shown_as_its_number() -> None:
    assert utc_text(10**30) == f"{10**30} ns"
    assert iso_utc(-(10**30)) == f"{-(10**30)} ns"


def test_on_clock_reads_both_utc_forms_again_on_a_zone_clock() -> None:
    text = (
        f"a message on /tracks at {iso_utc(T + 500_000_000)} skipped; first: {utc_text(T)}; "
        "the range is 1900-01-01 .. 2261-01-01 UTC"
    )
    assert on_clock(text, TOKYO) == (
        "a message on /tracks at 2012-10-24T09:20:20.500000+09:00 skipped; first: "
        "2012-10-24 09:20:20+09:00; the range is 1900-01-01 .. 2261-01-01 UTC"
    )
    assert on_clock(text, Zone(UTC, "UTC")) == text


def test_the_ends_of_a_span_within_a_second_read_apart() -> None:
    """Both ends of a span cut to the second read alike ("00:20:20 to 00:20:20") when it lies
    within one second: as many decimals as tell them apart, cut as utc_text cuts."""
    assert utc_ends(T + 200_000_000, T + 500_000_000) == (
        "2012-10-24 00:20:20.2 UTC",
        "2012-10-24 00:20:20.5 UTC",
    )
    assert utc_ends(T + 123_456_789, T + 129_999_999) == (
        "2012-10-24 00:20:20.123 UTC",
        "2012-10-24 00:20:20.129 UTC",
    )
    assert utc_ends(T + 1_000, T + 2_999) == (
        "2012-10-24 00:20:20.000001 UTC",
        "2012-10-24 00:20:20.000002 UTC",
    )
    # ends in other seconds, however close, keep utc_text's form
    assert utc_ends(T - 1, T) == ("2012-10-24 00:20:19 UTC", "2012-10-24 00:20:20 UTC")
    assert utc_ends(T, T + 3 * 60 * S) == (utc_text(T), "2012-10-24 00:23:20 UTC")
    # one instant, or ends no microsecond tells apart, or beyond datetime: as utc_text
    assert utc_ends(T, T) == (utc_text(T), utc_text(T))
    assert utc_ends(T + 1, T + 999) == (utc_text(T), utc_text(T))
    assert utc_ends(10**30, 10**30 + 1) == (f"{10**30} ns", f"{10**30 + 1} ns")


def test_on_clock_keeps_the_decimals_of_a_spans_ends() -> None:
    start, end = utc_ends(T + 250_000_000, T + 290_000_000)
    assert on_clock(f"from {start} to {end}", TOKYO) == (
        "from 2012-10-24 09:20:20.25+09:00 to 2012-10-24 09:20:20.29+09:00"
    )
    monrovia = Zone(ZoneInfo("Africa/Monrovia"), "Africa/Monrovia")  # -00:44:30 until 1972
    assert on_clock("1970-01-01 00:00:00.5 UTC", monrovia) == "1969-12-31 23:15:30.5-00:44:30"


def test_on_clock_gives_each_side_of_a_clock_change_its_offset() -> None:
    """Berlin's autumn change repeats 02:00..03:00: the two times read alike but for their
    offsets, as their UTC forms differ."""
    berlin = Zone(ZoneInfo("Europe/Berlin"), "Europe/Berlin")
    first = on_clock("2026-10-25 00:30:00 UTC", berlin)
    second = on_clock("2026-10-25 01:30:00 UTC", berlin)
    assert (first, second) == ("2026-10-25 02:30:00+02:00", "2026-10-25 02:30:00+01:00")


def test_on_clock_leaves_what_no_zone_can_show() -> None:
    west = Zone(timezone(-timedelta(hours=5)), "-05:00")
    assert on_clock("0001-01-01 00:00:00 UTC", west) == "0001-01-01 00:00:00 UTC"
    assert on_clock("2023-02-30 00:00:00 UTC", west) == "2023-02-30 00:00:00 UTC"
    assert on_clock("1795420200000000000 ns", west) == "1795420200000000000 ns"


def test_the_module_needs_the_standard_library_only() -> None:
    """Every layer imports it (formats, the engine, the CLI), so it imports none of them."""
    import ast
    import sys
    from pathlib import Path

    import aion_cli.engine.time_text as module

    tree = ast.parse(Path(str(module.__file__)).read_text())
    roots = {
        (node.module or "").split(".")[0] if isinstance(node, ast.ImportFrom) else alias.name
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
        for alias in node.names
    }
    assert roots <= set(sys.stdlib_module_names) | {"__future__"}, roots
