"""``START..END`` spans (``--observed``, ``--leave``) and ``now`` ending them: the time parser
of :mod:`tests.cli.test_timeparse` read relative to a span's start."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from aion_cli.cli.common import parse_span
from aion_cli.errors import InputError
from aion_cli.timeparse import parse_time, resolve_zone, to_ns
from tests.cli.test_timeparse import BERLIN, NOW, UTCZ, S, ns


def test_a_spans_end_counts_from_its_start_not_from_now() -> None:
    """A clock alone, a day word or a relative end of ``START..END`` is read from START's
    moment (the spans of --observed and --leave); a full date or UNIX seconds as given."""
    berlin = resolve_zone("Europe/Berlin")
    start, end = parse_span("2026-03-28 22:00..tomorrow 06:00", berlin, "--observed")
    assert (end - start) // 10**9 == 7 * 3600  # the night of the spring clock change
    start, end = parse_span("2017-06-09 09:00..18:30", resolve_zone("UTC"), "--observed")
    assert (start, end) == (1496998800 * 10**9, 1497033000 * 10**9)
    start, end = parse_span("1497000600..+2h", resolve_zone("UTC"), "--leave")
    assert end - start == 2 * 3600 * 10**9
    with pytest.raises(InputError, match="the end is not after the start"):
        parse_span("2017-06-09 22:00..06:00", resolve_zone("UTC"), "--observed")


def test_now_ends_a_span_now_not_at_its_start() -> None:
    """``now`` (and ``now+2h``) ending a span is the current time: it had been counted from
    the span's start as ``+2h`` is, so ``--from "2026-11-20 08:00" --to now`` was a series of
    its start alone and ``--leave "08:00..now"`` an empty span. ``+2h`` still counts from the
    start, and a bare ``now`` reads the same with or without a start."""
    start = datetime(2026, 11, 20, 8, 0, tzinfo=UTC)  # two days before NOW
    assert parse_time("now", UTCZ, NOW, start=start) == to_ns(NOW)
    assert parse_time("NOW", BERLIN, NOW, start=start) == to_ns(NOW)
    assert parse_time("now+2h", UTCZ, NOW, start=start) == to_ns(NOW) + 2 * 3600 * S
    assert parse_time("now -30m", UTCZ, NOW, start=start) == to_ns(NOW) - 1800 * S
    assert parse_time("+2h", UTCZ, NOW, start=start) == ns(2026, 11, 20, 10, 0)
    assert parse_time("18:00", UTCZ, NOW, start=start) == ns(2026, 11, 20, 18, 0)
    assert parse_time("tomorrow 06:00", UTCZ, NOW, start=start) == ns(2026, 11, 21, 6, 0)
    assert parse_time("now", UTCZ, NOW) == to_ns(NOW)


@pytest.mark.parametrize(
    ("span", "zone", "clock_change"),
    [
        # one instant written twice, no clock change anywhere near: only the times read
        ("2026-01-12 08:00..08:00", "UTC", False),
        ("1768204800..2026-01-12 08:00", "UTC", False),
        ("2026-01-12 09:00 Europe/Berlin..08:00", "UTC", False),
        ("2026-07-12 08:00..08:00", "Europe/Berlin", False),
        # Berlin skips 02:00..03:00 that day: both ends are 03:00 CEST, and that is why
        ("2026-03-29 02:00..03:00", "Europe/Berlin", True),
        ("2026-03-29 02:00 Europe/Berlin..2026-03-29 03:00 Europe/Berlin", "UTC", True),
    ],
)
def test_an_empty_span_blames_a_clock_change_only_where_there_is_one(
    span: str, zone: str, clock_change: bool
) -> None:
    """``--leave "2026-01-12 08:00..08:00"`` in UTC said "a clock change skips or repeats an
    hour there": any two spellings of one instant were blamed on daylight saving."""
    with pytest.raises(InputError, match="the end is not after the start") as caught:
        parse_span(span, resolve_zone(zone), "--leave")
    assert ("a clock change skips or repeats an hour there" in caught.value.message) is (
        clock_change
    )


@pytest.mark.parametrize(
    ("span", "zone", "clock_change"),
    [
        # one wall-clock time written twice beside a clock change: not the change's doing
        ("2026-03-29 03:00..03:00", "Europe/Berlin", False),
        ("2026-03-29 03:00..2026-03-29T03:00", "Europe/Berlin", False),
        ("2026-10-25 02:30..02:30", "Europe/Berlin", False),
        ("2026-03-29 02:30 Europe/Berlin..2026-03-29 02:30 Europe/Berlin", "UTC", False),
        # two zones' times of one instant: "03:30 CEST" is "01:30 UTC"
        ("2026-03-29 03:30..01:30 UTC", "Europe/Berlin", False),
        ("2026-03-29 01:30..2026-03-29 03:30 Europe/Berlin", "UTC", False),
        # the skipped hour's times are the change's doing
        ("2026-03-29 02:30..03:30", "Europe/Berlin", True),
        ("2026-03-29 02:30..2026-03-29 03:30 Europe/Berlin", "Europe/Berlin", True),
    ],
)
def test_an_empty_span_beside_a_clock_change_blames_it_only_for_two_wall_clock_times(
    span: str, zone: str, clock_change: bool
) -> None:
    """``--observed "2026-03-29 03:00..03:00"`` in Europe/Berlin said "a clock change skips or
    repeats an hour there": one time written twice, an hour after the change."""
    with pytest.raises(InputError, match="the end is not after the start") as caught:
        parse_span(span, resolve_zone(zone), "--observed")
    assert ("a clock change skips or repeats an hour there" in caught.value.message) is (
        clock_change
    )
