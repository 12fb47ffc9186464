"""Which profile bins — (kind of day, hour of the day) in the map's zone — a map observed, from
its manifest (``families.observed_bins``), asked per time: the flags ``predict``'s JSON
(``hour_observed``) and the report's charts carry, and the hours ``aion info`` lists.

A bin no log observed is forecast, not measured, in one of two ways
(:mod:`aion_cli.forecast_notes` says which in words): at an hour of the day no kind of day
observed, every entry forecasts its static rate (:func:`hour_observed` False); at an hour
another kind of day observed (a Saturday morning from a map of weekdays only), the forecast
follows the rhythm of the kinds of day seen (:func:`bin_observed` False, :func:`hour_observed`
True).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli import note_words as words

if TYPE_CHECKING:
    from aion_cli.manifest import Manifest


def bin_observed(manifest: Manifest, times_ns: list[int]) -> list[bool] | None:
    """Per time, whether some day of the map's data observed its profile bin: its hour of the
    day on its kind of day (weekday or weekend; with the weekly profile its day of the week;
    any day with ``profile = "day"``), in the map's zone. None for a map that does not list
    its observed bins (older maps) or has observed nothing."""
    table = _observed_table(manifest)
    if table is None:
        return None
    calendar, seen = table
    return [bool(b) for b in seen.reshape(-1)[calendar.profile_bin(list(times_ns))]]


def hour_observed(manifest: Manifest, times_ns: list[int]) -> list[bool] | None:
    """Per time, whether some day of the map's data observed its hour of the day (any kind
    of day; the map's zone): :func:`bin_observed` on any kind of day. None as there."""
    table = _observed_table(manifest)
    if table is None:
        return None
    calendar, seen = table
    at = calendar.profile_bin(list(times_ns)) % calendar.bins_per_day
    return [bool(h) for h in seen.any(axis=0)[at]]


def _observed_table(manifest: Manifest) -> tuple[Any, Any] | None:
    """The map's calendar and its observed bins as a table (kinds of day x bins of a day);
    None as :func:`bin_observed` says."""
    calendar = calendar_of(manifest.config, manifest.timezone)
    bins = observed_bins(manifest.families)
    if calendar is None or not bins:
        return None
    inside = [b for b in bins if b < calendar.n_bins]
    if not inside:
        return None
    seen = np.zeros(calendar.n_bins, dtype=bool)
    seen[inside] = True
    return calendar, seen.reshape(-1, calendar.bins_per_day)


def hours_of(manifest: Manifest, per_day: int) -> list[int]:
    """The in-day bins the map observed on some kind of day (empty: not listed); a bin past
    the profile's is left out, as :func:`hour_observed` leaves it out (bin 58 of a map of
    weekdays and weekends is no 10:00)."""
    calendar = calendar_of(manifest.config, manifest.timezone)
    limit = 1 << 20 if calendar is None else calendar.n_bins
    return sorted({b % per_day for b in observed_bins(manifest.families) if b < limit})


def observed_bins(families: Mapping[str, Any]) -> list[int]:
    """The manifest's ``observed_bins``: whole numbers from 0 (a map file is untrusted input:
    anything else in the list is left out, a list that is not one reads as empty)."""
    observed = families.get("observed_bins")
    if not isinstance(observed, list):
        return []
    return [b for b in observed if type(b) is int and 0 <= b < 1 << 20]


def observed_hours(
    families: Mapping[str, Any], config: Mapping[str, Any], timezone: str | None
) -> str | None:
    """The hours a map observed, per kind of day, for ``aion info``: ``weekdays 09:00-18:00;
    weekends none (UTC)``; None for a map that does not list its observed bins."""
    calendar = calendar_of(config, timezone)
    if not isinstance(families.get("observed_bins"), list) or calendar is None:
        return None
    observed = observed_bins(families)
    per_day = calendar.bins_per_day
    kinds = {"day": [""], "day_weekend": ["weekdays ", "weekends "]}.get(
        calendar.profile, [f"{name[:3]} " for name in words.WEEKDAYS]
    )
    by_kind: dict[str, list[str]] = {}
    for k, label in enumerate(kinds):
        hours = sorted(b - k * per_day for b in observed if b // per_day == k)
        text = words.clock_ranges(hours, calendar.bin_s) if hours else "none"
        by_kind.setdefault(text, []).append(label.strip())
    parts = [
        (", ".join(labels) + " " if any(labels) else "") + text
        for text, labels in by_kind.items()
    ]
    return f"{'; '.join(parts)} ({calendar.timezone})"


def calendar_of(config: Mapping[str, Any], timezone: str | None) -> Any:
    """The map's calendar (zone, profile, bin length) from its config; None for a zone this
    machine does not know (say nothing rather than fail) or a config it cannot read."""
    from aion_cli.engine.temporal.calendar import Calendar
    from aion_cli.errors import AionError

    zone = str(config.get("timezone", timezone or "UTC"))
    try:
        return Calendar(
            zone,
            str(config.get("profile", "day_weekend")),
            float(config.get("profile_bin_s", 3600.0)),
        )
    except (AionError, TypeError, ValueError):
        return None
