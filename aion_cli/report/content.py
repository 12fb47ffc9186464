"""What a map report says, gathered from the map (no drawing, no HTML).

Every number comes from the function that answers it elsewhere, so the page agrees with the
commands a colleague would run: the manifest as ``aion info MAP`` shows it
(:meth:`aion_cli.manifest.Manifest.shown`: inputs, time span, counts, families, zone), the
busiest entries as ``aion predict --top N`` lists them (:func:`aion_cli.predictions
.predicted_records`), room activity as ``aion predict --layer rooms`` sums it, evaluated at
many times at once (:func:`aion_cli.predictions.flow_series`), and what was observed from the
temporal state's observation sums (``TemporalState.observation``: windows per profile bin,
first and last observed window) and the fixed-sensor intervals the map keeps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import date, datetime, time, timedelta
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from aion_cli.engine.time_text import Zone
from aion_cli.number_text import WINDOWS_OBSERVED

if TYPE_CHECKING:
    from aion_cli.mapquery import LoadedMap

DAY_STEP_S = 900
"""Step of the one-day activity curves (15 minutes)."""
WEEK_STEP_S = 3600
"""Step of the one-week activity curves (an hour)."""
TOP_ROOMS = 6
"""Rooms drawn as lines of their own; the others are summed into one."""
TOP_ENTRIES = 10
"""Rows of the busiest-places table."""
ROSES = 6
"""Direction roses drawn (the busiest entries with a direction histogram)."""
_NS = 1_000_000_000
_DAY_TYPES = {
    "day": ("every day",),
    "day_weekend": ("Mon-Fri", "Sat-Sun"),
    "week": ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun"),
}


@dataclass(frozen=True)
class Observed:
    """When the map was observed: the logs' span, the first and last observed window (UNIX
    ns, None before any), the fixed-sensor intervals ``[start, end)`` (ns; none for a robot's
    coverage, which the map keeps only as tallies), and ``hours[D, H]``: the hours observed
    per profile bin (``D`` day types named ``day_types``, ``H`` bins a day, in the map's own
    zone ``model_zone``): per bin, the most any entry was observed in it."""

    span: tuple[int | None, int | None]
    first_ns: int | None
    last_ns: int | None
    fixed: tuple[Any, Any]
    hours: Any
    day_types: tuple[str, ...]
    model_zone: str
    source: str


@dataclass(frozen=True)
class Series:
    """Predicted flow at ``times_ns`` (UNIX ns), one column per line: ``names`` (the busiest
    rooms, then the others summed; or the whole map without rooms)."""

    title: str
    times_ns: Any
    names: tuple[str, ...]
    flows: Any
    unobserved: Any = None
    """Per time, whether its hour of the day (in the map's zone) was observed on no kind of
    day: the forecast there is extrapolated (None: not known)."""
    other_days: Any = None
    """Per time, whether its hour was observed on another kind of day only, never on its own
    (a Saturday from a map of weekdays; the map's zone): the forecast there follows the days
    the map saw (``bins_observed.bin_observed``; None: not known)."""


@dataclass(frozen=True)
class Busiest:
    """One row of the busiest-places table: the ``aion predict`` record, the room holding
    it (display text, "" for none) and the family that forecasts it."""

    record: dict[str, Any]
    room: str
    family: str


@dataclass(frozen=True)
class ReportContent:
    """Everything the page shows (see the module docstring)."""

    map_name: str
    shown: dict[str, Any]
    counts: dict[str, int | str]
    zone: Zone
    t_ns: int | None
    observed: Observed
    activity: tuple[Series, ...]
    busiest: tuple[Busiest, ...]
    bins: int
    window_s: float
    matched: int
    notes: tuple[str, ...] = field(default=())
    hour_observed: bool | None = None
    """Whether any day of the map's data observed ``t_ns``'s hour of the day (``aion predict
    --time``'s JSON ``hour_observed``; where not, the busiest entries and the map's picture
    are extrapolated); None as observed, or for a map that does not list its hours."""
    hours_observed: str | None = None
    """The hours the map observed per kind of day, as ``aion info`` lists them
    (``weekdays 09:00-18:00; weekends none (UTC)``); None for a map that does not list them."""


def gather(loaded: LoadedMap, map_path: Any, zone: Zone, t_ns: int | None) -> ReportContent:
    """The content of the report of ``loaded`` (read from ``map_path``) in ``zone``; the
    busiest entries at ``t_ns`` (None: as observed)."""
    from pathlib import Path

    from aion_cli.bins_observed import observed_hours
    from aion_cli.manifest import Manifest
    from aion_cli.predictions import hour_flags

    raw = dict(loaded.manifest)
    raw.setdefault("state", {})
    manifest = Manifest.from_dict(raw)
    shown = manifest.shown()
    observed = observed_coverage(loaded, shown)
    activity, notes = activity_series(loaded, zone, t_ns, observed)
    busiest, matched = busiest_entries(loaded, t_ns)
    return ReportContent(
        map_name=Path(str(map_path)).name,
        shown=shown,
        counts=map_counts(loaded, shown),
        zone=zone,
        t_ns=t_ns,
        observed=observed,
        activity=activity,
        busiest=busiest,
        bins=loaded.config.bins,
        window_s=float(loaded.config.window_s),
        matched=matched,
        notes=tuple(notes),
        hour_observed=hour_flags(loaded, [t_ns])[0],
        hours_observed=observed_hours(manifest.families, manifest.config, manifest.timezone),
    )


def map_counts(loaded: LoadedMap, shown: dict[str, Any]) -> dict[str, int | str]:
    """Places, rooms, buildings (the latest scene graph), hash cells, entries and detections
    (the manifest's counts, as ``aion info`` shows them; the entries in info's and compact's
    words, :func:`aion_cli.mapquery.entries_text`)."""
    from aion_cli.mapquery import entries_text, state_entry_counts

    counts = shown.get("counts") or {}
    graph = loaded.graph
    return {
        "places": len(graph.places) if graph is not None else 0,
        "places with flow": int(counts.get("nodes_with_flow", 0)),
        "rooms": len(graph.rooms) if graph is not None else 0,
        "buildings": len(graph.buildings) if graph is not None else 0,
        "hash cells": int(counts.get("cells", 0)),
        "cells bound to places": int(counts.get("bound_cells", 0)),
        "entries": entries_text(*state_entry_counts(loaded.state)),
        "detections read": int(counts.get("read", 0)),
        "detections accepted": int(counts.get("used", 0)),
        WINDOWS_OBSERVED: int(counts.get("windows", 0)),
    }


def observed_coverage(loaded: LoadedMap, shown: dict[str, Any]) -> Observed:
    """:class:`Observed` from the manifest's span and the temporal state's observation."""
    from aion_cli.engine.windows import EPOCH_NS

    state = loaded.state
    rows = state.entries.live_rows()
    view = state.query_temporal()
    obs = view.observation(rows, fourier=False)
    calendar = state.params.calendar
    per_day = calendar.bins_per_day
    if rows.size:
        profile = obs.profile.max(axis=0)
        first, last = float(np.nanmin(obs.first)), float(np.nanmax(obs.last))
    else:  # a map without entries: the global (fixed-sensor) block alone
        profile = view.glob.profile[0]
        first, last = float(view.glob.first[0]), float(view.glob.last[0])
    hours = profile.reshape(-1, per_day) * (float(state.config.window_s) / 3600.0)
    span = shown.get("time_span") or {}

    def ns(seconds: float) -> int | None:
        return None if not np.isfinite(seconds) else EPOCH_NS + round(float(seconds) * _NS)

    starts, ends = state.observation.merged_fixed()
    return Observed(
        span=(span.get("start_ns"), span.get("end_ns")),
        first_ns=ns(first),
        last_ns=ns(last),
        fixed=(starts.copy(), ends.copy()),
        hours=hours,
        day_types=_DAY_TYPES[calendar.profile],
        model_zone=calendar.timezone,
        source=str(shown.get("observation", "")),
    )


def local_midnight(day: date, zone: Zone) -> int:
    """UNIX ns of 00:00 of ``day`` in ``zone``."""
    from aion_cli.timeparse import to_ns

    return to_ns(datetime.combine(day, time(0)).replace(tzinfo=zone.tz))


def wall_steps(day: date, zone: Zone, step_s: int, length_s: int) -> Any:
    """UNIX ns of the wall-clock times ``day`` 00:00, then every ``step_s`` seconds of the
    clock for ``length_s`` (a day of 96 quarter hours, a week of 168 hours), in ``zone``: on a
    day whose clock changes the curve keeps to the clock (the times a change skips are left
    out; a repeated hour is shown once, its first time), where steps of elapsed time from
    midnight would draw every point after the change an hour off."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.timeparse import to_ns

    start = datetime.combine(day, time(0))
    out = []
    for k in range(length_s // step_s):
        wall = start + timedelta(seconds=k * step_s)
        t = to_ns(wall.replace(tzinfo=zone.tz))
        if from_ns(t, zone).replace(tzinfo=None) == wall:  # else a time the clock skipped
            out.append(t)
    return np.array(out, dtype=np.int64)


def series_days(anchor_ns: int, zone: Zone, inside: bool) -> tuple[date, date, date]:
    """The week (its Monday), weekday and weekend day the activity curves show, in ``zone``:
    the week holding ``anchor_ns`` and, when it is one, that day itself (``inside``: the
    report's ``--time``); else the first week starting after the day of ``anchor_ns`` (the
    end of the observations: the days the map forecasts next), its Monday and Saturday."""
    from aion_cli.engine.time_text import from_ns

    day = from_ns(anchor_ns, zone).date()
    if inside:
        monday = day - timedelta(days=day.weekday())
        weekday = day if day.weekday() < 5 else monday
        weekend = day if day.weekday() >= 5 else monday + timedelta(days=5)
        return monday, weekday, weekend
    monday = day + timedelta(days=7 - day.weekday())
    return monday, monday, monday + timedelta(days=5)


def activity_series(
    loaded: LoadedMap, zone: Zone, t_ns: int | None, observed: Observed
) -> tuple[tuple[Series, ...], list[str]]:
    """Predicted flow per room over a weekday and a weekend day (15-minute steps) and over a
    week (hourly), the busiest rooms as lines of their own; the whole map's total when the
    map has no rooms. Empty (with a note) for a map that observed nothing."""
    from aion_cli.predictions import flow_series

    notes: list[str] = []
    anchor = t_ns if t_ns is not None else observed.last_ns or observed.span[1]
    if anchor is None:
        return (), ["the map has observed nothing yet: no activity to forecast"]
    monday, weekday, weekend = series_days(anchor, zone, t_ns is not None)
    spans = (
        (f"{weekday:%A %Y-%m-%d}", weekday, DAY_STEP_S, 86_400),
        (f"{weekend:%A %Y-%m-%d}", weekend, DAY_STEP_S, 86_400),
        (f"week of Monday {monday:%Y-%m-%d}", monday, WEEK_STEP_S, 604_800),
    )
    times = [wall_steps(day, zone, step, length) for _, day, step, length in spans]
    from aion_cli.room_names import rooms_off_the_nav_layer

    graph = loaded.graph
    off = None if graph is None else rooms_off_the_nav_layer(graph)
    layer: Literal["rooms", "all"] = (
        "rooms" if graph is not None and len(graph.rooms) and off is None else "all"
    )
    if off is not None:  # room curves would be empty: none holds a place
        notes.append(f"{off[0]}: the curves show the whole map's flow")
    elif layer == "all":
        notes.append("the map has no rooms: the curves show the whole map's flow")
    ids, flows = flow_series(loaded, np.concatenate(times), layer)
    names, columns = _top_columns(loaded, [str(i) for i in ids], flows, times[-1].size)
    out, at = [], 0
    for (title, _, _, _), when in zip(spans, times, strict=True):
        flags = _extrapolated(loaded, when)
        out.append(Series(title, when, names, columns[at : at + when.size], *flags))
        at += when.size
    return tuple(out), notes + _unseen_days(loaded, [s[0] for s in spans[:2]], times[:2])


def _unseen_days(loaded: LoadedMap, titles: list[str], times: list[Any]) -> list[str]:
    """The note of ``aion predict`` for each day curve (``titles``, ``times``) on a kind of
    day the map never observed (``forecast_notes.unseen_day``: the Saturday of a map of
    weekdays, drawn as a measured curve, follows the weekdays' rhythm), none for a map whose
    every entry forecasts its static rate (the same whatever the day)."""
    from aion_cli.forecast_notes import all_static, unseen_day
    from aion_cli.manifest import Manifest

    manifest = Manifest.from_dict(loaded.manifest)
    if all_static(manifest) is not None:
        return []
    notes = (unseen_day(manifest, int(t[t.size // 2])) if t.size else None for t in times)
    return [f"{title}: {note}" for title, note in zip(titles, notes, strict=True) if note]


def _extrapolated(loaded: LoadedMap, times: Any) -> tuple[Any, Any]:
    """Per time, whether no kind of day observed its hour (the hours the forecast notes and
    ``hour_observed`` call extrapolated), and whether only another kind of day did (a Saturday
    from a map of weekdays, which ``unseen_day``'s note names): ``bins_observed``'s
    ``hour_observed`` and ``bin_observed``; (None, None) for a map that does not list its
    observed hours."""
    from aion_cli.bins_observed import bin_observed, hour_observed
    from aion_cli.manifest import Manifest

    raw = dict(loaded.manifest or {})
    raw.setdefault("state", {})
    manifest = Manifest.from_dict(raw)
    listed = [int(t) for t in times]
    hours, bins = hour_observed(manifest, listed), bin_observed(manifest, listed)
    if hours is None or bins is None:
        return None, None
    hour, own = np.asarray(hours, bool), np.asarray(bins, bool)
    return ~hour, hour & ~own


def _top_columns(
    loaded: LoadedMap, ids: list[str], flows: Any, week: int
) -> tuple[tuple[str, ...], Any]:
    """The ``TOP_ROOMS`` rooms with the most flow over the week (the last ``week`` rows) as
    columns of their own, the others summed into one ("other rooms (k)")."""
    if len(ids) == 1 and ids[0] == "all":
        return ("whole map",), flows
    total = flows[-week:].sum(axis=0)
    order = np.lexsort((np.asarray(ids), -total))
    top, rest = order[:TOP_ROOMS], order[TOP_ROOMS:]
    labels = room_labels(loaded)
    names = [f"{ids[i]} {labels.get(ids[i], '')}".strip() for i in top]
    columns = [flows[:, top]]
    if rest.size:
        names.append(f"other rooms ({rest.size})")
        columns.append(flows[:, rest].sum(axis=1, keepdims=True))
    return tuple(names), np.concatenate(columns, axis=1)


def room_labels(loaded: LoadedMap) -> dict[str, str]:
    """Display id (``R3``) -> name of each room of the latest graph ("" when it has none, or
    only its id: :func:`aion_cli.room_names.name_of`)."""
    from aion_cli.engine.query import node_symbol
    from aion_cli.room_names import name_of

    graph = loaded.graph
    if graph is None or not len(graph.rooms):
        return {}
    rooms = graph.rooms
    labels = [name_of(rooms, k) or "" for k in range(len(rooms))]
    return dict(zip(node_symbol(rooms.ids).tolist(), labels, strict=True))


def busiest_entries(loaded: LoadedMap, t_ns: int | None) -> tuple[tuple[Busiest, ...], int]:
    """The ``TOP_ENTRIES`` busiest entries (places and cells) at ``t_ns`` (None: as
    observed) that have any flow, exactly as ``aion predict --top N`` lists them, with each
    one's room and its flow family (at ``t_ns``, the family that forecasts it then; as
    observed, the family it chose: a forecast at an hour no log observed uses ``static``,
    and one of an entry that chose ``static`` at an hour it never observed uses ``shape``,
    ``temporal.model.Predictor``), and how many entries the map has."""
    from aion_cli.engine.node_ids import parse_node_id
    from aion_cli.engine.query import node_symbol, parent_ids
    from aion_cli.predictions import entry_ids, entry_table, predicted_records

    rows, matched = predicted_records(loaded, t_ns, "all", top=TOP_ENTRIES)
    rows = [r for r in rows if (r.get("flow") or 0) > 0]  # a busiest place has some flow
    families = {r["id"]: r["family"] for r in rows}
    if t_ns is None and rows:  # historical records say "historical": the families chosen
        table = entry_table(loaded, None)  # its first rows are the predictor's, in its order
        _order, predictor = loaded.state.predictor()
        chosen = np.asarray(predictor.params.flow, dtype=str)[predictor.flow_choice]
        ids = entry_ids(table, np.arange(chosen.size))
        pick = np.flatnonzero(np.isin(ids, [r["id"] for r in rows]))
        families = dict(zip(ids[pick].tolist(), chosen[pick].tolist(), strict=True))
    rooms = [""] * len(rows)
    graph = loaded.graph
    if graph is not None and rows:
        labels = room_labels(loaded)
        nodes = [i for i, r in enumerate(rows) if r["kind"] == "node"]
        ids = np.asarray([parse_node_id(rows[i]["id"]) for i in nodes], dtype=np.uint64)
        parents = parent_ids(graph.places.ids, graph.places.parent, ids)
        for i, parent, symbol in zip(nodes, parents, node_symbol(parents), strict=True):
            if parent:
                rooms[i] = f"{symbol} {labels.get(str(symbol), '')}".strip()
    out = tuple(
        Busiest(r, room, families.get(r["id"], r["family"]))
        for r, room in zip(rows, rooms, strict=True)
    )
    return out, matched
