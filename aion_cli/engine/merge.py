"""Merging two maps of disjoint time (e.g. built from two logs on different days).

The earlier map's open window is closed first (as the later map's first detection would have
done in a single pass; up to the later map's first recorded window when that map closed no
day). Then the later map is the base (its graph, node table, redirects, open
window and pending poses are the newest) and every entry of the earlier map is added to where
its state belongs there: a cell goes to the later map's cell at the same key, or follows the
later map's redirect; a node goes to the node's entry (created if the node lives in the later
graph) or, if the node is gone, is released to the cell at its position. Counts, speed sums and
temporal accumulators add — exact for disjoint time: observations (windows, Σe^{iωt}, windows
per profile bin, first = min, last = max; several earlier entries bound for one entry, such
as two released nodes in one cell, first fold by the larger, as within one map), counts
(Σn·e^{iωt}, per profile bin) and scores;
the global fixed-sensor observations of the two maps add, so an entry only one map has counts
as observed-empty over the other's fixed-sensor windows, as a single pass would. The earlier
map's pending day is scored and absorbed first, unless it is the local day on which the later
map starts and the later map has closed no day (its first day still pending): then the
earlier map's windows of that day come before the later map's in one pending day, scored once
when the day is over, as one build holds it (:mod:`aion_cli.engine.merge_days`). Then the
earlier map's redirects to nodes alive in the later graph are kept, moving any later cell at
such a key into the node, and the cells that hold the earlier map's cells bind to the later
map's stable places in reach, as one build binds a cell once a place near it turns stable.
A consuming merge (``aion merge``'s fold) is built in the earlier map's storage when it is
the larger: for maps without nodes by :mod:`aion_cli.engine.merge_cells`, for others by
:mod:`aion_cli.engine.merge_rows` (the earlier entries the later map can touch merged as
above, the rest left where they are): the same map, at the later map's cost.

Approximated: (1) a map built from one log alone cannot know the robot-observed empty windows
of entries that only the other log created (a single pass would record real zeros for them),
nor windows in which one map's cells were still unbound while the other's node owned them;
(2) the day-ahead scores add (each map scored its days against its own history, and the later
map's first day was not scored against the earlier map's model); (3) a node's stability timer
keeps the earlier start only when the later map's reference position is within
``stable_move_tolerance`` of the earlier one; (4) when the earlier map ends on the day the
later one starts and the later map goes on past that day (it closed the day: its windows of
it are scored and absorbed, which cannot be undone) or starts in the earlier map's last
window, that day is scored as two days (a later map that ends on the day it starts joins the
earlier map's windows of the day exactly); (5) the earlier map's cells bind to the later
map's places where those ended (a map keeps no history of its places' positions): one build
binds a cell to a place that was in reach at any time after the place turned stable, so a
place that a loop closure moved out of ``bind_radius`` may hold the cell in one build and not
in a merge, and merges in a different grouping may differ in it. Maps whose times overlap
merge without error but count shared windows twice.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from aion_cli.engine.entries import ADDITIVE, CELL, NODE
from aion_cli.engine.merge_cells import cells_only, merge_into_earlier
from aion_cli.engine.merge_days import carry_pending, close_earlier
from aion_cli.engine.merge_rows import in_earlier_storage, merge_in_earlier
from aion_cli.engine.nearest import nearest_nodes
from aion_cli.engine.node_drift import approximate_timers
from aion_cli.engine.ownership import (
    BindPlan,
    apply_binds,
    node_rows_creating,
    plan_binds,
    rows_for_keys,
)
from aion_cli.engine.spatial_hash import keys_for_points
from aion_cli.errors import ConfigError

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import F64, I64, U64


def merge_maps(a: MapState, b: MapState, *, consume: bool = False) -> MapState:
    """A map holding both maps' dynamics. The inputs are not modified unless ``consume``:
    then the result is built in the later one and the earlier one is changed too (a caller
    that drops both, as ``aion merge`` does, saves the two copies: most of a merge's cost),
    or in the earlier one when it is the larger (:mod:`aion_cli.engine.merge_cells` for maps
    without nodes, :mod:`aion_cli.engine.merge_rows` for others: a fold of many maps then
    costs each map once, not the result so far)."""
    if a.config != b.config:
        raise ConfigError(
            "cannot merge maps built with different model parameters",
            hint="rebuild one of them with the other's config",
        )
    earlier, later = sorted((a, b), key=_start_order)
    if consume and earlier.entries.n >= later.entries.n and cells_only(a) and cells_only(b):
        return merge_into_earlier(earlier, later)  # the same map; costs the later one only
    early = earlier if consume else _copy(earlier)
    close_earlier(early, later)
    out = later if consume else _copy(later)
    if consume and in_earlier_storage(early, out):
        return merge_in_earlier(early, out)  # the same map; costs the later one only
    return merge_closed(early, out)


def merge_closed(early: MapState, out: MapState) -> MapState:
    """The merge built in the later map ``out`` (changed) once :func:`close_earlier` closed
    ``early``: every entry of ``early`` added where it belongs in ``out``, and its pending
    day, if left open, before ``out``'s."""
    merge_timers(out, early)
    src_rows = early.entries.canonical_order()
    dst = destinations(out, early, src_rows)
    add_entries(out, early, src_rows, dst)
    if early.pending:  # the later map's first day: one day (moves below re-label it)
        row_map = np.full(early.entries.capacity, -1, np.int64)
        row_map[src_rows] = dst
        carry_pending(out, early, row_map)
    adopt_redirects(out, early)
    bind_early_cells(out, np.unique(dst))
    # the earlier map's fixed-sensor intervals (and any poses left): the merged map observed
    # what both did, as one build does (its description counted the later map's alone)
    out.observation.join(early.observation)
    out.accepted += early.accepted
    for reason, count in early.dropped.items():
        out.dropped[reason] = out.dropped.get(reason, 0) + count
    if early.log_time_ns is not None:
        out.log_time_ns = max(out.log_time_ns or early.log_time_ns, early.log_time_ns)
    out.rebuild_routes()
    return out


def _start_order(state: MapState) -> tuple[int, int]:
    """Sort key: maps that never saw a window first, then by open window."""
    w = state.open_window
    return (0, 0) if w is None else (1, w)


def _copy(state: MapState) -> MapState:
    """A writable copy of ``state``, without the forecast priors (a writable state read back
    never uses them; the merged map's are computed when it is written)."""
    arrays, meta = state.to_arrays(priors=False)
    return type(state).from_arrays(arrays, meta)


def destinations(out: MapState, early: MapState, rows: np.ndarray) -> np.ndarray:
    """Rows of ``out`` receiving each of ``early``'s entries (created where needed)."""
    dst = np.full(len(rows), -1, np.int64)
    kind = early.entries.kind[rows]
    node_ids = early.entries.node_id[rows]
    alive = np.isin(node_ids, out.nodes.ids) & (kind == NODE)
    if alive.any():
        at = np.searchsorted(out.nodes.ids, node_ids[alive])
        dst[alive] = node_rows_creating(out, node_ids[alive], out.nodes.xyz[at])
    cellish = ~alive
    if cellish.any():
        keys = np.where(
            kind[cellish] == CELL,
            early.entries.key[rows[cellish]],
            keys_for_points(early.entries.xyz[rows[cellish]], out.config.cell_size),
        )
        dst[cellish] = rows_for_keys(out, keys)
    return dst


def add_entries(
    out: MapState,
    early: MapState,
    src: np.ndarray,
    dst: np.ndarray,
    observation: Literal["max", "add"] = "add",
) -> None:
    """out[dst] += early[src] for every quantity; windows observed add across the maps
    (``observation="max"``: the larger, as an ownership move within one map does), those of
    several of ``early``'s entries bound for one row counted once (:func:`_fold_shared_rows`)."""
    e, o = early.entries, out.entries
    for name in ADDITIVE:
        np.add.at(getattr(o, name), dst, getattr(e, name)[src])
    if observation == "add":
        src, dst = _fold_shared_rows(early, src, dst)
    out.temporal.add_from(early.temporal, src, dst, observation)
    out.temporal.glob.add_block(np.array([0]), early.temporal.glob)
    out.temporal.add_map_sums(early.temporal)
    out.temporal.touch()


def _fold_shared_rows(
    early: MapState, src: np.ndarray, dst: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Sources and destinations with one source per destination: ``early``'s entries bound
    for one row of the merged map (a node gone from the later graph and the cell at its
    position, two nodes released into one cell) watched the same windows of the earlier map,
    so their temporal states fold into the first of them (changing ``early``) with the
    larger observation block, as an ownership move within one map does; only then does the
    merge add across the maps. Added as they were, a window both had watched counted twice:
    an entry of a two-day merge had 432 windows observed of 288."""
    targets, first, slot = np.unique(dst, return_index=True, return_inverse=True)
    if targets.size == dst.size:
        return src, dst
    rest = np.setdiff1d(np.arange(dst.size), first)
    early.temporal.add_rows(src[rest], src[first][slot.reshape(-1)[rest]], "max")
    return src[first], targets


def adopt_redirects(out: MapState, early: MapState) -> None:
    """Keep the earlier map's redirects to nodes that live (with an entry) in ``out``."""
    keys, nodes = early.redirects.keys, early.redirects.nodes
    rows = out.node_entry_rows(nodes)
    _, redirected = out.redirects.lookup(keys)
    keep = (rows >= 0) & ~redirected
    if not keep.any():
        return
    keys, nodes, rows = keys[keep], nodes[keep], rows[keep]
    out.rebuild_routes()
    cell_rows, has_cell = out.routes.lookup(keys)
    is_cell = has_cell & (out.entries.kind[np.maximum(cell_rows, 0)] == CELL)
    if is_cell.any():
        out.move(cell_rows[is_cell], rows[is_cell])
    out.redirects.add(keys, nodes)


def merge_timers(out: MapState, early: MapState) -> None:
    """Nodes in both tables that have not moved keep the earlier stability start: the
    approximation of :func:`aion_cli.engine.node_drift.approximate_timers` (ordinary maps
    keep no drift of their nodes; a shard's join is exact, :mod:`aion_cli.engine.shards`)."""
    approximate_timers(out.nodes, early.nodes, out.config.stable_move_tolerance)


def bind_early_cells(out: MapState, rows: I64, first: tuple[U64, F64] | None = None) -> None:
    """Bind the cells holding the earlier map's cells (``rows``) that a stable node covers,
    as a single pass would have bound them once the node was stable (and then routed the
    shard's detections there to the node): against the shard's first stable nodes (``first``,
    where they still exist), then its last (an ordinary map's merge knows only those: a
    cell the earlier map saw near a place the later map's graph made stable stayed a cell,
    which one build binds)."""
    cells = rows[out.entries.kind[rows] == CELL]
    if first is not None and cells.size:
        ids, xyz = first
        alive = np.isin(ids, out.nodes.ids)
        ids, xyz = ids[alive], xyz[alive]
        cfg = out.config
        hit = nearest_nodes(
            out.entries.xyz[cells], xyz, cfg.bind_radius, cfg.bind_vertical_tolerance
        )
        bound = hit >= 0
        if bound.any():
            picked = cells[bound]
            order = np.argsort(out.entries.key[picked], kind="stable")
            at = np.searchsorted(out.nodes.ids, ids[hit[bound]][order])
            apply_binds(out, BindPlan(picked[order], ids[hit[bound]][order], out.nodes.xyz[at]))
            cells = np.setdiff1d(cells, picked)
    if cells.size == 0 or out.log_time_ns is None:
        return
    plan = plan_binds(out, int(out.log_time_ns))
    if plan is None:
        return
    keep = np.isin(plan.cells, cells)
    if keep.any():
        apply_binds(out, BindPlan(plan.cells[keep], plan.node_ids[keep], plan.node_xyz[keep]))
