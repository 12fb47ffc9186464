"""``aion info MAP``: a map's manifest, its rooms, ``--verify``, and the table of them.

Split from :mod:`aion_cli.cli.info` (logs and graph files); the command there calls these.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.cli.output import human_size, markup_safe
from aion_cli.errors import path_word
from aion_cli.listing import first_few


def describe_map(path: Path) -> dict[str, Any]:
    """The manifest of a map file without the internal tables
    (:meth:`aion_cli.manifest.Manifest.shown`), and the rooms of its scene graph with their
    names (``plan --from kitchen`` takes them). Cheap: of the arrays only the graph's and
    the entries' kinds and node ids are read, never the accumulators."""
    from aion_cli.formats.mapfile import read_manifest
    from aion_cli.manifest import Manifest

    shown = Manifest.from_dict(read_manifest(path)).shown()
    return {"map": str(path)} | shown | _entries(path) | _hierarchy(path)


def _entries(path: Path) -> dict[str, int | None]:
    """``entries`` (places and hash cells with a model) and ``places_without_data`` (the
    graph's places holding none, rows of ``aion predict`` too) as compact and report count
    them (:func:`aion_cli.mapquery.entry_counts`: two entry members and the graph); None when
    the map cannot be read (:func:`_hierarchy` warns why)."""
    from aion_cli.errors import AionError
    from aion_cli.mapquery import entry_counts

    try:
        entries, without = entry_counts(path)
    except AionError:
        return {"entries": None, "places_without_data": None}
    return {"entries": entries, "places_without_data": without}


def verify_map(path: Path) -> dict[str, Any]:
    """``info --verify``: every member read and checked against its checksum (a query reads,
    and so checks, only the members it needs), then the state loaded and checked for
    consistency. :class:`~aion_cli.errors.InputError` (corrupt, inconsistent) otherwise.
    ``sealed``: the map carries the seal of its derived members (written since stop 71);
    ``derived_stale``: why they are not its own (queries compute them again), else None."""
    from aion_cli.derived_seal import FIELD, stale_because
    from aion_cli.formats.mapfile import read_map
    from aion_cli.mapquery import load_map

    arrays, manifest = read_map(path)
    members, size = len(arrays), sum(int(a.nbytes) for a in arrays.values())
    del arrays
    load_map(path)
    return {"members": members, "bytes": size, "consistent": True,
            "sealed": manifest.get(FIELD) is not None, "derived_stale": stale_because(manifest)}


def _derived_text(verified: dict[str, Any]) -> str:
    """What ``info --verify`` says of the map's derived members (``aion_cli.derived_seal``)."""
    what = "; its derived members (forecast_*, provisional_*)"
    if not verified.get("sealed"):
        return (f"{what} carry no seal (written by an aion before 2026-12-08, or by another "
                "writer): queries use them as stored")
    stale = verified.get("derived_stale")
    if stale is None:
        return f"{what} are its own"
    return f"{what} are not its own ({markup_safe(stale)}): queries compute them again"


def _hierarchy(path: Path) -> dict[str, Any]:
    """The layer the map's latest scene graph took its places from (``nav_layer``:
    ``places``, ``mesh_places``, ...), each of its rooms (id, name: None when the graph gives
    none, and how many places it holds) and each building (id, name, and how many rooms it
    holds); None and empty without a graph, or, with a warning that says why (under
    ``warnings``), when the state and graph cannot be read: a damaged member, a state a
    newer aion wrote, an invalid stored configuration."""
    import numpy as np

    from aion_cli.engine.node_ids import node_label
    from aion_cli.errors import AionError
    from aion_cli.mapquery import load_map_head
    from aion_cli.room_names import name_of

    try:
        graph = load_map_head(path).graph
    except AionError as exc:
        return {
            "nav_layer": None,
            "rooms": [],
            "buildings": [],
            "warnings": [
                f"{path.name}: aion cannot read this map's state and scene graph ({exc}): "
                f"its graph layer, rooms and buildings are not shown, and queries refuse the "
                f"map; `aion info {path_word(path)} --verify` checks every member"
            ],
        }
    if graph is None:
        return {"nav_layer": None, "rooms": [], "buildings": [], "warnings": []}

    def held(layer: Any, children: Any, key: str) -> list[dict[str, Any]]:
        return [
            {
                "id": node_label(int(node_id)),
                "name": name_of(layer, k),
                key: int(np.count_nonzero(children.parent == np.uint64(node_id))),
            }
            for k, node_id in enumerate(layer.ids.tolist())
        ]

    return {
        "nav_layer": graph.layer_name,
        "rooms": held(graph.rooms, graph.places, "places"),
        "buildings": held(graph.buildings, graph.rooms, "rooms"),
        "warnings": [],
    }


def span_with_days(length: str, start: Any, end: Any, report: dict[str, Any]) -> str:
    """``5d00h: Mon 2026-01-05 00:00 to Sat 2026-01-10 00:00 UTC``: the span's ends in
    the map's zone with their weekdays (which kinds of day the map can know); the length
    alone for a zone this machine does not know or a map without data."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.errors import AionError
    from aion_cli.timeparse import resolve_zone

    if not isinstance(start, int) or not isinstance(end, int):
        return length
    try:
        zone = resolve_zone(str(report.get("timezone") or "UTC"))
    except AionError:
        return length

    def when(t_ns: int, cut: int) -> str:  # to the microsecond, less ``cut`` characters
        full = from_ns(t_ns, zone).strftime("%a %Y-%m-%d %H:%M:%S.%f")
        return full[: len(full) - cut]

    # to the minute; a span inside one minute (a half-second leg_tracker bag read "03:16 to
    # 03:16") to the second, or to the millisecond, where its ends first differ
    cut = next((c for c in (10, 7) if when(start, c) != when(end, c)), 3)
    cut = 10 if start == end else cut
    return f"{length}: {when(start, cut)} to {when(end, cut)} {zone.name}"


def clock_in(t_ns: int, zone: str) -> str:
    """``2012-10-24 09:00:00``: a UNIX-ns time on the clock of ``zone`` (a zone name info has
    resolved), cut to the second, without the zone's name: ``aion info`` shows every time of
    a log or a map in one zone and names it once."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.timeparse import resolve_zone

    return from_ns(int(t_ns), resolve_zone(zone)).strftime("%Y-%m-%d %H:%M:%S")


def created_text(created: Any, report: dict[str, Any]) -> str:
    """When the map was written (the manifest's ``created``, UTC ``2026-12-07T04:44:13Z``)
    on the clock of the map's zone, as :func:`clock_in` writes it, followed by the zone's
    name as the time span row ends with it (``2026-12-07 13:44:13 Asia/Tokyo``: a bare time
    read as the machine's own); as the manifest has it when either cannot be read (a zone
    this machine does not know, a hand-edited manifest)."""
    from datetime import datetime

    from aion_cli.errors import AionError
    from aion_cli.timeparse import resolve_zone, to_ns

    try:
        moment = datetime.fromisoformat(str(created))
        zone = resolve_zone(str(report.get("timezone") or "UTC")).name
    except (AionError, ValueError):
        return str(created)
    if moment.tzinfo is None:
        return str(created)
    return f"{clock_in(to_ns(moment), zone)} {zone}"


def print_map(report: dict[str, Any]) -> None:
    """The table of a map's manifest; its strings (input names, creator, sources, config
    values) are escaped like a log's (:func:`_print`): a map file is input too."""
    from rich.table import Table

    from aion_cli.cli.build_summary import span_text
    from aion_cli.cli.console import print_table
    from aion_cli.cli.output import markup_safe as safe
    from aion_cli.engine.config import ModelConfig

    span = report.get("time_span", {})
    start, end = span.get("start_ns"), span.get("end_ns")
    seconds = None if start is None or end is None else (end - start) / 1e9
    counts = report.get("counts", {})
    table = Table(title=f"map {safe(report['map'])}", show_header=False, title_justify="left")
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value")
    table.add_row("format", safe(f"{report.get('format')} {report.get('version')}"))
    # the span names the map's zone; the build's own time is on the same clock, named too
    span_row = span_with_days(span_text(seconds), start, end, report)
    table.add_row("time span", span_row)
    created = created_text(report.get("created"), report)
    table.add_row("created", safe(f"{created} by {report.get('creator')}"))
    table.add_row("detections used", f"{counts.get('used', 0):,} of {counts.get('read', 0):,}")
    for reason, count in sorted((counts.get("dropped") or {}).items()):
        if count:  # as the build's summary names them
            table.add_row(f"  dropped: {safe(reason)}", f"{count:,}")
    table.add_row("nodes / cells", f"{counts.get('nodes', 0):,} / {counts.get('cells', 0):,}")
    if report.get("entries") is not None:
        from aion_cli.mapquery import entries_text

        table.add_row("entries", entries_text(report["entries"], report["places_without_data"]))
    if "windows" in counts:  # as the build's summary counted them (mapquery.state_counts)
        table.add_row("windows observed", f"{counts['windows']:,}")
    layer = report.get("nav_layer")
    from aion_cli.derive_graph import DERIVED_LAYER

    # a derived graph's places are its own ("derived from walking people"): no layer to name
    named = layer and layer != DERIVED_LAYER
    graph_text = f"{report.get('graph_source')}" + (f", places from layer {layer}" if named else "")
    table.add_row("graph", safe(graph_text))
    if report.get("map_frame"):  # every position of the map is in it (build --map-frame)
        table.add_row("map frame", safe(report["map_frame"]))
    rooms = report.get("rooms") or []
    if rooms:
        named = [f"{r['name']} ({r['id']})" if r.get("name") else str(r["id"]) for r in rooms]
        table.add_row("rooms", safe(f"{len(rooms):,}: {first_few(named, 12)}"))
    buildings = report.get("buildings") or []
    if buildings:
        named = [f"{b['name']} ({b['id']})" if b.get("name") else str(b["id"]) for b in buildings]
        table.add_row("buildings", safe(f"{len(buildings):,}: {first_few(named, 12)}"))
    table.add_row("observation", safe(report.get("observation")))
    merged = report.get("merged_from") or []
    if merged:  # how the maps were joined here; which maps, one row each below the inputs
        from aion_cli.merge_names import merged_from_text

        table.add_row("merged from", safe(merged_from_text(len(merged), report.get("lineage"))))
    query_only = report.get("query_only")
    if isinstance(query_only, dict):
        from aion_cli.query_only import query_only_text

        table.add_row("query only", safe(query_only_text(query_only)))
    part = report.get("part")
    if isinstance(part, dict):
        held = int(part.get("held_days", 0))
        table.add_row(
            "part map",
            safe(f"aion build --part: {held:,} closed day{'' if held == 1 else 's'} held "
                 f"unscored, and the last day open, for a merge; aion merge "
                 f"{path_word(str(report['map']))} [more parts] -o MAP.aion scores them into a "
                 "map"),
        )
    families = report.get("families") or {}
    for kind in ("flow", "direction"):
        tally = families.get(kind) or {}
        if tally:
            text = ", ".join(f"{name} {count:,}" for name, count in sorted(tally.items()))
            table.add_row(f"{kind} models", safe(text))
    from aion_cli.engine.temporal.choice import CHOICE_RULES

    if families.get("flow") and families.get("rules", 1) != CHOICE_RULES:
        table.add_row(
            "models note",
            safe("counted by an aion whose rules chose differently; this one chooses afresh "
                 "for each query (aion predict --format json names each entry's family; "
                 "continuing the map with more logs, or rebuilding it, counts them again)"),
        )
    from aion_cli.manifest import days_scored_text

    scored = days_scored_text(report)
    if scored is not None:
        table.add_row("days scored", scored)
    calendar = families.get("calendar")
    if isinstance(calendar, dict):
        profile = str((report.get("config") or {}).get("profile", "day_weekend"))
        table.add_row("calendar", safe(calendar_text(calendar, profile)))
    from aion_cli.forecast_notes import observed_hours

    hours = observed_hours(families, report.get("config") or {}, report.get("timezone"))
    if hours is not None:
        zone = f" ({report.get('timezone')})"
        if span_row.endswith(zone[2:-1]):  # the time span row names the zone: once is enough
            hours = hours.removesuffix(zone)
        table.add_row("hours observed", safe(hours))
    if families:
        table.add_row(
            "reconciled", "yes: totals follow the map's own forecast" if families.get("reconciled")
            else "no"
        )
    verified = report.get("verified")
    if isinstance(verified, dict):
        table.add_row(
            "verified",
            f"every member ({verified['members']:,}, {human_size(verified['bytes'])}) matches "
            "its checksum; the state is consistent" + _derived_text(verified),
        )
    defaults = ModelConfig().parameters()
    changed = {k: v for k, v in report.get("config", {}).items() if defaults.get(k) != v}
    table.add_row(
        "config", safe(", ".join(f"{k}={v}" for k, v in changed.items()) or "defaults")
    )
    for text in input_rows(report.get("inputs", [])):
        table.add_row("input", safe(text))
    for text in input_rows(merged, what="maps"):  # aion merge's inputs, as the logs are
        table.add_row("merged map", safe(text))
    print_table(table)
    from aion_cli.cli.console import warn_each

    warn_each(list(report.get("warnings", [])))


INPUT_ROWS = 8
"""Inputs a map's table lists one per row; a map continued day after day for months lists
its first and last few and counts the rest (its JSON lists every one)."""


def input_rows(
    inputs: list[dict[str, Any]], limit: int = INPUT_ROWS, what: str = "logs"
) -> list[str]:
    """The table's ``input`` cells: each log's name, size and sha256 prefix, or, beyond
    ``limit`` logs, the first and last ``limit // 2`` with one cell counting those between;
    the same of the maps a merged map came from (``what="maps"``)."""
    from aion_cli.cli.output import human_size
    from aion_cli.merge_names import shown_names

    cells = [
        f"{shown}  {human_size(entry['size'])}  sha256 {entry['sha256'][:12]}"
        for entry, shown in zip(inputs, shown_names(inputs), strict=True)
    ]
    if len(inputs) <= limit:
        return cells
    half = limit // 2
    between = len(inputs) - 2 * half
    return [
        *cells[:half],
        f"... {between:,} more {what} (of {len(inputs):,}; --format json lists every one)",
        *cells[-half:],
    ]


def calendar_text(calendar: dict[str, Any], profile: str) -> str:
    """The ``calendar`` row of ``aion info``: the calendar the map's days ask for
    (``families.calendar``, :mod:`aion_cli.engine.temporal.week_evidence`) and the one its
    forecasts use (``profile``; a ``week`` map's follow the choice,
    :mod:`aion_cli.engine.temporal.calendar_view`)."""
    from aion_cli.engine.temporal.week_evidence import MIN_DAYS

    gain, days = float(calendar.get("gain", 0.0)), int(calendar.get("weekday_days", 0))
    using = f"forecasts use profile = \"{profile}\""
    if profile == "week":
        using += (", the week's hours" if calendar.get("calendar") == "week" else
                  ", its hours pooled into weekdays and weekends")
    if calendar.get("calendar") == "week":
        hint = "" if profile == "week" else (
            "; profile = \"week\" keeps each weekday's own hours (3.5 times an entry's "
            "profile bytes)"
        )
        return (f"week: the hours of the week forecast the closed days {gain:,.1f} nats "
                f"better day ahead than those of weekdays and weekends; {using}{hint}")
    if days < MIN_DAYS:
        return (f"weekdays and weekends: too few days to judge the week's hours (each "
                f"day of the week observed needs {MIN_DAYS}, the fewest seen {days}); {using}")
    return (f"weekdays and weekends: the hours of the week forecast the closed days no "
            f"better day ahead ({gain:+,.1f} nats); {using}")
