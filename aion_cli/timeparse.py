"""Times the user types on the command line -> int64 nanoseconds since the UNIX epoch.

Accepted forms (case-insensitive), interpreted in the zone given by ``--tz`` (default: the
machine's local zone) unless the text carries its own offset:

* ISO 8601 with or without a zone: ``2026-11-23 08:30`` (or ``8:30``),
  ``2026-11-23T08:30:00+01:00``, ``2026-11-23T07:30Z``, ``2026-11-23`` (midnight), and any
  form followed by a zone: ``2026-11-23 08:30 Europe/Berlin``, ``tomorrow 12:00 UTC``,
  ``08:30 +01:00``;
* UNIX time: ``1795420200``, ``@1795420200.5`` (seconds), ``1795420200000000000ns``;
* wherever seconds go, up to 9 decimals, kept to the nanosecond (``10:00:00.123456789``,
  ``@1495620000.123456789``); more is an error, never cut;
* relative to now: ``now``, ``+2h``, ``-30m``, ``+1d12h``, ``now+90s`` (units w, d, h, m, s);
* a day word and an optional wall-clock time: ``today 17:00``, ``tomorrow 12:00``,
  ``yesterday 08:15:30``, ``monday 08:30`` (the next Monday, today included), ``tomorrow``
  (now + 1 day), ``monday`` (next Monday, 00:00);
* a bare wall-clock time ``08:30`` (today);
* wherever a wall-clock time goes, its 12-hour form: ``9am``, ``9:30 pm``, ``tomorrow 9am``,
  ``friday 5:45pm``, ``2026-11-23 9am`` (``12am`` is midnight, ``12pm`` noon).

Nothing here depends on click: errors are :class:`TimeFormatError` (an ``InputError``).
"""

from __future__ import annotations

import re
from datetime import UTC, date, datetime, time, timedelta
from decimal import Decimal, InvalidOperation

from aion_cli.engine.time_text import EPOCH, Zone, from_ns, offset_text
from aion_cli.time_numbers import refuse_misread_number
from aion_cli.time_zones import ZONE_HINT as ZONE_HINT
from aion_cli.time_zones import TimeFormatError as TimeFormatError
from aion_cli.time_zones import local_zone as local_zone
from aion_cli.time_zones import refuse_capital_m as refuse_capital_m
from aion_cli.time_zones import resolve_zone as resolve_zone

NS_PER_S = 1_000_000_000
MIN_TIME_NS = -2_208_988_800 * NS_PER_S
"""Earliest time accepted, 1900-01-01T00:00Z."""
MAX_TIME_NS = 9_183_110_400 * NS_PER_S
"""Latest time accepted, 2261-01-01T00:00Z: times are int64 nanoseconds (which end on
2262-04-11), and the margin keeps window, calendar and planning arithmetic exact."""
RANGE_TEXT = "1900-01-01 .. 2261-01-01 UTC"

FORMS_HINT = (
    'use ISO 8601 ("2026-11-23 08:30", "2026-11-23T08:30:00+01:00"), UNIX seconds '
    '("1795420200"), a relative time ("now", "+2h", "-30m") or "tomorrow 12:00" / "tomorrow 9am"'
)

DAY_SHIFTS = {"today": 0, "tomorrow": 1, "yesterday": -1}
"""The day words, by the days they shift today (alone: now shifted, as GNU date)."""

UNITS_S = {"w": 604800, "d": 86400, "h": 3600, "m": 60, "min": 60, "s": 1, "sec": 1}
_WEEKDAYS = {
    name: i
    for i, names in enumerate(
        [
            ("monday", "mon"),
            ("tuesday", "tue"),
            ("wednesday", "wed"),
            ("thursday", "thu"),
            ("friday", "fri"),
            ("saturday", "sat"),
            ("sunday", "sun"),
        ]
    )
    for name in names
}
_CLOCK = r"(\d{1,2}):(\d{2})(?::(\d{2})(?:\.(\d{1,6}))?)?"
_RE_CLOCK = re.compile(rf"^{_CLOCK}$")
_RE_CLOCK12 = re.compile(r"^(\d{1,2})(?::(\d{2})(?::(\d{2}))?)?\s*(am|pm)$")
_RE_DAYWORD = re.compile(r"^([a-z]+)(?:\s+(.+))?$")
_RE_RELATIVE = re.compile(r"^(?:now\s*)?([+-])\s*((?:\d+(?:\.\d+)?\s*[a-z]+\s*)+)$")
_RE_NOW = re.compile(r"^now(?![a-z])")  # the current moment (now, now+2h), whatever it ends
RE_REL_PART = re.compile(r"(\d+(?:\.\d+)?)\s*([a-z]+)")
_RE_UNIX = re.compile(r"^@?(-?\d+(?:\.\d+)?)\s*(s|ns)?$")
_RE_ONE_DIGIT_HOUR = re.compile(r"^(\d{4}-\d{2}-\d{2}[ T])(\d:)")
_RE_DATE_CLOCK12 = re.compile(r"^(\d{4}-\d{2}-\d{2})[ t](\d.*[ap]m)$")
_RE_ZONE_WORD = re.compile(r"^[a-z][a-z0-9_+/-]*$", re.IGNORECASE)
_RE_OFFSET_WORD = re.compile(r"^[+-]\d{2}(?::?\d{2})?$")
"""A UTC offset written alone after a time (``+01:00``, ``-0500``, ``+05``)."""
_RE_FRACTION = re.compile(r"(\d:\d{2}:\d{2})[.,](\d+)")
"""The fraction of a clock's seconds (``10:00:00.123456789``, ISO's ``10:00:00,5`` too)."""
_RE_OWN_OFFSET = re.compile(r"\d:\d{2}(?::\d{2}(?:\.\d+)?)?\s*(z|[+-]\d{2}(?::?\d{2})?)$")
"""An ISO time's own offset at its end (``...08:30Z``, ``...08:30+02:00``, ``...08:30-05``)."""


# -- conversions -------------------------------------------------------------------------------
def to_ns(moment: datetime) -> int:
    """An aware datetime -> exact int nanoseconds since the UNIX epoch."""
    delta = moment - EPOCH
    return (delta.days * 86400 + delta.seconds) * NS_PER_S + delta.microseconds * 1000


def zone_named_in(text: str, zone: Zone) -> Zone:
    """The zone :func:`parse_time` reads ``text`` in: the one it names at its end
    (``08:30 Europe/Berlin``), else ``zone``."""
    return _split_zone(" ".join(text.strip().split()), zone)[1]


def offset_changes_near(t_ns: int, zone: Zone, hours: int = 3) -> bool:
    """Whether ``zone``'s UTC offset differs ``hours`` before and after ``t_ns``: a clock
    change (daylight saving) near that moment, which can make two wall-clock times one
    instant."""
    shift = hours * 3600 * NS_PER_S
    return from_ns(t_ns - shift, zone).utcoffset() != from_ns(t_ns + shift, zone).utcoffset()


def one_wall_clock(start: str, end: str, zone: Zone) -> bool:
    """Whether a span's two ends name one wall-clock time, whatever zones they are read in
    (``2026-03-29 03:00..03:00``: one time, even where a clock change is near; not
    ``02:30..03:30``, which Berlin's spring change makes one instant)."""
    utc = resolve_zone("UTC")
    try:
        a = parse_time(_split_zone(" ".join(start.strip().split()), zone)[0], utc)
        b = parse_time(
            _split_zone(" ".join(end.strip().split()), zone)[0], utc, start=from_ns(a, utc)
        )
    except TimeFormatError:
        return False
    return a == b


def _wall(day: date, clock: time, zone: Zone) -> datetime:
    return datetime.combine(day, clock).replace(tzinfo=zone.tz)


def _wall_clock(part: str, text: str) -> time | None:
    """The wall-clock time ``part`` (``08:30``, ``8:30:15.5``, ``9am``, ``9:30 pm``) of the
    time ``text``; None if ``part`` is not one."""
    match = _RE_CLOCK.match(part)
    if match:
        return _clock(match.groups(), text)
    match = _RE_CLOCK12.match(part)
    if not match:
        return None
    hour, minute, second, half = match.groups()
    if not 1 <= int(hour) <= 12:
        raise TimeFormatError(
            f"invalid clock time in {text!r}: the hour of a 12-hour time is 1 to 12", FORMS_HINT
        )
    hour24 = int(hour) % 12 + (12 if half == "pm" else 0)
    return _clock((str(hour24), minute, second, None), text)


def _clock(groups: tuple[str | None, ...], text: str) -> time:
    hour, minute, second, frac = groups
    try:
        return time(
            int(hour or 0),
            int(minute or 0),
            int(second or 0),
            int((frac or "0").ljust(6, "0")),
        )
    except ValueError as exc:
        raise TimeFormatError(f"invalid clock time in {text!r}: {exc}", FORMS_HINT) from exc


# -- parsing -----------------------------------------------------------------------------------
def parse_time(
    text: str, zone: Zone, now: datetime | None = None, *, start: datetime | None = None
) -> int:
    """Parse ``text`` (see the module docstring) -> int nanoseconds since the UNIX epoch.
    ``now`` (aware) pins the reference for relative forms; default: the current time.
    ``start`` (aware): the start of the span ``text`` ends, which a clock alone, a day word or
    ``+2h`` counts from instead; ``now`` (``now+2h``) is still the current time."""
    raw = text
    refuse_capital_m(text)
    whole = " ".join(text.strip().split())
    text, zone = _split_zone(whole, zone)
    named = len(text) < len(whole)  # a zone named after the time
    text, below_us = _below_microsecond(text.lower(), raw)
    if not text:
        raise TimeFormatError("empty time", FORMS_HINT)
    current = (now or datetime.now(UTC)).astimezone(zone.tz)
    if start is not None and _RE_NOW.match(text) is None:
        current = start.astimezone(zone.tz)
    for parser in (_parse_relative, _parse_unix, _parse_dayword, _parse_clock, _parse_iso):
        try:
            result = parser(text, zone, current)
        except OverflowError:  # datetime arithmetic beyond year 9999
            raise _out_of_range(raw) from None
        if result is not None:
            if named:  # its own offset agrees with the zone
                _check_own_offset(text, zone, result, raw)
            return check_range(result + below_us, raw)
    raise _unreadable(raw, zone, now)


def _below_microsecond(text: str, raw: str) -> tuple[str, int]:
    """``text`` with the digits of its seconds' fraction past the sixth taken off, and the
    nanoseconds they are (``10:00:00.123456789`` -> ``10:00:00.123456`` and 789): a
    ``datetime`` holds microseconds and ``fromisoformat`` cut the rest without a word, while
    aion's times are whole nanoseconds. A digit other than 0 past the 9th is a
    :class:`TimeFormatError`: it would be cut."""
    match = _RE_FRACTION.search(text)
    if match is None or len(match.group(2)) <= 6:
        return text, 0
    digits = match.group(2)  # zeros past the 9th are no precision lost
    if digits[9:].strip("0"):
        raise _past_nanoseconds(raw, len(digits.rstrip("0")))
    cut = match.start(2) + 6
    return text[:cut] + text[match.end(2) :], int(digits[6:9].ljust(3, "0"))


def _past_nanoseconds(raw: str, decimals: int) -> TimeFormatError:
    return TimeFormatError(
        f"the time {raw!r} has {decimals} decimals: aion's times are whole nanoseconds",
        "give at most 9 decimals of a second",
    )


def _check_own_offset(text: str, zone: Zone, t_ns: int, raw: str) -> None:
    """:class:`TimeFormatError` when an ISO time with an offset of its own is followed by a
    zone whose offset at that instant differs (``2026-03-29T08:00Z Europe/Berlin``): the
    offset decided the instant, and the zone named after it would have been ignored."""
    own = _RE_OWN_OFFSET.search(text)
    if own is None:
        return
    mark = own.group(1)
    stated = datetime.fromisoformat("2000-01-01T00:00" + ("+00:00" if mark == "z" else mark))
    moment = from_ns(t_ns, zone)
    if stated.utcoffset() != moment.utcoffset():
        raise TimeFormatError(
            f"the time {raw!r} names two zones that disagree: its offset {mark.upper()} and "
            f"{zone.name} (UTC{offset_text(moment)} then)",
            "give the offset or the zone, not both",
        )


def _unreadable(raw: str, zone: Zone, now: datetime | None) -> TimeFormatError:
    """The error for a time no form reads: where it is a time followed by a word no zone
    has (``08:30 PST``, ``08:30 local``), the word is named as the zone it was meant as."""
    head, _, last = " ".join(raw.strip().split()).rpartition(" ")
    meant_as_zone = head and _RE_ZONE_WORD.match(last) and last.lower() not in _NOT_ZONES
    if (meant_as_zone or last.lower() == "local") and _reads(head, zone, now):
        return TimeFormatError(
            f"unknown time zone {last!r} in the time {raw!r}",
            "the machine's zone is --tz local, not a word of the time"
            if last.lower() == "local"
            else 'use an IANA zone name ("America/Los_Angeles", "Europe/Berlin"), an offset '
            '("UTC-08:00") or UTC: abbreviations such as PST or CEST name no zone',
        )
    return TimeFormatError(f"cannot read the time {raw!r}", FORMS_HINT)


def _reads(text: str, zone: Zone, now: datetime | None) -> bool:
    """Whether ``text`` is a time that names no zone of its own at its end."""
    try:
        return zone_named_in(text, zone) is zone and parse_time(text, zone, now) is not None
    except TimeFormatError:
        return False


def _out_of_range(text: str) -> TimeFormatError:
    return TimeFormatError(
        f"the time {text!r} is outside the range aion handles ({RANGE_TEXT})",
        "times are nanoseconds since 1970 in 64 bits; give a time in that range",
    )


def check_range(t_ns: int, text: str) -> int:
    """``t_ns`` if it lies in ``MIN_TIME_NS .. MAX_TIME_NS``, else a :class:`TimeFormatError`
    naming ``text`` (what the user typed)."""
    if not MIN_TIME_NS <= t_ns <= MAX_TIME_NS:
        raise _out_of_range(text)
    return t_ns


_NOT_ZONES = frozenset(
    {"am", "pm", "noon", "midnight", "now", "today", "tomorrow", "yesterday", "local"}
)
"""Trailing words of a time that are no zone (``9:30 pm``), whatever ``zoneinfo`` knows."""


def _split_zone(text: str, zone: Zone) -> tuple[str, Zone]:
    """A trailing zone overrides ``zone``, in any form ``--tz`` takes but ``local``:
    ``2026-11-23 08:30 Europe/Berlin``, ``... UTC``, ``... UTC+05:30``, ``... CET``. A name
    with a ``/`` that is no zone is an error; another last word is part of the time. An
    offset alone (``08:30 +01:00``, ``tomorrow 9am -05``) is a zone too, as ``--tz +01:00``."""
    head, _, last = text.rpartition(" ")
    if head and _RE_OFFSET_WORD.match(last) and not _names_an_instant(head):
        return head, resolve_zone(last)
    if not head or not any(c.isalpha() for c in last) or last.lower() in _NOT_ZONES:
        return text, zone
    try:
        return head, resolve_zone(last)
    except TimeFormatError:
        if "/" in last:  # meant as a zone name
            raise
        return text, zone  # a weekday, a word of the time: not a zone


def is_unix_time(text: str) -> bool:
    """Whether ``text`` is a UNIX time (``1351036800``, ``@1351036800.5``, ``...ns``): an
    instant that no time zone changes."""
    return _RE_UNIX.match(text.strip()) is not None


def _names_an_instant(text: str) -> bool:
    """Whether ``text`` is ``now`` or relative to it (``now -12`` is no time at UTC-12)."""
    lowered = text.lower()
    return lowered == "now" or _RE_RELATIVE.match(lowered) is not None


def _parse_unix(text: str, zone: Zone, current: datetime) -> int | None:
    match = _RE_UNIX.match(text)
    if not match:
        return None
    number, unit = match.groups()
    if unit is None and not text.startswith("@"):
        refuse_misread_number(text)
    try:
        value = Decimal(number)
    except InvalidOperation:  # pragma: no cover - the regex admits only numbers
        return None
    if unit == "ns":
        if value != value.to_integral_value():
            raise TimeFormatError(f"nanoseconds must be an integer: {text!r}", FORMS_HINT)
        return int(value)
    decimals = len(number.partition(".")[2].rstrip("0"))
    if decimals > 9:  # int() below would cut them
        raise _past_nanoseconds(text, decimals)
    if abs(value) > Decimal(10) ** 11:
        raise TimeFormatError(
            f"{text!r} is beyond year 5000 as UNIX seconds", _finer_unit_hint(value)
        )
    return int(value * NS_PER_S)


def _finer_unit_hint(value: Decimal) -> str:
    """The hint for a number too large for UNIX seconds: the coarsest unit that makes it a
    time before year 5000 (a JavaScript ``Date.now()`` is milliseconds, where
    appending 'ns' would read 1970), named with the time in seconds and in nanoseconds."""
    for unit, scale in (("milliseconds", 10**3), ("microseconds", 10**6)):
        seconds = value / scale
        if abs(seconds) <= Decimal(10) ** 11:
            ns = int(value * (NS_PER_S // scale))
            return (
                f"as UNIX {unit} it is {seconds.normalize():f} seconds: give that, or "
                f"{ns}ns"
            )
    if value == value.to_integral_value():
        return f"as UNIX nanoseconds, append 'ns': {int(value)}ns"
    return "append 'ns' for nanoseconds (e.g. 1795420200000000000ns)"


def _parse_relative(text: str, zone: Zone, current: datetime) -> int | None:
    if text == "now":
        return to_ns(current)
    match = _RE_RELATIVE.match(text)
    if not match:
        return None
    sign, body = match.groups()
    total = Decimal(0)
    for amount, unit in RE_REL_PART.findall(body):
        if unit not in UNITS_S:
            raise TimeFormatError(
                f"unknown unit {unit!r} in {text!r}", "units: w, d, h, m (or min), s"
            )
        total += Decimal(amount) * UNITS_S[unit]
    offset_ns = int(total * NS_PER_S)
    return to_ns(current) + (-offset_ns if sign == "-" else offset_ns)


def _parse_dayword(text: str, zone: Zone, current: datetime) -> int | None:
    match = _RE_DAYWORD.match(text)
    if not match:
        return None
    word, clock_text = match.groups()
    has_clock = clock_text is not None
    clock = _wall_clock(clock_text, text) if has_clock else time(0, 0)
    if clock is None:
        return None
    today = current.date()
    if word in DAY_SHIFTS:
        shift = DAY_SHIFTS[word]
        if not has_clock:  # GNU date semantics: "tomorrow" is now + 1 day
            return to_ns(current + timedelta(days=shift))
        day = today + timedelta(days=shift)
    elif word in _WEEKDAYS:
        day = today + timedelta(days=(_WEEKDAYS[word] - today.weekday()) % 7)
    else:
        return None
    return to_ns(_wall(day, clock, zone))


def _parse_clock(text: str, zone: Zone, current: datetime) -> int | None:
    clock = _wall_clock(text, text)
    if clock is None:
        return None
    return to_ns(_wall(current.date(), clock, zone))


def _parse_iso(text: str, zone: Zone, current: datetime) -> int | None:
    dated = _RE_DATE_CLOCK12.match(text)  # a date and a 12-hour clock: 2026-11-23 9am
    if dated:
        clock = _wall_clock(dated.group(2), text)
        if clock is not None:
            try:
                day = date.fromisoformat(dated.group(1))
            except ValueError as exc:
                raise TimeFormatError(f"invalid date {text!r}: {exc}", FORMS_HINT) from None
            return to_ns(_wall(day, clock, zone))
    candidate = _RE_ONE_DIGIT_HOUR.sub(r"\g<1>0\g<2>", text.upper())
    if candidate.endswith(" Z"):
        candidate = candidate[:-2] + "Z"
    try:
        moment = datetime.fromisoformat(candidate)
    except ValueError as exc:
        reason = str(exc)
        if re.match(r"\d{4}-\d{2}-\d{2}", candidate) and ("range" in reason or "must be" in reason):
            # the form is right, a field is not: say which ("2026-02-30 12:00")
            raise TimeFormatError(f"invalid date or time {text!r}: {reason}", FORMS_HINT) from None
        return None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=zone.tz)
    return to_ns(moment)
