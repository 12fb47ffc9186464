"""aion's times, int64 nanoseconds since 1970 (UTC), as datetimes and as text: the one place
that turns them into either, for every layer (standard library only, no file I/O).

A ``datetime`` holds microseconds, so a time becomes one by integer floor division
(:func:`utc_of`), never through float seconds: near 2023 a float second has steps of about
0.24 µs and ``fromtimestamp`` rounds, so ``...59.999999999`` became the next second, minute or
day; floor division cuts a time before 1970 towards the earlier microsecond too. The text forms:

* :func:`utc_text`: ``2038-01-01 00:00:00 UTC``, as reports, notes and errors print a time,
  and :func:`utc_ends`, the two ends of a span so, with decimals where they would read alike;
* :func:`iso_utc`: ``2023-11-14T22:13:20.123456Z``, a log time to its microsecond
  (``aion info``'s ``start`` and ``end``, readers' warnings naming a message);
* :func:`format_ns`: ``2026-11-23 08:30:00+01:00``, a time on a zone's clock with its offset
  (:func:`offset_text`), and :func:`clock_labels`, times in a zone as labels that never read
  alike for two instants (the hour a clock change repeats);
* :func:`on_clock`: a message's times in the first two forms, read again on a zone's clock.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta, tzinfo

EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
"""The UNIX epoch, 1970-01-01T00:00Z, as an aware datetime."""
_NS_PER_US = 1000


@dataclass(frozen=True)
class Zone:
    """A time zone and the name shown to the user (``aion_cli.timeparse.resolve_zone``
    makes one from what ``--tz`` takes)."""

    tz: tzinfo
    name: str


def utc_of(t_ns: int) -> datetime:
    """A UNIX-ns time as an aware UTC datetime, cut to the microsecond in integer arithmetic
    (floor division: a time before 1970 is cut towards the earlier microsecond too).
    :class:`OverflowError` outside datetime's years 1..9999."""
    return EPOCH + timedelta(microseconds=int(t_ns) // _NS_PER_US)


def from_ns(t_ns: int, zone: Zone) -> datetime:
    """A UNIX-ns time as an aware datetime on ``zone``'s clock (cut to the microsecond, as
    :func:`utc_of` cuts it)."""
    return utc_of(t_ns).astimezone(zone.tz)


def utc_text(t_ns: int) -> str:
    """``2038-01-01 00:00:00 UTC`` for a UNIX-ns time (any Python int), cut to the second:
    the time as reports, notes and errors print it; the raw value (``... ns``) outside
    datetime's years."""
    try:
        return utc_of(t_ns).strftime("%Y-%m-%d %H:%M:%S UTC")
    except OverflowError:
        return f"{t_ns} ns"


def utc_ends(start_ns: int, end_ns: int) -> tuple[str, str]:
    """:func:`utc_text` of the two ends of a span; where they would read alike (a span of less
    than a second), both with as many decimals as tell them apart (up to six: a microsecond),
    cut as :func:`utc_of` cuts: ``2026-01-05 03:16:51.2 UTC`` to ``2026-01-05 03:16:51.5 UTC``."""
    first, last = utc_text(start_ns), utc_text(end_ns)
    if first != last or first.endswith(" ns"):
        return first, last
    for digits in range(1, 7):
        step = 10 ** (9 - digits)
        if start_ns // step != end_ns // step:
            return _with_decimals(start_ns, digits), _with_decimals(end_ns, digits)
    return first, last


def _with_decimals(t_ns: int, digits: int) -> str:
    """:func:`utc_text` with ``digits`` decimals of the second (cut, not rounded)."""
    moment = utc_of(t_ns)
    return f"{moment:%Y-%m-%d %H:%M:%S}.{moment.microsecond:06d}"[: 20 + digits] + " UTC"


def iso_utc(t_ns: int) -> str:
    """A log time as UTC ISO 8601 with microseconds, cut (never rounded up) as :func:`utc_of`
    cuts it: ``2023-11-14T22:13:20.123456Z`` (``aion info``'s ``start`` and ``end``, and
    messages); the raw value (``... ns``) outside datetime's years."""
    try:
        return utc_of(t_ns).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    except OverflowError:
        return f"{t_ns} ns"


def format_ns(t_ns: int, zone: Zone, *, millis: bool = False) -> str:
    """Readable ISO form with offset, e.g. ``2026-11-23 08:30:00+01:00``; with ``millis``,
    rounded to the nearest millisecond (``2026-11-23 08:30:02.667+01:00``), else cut to the
    second."""
    if not millis:
        return from_ns(t_ns, zone).isoformat(sep=" ", timespec="seconds")
    ns_per_ms = 1_000_000
    nearest = (int(t_ns) + ns_per_ms // 2) // ns_per_ms * ns_per_ms
    return from_ns(nearest, zone).isoformat(sep=" ", timespec="milliseconds")


def offset_text(moment: datetime) -> str:
    """The UTC offset of an aware ``moment`` as ISO writes it: ``+02:00`` (``-00:44:30`` for
    an offset of seconds, Monrovia's until 1972)."""
    seconds = round((moment.utcoffset() or timedelta(0)).total_seconds())
    hours, rest = divmod(abs(seconds), 3600)
    text = f"{'-' if seconds < 0 else '+'}{hours:02d}:{rest // 60:02d}"
    return text + (f":{rest % 60:02d}" if rest % 60 else "")


def repeated_wall_clock(moment: datetime) -> bool:
    """Whether the wall-clock time of an aware ``moment`` happens twice (the hour a clock
    change repeats): its other fold has another offset."""
    return moment.replace(fold=1 - moment.fold).utcoffset() != moment.utcoffset()


def clock_labels(times_ns: Sequence[int], zone: Zone, form: str) -> list[str]:
    """``strftime(form)`` of each time in ``zone``; where two different times read the same
    (the hour a clock change repeats: 01:30 twice), their UTC offsets are added
    (``01:30 +02:00``, ``01:30 +01:00``), so no two rows or panels look alike."""
    stamps = [from_ns(int(t), zone) for t in times_ns]
    labels = [s.strftime(form) for s in stamps]
    instants: dict[str, set[int]] = {}
    for label, t in zip(labels, times_ns, strict=True):
        instants.setdefault(label, set()).add(int(t))
    return [
        f"{label} {offset_text(s)}" if len(instants[label]) > 1 else label
        for label, s in zip(labels, stamps, strict=True)
    ]


_UTC_FORMS = re.compile(
    r"\b(\d{4}-\d{2}-\d{2}) (\d{2}:\d{2}:\d{2})(\.\d{1,6})? UTC\b"  # utc_text's, utc_ends'
    r"|\b(\d{4}-\d{2}-\d{2})T(\d{2}:\d{2}:\d{2})\.(\d{6})Z\b"  # iso_utc's
)


def on_clock(text: str, zone: Zone) -> str:
    """``text`` (a warning, a note) with each time :func:`utc_text` or :func:`iso_utc` wrote
    in it read again on ``zone``'s clock with its offset, at the precision it had:
    ``2012-10-24 00:20:20 UTC`` -> ``2012-10-24 09:20:20+09:00``,
    ``2012-10-24 00:20:20.25 UTC`` (:func:`utc_ends`) -> ``2012-10-24 09:20:20.25+09:00``,
    ``2012-10-24T00:20:20.500000Z`` -> ``2012-10-24T09:20:20.500000+09:00`` (Asia/Tokyo).
    Messages are written in UTC wherever they arise (a reader knows no zone); a command that
    shows every time on one zone's clock passes its messages through this. Unchanged in UTC."""
    if zone.tz is UTC:
        return text

    def local(match: re.Match[str]) -> str:
        day, clock, decimals, day_us, clock_us, micros = match.groups()
        try:
            if day is not None:
                moment = datetime.fromisoformat(f"{day}T{clock}+00:00")
                shown = moment.astimezone(zone.tz).isoformat(sep=" ", timespec="seconds")
                return shown[:19] + (decimals or "") + shown[19:]  # the decimals before the offset
            moment = datetime.fromisoformat(f"{day_us}T{clock_us}.{micros}+00:00")
            return moment.astimezone(zone.tz).isoformat(timespec="microseconds")
        except (ValueError, OverflowError):  # no date (2023-02-30), or the zone's is beyond 9999
            return match.group(0)

    return _UTC_FORMS.sub(local, text)
