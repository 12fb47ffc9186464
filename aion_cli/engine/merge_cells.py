"""The merge of two maps of hash cells only, built in the earlier map's storage.

:func:`aion_cli.engine.merge.merge_maps` builds its result in the later map: every entry of
the earlier map is added there. ``aion merge`` folds many maps in time order, so the earlier
map is the growing result and each step copied all of it again (a fleet of 40 fixed-sensor
maps of different areas: 18 s, most of it these copies). When neither map holds a node (no
node entry, node table or redirect: fixed-sensor maps without a graph, or maps whose nodes
were released, ``--lineage different``) and neither is a part map, nothing of the merge
depends on which storage holds the result: the earlier map's cells go to the later map's
cell at the same key or to a new one, and no cell binds, moves or follows a redirect. Then
:func:`merge_into_earlier` adds the later map's cells into the earlier map instead (new keys
get new rows; amortised growth), and gives it the later map's pending day (its rows
renumbered), graph, open window and fixed-sensor intervals, as the result in the later map
has them: a step costs the later map, not the result so far.

The result is the same map: every quantity is a sum of one value of each map per entry (or a
min/max), and ``a + b == b + a`` exactly (a cell sits at its key's centre in every map, so
the positions agree too); only the rows differ, and maps are exported in canonical order
(:meth:`MapState.to_arrays`). The day-ahead scores of a day scored during the fold may differ
in the last bit (40 maps of different areas: 6 of 327,600 flow scores), as they do for one
map whose rows are merely laid out in another order; within ``engine.compare``'s tolerance.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.entries import ADDITIVE, CELL, NODE
from aion_cli.engine.merge_days import close_earlier
from aion_cli.engine.spatial_hash import unpack_keys

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def cells_only(state: MapState) -> bool:
    """Whether ``state`` is an ordinary map without nodes: no node entry, node, redirect."""
    n = state.entries.n
    return (
        state.deferred is None
        and state.nodes.ids.size == 0
        and len(state.redirects) == 0
        and not bool((state.entries.kind[:n] == NODE).any())
    )


def merge_into_earlier(early: MapState, late: MapState) -> MapState:
    """``merge_maps(early, late, consume=True)`` for two :func:`cells_only` maps (``early``
    first in time), built in ``early``; ``late`` is left in an unspecified state."""
    close_earlier(early, late)
    src = late.entries.canonical_order()
    dst, new = _rows_for(early, late, src)
    _add_entries(early, late, src, dst, new)
    early.temporal.add_from(late.temporal, src, dst, "add")
    early.temporal.glob.add_block(np.array([0]), late.temporal.glob)
    early.temporal.add_map_sums(late.temporal)
    early.temporal.touch()
    row_map = np.full(late.entries.capacity, -1, np.int64)
    row_map[src] = dst
    early.pending.extend(late.pending.relabelled(row_map))  # after its own, if left open
    # what the result built in the later map has of the later map's own, and the sums
    observation = late.observation
    observation.join(early.observation)
    early.observation = observation
    early.graph, early.nodes, early.redirects = late.graph, late.nodes, late.redirects
    early.open_window = late.open_window
    if early.log_time_ns is None:
        early.log_time_ns = late.log_time_ns
    else:
        early.log_time_ns = max(late.log_time_ns or early.log_time_ns, early.log_time_ns)
    early.accepted += late.accepted
    dropped = dict(late.dropped)
    for reason, count in early.dropped.items():
        dropped[reason] = dropped.get(reason, 0) + count
    early.dropped = dropped
    early._view = early._predictor = early._provisional = None
    return early


def _rows_for(early: MapState, late: MapState, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``early`` receiving ``late``'s cells ``src`` (new cells created for keys
    ``early`` lacks) and a mask of the new ones. ``early``'s route table is current: it was
    built when the map was read or merged, and a map without nodes changes no ownership."""
    keys = late.entries.key[src]
    before = early.entries.n
    free = early.entries.free

    def create(new_keys: np.ndarray) -> np.ndarray:
        return early.allocate(
            CELL, new_keys, np.zeros(new_keys.size, np.uint64), np.zeros((new_keys.size, 3))
        )

    dst = early.routes.route(keys, unpack_keys(keys), create)
    new = (dst >= before) | np.isin(dst, free)
    return dst, new


def _add_entries(
    early: MapState, late: MapState, src: np.ndarray, dst: np.ndarray, new: np.ndarray
) -> None:
    """``early[dst] += late[src]`` for the entry sums (one source per row); new rows take
    ``late``'s values as they are, and every row ``late``'s position (the cell's centre)."""
    e, o = late.entries, early.entries
    for name in ADDITIVE:
        mine, theirs = getattr(o, name), getattr(e, name)
        mine[dst[new]] = theirs[src[new]]
        mine[dst[~new]] += theirs[src[~new]]
    o.xyz[dst] = e.xyz[src]
    o.window_mark[dst] |= e.window_mark[src]
