"""Entry tables as records: the rows of ``aion predict``, ``export`` and ``Map.predict``.

Field names (stable, documented in ``aion predict --help``):

``id`` ("p12", "R3", or "c<key>" for a hash cell), ``name`` (a room's or building's name in
the scene graph, "kitchen"; null for the rest), ``kind`` (node, cell, room, building), ``layer``,
``x``/``y``/``z`` (m), ``flow`` (expected detections per window), ``flow_per_hour``,
``direction_deg`` (dominant direction: the direction of the argmax bin, degrees from +x
counter-clockwise; null without flow), ``direction_bin`` (that bin, -1 without flow),
``concentration`` (0..1, the mean resultant length of the histogram),
``entropy`` (normalised directional entropy 0..1, null without flow), ``mean_speed`` (m/s
over bins with known speed, null if unknown), ``histogram`` (B direction probabilities, bin b
centred at -180 + (b + 0.5)·360/B degrees), ``speed_per_bin`` (m/s per bin, JSON only),
``family`` / ``direction_family`` (the temporal model that forecast the flow and the
directions: static, shape, profile, fremen1..4; "historical" for what was observed, "none" for
a place without data, "aggregate" for rooms), ``flow_p10`` / ``flow_p90`` (10th and 90th
percentile of the number of detections in a window, from the predictive negative binomial;
a room's or building's with its places' covariance, ``engine.temporal.totals``; null
historically).

The CLI (``aion_cli.cli.predict``, ``cli.export``) and the Python API format these records;
nothing here knows click or rich.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

from aion_cli.engine.time_text import Zone

if TYPE_CHECKING:
    from aion_cli.entry_columns import EntryColumns
    from aion_cli.mapquery import LoadedMap

KINDS = {0: "cell", 1: "node", 2: "room", 3: "building"}


def kind_label(kind: Any) -> str:
    """An entry's kind as a record names it: an ``EntryTable`` kind code through
    :data:`KINDS` (the code itself, as text, when unknown); a name stays as it is."""
    return kind if isinstance(kind, str) else KINDS.get(int(kind), str(kind))
LAYERS = ("all", "places", "cells", "rooms", "buildings")

#: the columns of ``predict``'s CSV (and ``export``'s entries.csv), in order: the record
#: fields (JSON has these and ``speed_per_bin``), then the time's ``hour_observed``
#: (:func:`observed_text`, the same on every row), as the series CSV ends with it
CSV_KEYS = [
    "id",
    "kind",
    "layer",
    "x",
    "y",
    "z",
    "flow",
    "flow_per_hour",
    "flow_p10",
    "flow_p90",
    "direction_deg",
    "direction_bin",
    "concentration",
    "entropy",
    "mean_speed",
    "histogram",
    "family",
    "direction_family",
    "name",
    "hour_observed",
]


def observed_text(seen: bool | None) -> str | None:
    """A time's ``hour_observed`` as a CSV cell: ``true`` / ``false`` as JSON writes it, None
    (an empty cell) where not known: historical, or a map that does not list its hours."""
    return None if seen is None else "true" if seen else "false"


def rows_from_table(
    table: Any, index: Any = None, names: Mapping[str, str] | None = None
) -> list[dict[str, Any]]:
    """One dict per entry of an engine ``EntryTable``, for the rows ``index`` (an array of
    row numbers, in that order; default every row): a query that prints ten rows of a map of
    10^5 entries builds ten dicts, and computes the count quantiles of those ten only.
    ``names``: the graph's names of rooms and buildings by id ("R2": "kitchen"), the rows'
    ``name`` (None for the rest). The dicts of :func:`aion_cli.entry_columns.entry_columns`,
    which the JSON and CSV writers use without dicts."""
    from aion_cli.entry_columns import entry_columns

    return entry_columns(table, index, names).records()


def entry_ids(table: Any, index: Any) -> Any:
    """Display ids (``EntryTable.ids``) of rows ``index`` only, formatted as the table
    formats them (``c<key>`` for cells, the node symbol otherwise) without formatting the
    other 10^5."""
    import numpy as np


    picked = np.asarray(index, dtype=np.int64)
    cached = getattr(table, "__dict__", {}).get("ids")
    if cached is not None or not (hasattr(table, "key") and hasattr(table, "node_id")):
        return np.asarray(table.ids)[picked]
    from aion_cli.engine.query import node_symbol

    kind = np.asarray(table.kind)[picked]
    is_cell = kind == 0
    out = np.empty(picked.size, dtype=object)
    out[is_cell] = [f"c{k}" for k in np.asarray(table.key)[picked[is_cell]].tolist()]
    out[~is_cell] = list(node_symbol(np.asarray(table.node_id)[picked[~is_cell]]))
    return out


def ordered_rows(table: Any, index: Any, top: int | None) -> Any:
    """The rows ``index`` in :func:`sort_rows` order (busiest first, entries without a known
    flow last, ties by id), the first ``top`` of them: the order of the dicts, computed on
    arrays. Only rows tied with the ``top``-th busiest (and those above it) are formatted
    and sorted, found with ``np.partition``."""
    import numpy as np


    picked = np.asarray(index, dtype=np.int64)
    flow = np.asarray(table.flow, dtype=np.float64)[picked]  # the descriptors' flow
    key = np.where(np.isfinite(flow), -flow, np.inf)  # unknown flows last, then by id
    if top is not None and top < picked.size:
        threshold = np.partition(key, top - 1)[top - 1]
        keep = np.flatnonzero(key <= threshold)
        picked, key = picked[keep], key[keep]
    ids = np.asarray([str(i) for i in entry_ids(table, picked)], dtype=str)
    order = np.lexsort((ids, key)) if picked.size else np.zeros(0, np.int64)
    out = picked[order]
    return out if top is None else out[:top]


def sort_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Busiest first; entries without a known flow last; ties by id for a stable order."""
    return sorted(rows, key=lambda r: (r["flow"] is None, -(r["flow"] or 0.0), r["id"]))


def document(
    map_path: Any,
    bins: int,
    rows: list[dict[str, Any]],
    t_ns: int | None,
    zone: Zone | None,
    hour_observed: bool | None = None,
) -> dict[str, Any]:
    """The JSON document of ``predict`` and of ``export``'s entries.json: metadata and rows.
    ``t_ns`` None means historical (what was observed); ``hour_observed`` (when known:
    :func:`hour_flags`) whether any day observed the time's hour of the day."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.formats.outputs import safe_text

    when = None if t_ns is None or zone is None else (format_ns(t_ns, zone), zone.name)
    doc: dict[str, Any] = {
        "map": safe_text(map_path),  # UTF-8 in the JSON whatever the file name's bytes
        "mode": "historical" if when is None else "predicted",
        "time": None if when is None else when[0],
        "time_ns": t_ns,
        "zone": None if when is None else when[1],
        "bins": int(bins),
        "bin_centres_deg": [-180.0 + (b + 0.5) * 360.0 / bins for b in range(bins)],
    }
    if hour_observed is not None:
        doc["hour_observed"] = hour_observed
    doc["entries"] = rows
    return doc


def hour_flags(loaded: LoadedMap, times_ns: Sequence[int | None]) -> list[bool | None]:
    """Per time, whether the map observed its hour of the day on some day (JSON
    ``hour_observed``; where not, the forecast is extrapolated); None for a time that is
    None (as observed) and for every time of a map that does not list its observed hours."""
    from aion_cli.forecast_notes import hour_observed
    from aion_cli.manifest import Manifest

    raw = dict(loaded.manifest or {})
    raw.setdefault("state", {})
    known = [int(t) for t in times_ns if t is not None]
    flags = hour_observed(Manifest.from_dict(raw), known) if known else None
    if flags is None:
        return [None] * len(times_ns)
    it = iter(flags)
    return [None if t is None else next(it) for t in times_ns]


def scene_about(loaded: LoadedMap, t_ns: int | None, zone: Zone | None) -> list[str]:
    """What a PLY / PCD scene's header says of its forecast (its comments after aion's
    marker; the file has no JSON document): ``aion mode``, ``aion time``, ``aion zone`` and
    ``aion hour_observed`` as :func:`document` gives them (the time in ``zone``, UTC without
    one; the flag ``true`` / ``false``, left out where not known), ``aion mode historical``
    alone as observed."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.timeparse import resolve_zone

    if t_ns is None:
        return ["aion mode historical"]
    where = zone if zone is not None else resolve_zone("UTC")
    lines = [
        "aion mode predicted",
        f"aion time {format_ns(t_ns, where)}",
        f"aion zone {where.name}",
    ]
    seen = observed_text(hour_flags(loaded, [t_ns])[0])
    return lines if seen is None else [*lines, f"aion hour_observed {seen}"]


def predicted_records(
    loaded: LoadedMap,
    t_ns: int | None,
    layer: str = "all",
    nodes: Sequence[str | int] = (),
    at: str | None = None,
    top: int | None = None,
) -> tuple[list[dict[str, Any]], int]:
    """The records of the entries asked for (``--layer``, ``--node``, ``--at``) at ``t_ns``
    (None: historical), busiest first, the first ``top`` of them; and how many entries
    matched. Rows are ordered and cut on arrays, so dicts are made for the rows returned only
    (``aion predict`` and :meth:`aion_cli.Map.predict`)."""
    columns, count = predicted_columns(loaded, t_ns, layer, nodes, at, top)
    return columns.records(), count


def predicted_columns(
    loaded: LoadedMap,
    t_ns: int | None,
    layer: str = "all",
    nodes: Sequence[str | int] = (),
    at: str | None = None,
    top: int | None = None,
) -> tuple[EntryColumns, int]:
    """:func:`predicted_records` as columns (:mod:`aion_cli.entry_columns`), which
    ``predict --format json|csv`` writes as text without a dict per entry."""
    from aion_cli.entry_columns import entry_columns
    from aion_cli.entry_selection import chosen_entries

    table, _, index, names = chosen_entries(loaded, t_ns, layer, nodes, at)
    return entry_columns(table, ordered_rows(table, index, top), names), len(index)


def entry_table(loaded: LoadedMap, t_ns: int | None, layer: str = "all") -> Any:
    """The engine's entry table of a map at ``t_ns`` (None: historical), aggregated to rooms
    or buildings for those layers (an :class:`InputError` for a map without a scene graph)."""
    from aion_cli.engine import query
    from aion_cli.errors import InputError

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
        if len(table.xyz) == 0:  # an empty table would read as "nobody walks there"
            from aion_cli.room_names import rooms_off_the_nav_layer

            off = rooms_off_the_nav_layer(loaded.graph)
            if off is not None and (level == "rooms" or len(loaded.graph.buildings)):
                raise InputError(off[0], hint=off[1])
            raise InputError(
                f"the map's scene graph has no {layer} that hold its places",
                hint="--layer places answers per place; rooms and buildings come from a "
                "Hydra scene graph that has them (a graph aion derives has places only)",
            )
    return table


SERIES_PAIRS = 1 << 18
"""(entry, time) pairs one :func:`flow_series` step evaluates at once (bounds the direction
histograms ``Predictor.pairs`` returns with the flows: pairs x bins floats)."""


def flow_series(
    loaded: LoadedMap,
    times_ns: Any,
    layer: Literal["rooms", "buildings", "all"] = "rooms",
) -> tuple[Any, Any]:
    """Predicted flow (expected detections per window) at many times (``times_ns``, UNIX
    ns, any int sequence or array), summed per room or building (``layer``) or over the
    whole map (``"all"``, one column): the display ids (``R3``; ``"all"``) and
    ``float64[T, G]``. Each row equals the ``flow`` of ``entry_table(loaded, t, layer)`` at
    that time (``aion predict --layer rooms``), computed with the predictor's batch path
    (``Predictor.pairs`` over every entry x time pair, a block of times at a time) instead of
    one table per time; entries never observed count as 0, as in the room sums. With
    :func:`group_flow_series` the ids as numbers."""
    labels, _, out = group_flow_series(loaded, times_ns, layer)
    return labels, out


def group_flow_series(
    loaded: LoadedMap,
    times_ns: Any,
    layer: Literal["rooms", "buildings", "all"] = "rooms",
    progress: Callable[[int], None] | None = None,
) -> tuple[Any, Any, Any]:
    """:func:`flow_series` with the groups' node ids (``uint64[G]``, sorted; one 0 for
    ``"all"``) beside their display ids: ``(labels, ids, flow)``; ``progress(k)`` after
    each block of times, ``k`` the times done."""
    import numpy as np

    from aion_cli.engine.query import node_symbol, parent_ids
    from aion_cli.errors import InputError

    times = np.asarray(times_ns, dtype=np.int64).reshape(-1)
    state = loaded.state
    rows, predictor = state.predictor()
    graph = loaded.graph
    if layer in ("rooms", "buildings"):
        if graph is None:
            raise InputError(
                f"the map has no scene graph, so no {layer}",
                hint="build with a Hydra scene graph (--graph FILE) to get rooms and buildings",
            )
        parent = parent_ids(graph.places.ids, graph.places.parent, state.entries.node_id[rows])
        parent[state.entries.kind[rows] != 1] = 0  # hash cells belong to no room
        above = graph.places.parent  # every group holding a place (without entries: 0 flow)
        if layer == "buildings":  # via the rooms, as aggregate_table goes
            parent = parent_ids(graph.rooms.ids, graph.rooms.parent, parent)
            above = parent_ids(graph.rooms.ids, graph.rooms.parent, above)
        members = np.flatnonzero(parent != 0)
        ids = np.unique(np.concatenate([parent[members], above]))
        ids = ids[ids != 0]
        inverse = np.searchsorted(ids, parent[members])
        labels = node_symbol(ids)
    else:
        members = np.arange(rows.size)
        inverse = np.zeros(rows.size, np.int64)
        ids = np.zeros(1, np.uint64)
        labels = np.asarray(["all"])
    out = np.zeros((times.size, labels.size))
    if members.size == 0 or times.size == 0:
        if progress is not None:
            progress(times.size)
        return labels, ids, out
    per_step = max(1, SERIES_PAIRS // members.size)
    for a in range(0, times.size, per_step):
        block = times[a : a + per_step]
        flow = predictor.flows(np.tile(members, block.size), np.repeat(block, members.size))
        # per (time, room), summed in entry order as hierarchy.aggregate sums a room's places
        slot = (np.arange(block.size)[:, None] * labels.size + inverse[None, :]).reshape(-1)
        sums = np.bincount(slot, weights=np.nan_to_num(flow), minlength=block.size * labels.size)
        out[a : a + block.size] = sums.reshape(block.size, labels.size)
        if progress is not None:
            progress(a + block.size)
    return labels, ids, out
