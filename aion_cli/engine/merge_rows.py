"""The merge of two maps with nodes, built in the earlier map's storage.

:func:`aion_cli.engine.merge.merge_maps` builds its result in the later map: every entry of
the earlier map is added there. ``aion merge`` folds many maps in time order, so the earlier
map is the growing result, and when the maps' entries do not repeat (a scene-graph session
whose robot maps one area a day: each map holds places and cells of its own) each step
copied all of it again (40 such maps: 19 s, most of it these copies and the searches over
the copied rows). :mod:`aion_cli.engine.merge_cells` avoids the copy for maps without nodes;
this does for any two ordinary maps.

Most of the earlier map's entries take no part in what the merge decides: a cell whose key
the later map neither holds nor redirects, that no place of the later graph could bind and
that no node of the earlier map is released into, goes to a new cell of the result and
receives nothing else. Only the others, the *touched* rows (every node entry, and the cells
at the later map's keys, at the keys of the earlier nodes the later graph lacks, or in reach
of a later place), go through :func:`~aion_cli.engine.merge.merge_closed` with the later map,
as a small map of their own carrying the earlier map's node table, redirects, observation
and global temporal block. The result's rows then replace the touched rows in the earlier
map's storage, with the later map's graph, node table, redirects, pending day and open
window, as the result built in the later map has them: a step costs the later map and the
touched rows (vectorised searches of the earlier map's cells aside), not the result so far.

The result is the same map: an untouched row's values are its own in both (added once to a
new row's zeros), every touched row meets the same sums in the same order (the small merge
is the merge itself), and maps are exported in canonical order (:meth:`MapState.to_arrays`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.entries import CELL, NODE, EntryStore
from aion_cli.engine.nearest import nearest_nodes
from aion_cli.engine.spatial_hash import keys_for_points
from aion_cli.engine.temporal.pending import PendingDay

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import F64, I64, BoolA


def in_earlier_storage(early: MapState, late: MapState) -> bool:
    """Whether :func:`merge_in_earlier` applies and pays: two ordinary maps (no part), the
    earlier one the larger, its pending day scored (``engine.merge_days.close_earlier``)."""
    return (
        early.deferred is None
        and late.deferred is None
        and not early.pending
        and early.entries.n >= late.entries.n
    )


def merge_in_earlier(early: MapState, late: MapState) -> MapState:
    """``merge_closed(early, late)`` built in ``early``'s storage; ``late`` is left in an
    unspecified state."""
    from aion_cli.engine.merge import merge_closed

    rows = np.flatnonzero(touched_rows(early, late))
    small = merge_closed(_take(early, rows), late)
    early.delete(rows)
    live = small.entries.live_rows()
    kind = small.entries.kind[live]
    new = np.empty(live.size, np.int64)
    for k in (NODE, CELL):  # rows of each kind in the earlier map's storage (freed first)
        of = kind == k
        e = small.entries
        new[of] = early.allocate(k, e.key[live[of]], e.node_id[live[of]], e.xyz[live[of]])
    entries = early.entries
    for name in EntryStore._array_names():
        getattr(entries, name)[new] = getattr(small.entries, name)[live]
    entries.window_mark[new] = small.entries.window_mark[live]
    early.temporal.put_rows(new, small.temporal, live)
    early.temporal.glob = small.temporal.glob
    early.temporal.window_chi2 = small.temporal.window_chi2
    early.temporal.day_level = small.temporal.day_level
    early.temporal.week_sums = small.temporal.week_sums
    row_map = np.full(small.entries.capacity, -1, np.int64)
    row_map[live] = new
    early.pending = small.pending.relabelled(row_map)
    early.graph, early.nodes, early.redirects = small.graph, small.nodes, small.redirects
    early.observation, early.open_window = small.observation, small.open_window
    early.log_time_ns, early.accepted, early.dropped = (
        small.log_time_ns,
        small.accepted,
        small.dropped,
    )
    early._view = early._predictor = early._provisional = None
    early.rebuild_routes()
    return early


def touched_rows(early: MapState, late: MapState) -> BoolA:
    """Per row slot of ``early``, whether the merge with ``late`` can do more to its entry
    than copy it to a new row: node entries (they follow the later graph: kept, moved, or
    released), cells at keys the later map routes (its cells and redirects), cells that a
    released node joins, cells in reach of a later place (a bind)."""
    entries = early.entries
    n = entries.n
    out: BoolA = entries.kind[:n] == NODE
    cells = np.flatnonzero(entries.kind[:n] == CELL)
    keys = entries.key[cells]
    late.rebuild_routes()
    _, routed = late.routes.lookup(keys)
    nodes = np.flatnonzero(out)
    gone = nodes[~np.isin(entries.node_id[nodes], late.nodes.ids)]
    released = np.isin(keys, keys_for_points(entries.xyz[gone], early.config.cell_size))
    out[cells[routed | released | _in_reach(entries.xyz[cells], late)]] = True
    return out


def _in_reach(xyz: F64, late: MapState) -> BoolA:
    """Per position, whether a place of ``late`` lies within bind reach of it (only those
    inside the places' bounding box, widened twice the reach, are searched: an earlier map
    of another area costs a comparison per cell)."""
    cfg, places = late.config, late.nodes.xyz
    out = np.zeros(len(xyz), bool)
    if len(places) == 0 or len(xyz) == 0:
        return out
    reach = 2 * np.array([cfg.bind_radius, cfg.bind_radius, cfg.bind_vertical_tolerance])
    low, high = places.min(axis=0) - reach, places.max(axis=0) + reach
    box = np.flatnonzero(((xyz >= low) & (xyz <= high)).all(axis=1))
    hit = nearest_nodes(xyz[box], places, cfg.bind_radius, cfg.bind_vertical_tolerance)
    out[box[hit >= 0]] = True
    return out


def _take(early: MapState, rows: I64) -> MapState:
    """A map of ``early``'s entries ``rows`` (closed: no pending day) with everything else of
    ``early``'s: node table, redirects, graph, observation, global temporal block, counts."""
    from aion_cli.engine.state import MapState

    e = early.entries
    store = EntryStore.empty(e.bins, rows.size)
    for name in EntryStore._array_names():
        getattr(store, name)[: rows.size] = getattr(e, name)[rows]
    store.window_mark[: rows.size] = e.window_mark[rows]
    store.n = rows.size
    part = MapState(
        early.config,
        store,
        early.temporal.take(np.pad(rows, (0, store.capacity - rows.size))),
        PendingDay(early.params.values),
        nodes=early.nodes,
        redirects=early.redirects,
        observation=early.observation,
        graph=early.graph,
        open_window=early.open_window,
        log_time_ns=early.log_time_ns,
        accepted=early.accepted,
        dropped=early.dropped,
    )
    part.rebuild_routes()
    return part
