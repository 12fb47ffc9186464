"""What a forecast at a time can and cannot say, from the map's manifest: the notes ``predict``,
``plan``, ``export`` and ``report`` print beside the time they used.

Two situations surprise people and look like defects when unexplained:

* **Every entry forecasts its static rate**, so the tables at 03:30 and at 12:30 are the same.
  An entry chooses a time-varying family by its day-ahead scores, and needs two scored days
  for that (each day scored against the days before it): a map of one or two days (or of a
  few hours) has none, and forecasts the same at every hour unless its total is reconciled to
  a map-wide rhythm.
* **The time lies outside the map's data**: before its first detection, or more than a week
  after its last. The forecast is the rhythm the map learnt (its day and week), repeated; it
  knows nothing of what changed since.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from aion_cli.engine.temporal.calendar import DAY_NS

if TYPE_CHECKING:
    from aion_cli.manifest import Manifest

FAR_AFTER_NS = 7 * DAY_NS
"""Beyond this after a map's last data a forecast repeats a rhythm learnt long before; a
week is one turn of the longest rhythm the default model learns."""


def forecast_notes(manifest: Manifest, t_ns: int) -> list[str]:
    """The notes for a forecast at ``t_ns`` (UNIX ns) from the map of ``manifest``; empty
    when there is nothing to say."""
    notes = []
    static = _all_static(manifest.families)
    if static is not None:
        notes.append(static)
    where = _outside(manifest.start_ns, manifest.end_ns, int(t_ns), static is not None)
    if where is not None:
        notes.append(where)
    return notes


def _all_static(families: Mapping[str, Any]) -> str | None:
    flow = families.get("flow") or {}
    entries = sum(int(n) for n in flow.values())
    if entries == 0 or int(flow.get("static", 0)) != entries or families.get("reconciled"):
        return None
    days = int(families.get("scored_days", 0))
    return (
        f"every entry forecasts its static rate, whatever the time: the map has {days} scored "
        f"day{'' if days == 1 else 's'}, and an entry needs two (each scored against the days "
        "before it) to follow a daily or weekly rhythm; build from more days of logs"
    )


def _outside(start_ns: int | None, end_ns: int | None, t_ns: int, static: bool) -> str | None:
    if start_ns is None or end_ns is None:
        return None
    start, end = int(start_ns), int(end_ns)
    if start <= t_ns <= end + FAR_AFTER_NS:
        return None
    before = t_ns < start
    first, last = _day(start), _day(end)
    text = (
        f"this time is {_duration(start - t_ns if before else t_ns - end)} "
        f"{'before' if before else 'after'} the map's data "
        f"({first if first == last else f'{first} to {last}'})"
    )
    if static:
        return text
    text += ": the forecast repeats the rhythm the map learnt"
    return text if before else text + " and knows nothing of what changed since"


def _duration(ns: int) -> str:
    """``ns`` rounded for reading: hours, days, weeks or years."""
    hours = ns / 3.6e12
    for below_h, unit_h, unit in ((48, 1, "hour"), (14 * 24, 24, "day"), (730 * 24, 168, "week")):
        if hours < below_h:
            n = round(hours / unit_h)
            return f"{n} {unit}{'' if n == 1 else 's'}"
    return f"{hours / (365.25 * 24):.1f} years"


def _day(t_ns: int) -> str:
    from aion_cli.engine.windows import iso

    return iso(t_ns)[:10]
