"""Which instant a wall-clock time a clock change skips or repeats was read as.

``--time "2026-03-29 02:30"`` in Europe/Berlin names a time that does not exist (the clocks
jump from 02:00 to 03:00) and is read as 03:30 summer time; ``"2026-10-25 02:30"`` happens
twice and is read as its first occurrence (summer time). :mod:`aion_cli.timeparse` reads
them so (PEP 495's ``fold=0``); :func:`clock_change_note` says so, where the text was a
wall-clock time of its zone (not a UNIX time, an ISO time with its own offset, or a
relative one, which name one instant); :func:`wall_clock_note` also for the Python API's
naive ``datetime`` (read by its ``fold``).
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, cast

from aion_cli.engine.time_text import Zone, format_ns, from_ns, repeated_wall_clock
from aion_cli.timeparse import (
    TimeFormatError,
    offset_changes_near,
    parse_time,
    resolve_zone,
    to_ns,
    zone_named_in,
)


def clock_change_note(text: str, zone: Zone, t_ns: int, now: datetime | None = None) -> str | None:
    """A note when ``text`` (read in ``zone`` unless it names one) is a wall-clock time that a
    clock change skips or repeats, saying which instant ``t_ns`` it was read as; None
    otherwise. ``now`` (aware): the moment day words count from (default: the current
    time)."""
    where = zone_named_in(text, zone)
    if not offset_changes_near(t_ns, where):
        return None
    wall = _wall_clock_of(text, zone, now)
    if wall is None:
        return None
    local = from_ns(t_ns, where)
    said = wall.isoformat(sep=" ", timespec="minutes")
    if local.replace(tzinfo=None) != wall:
        return (
            f"{said} does not exist in {where.name} (a clock change skips it): read as "
            f"{format_ns(t_ns, where)}, as late as the clocks jump"
        )
    if not repeated_wall_clock(local):
        return None
    second = to_ns(wall.replace(tzinfo=where.tz, fold=1))
    return (
        f"{said} happens twice in {where.name} (a clock change repeats it): read as the "
        f"first, {format_ns(t_ns, where)}; the second is {format_ns(second, where)}"
    )


def skipped_wall(
    text: object, zone: Zone, t_ns: int, now: datetime | None = None
) -> datetime | None:
    """The wall-clock time (naive) ``text`` names in ``zone`` when a clock change skips it, so
    ``t_ns`` reads otherwise (``2026-03-29 02:30`` in Europe/Berlin, read as 03:30 summer
    time); None for any other time, a time of another zone it names, or a ``text`` that is no
    string nor a naive ``datetime`` (the API's aware datetimes and numbers name one instant;
    a naive one is a wall-clock time of ``zone``, as a string without an offset is). A daily
    series from such a start keeps the wall-clock time typed on its other days (02:30, not
    03:30)."""
    if isinstance(text, datetime):
        wall: datetime | None = text.replace(fold=0) if text.tzinfo is None else None
    elif not isinstance(text, str) or zone_named_in(text, zone).tz != zone.tz:
        return None
    else:
        wall = _wall_clock_of(text, zone, now)
    if wall is None or from_ns(t_ns, zone).replace(tzinfo=None) == wall:
        return None
    return wall if to_ns(wall.replace(tzinfo=zone.tz, fold=0)) == t_ns - t_ns % 1000 else None


def _wall_clock_of(text: str, zone: Zone, now: datetime | None) -> datetime | None:
    """The wall-clock time (naive) ``text`` names in the zone it is read in (the one it names
    at its end, else ``zone``); None where it names an instant of its own (a UNIX time, an
    ISO time with an offset, a relative time) or is no time."""
    where = zone_named_in(text, zone)
    head = " ".join(text.strip().split())
    if where is not zone:
        head = head.rpartition(" ")[0]
    utc = resolve_zone("UTC")
    # the same wall clock as the zone's "now", so day words name the same day
    local_now = (now or datetime.now(UTC)).astimezone(where.tz).replace(tzinfo=UTC)
    try:
        wall_ns = parse_time(head, utc, local_now)
        shifted = parse_time(head, resolve_zone("UTC+01:00"), local_now)
    except TimeFormatError:
        return None
    if wall_ns == shifted:  # an instant of its own: UNIX, ISO with an offset, relative
        return None
    return from_ns(wall_ns, utc).replace(tzinfo=None)


def wall_clock_note(time: object, zone: Zone, t_ns: int) -> str | None:
    """:func:`clock_change_note` of a time as the Python API takes it: a string, or a naive
    ``datetime`` or ``numpy.datetime64``, a wall-clock time of ``zone`` as a string without
    an offset is (README: a naive datetime is such a wall-clock time), read by its ``fold``
    as PEP 495 has it: 0 (the default) the first of a repeated time and a skipped one as late
    as the clocks jump, as a string is read; 1 the other (a ``datetime64`` has no fold: 0,
    and its note says a ``datetime`` names the other). None for an aware ``datetime`` or
    nanoseconds (one instant each), and away from a clock change."""
    if isinstance(time, str):
        return clock_change_note(time, zone, t_ns)
    other_fold = "fold={}"  # how to ask for the other instant
    if type(time).__name__ == "datetime64":  # numpy's, read as a naive datetime of fold 0
        micro = cast(Any, time).astype("datetime64[us]").item()  # NaT: None
        time = micro if isinstance(micro, datetime) else None
        other_fold = "a datetime64 has no fold: a datetime with fold={} names it"
    if not isinstance(time, datetime) or time.tzinfo is not None:
        return None
    if not offset_changes_near(t_ns, zone):
        return None
    said = time.isoformat(sep=" ", timespec="minutes")
    local = from_ns(t_ns, zone)
    if local.replace(tzinfo=None) != time.replace(tzinfo=None):
        return (
            f"{said} does not exist in {zone.name} (a clock change skips it): read as "
            f"{format_ns(t_ns, zone)}, as "
            + ("late as the clocks jump" if time.fold == 0 else "early as the clocks jump (fold=1)")
        )
    if not repeated_wall_clock(local):
        return None
    other = format_ns(to_ns(time.replace(tzinfo=zone.tz, fold=1 - time.fold)), zone)
    which, rest = ("first", "second") if time.fold == 0 else ("second", "first")
    return (
        f"{said} happens twice in {zone.name} (a clock change repeats it): read as the "
        f"{which}, {format_ns(t_ns, zone)}; the {rest} is {other} "
        f"({other_fold.format(1 - time.fold)})"
    )
