"""aion's times from a Python caller's values: :func:`to_ns` reads an aion time string, a
``datetime`` (a pandas ``Timestamp`` to its nanosecond), a ``numpy.datetime64`` or integer
nanoseconds, as the API's queries take them (their arguments checked by
:mod:`aion_cli.api_checks`)."""

from __future__ import annotations

from datetime import datetime, tzinfo
from typing import Any

from aion_cli.api_checks import TimeLike, time_value, zone_name
from aion_cli.api_keywords import keywords_checked
from aion_cli.engine.time_text import Zone
from aion_cli.errors import InputError


@keywords_checked
def to_ns(time: TimeLike, zone: Zone | str | tzinfo | None = "UTC") -> int:
    """Nanoseconds since 1970 (UTC) of an aion time string, a ``datetime`` (a pandas
    ``Timestamp`` to its nanosecond), a ``date`` (its midnight, as its text ``"2026-01-12"``)
    or a ``numpy.datetime64`` (naive: in ``zone``, a name
    such as ``"Europe/London"``, a ``ZoneInfo`` or an aion ``Zone``; default UTC, None: the
    machine's) or integer nanoseconds (one below 10^16, which would lie in 1970's first
    months, is refused as likely seconds); outside 1900 .. 2261 is an ``InputError``."""
    from aion_cli.engine.time_text import Zone
    from aion_cli.timeparse import check_range, parse_time, resolve_zone
    from aion_cli.timeparse import to_ns as datetime_ns

    if not isinstance(zone, Zone):
        zone = resolve_zone(zone_name(zone, "zone"))
    if type(time).__name__ == "datetime64":  # numpy's: no zone, read as a naive datetime
        moment, below_us = _wall_clock(time)
        return check_range(datetime_ns(moment.replace(tzinfo=zone.tz)) + below_us, str(time))
    time = time_value(time)  # type: ignore[assignment]
    if isinstance(time, int):
        return check_range(int(time), f"{time} ns")
    if isinstance(time, datetime):
        moment = time if time.tzinfo is not None else time.replace(tzinfo=zone.tz)
        below_us = getattr(time, "nanosecond", 0)  # a pandas Timestamp's, below its microsecond
        below_us = below_us if isinstance(below_us, int) else 0
        return check_range(datetime_ns(moment) + below_us, moment.isoformat())
    if isinstance(time, str):
        return parse_time(time, zone)
    raise InputError(f"not a time: {time!r}", hint="a time string, a datetime or nanoseconds")


def _wall_clock(value: Any) -> tuple[datetime, int]:
    """A ``numpy.datetime64`` as a naive ``datetime`` and the nanoseconds below its
    microsecond; NaT is an :class:`InputError`, a year outside 1 .. 9999 out of range."""
    import numpy as np

    from aion_cli.timeparse import check_range

    if np.isnat(value):
        raise InputError(f"not a time: {value!r}", hint="NaT marks a missing time")
    micro = value.astype("datetime64[us]")
    moment = micro.item()  # a datetime, or an int beyond datetime's years
    if not isinstance(moment, datetime):
        check_range(int(micro.astype(np.int64)) * 1000, str(value))
    return moment, int((value - micro) / np.timedelta64(1, "ns"))


def query_zone(tz: object, default: str | None) -> Zone:
    """The zone of a query: ``tz`` (a name, a ``ZoneInfo`` or a fixed offset), else a map's
    zone ``default``, else the machine's."""
    from aion_cli.timeparse import resolve_zone

    name = zone_name(tz)
    return resolve_zone(name if name is not None else default)


def query_time(
    time: TimeLike, tz: object, default: str | None, after_ns: int | None = None
) -> tuple[int, Zone]:
    """``time`` (as :func:`to_ns` takes it) in ``tz``, else in a map's zone ``default`` (else
    the machine's), and that zone; ``after_ns``: the start of the span whose end ``time`` is,
    which a clock alone, a day word or a relative string counts from (``("2026-11-23 08:00",
    "10:00")`` is two hours, as ``--leave`` reads it)."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.timeparse import parse_time

    zone = query_zone(tz, default)
    if after_ns is not None and isinstance(time, str):
        return parse_time(time, zone, start=from_ns(after_ns, zone)), zone
    return to_ns(time, zone), zone


def query_times(
    time: TimeLike | None, historical: object, series: object, step: object, tz: object,
    default: str | None,
) -> tuple[list[int | None], Zone | None]:
    """The times of an export or a picture (``Map.export``, ``Map.picture``): ``[None]`` as
    observed, ``time``'s (None: now), or ``series=(start, end)`` every ``step`` (None:
    ``"1h"``), as ``aion export --from --to --step``; in ``tz``, else the zone ``default``."""
    from aion_cli.api_checks import historical as checked_historical
    from aion_cli.api_checks import pair
    from aion_cli.api_checks import step as checked_step
    from aion_cli.prediction_series import series_times
    from aion_cli.time_steps import parse_step

    observed = checked_historical(time, historical)
    if series is None:
        if step is not None:
            raise InputError("step needs series", hint='e.g. series=("06:00", "20:00")')
        if observed:
            return [None], None
        when, zone = query_time("now" if time is None else time, tz, default)
        return [when], zone
    if time is not None or observed:
        raise InputError(
            f"choose {'time' if time is not None else 'historical=True'} or series, not both",
            hint="time= is one time; series=(start, end) one every step",
        )
    first, last = pair(series, "series", "start, end")
    every = parse_step(checked_step("1h" if step is None else step), "step")
    t0, zone = query_time(first, tz, default)
    t1 = query_time(last, tz, default, after_ns=t0)[0]
    names = ("series[0]", "series[1]")
    return list(series_times(t0, t1, every, zone, names, "frames", first)), zone
