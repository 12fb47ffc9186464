"""Whether a shard's join (:func:`aion_cli.engine.shards.join_shard`) would equal a single pass,
and if not, why: :func:`join_blocker`, whose :class:`JoinBlock` is the sentence a note gives.

The join is exact unless ownership in the shard depended on history it did not have (the
places of the map before it, their stability timers and bindings), or changed what its held
days were scored on (ownership or pooling groups that moved after a day was held); the caller
then learns the shard's logs onto the map in sequence instead (:mod:`aion_cli.parallel_build`,
:mod:`aion_cli.merging`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.closing import closing_binds, closing_entries
from aion_cli.engine.entries import CELL, NODE
from aion_cli.engine.nearest import boxes_in_reach, nearest_nodes
from aion_cli.engine.node_drift import timers_blocker
from aion_cli.engine.ownership import stable_nodes
from aion_cli.engine.shards import _closing_stop, _first_window, overlap_blocker
from aion_cli.engine.spatial_hash import cell_centres
from aion_cli.engine.temporal.groups import groups_moved
from aion_cli.engine.types import F64, I64, U64, BoolA
from aion_cli.engine.windows import window_index, window_start_ns

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


class JoinBlock(str):
    """Why a join would not be exact: the sentence a note about one shard gives (the string
    itself), and :attr:`cause`, the short phrase a note about several shards names it by."""

    cause: str

    def __new__(cls, why: str, cause: str) -> JoinBlock:
        block = super().__new__(cls, why)
        block.cause = cause
        return block

    def __reduce__(self) -> tuple[type[JoinBlock], tuple[str, str]]:
        return JoinBlock, (str(self), self.cause)


def join_blocker(acc: MapState, shard: MapState) -> JoinBlock | None:
    """Why joining ``shard`` onto ``acc`` would not equal a single pass (None: it would).

    The join is exact unless ownership in the shard depended on history it did not have, or
    changed what its held days were scored on: the caller then learns the shard's logs onto
    ``acc`` in sequence instead."""
    held = shard.deferred
    if held is None:
        return JoinBlock("the shard was not built for a join", "a shard not built for a join")
    overlap = overlap_blocker(acc, shard)
    if overlap is not None:
        return JoinBlock(overlap, "logs starting in a window the map before them had recorded")
    if held.moved_after_hold:
        return JoinBlock(
            "ownership changed inside these logs after one of their days had closed (the scene "
            "graph changed), which the day-ahead scores of that day depend on",
            "ownership that changed inside their logs after one of their days had closed",
        )
    if held.groups_changed_after_hold or (held.held_before_graph and _groups_differ(acc, shard)):
        return JoinBlock(
            "the scene graph moved places to other rooms (or neighbourhoods) inside these logs "
            "after one of their days had closed, which that day's pooling depends on",
            "places moved to other rooms inside their logs after one of their days had closed",
        )
    if acc.graph is not None and shard.graph is None:
        return JoinBlock(
            "these logs carry no scene graph of their own, and the map before them has one",
            "logs without a scene graph after a map with one",
        )
    # the join first closes the windows of acc before the shard's first (as the shard's
    # first message does in one pass): acc's own graph binds some of its cells then, and
    # the robot's view gives entries to stable places without one
    bound, bound_to = _closing_binds(acc, shard)
    keys = np.concatenate([acc.redirects.keys, acc.entries.key[bound]])
    theirs, found = shard.redirects.lookup(keys)
    if (found & (theirs != np.concatenate([acc.redirects.nodes, bound_to]))).any():
        return JoinBlock(
            "these logs bound cells to other places than the map before them did (one pass "
            "keeps the earlier binding)",
            "cells bound to other places than the map before them",
        )
    early = acc.entries.live_rows()
    early_ids = np.union1d(acc.entries.node_id[early[acc.entries.kind[early] == NODE]], bound_to)
    stop = _closing_stop(acc, shard)
    if stop is not None:  # and the places the robot observes then get entries
        early_ids = np.union1d(early_ids, closing_entries(acc, stop))
    first = held.first_graph
    if first is not None and not np.isin(early_ids, first).all():
        return JoinBlock(
            "the first scene graph of these logs lacks places of the map before them (one "
            "pass releases them there)",
            "a first scene graph without places of the map before them",
        )
    timers = timers_blocker(
        shard.nodes, acc.nodes, held.drift, shard.config.stable_move_tolerance
    )
    if timers is not None:
        return JoinBlock(timers, "places that drifted about the stability tolerance")
    if shard.graph is not None and not np.isin(early_ids, shard.nodes.ids).all():
        return JoinBlock(
            "places of the map before these logs left the scene graph during them",
            "places of the map before them that left the scene graph",
        )
    if _left_later(shard, early_ids):
        return JoinBlock(
            "places of the map before these logs left the scene graph during them and came "
            "back (one pass released what they held there)",
            "places of the map before them that left the scene graph and came back",
        )
    cells = np.setdiff1d(early[acc.entries.kind[early] == CELL], bound)
    if held.first_stable is None and _unbound_in_reach(acc, shard, cells, keys):
        return JoinBlock(
            "the places of the scene graph of these logs were stable at none of their "
            "ownership checks (one comes with each graph and at each window's end), so the "
            "join cannot tell which cells one pass bound to them (with the stability the map "
            "before them gave them)",
            "a scene graph stable at none of the ownership checks inside their logs",
        )
    before = _before_graph_blocker(acc, shard)
    if before is not None:
        return before
    return _late_cells_blocker(acc, shard, cells)


def _before_graph_blocker(acc: MapState, shard: MapState) -> JoinBlock | None:
    """Why the windows the shard closed before its first scene graph went otherwise in one
    pass, which closed them with the places of ``acc`` (None: they did not): it bound the
    shard's cells in reach of those stable then (the shard, once its graph was stable, may
    bind them elsewhere or not at all), and gave entries to the stable places without one
    that the robot saw (the shard, to none)."""
    held = shard.deferred
    drift = held.drift if held is not None else None
    if drift is None or len(acc.nodes) == 0 or shard.open_window is None:
        return None
    delta = shard.window_ns
    first, graph_window = _first_window(shard), int(window_index(drift.t0_ns, delta))
    if first >= graph_window:  # no window closed before the graph
        return None
    stable = stable_nodes(acc, int(drift.t0_ns))  # every place stable at one of those checks
    if not stable.any():
        return None
    cfg = shard.config
    ids, xyz = acc.nodes.ids[stable], acc.nodes.xyz[stable]
    # the shard's cells with detections in those windows (they were there at those checks),
    # and the keys it redirected
    cells = np.intersect1d(_counted_before(shard, graph_window), shard.entries.cell_rows())
    keys = np.concatenate([shard.entries.key[cells], shard.redirects.keys])
    hit = nearest_nodes(
        cell_centres(keys, cfg.cell_size), xyz, cfg.bind_radius, cfg.bind_vertical_tolerance
    )
    theirs, found = shard.redirects.lookup(keys[hit >= 0])
    same_set = np.array_equal(stable, stable_nodes(acc, int(window_start_ns(first + 1, delta))))
    if hit.max(initial=-1) >= 0 and not (
        same_set and found.all() and np.array_equal(theirs, ids[hit[hit >= 0]])
    ):
        return JoinBlock(
            "these logs recorded time windows before their first scene graph, in which one "
            "pass bound their cells to the places of the map before them (the join binds "
            "them by these logs' own graph)",
            "cells bound before their first scene graph by the places of the map before them",
        )
    waiting = acc.node_entry_rows(ids) < 0
    windows = shard.observation.covered_windows(first, graph_window, delta)
    robot = windows[shard.observation.fixed_share(windows, delta, cfg) == 0]
    if waiting.any() and any(
        (shard.observation.coverage(xyz[waiting, :2], int(w), delta, cfg) > 0).any()
        for w in robot.tolist()
    ):
        return JoinBlock(
            "the robot of these logs saw places of the map before them before these logs' "
            "first scene graph, which one pass gave entries there",
            "places of the map before them that the robot saw before their first scene graph",
        )
    return None


def _counted_before(shard: MapState, window: int) -> I64:
    """The entry rows the shard's held and pending days count detections for in a window
    before ``window``."""
    assert shard.deferred is not None
    rows = [np.zeros(0, np.int64)]
    for day in [held.pending for held in shard.deferred.days] + [shard.pending]:
        if day:
            c = day.consolidated()
            rows.append(c.cnt_entry[np.asarray(c.windows)[c.cnt_slot] < window])
    return np.unique(np.concatenate(rows))


def _unbound_in_reach(acc: MapState, shard: MapState, cells: I64, redirected: I64) -> bool:
    """Whether a check of the shard had its own cells in reach of places not yet stable
    (but for those of keys ``acc`` redirects, ``redirected``: one pass routed their
    detections to the place, the join moves them there), or a place of the shard is in reach
    of a cell of ``acc`` (rows ``cells``): a shard none of whose checks saw a stable place
    did not bind them, where one pass, with the timers the map before gave its places, may
    have."""
    assert shard.deferred is not None
    if np.setdiff1d(shard.deferred.unstable_keys, redirected).size:
        return True
    cfg = shard.config
    xyz = acc.entries.xyz[cells]
    hit = nearest_nodes(xyz, shard.nodes.xyz, cfg.bind_radius, cfg.bind_vertical_tolerance)
    return bool((hit >= 0).any())


def _late_cells_blocker(acc: MapState, shard: MapState, cells: I64) -> JoinBlock | None:
    """Why the shard's places bind cells of ``acc`` (rows ``cells``, those it still has once
    its windows are closed) otherwise than one pass would (None: they do not): the join
    binds them to the shard's first stable places, then to its last."""
    held = shard.deferred
    assert held is not None
    if cells.size == 0 or len(shard.nodes) == 0 or held.first_stable is None:
        return None
    cfg = shard.config
    xyz = acc.entries.xyz[cells]
    first_at = nearest_nodes(
        xyz, held.first_stable[1], cfg.bind_radius, cfg.bind_vertical_tolerance
    )
    first_hit = first_at >= 0
    if _left_later(shard, held.first_stable[0][first_at[first_hit]]):
        return JoinBlock(
            "places of the scene graph of these logs that one pass bound cells of the map "
            "before them to left the graph later on (one pass then released what those "
            "cells held into the places' own cells)",
            "places that bound cells of the map before them and left the scene graph later",
        )
    if _moved_into_reach(shard, xyz, first_hit):
        return JoinBlock(
            "places of the scene graph of these logs came within reach of cells of the map "
            "before them after their first ownership check (moved there, or new there), and "
            "one pass binds such a cell where the place reached it (the join knows the places' "
            "first and last positions only)",
            "places that came within reach of cells of the map before them",
        )
    if first_hit.any() and held.first_stable_late:
        return JoinBlock(
            "the scene graph of these logs became stable only after their first day",
            "a scene graph stable only after their first day",
        )
    stable = stable_nodes(shard, int(shard.log_time_ns or 0))
    last_hit = (
        nearest_nodes(xyz, shard.nodes.xyz[stable], cfg.bind_radius, cfg.bind_vertical_tolerance)
        >= 0
        if stable.any()
        else np.zeros(cells.size, bool)
    )
    if not (last_hit & ~first_hit).any():
        return None
    return JoinBlock(
        "the scene graph of these logs reached cells of the map before them only later on (a "
        "single pass would have bound them then)",
        "a scene graph that reached cells of the map before them only later on",
    )


def _moved_into_reach(shard: MapState, xyz: F64, first_hit: BoolA) -> bool:
    """Whether a cell of the map before the shard (at ``xyz``) that the shard's first stable
    places do not reach (``~first_hit``) lies in reach of a position a place of the shard's
    first graph had before its timer first restarted (the drift box, :mod:`node_drift`: one
    pass may have had it stable there, with the earlier map's timer), or one any place had
    stable at a check of the shard (``DeferredDays.reach``): one pass bound it at the check
    where the place was there, which the join, binding by the first and last positions only,
    misses (a graph that jitters a place into reach, or a place that comes and goes)."""
    held = shard.deferred
    if held is None or first_hit.all():
        return False
    boxes = [] if held.drift is None else [(held.drift.low, held.drift.high)]
    if held.reach is not None:  # every position a place had stable at a check
        boxes.append(held.reach[1:])
    cfg = shard.config
    return any(
        bool(
            boxes_in_reach(
                xyz[~first_hit], low, high, cfg.bind_radius, cfg.bind_vertical_tolerance
            ).any()
        )
        for low, high in boxes
    )


def _left_later(shard: MapState, ids: U64) -> bool:
    """Whether a place of ``ids`` is not in the shard's last graph, or left one of its graphs
    after its first (and came back: its timer restarted by leaving, :mod:`node_drift`)."""
    if not np.isin(ids, shard.nodes.ids).all():
        return True
    drift = shard.deferred.drift if shard.deferred is not None else None
    if drift is None or ids.size == 0:
        return False
    at = np.minimum(np.searchsorted(drift.ids, ids), len(drift.ids) - 1)
    known = drift.ids[at] == ids
    left = (drift.restart_ns[at] >= 0) & np.isnan(drift.restart_xyz[at]).any(axis=1)
    return bool((known & left).any())


def _closing_binds(acc: MapState, shard: MapState) -> tuple[I64, U64]:
    """The cells of ``acc`` its own graph binds when :func:`join_shard` closes its windows
    (rows), and the ids of the nodes they go to."""
    stop = _closing_stop(acc, shard)
    if stop is None:
        return np.zeros(0, np.int64), np.zeros(0, np.uint64)
    return closing_binds(acc, stop)


def _groups_differ(acc: MapState, shard: MapState) -> bool:
    """Whether a place both maps' last graphs hold is in another pooling group in each."""
    before, after = acc.place_group_keys(), shard.place_group_keys()
    return before is not None and after is not None and groups_moved(before, after)
