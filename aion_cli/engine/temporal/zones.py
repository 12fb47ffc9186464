"""Time-zone names of the model (``ModelConfig.timezone``), without numpy (the CLI parses
``--tz`` with it at start-up)."""

from __future__ import annotations

import difflib
import re
from datetime import UTC, timedelta, timezone, tzinfo
from functools import cache
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError, available_timezones

from aion_cli.errors import ConfigError

_OFFSET = re.compile(r"^(?:utc|gmt)?\s*([+-])(\d{1,2})(?::?(\d{2}))?$")
ZONE_HINT = "use UTC, an offset such as +09:00 or UTC-05:00, or an IANA name such as Europe/Madrid"


def zone_of(name: str) -> tzinfo:
    """The time zone called ``name``: ``UTC`` (also ``Z``, ``GMT``), a fixed offset
    (``+09:00``, ``UTC-5``, ``+0530``) or an IANA name, in any case (``europe/berlin`` is
    ``Europe/Berlin``, as on a machine whose file system ignores case); :class:`ConfigError`
    otherwise (an empty name too), whose hint names the zone meant where one is close
    (``Europe/Berln``)."""
    text = name.strip()
    if not text:  # the wording of timeparse.resolve_zone, which --tz goes through
        raise ConfigError("empty time zone", hint=ZONE_HINT)
    if text.lower() in ("utc", "z", "gmt"):
        return UTC
    offset = _OFFSET.match(text.lower())
    if offset:
        sign, hours, minutes = offset.groups()
        delta = timedelta(hours=int(hours), minutes=int(minutes or 0))
        if delta >= timedelta(hours=24) or int(minutes or 0) >= 60:
            raise ConfigError(f"time-zone offset out of range: {name!r}", hint=ZONE_HINT)
        return timezone(-delta if sign == "-" else delta)
    try:
        return ZoneInfo(text)
    except (ZoneInfoNotFoundError, ValueError, IsADirectoryError, OSError) as exc:
        key = _keys_by_lower_case().get(text.lower())
        if key is not None:
            return ZoneInfo(key)
        meant = suggest_zone(text)
        hint = f'did you mean "{meant}"? otherwise {ZONE_HINT}' if meant else ZONE_HINT
        raise ConfigError(f"unknown time zone {name!r}", hint=hint) from exc


def zone_key(name: str) -> str:
    """The one spelling of the zone called ``name`` (:func:`zone_of`; :class:`ConfigError`
    for none): ``UTC`` for utc, Z, GMT and +00:00, ``UTC+05:30`` for +0530 or utc+5:30, the
    IANA spelling of an IANA name in any case. A map records its zone so, and two names of
    one zone compare equal."""
    tz = zone_of(name)
    if tz is UTC:
        return "UTC"
    offset = _OFFSET.match(name.strip().lower())
    if offset:
        sign, hours, minutes = offset.groups()
        return f"UTC{sign}{int(hours):02d}:{int(minutes or 0):02d}"
    key = getattr(tz, "key", None)
    return key if isinstance(key, str) else name.strip()


def suggest_zone(name: str) -> str | None:
    """The IANA name closest to the unknown ``name`` (a letter missing, swapped or another
    case), None when none is close."""
    keys = _keys_by_lower_case()
    close = difflib.get_close_matches(name.strip().lower(), list(keys), n=1, cutoff=0.85)
    return keys[close[0]] if close else None


@cache
def _keys_by_lower_case() -> dict[str, str]:
    """Every IANA name this machine knows, by its lower-case form (read once, and only for a
    name ``ZoneInfo`` did not find: no two names differ by case alone)."""
    return {key.lower(): key for key in available_timezones()}


def same_zone(a: str, b: str) -> bool:
    """Whether the zones called ``a`` and ``b`` keep the same clock at every time: one
    spelling (:func:`zone_key`), or IANA names of one zone's data (``Asia/Calcutta`` is a
    link to ``Asia/Kolkata``, ``Etc/UTC`` to ``UTC``, ``US/Eastern`` to
    ``America/New_York``: their tz database files are the same bytes). Zones whose data
    cannot be found compare by spelling only."""
    try:
        keys = zone_key(a), zone_key(b)
    except ConfigError:
        return a == b
    if keys[0] == keys[1]:
        return True
    data = [_zone_data(k) for k in keys]
    return data[0] is not None and data[0] == data[1]


@cache
def _zone_data(key: str) -> bytes | None:
    """The tz database file (TZif) of the zone ``key``, where :class:`ZoneInfo` finds it (the
    system's ``TZPATH``, then the ``tzdata`` package); None for a fixed offset or a zone not
    found."""
    import zoneinfo
    from importlib import resources
    from pathlib import Path

    if key.startswith(("UTC+", "UTC-")):
        return None  # a fixed offset: no file, and one spelling each
    for root in zoneinfo.TZPATH:
        path = Path(root, key)
        if path.is_file():
            return path.read_bytes()
    try:
        return resources.files("tzdata.zoneinfo").joinpath(*key.split("/")).read_bytes()
    except (ModuleNotFoundError, OSError):
        return None
