"""``aion predict``: flows per place (or cell, room, building) at a time, from a map."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import (
    STEP_HELP,
    TIME_HELP,
    announce_time,
    map_argument,
    note_empty,
    option_given,
    quiet_option,
    resolve_time,
    tz_option,
)
from aion_cli.cli.completion import complete_nodes
from aion_cli.cli.entries import COLUMNS
from aion_cli.cli.output import AionCommand, Column, emit, emit_chunks, format_option
from aion_cli.cli.predict_series import (
    TABLE_COLUMNS,
    check_series_options,
    run_series,
    say_flowless,
    say_nearest,
)
from aion_cli.note_words import EXTRAPOLATED
from aion_cli.predictions import LAYERS

EPILOG = """\b
Examples:
  aion predict office.aion --time "2026-11-23 08:30"          the 100 busiest (JSON/CSV: all)
  aion predict office.aion --time "tomorrow 12:00" --top 10    the ten busiest
  aion predict office.aion --time now --node p12 --format json
  aion predict office.aion --time "+2h" --at 3.5,-1.0          the entry nearest a point
  aion predict office.aion --time "monday 08:30" --layer rooms
  aion predict office.aion --historical --format csv > hist.csv  what was observed
  aion predict office.aion --node p12 --from "monday 06:00" --to "monday 20:00" --step 1h
                                                               how busy p12 is over the day

\b
JSON keys: map, mode (predicted / historical), time, time_ns, zone, bins, bin_centres_deg,
hour_observed (not with --historical: whether any day of the data observed the time's hour),
entries[{the fields}].
CSV: a row per entry, the fields below, then hour_observed (the JSON's, true / false on every
row; empty with --historical or for a map that lists no hours).
Fields (JSON keys, CSV columns): id, kind (node/cell/room/building), layer, x, y, z,
flow (expected detections per window), flow_per_hour, direction_deg (dominant direction:
where most people walk, degrees counter-clockwise from +x), direction_bin (its bin),
concentration (0..1, 1 = everyone walks one way, 0 = balanced, e.g. both ways), entropy (0..1,
1 = people walk every way), mean_speed (m/s), histogram (B direction probabilities; bin b
is centred at -180 + (b + 0.5)*360/B degrees; CSV: histogram_0 .. histogram_<B-1>),
speed_per_bin (JSON only), family /
direction_family (the model that forecast the flow and the directions), flow_p10 / flow_p90
(the predictive spread of a window's count), name (a room's or building's name in the scene
graph; empty for the rest).
A series (--from, --to, --step) prints one row per time and a column per entry (the
busiest over the series); JSON (map, mode: series, zone, times, times_ns, hour_observed
per time, entries) lists each entry (id, name, kind, layer, x, y, z) with its
flow and flow_per_hour per time,
CSV has one row per time and entry (time, time_ns, id, name, kind, layer, x, y, z,
flow, flow_per_hour, hour_observed: true / false as in the JSON, empty for a map that lists
no hours). Each value equals `predict --time` at that time. The series includes --to
when it falls on a step. A step of days or weeks (1d, 1w) keeps the wall-clock time in the
zone across a daylight-saving change; 24h is 24 elapsed hours. A day's time the change skips
(02:30 on the spring change) is read as --time reads it: as late as the clocks jump (03:30);
one it repeats is its first occurrence.
"""

TABLE_LIMIT = 100
"""Rows a terminal table shows without --top (JSON and CSV always have every entry)."""



@click.command(
    "predict",
    short_help="Flows per place at a time, or as observed.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("tz",),
    once={
        "time_text": "for several times, a series: --from T0 --to T1 --step 1h",
        "t_from": "a series has one start", "t_to": "a series has one end",
        "at": "for several entries, --node ID (repeatable)",
    },
)
@map_argument
@click.option(
    "-t", "--time", "time_text", metavar="T", default="now", show_default=True, help=TIME_HELP
)
@tz_option
@click.option(
    "--historical",
    is_flag=True,
    help="What was observed (detections per observed window, the raw direction "
    "proportions) instead of a prediction.",
)
@click.option(
    "--node",
    "nodes",
    multiple=True,
    metavar="ID",
    help="Only this entry: a place (p12), a hash cell (c<key>), or a room or building by id "
    "or name (R2, kitchen: answered per room); repeatable.",
    shell_complete=complete_nodes,
)
@click.option("--at", "at", metavar="X,Y[,Z]", help="Only the entry nearest to this point.")
@click.option(
    "--layer",
    type=click.Choice(LAYERS, case_sensitive=False),
    default="all",
    show_default=True,
    help="Places (nodes), hash cells, or aggregated rooms / buildings.",
)
@click.option(
    "--top",
    metavar="N",
    type=click.IntRange(min=1),
    help="Only the N busiest entries (a series: the N busiest over it) [default: all; a table "
    f"shows the {TABLE_LIMIT} busiest, a series' table {TABLE_COLUMNS}].",
)
@click.option("--from", "t_from", metavar="T", help="Start of a series of predictions.")
@click.option("--to", "t_to", metavar="T", help="End of the series (inclusive).")
@click.option("--step", metavar="DURATION", help=f"Series step: {STEP_HELP} [default: 1h].")
@format_option()
@quiet_option
def command(
    map_path: Path,
    time_text: str,
    tz: str | None,
    historical: bool,
    nodes: tuple[str, ...],
    at: str | None,
    layer: str,
    top: int | None,
    t_from: str | None,
    t_to: str | None,
    step: str | None,
    fmt: str,
) -> None:
    """Predict the flow dynamics of every place of MAP at a time.

    For each entry: how many people are expected per time window, their dominant walking
    direction, how ordered the flow is (entropy, concentration), their speed, and the
    histogram of directions.
    """
    from aion_cli.cli.common import load
    from aion_cli.engine.time_text import format_ns
    from aion_cli.predictions import document, hour_flags, predicted_columns

    time_given = option_given("time_text")
    series = check_series_options(t_from, t_to, step, historical, time_given, tz is not None)
    if at is not None:  # a mistyped point fails now, not after the map's first query
        from aion_cli.engine.node_ids import require_point

        require_point(at, "--at")
    loaded = load(map_path)
    if series and t_from is not None and t_to is not None:
        request = (layer, nodes, at, top)
        run_series(map_path, loaded, t_from, t_to, "1h" if step is None else step, tz, request, fmt)
        return
    t_ns: int | None = None
    zone = None
    if not historical:
        t_ns, zone = resolve_time(time_text, tz, loaded)
    fmt = fmt.lower()
    shown = TABLE_LIMIT if fmt == "table" and top is None else top
    entries, count = predicted_columns(loaded, t_ns, layer, nodes, at, shown)
    if t_ns is not None and zone is not None:
        announce_time(t_ns, zone, loaded=loaded, text=time_text)
    else:  # --historical: no forecast's notes, but an empty map's
        note_empty(loaded)
    say_nearest(at, next(iter(entries.records()), None) if at is not None else None)
    say_flowless(loaded, entries.column("kind"))
    (seen,) = hour_flags(loaded, [t_ns])
    if fmt in ("json", "csv"):
        doc = document(map_path, loaded.config.bins, [], t_ns, zone, seen)
        _emit_text(fmt, entries, doc, seen)
        return
    rows = entries.records()
    title = (
        "historical flows"
        if t_ns is None or zone is None
        else (f"predicted flows at {format_ns(t_ns, zone)}")
    )
    if seen is False:  # as a series marks such a row: stdout kept in a file keeps the word
        title += f" {EXTRAPOLATED}"
    if top is None and count > TABLE_LIMIT:
        from aion_cli.cli.console import note

        note(
            f"showing the {TABLE_LIMIT} busiest of {count:,} entries: use --top N, "
            "--format csv or --format json for all"
        )
    columns = COLUMNS
    if any(row.get("name") for row in rows):  # rooms the graph names: a column for them
        columns = [COLUMNS[0], Column("name", "name", lambda v: v or "", justify="left"),
                   *COLUMNS[1:]]
    emit(fmt, rows, columns, title=title)


def _emit_text(fmt: str, entries: Any, doc: dict[str, Any], seen: bool | None) -> None:
    """Every entry as JSON (``doc`` with them) or CSV on stdout, written from the columns
    ``entries`` (:mod:`aion_cli.entry_text`): the bytes of ``emit``'s ``to_json`` /
    ``to_csv`` of the records, each CSV row with the time's ``hour_observed`` (``seen``, as
    the JSON's ``hour_observed``)."""
    from aion_cli.entry_text import predict_csv, predict_json
    from aion_cli.predictions import CSV_KEYS

    if fmt == "json":
        emit_chunks(predict_json(doc, entries), nl=True)
    else:
        emit_chunks(predict_csv(entries, CSV_KEYS, seen), nl=False)
