"""Time-zone names of the model (``ModelConfig.timezone``), without numpy (the CLI parses
``--tz`` with it at start-up)."""

from __future__ import annotations

import re
from datetime import UTC, timedelta, timezone, tzinfo
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from aion_cli.errors import ConfigError

_OFFSET = re.compile(r"^(?:utc|gmt)?\s*([+-])(\d{1,2})(?::?(\d{2}))?$")
ZONE_HINT = "use UTC, an offset such as +09:00 or UTC-05:00, or an IANA name such as Europe/Madrid"


def zone_of(name: str) -> tzinfo:
    """The time zone called ``name``: ``UTC`` (also ``Z``, ``GMT``), a fixed offset
    (``+09:00``, ``UTC-5``, ``+0530``) or an IANA name; :class:`ConfigError` otherwise."""
    text = name.strip()
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
        raise ConfigError(f"unknown time zone {name!r}", hint=ZONE_HINT) from exc
