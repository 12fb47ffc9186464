"""Words for times in aion's notes: clock times of in-day bins and their runs, spans of
days, durations rounded for reading, and dates in a zone. Shared by the forecast notes, with
the mark of a forecast at an hour no log observed (:data:`EXTRAPOLATED`)."""

from __future__ import annotations

EXTRAPOLATED = "(extrapolated: an hour no log observed)"
"""The mark, in a title, of a forecast at a time whose hour no day of the map observed (JSON
``hour_observed`` false): the tables of ``predict --time`` and ``plan``, the pictures of
``plan --png`` and of ``export --format png`` at one time (a series marks each row or panel
``extrapolated`` alone). Here, beside no import, so that the CLI names it at load."""

WEEKDAYS = ("Monday", "Tuesday", "Wednesday", "Thursday", "Friday", "Saturday", "Sunday")


def clock(index: int, bin_s: float) -> str:
    """``HH:MM`` of the start of in-day bin ``index`` (24:00 for the end of the day)."""
    minutes = round(index * bin_s / 60.0)
    return f"{minutes // 60:02d}:{minutes % 60:02d}"


def clock_ranges(bins: list[int], bin_s: float) -> str:
    """``09:00-12:00, 13:00-18:00`` for sorted in-day bins, runs joined."""
    runs: list[tuple[int, int]] = []
    for b in bins:
        if runs and b == runs[-1][1]:
            runs[-1] = (runs[-1][0], b + 1)
        else:
            runs.append((b, b + 1))
    return ", ".join(f"{clock(a, bin_s)}-{clock(b, bin_s)}" for a, b in runs)


def span_days(first: int, last: int) -> str:
    """``Mon 2026-01-05 to Fri 2026-01-09`` for local day indices."""
    from datetime import date, timedelta

    def name(d: int) -> str:
        when = date(1970, 1, 1) + timedelta(days=d)
        return f"{WEEKDAYS[when.weekday()][:3]} {when.isoformat()}"

    return name(first) if first == last else f"{name(first)} to {name(last)}"


def duration(ns: int) -> str:
    """``ns`` rounded for reading: seconds, minutes, hours, days, weeks or years (under an
    hour in minutes, under a minute in seconds, at least one: a time 40 s before a map's
    first detection was "0 hours before" it)."""
    hours = ns / 3.6e12
    for n, unit in ((max(1, round(ns / 1e9)), "second"), (round(ns / 6e10), "minute")):
        if n < 60:
            return f"{n} {unit}{'' if n == 1 else 's'}"
    for below_h, unit_h, unit in ((48, 1, "hour"), (14 * 24, 24, "day"), (730 * 24, 168, "week")):
        if hours < below_h:
            n = round(hours / unit_h)
            return f"{n} {unit}{'' if n == 1 else 's'}"
    return f"{hours / (365.25 * 24):.1f} years"


def day(t_ns: int, zone: str | None = None) -> str:
    """The date of ``t_ns`` in ``zone`` (UTC when None), ``YYYY-MM-DD``."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.errors import AionError
    from aion_cli.timeparse import resolve_zone

    try:
        resolved = resolve_zone(zone or "UTC")
    except AionError:  # a damaged manifest's zone: the note still reads, in UTC
        resolved = resolve_zone("UTC")
    return format_ns(t_ns, resolved)[:10]
