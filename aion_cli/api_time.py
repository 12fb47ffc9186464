"""aion's times from a Python caller's values: :func:`to_ns` reads an aion time string, a
``datetime`` (a pandas ``Timestamp`` to its nanosecond), a ``numpy.datetime64`` or integer
nanoseconds, as the API's queries take them (their arguments checked by
:mod:`aion_cli.api_checks`)."""

from __future__ import annotations

from datetime import datetime, tzinfo
from typing import Any

from aion_cli.api_checks import TimeLike, keywords_checked, time_value, zone_name
from aion_cli.errors import InputError
from aion_cli.timeparse import Zone


@keywords_checked
def to_ns(time: TimeLike, zone: Zone | str | tzinfo | None = "UTC") -> int:
    """Nanoseconds since 1970 (UTC) of an aion time string, a ``datetime`` (a pandas
    ``Timestamp`` to its nanosecond) or a ``numpy.datetime64`` (naive: in ``zone``, a name
    such as ``"Europe/London"``, a ``ZoneInfo`` or an aion ``Zone``; default UTC, None: the
    machine's) or integer nanoseconds (one below 10^16, which would lie in 1970's first
    months, is refused as likely seconds); outside 1900 .. 2261 is an ``InputError``."""
    from aion_cli.timeparse import Zone, check_range, parse_time, resolve_zone
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
