"""The time zones the user names (``--tz``, a zone after a time) and the error every
time the user types raises, :class:`TimeFormatError`; and the one check of a length's
letters that both times and steps make (a capital ``M``). Apart from
:mod:`aion_cli.timeparse`, which reads times and re-exports these: zones are looked up, not
parsed, and the steps' module (:mod:`aion_cli.time_steps`) needs the error without the
parser."""

from __future__ import annotations

import os
import re
from datetime import UTC, datetime
from pathlib import Path
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from aion_cli.engine.temporal.zones import suggest_zone, zone_key, zone_of
from aion_cli.engine.time_text import Zone
from aion_cli.errors import ConfigError, InputError

ZONE_HINT = 'use an IANA zone name ("Europe/Berlin", "UTC"), an offset ("+01:00") or "local"'


class TimeFormatError(InputError):
    """A time or time-zone string the user typed cannot be understood."""


_RE_CAPITAL_M = re.compile(r"\d\s*M(?![A-Za-z])")


def refuse_capital_m(text: str, what: str = "") -> None:
    """A length written with a capital ``M`` (``1M``, ``now-1M``): every duration aion reads
    ignores case, so it would be a minute, where the writer most likely meant a month (a unit
    aion has not). :class:`TimeFormatError` naming ``what`` (an option, or nothing where the
    caller names it) and the ways to write either."""
    if _RE_CAPITAL_M.search(text):
        named = f"{what} {text!r}" if what else repr(text)
        raise TimeFormatError(
            f"a capital M in {named} would read as minutes, not months",
            "write minutes as m or min (10m); months have no unit here: write days (30d)",
        )


# -- zones -------------------------------------------------------------------------------------
def local_zone() -> Zone:
    """The machine's local zone: ``$TZ``, else /etc/localtime, else the C library's offset."""
    env = os.environ.get("TZ", "").lstrip(":")
    if env:
        try:
            return Zone(ZoneInfo(env), env)
        except (ZoneInfoNotFoundError, ValueError):
            pass  # a POSIX TZ string such as "CET-1CEST": fall through to the C library
    if not env:
        name = _zone_name_from_system()
        if name:
            try:
                return Zone(ZoneInfo(name), name)
            except (ZoneInfoNotFoundError, ValueError):
                pass
    tz = datetime.now().astimezone().tzinfo or UTC
    return Zone(tz, datetime.now(tz).tzname() or "local")


def _zone_name_from_system() -> str | None:
    localtime = Path("/etc/localtime")
    try:
        target = str(localtime.resolve())
    except OSError:
        target = ""
    if "zoneinfo/" in target:
        return target.split("zoneinfo/", 1)[1]
    try:
        return Path("/etc/timezone").read_text().strip() or None
    except OSError:
        return None


def resolve_zone(name: str | None) -> Zone:
    """``--tz`` value -> zone. ``None`` or "local" is the machine's local zone; an empty
    value is a :class:`TimeFormatError` (an unset shell variable must not silently mean the
    machine's zone instead of the map's)."""
    if name is None or name.strip().lower() == "local":
        return local_zone()
    if not name.strip():
        raise TimeFormatError("empty time zone", ZONE_HINT)
    text = name.strip()
    try:
        tz = zone_of(text)
    except ConfigError as exc:
        meant = suggest_zone(text)
        hint = f'did you mean "{meant}"? otherwise {ZONE_HINT}' if meant else ZONE_HINT
        raise TimeFormatError(exc.message, hint) from exc
    return Zone(tz, zone_key(text))
