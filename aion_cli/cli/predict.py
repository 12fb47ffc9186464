"""``aion predict``: flows per place (or cell, room, building) at a time, from a map."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import click

from aion_cli.cli.common import (
    TIME_HELP,
    announce_time,
    map_argument,
    resolve_time,
    tz_option,
)
from aion_cli.cli.entries import COLUMNS, CSV_KEYS, document, ordered_rows, rows_from_table
from aion_cli.cli.output import AionCommand, emit, format_option

EPILOG = """\b
Examples:
  aion predict office.aion --time "2026-11-23 08:30"          every place and cell
  aion predict office.aion --time "tomorrow 12:00" --top 10    the ten busiest
  aion predict office.aion --time now --node p12 --format json
  aion predict office.aion --time "+2h" --at 3.5,-1.0          the entry nearest a point
  aion predict office.aion --time "monday 08:30" --layer rooms
  aion predict office.aion --historical --format csv > hist.csv  what was observed

\b
Fields (JSON keys, CSV columns): id, kind (node/cell/room/building), layer, x, y, z,
flow (expected detections per window), flow_per_hour, direction_deg (dominant direction,
degrees counter-clockwise from +x), direction_bin, concentration (0..1), entropy (0..1,
1 = people walk every way), mean_speed (m/s), histogram (B direction probabilities; bin b
is centred at -180 + (b + 0.5)*360/B degrees), speed_per_bin (JSON only).
"""

LAYERS = ("all", "places", "cells", "rooms", "buildings")
TABLE_LIMIT = 100
"""Rows a terminal table shows without --top (JSON and CSV always have every entry)."""


@click.command(
    "predict",
    short_help="Flows per place at a time, or as observed.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("tz",),
)
@map_argument
@click.option(
    "-t", "--time", "time_text", metavar="T", default="now", show_default=True, help=TIME_HELP
)
@tz_option
@click.option(
    "--historical",
    is_flag=True,
    help="What was observed (cumulative counts) instead of a prediction.",
)
@click.option(
    "--node", "nodes", multiple=True, metavar="ID", help="Only this node (e.g. p12); repeatable."
)
@click.option("--at", "at", metavar="X,Y[,Z]", help="Only the entry nearest to this point.")
@click.option(
    "--layer",
    type=click.Choice(LAYERS),
    default="all",
    show_default=True,
    help="Places (nodes), hash cells, or aggregated rooms / buildings.",
)
@click.option("--top", type=click.IntRange(min=1), help="Only the N busiest entries.")
@format_option()
def command(
    map_path: Path,
    time_text: str,
    tz: str | None,
    historical: bool,
    nodes: tuple[str, ...],
    at: str | None,
    layer: str,
    top: int | None,
    fmt: str,
) -> None:
    """Predict the flow dynamics of every place of MAP at a time.

    For each entry: how many people are expected per time window, their dominant walking
    direction, how ordered the flow is (entropy, concentration), their speed, and the
    histogram of directions.
    """
    from aion_cli.cli.common import load
    from aion_cli.cli.timeparse import format_ns

    loaded = load(map_path)
    t_ns: int | None = None
    zone = None
    if not historical:
        t_ns, zone = resolve_time(time_text, tz, loaded)
    table = _table(loaded, t_ns, layer)
    # rows are ordered and cut on arrays; dicts are made for the rows printed only
    index = _select(table, layer, nodes, at)
    count = len(index)
    if fmt == "table" and top is None and count > TABLE_LIMIT:
        rows = rows_from_table(table, ordered_rows(table, index, TABLE_LIMIT))
    else:
        rows = rows_from_table(table, ordered_rows(table, index, top))
    payload = document(map_path, loaded.config.bins, rows, t_ns, zone)
    if t_ns is not None and zone is not None:
        announce_time(t_ns, zone)
    title = (
        "historical flows"
        if t_ns is None or zone is None
        else (f"predicted flows at {format_ns(t_ns, zone)}")
    )
    if fmt == "table" and top is None and count > TABLE_LIMIT:
        from aion_cli.cli.console import note

        note(
            f"showing the {TABLE_LIMIT} busiest of {count:,} entries: use --top N, "
            "--format csv or --format json for all"
        )
    emit(fmt, rows, COLUMNS, json_payload=payload, csv_keys=CSV_KEYS, title=title)


def _table(loaded: Any, t_ns: int | None, layer: str) -> Any:
    from aion_cli.engine import query
    from aion_cli.engine.errors import InputError

    table = (
        query.historical_table(loaded.state)
        if t_ns is None
        else query.predict_table(loaded.state, t_ns)
    )
    if layer in ("rooms", "buildings"):
        if loaded.graph is None:
            raise InputError(
                f"the map has no scene graph, so no {layer}",
                hint="build with a Hydra scene graph (--graph FILE) to get rooms and buildings",
            )
        level: Literal["rooms", "buildings"] = "rooms" if layer == "rooms" else "buildings"
        table = query.aggregate_table(table, loaded.graph, level)
    return table


def _select(table: Any, layer: str, nodes: tuple[str, ...], at: str | None) -> Any:
    """Row numbers of the entries asked for (``--layer``, ``--node``, ``--at``), in table
    order (``--node``: in the order given), as an int64 array."""
    import numpy as np

    from aion_cli.cli.entries import KINDS, entry_ids
    from aion_cli.engine.errors import UnknownNodeError
    from aion_cli.engine.node_ids import node_label, parse_node_id, require_point

    index = np.arange(len(table.xyz), dtype=np.int64)
    if layer in ("places", "cells"):
        kind = np.asarray(table.kind)
        names = (
            np.asarray([KINDS.get(int(k), str(k)) for k in np.unique(kind)], dtype=object)
            if kind.dtype.kind in "iu"
            else None
        )
        want = "node" if layer == "places" else "cell"
        if names is not None:
            codes = np.unique(kind)[names == want]
            index = index[np.isin(kind, codes)]
        else:
            index = index[kind == want]
    if nodes:
        wanted = [node_label(parse_node_id(text)) for text in nodes]
        labels = [str(i) for i in entry_ids(table, index)]
        by_id = dict(zip(labels, index.tolist(), strict=True))
        missing = [w for w in wanted if w not in by_id]
        if missing:
            if layer not in ("rooms", "buildings") and all(m[:1] in "RB" for m in missing):
                hint = "rooms and buildings are answered with --layer rooms / --layer buildings"
            else:
                kind_names = [_kind_name(table, e) for e in index.tolist()]
                ids = [i for i, k in zip(labels, kind_names, strict=True) if k != "cell"][:8]
                hint = f"ids include {', '.join(ids)}" if ids else "the map has no nodes"
            raise UnknownNodeError(f"node {', '.join(missing)} is not in the map", hint=hint)
        index = np.asarray([by_id[w] for w in wanted], dtype=np.int64)
    if at is not None:
        x, y, z = require_point(at, "--at")
        if not index.size:
            return index
        xyz = np.asarray(table.xyz, dtype=np.float64)[index]
        dist = np.sqrt(((xyz - np.array([x, y, z])) ** 2).sum(axis=1))
        nearest = float(dist.min())
        # candidates by numpy, the choice by math.dist as the rows' own floats give it
        close = index[dist <= nearest * (1 + 1e-9) + 1e-12] if math.isfinite(nearest) else index
        best = min(
            close.tolist(),
            key=lambda e: math.dist(tuple(float(v) for v in table.xyz[e][:3]), (x, y, z)),
        )
        index = np.array([best], dtype=np.int64)
    return index


def _kind_name(table: Any, e: int) -> str:
    from aion_cli.cli.entries import KINDS

    kind = table.kind[e]
    return kind if isinstance(kind, str) else KINDS.get(int(kind), str(kind))
