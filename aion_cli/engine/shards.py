"""Joining the shards of a parallel build into the map one pass would have made.

A parallel build (``aion build --workers N``) splits its logs into *shards*: groups of logs
that share no time window, built independently, each from an empty map. Counts, speed sums,
observed windows and the temporal accumulators add across disjoint time; what does not is the
day-ahead score, because a single pass scores every day against the model of *all* earlier
days, other shards' included. So a shard is built with :attr:`MapState.deferred` set: each
closed day is held unscored (with the entries live when it closed, the population its forecast
pools over), re-labelled by ownership transfer like the pending day. :func:`join_shard` then
folds a shard into the map of every earlier shard, in time order:

1. the earlier map's open window is closed, as the shard's first message would have closed it;
   its pending day is closed (scored against its own history) unless the shard starts on the
   same local day, in which case the two parts of that day are scored together;
2. the shard is the base (its graph, node table, redirects, open window and pending poses are
   the newest) and the earlier map's entries are added where their state belongs in it, exactly
   as :func:`aion_cli.engine.merge.merge_maps` does;
3. the shard's held days are scored and absorbed one by one, in time order, each against the
   accumulators of everything before it and pooled over the entries live at its close (the
   shard's then-live entries and every entry of the earlier map); the shard's last day stays
   pending, as in a single pass.

The earlier map's entries were live all along in a single pass, so in the shard's robot-covered
windows they are recorded as observed where the robot's sensor range reached them (the shard
keeps its poses for this; a single pass forgets them as windows close).

The result equals a single pass over all the shards' logs (ints exact, floats to rounding;
``tests/engine/test_shards.py``, ``tests/test_parallel_build.py``) for fixed sensors and robot
trajectories, a shared graph and one that moves; the places' stability timers are those of
one pass, or the join is refused (:mod:`aion_cli.engine.node_drift`), and so is a shard whose
graph moved a place to another pooling group (room, or neighbourhood) after one of its days
was held (that day was pooled by the groups it had then; a day held before the shard's first
graph, by the earlier map's graph), and so is one whose places came within reach of the
earlier map's cells at checks between their first and last (a graph that moved a place
nearer: one pass bound those cells there). What a shard cannot know, and so the join
approximates: a node's stability timer restarts at the shard's first graph (binds in its
first ``stability_s`` go through cells first; the counts end in the node either way).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.closing import close_windows, closing_binds, closing_entries
from aion_cli.engine.entries import CELL, NODE
from aion_cli.engine.merge import add_entries, adopt_redirects, bind_early_cells, destinations
from aion_cli.engine.nearest import boxes_in_reach, nearest_nodes
from aion_cli.engine.node_drift import join_timers, timers_blocker
from aion_cli.engine.ownership import stable_nodes
from aion_cli.engine.spatial_hash import cell_centres
from aion_cli.engine.temporal.groups import groups_moved
from aion_cli.engine.temporal.held_days import DeferredDays, HeldDay
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.time_text import utc_text
from aion_cli.engine.types import F64, I64, U64, BoolA
from aion_cli.engine.windows import window_index, window_start_ns
from aion_cli.errors import ConfigError

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def start_shard(state: MapState) -> MapState:
    """Make an empty map a shard: its closed days are held for :func:`join_shard`."""
    if state.recorded_anything() or state.open_window is not None:
        raise ValueError("only an empty map can start a shard")
    state.deferred = DeferredDays()
    return state


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


def _closing_stop(acc: MapState, shard: MapState) -> int | None:
    """The window up to which :func:`join_shard` closes the windows of ``acc``, as the
    shard's first message does in one pass (None: it closes none)."""
    if acc.open_window is None or shard.open_window is None:
        return None
    return max(acc.open_window + 1, _first_window(shard))


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


def overlap_blocker(acc: MapState, shard: MapState) -> str | None:
    """Why ``shard`` cannot follow ``acc`` in time (None: it can): a join needs the shard's
    first recorded window after every window of ``acc``, whose open window one pass would
    have continued with the shard's messages."""
    if acc.open_window is None or shard.open_window is None or shard.deferred is None:
        return None
    first = _first_window(shard)
    if first > acc.open_window:
        return None
    return (
        "these logs start in a time window the map before them had already recorded (window "
        f"starting {utc_text(int(window_start_ns(first, shard.window_ns)))}; that map's last "
        "starts "
        f"{utc_text(int(window_start_ns(acc.open_window, acc.window_ns)))})"
    )


def join_shard(acc: MapState, shard: MapState) -> MapState:
    """``acc`` (an ordinary map) followed in time by ``shard`` (built with
    :func:`start_shard`): the map a single pass over both would have made. Both inputs are
    consumed (the result is built in ``shard``)."""
    if shard.deferred is None:
        raise ValueError("join_shard needs a shard built with start_shard")
    if acc.deferred is not None:
        raise ValueError("the map a shard joins must be an ordinary map")
    if acc.config != shard.config:
        raise ConfigError(
            "cannot join shards built with different model parameters",
            hint="every shard of a build uses the build's config",
        )
    overlap = overlap_blocker(acc, shard)
    if overlap is not None:
        raise ValueError(f"a shard must follow the map it joins in time: {overlap}")
    first_day = _first_day(shard)
    stop = _closing_stop(acc, shard)
    if stop is not None:
        # every window of the earlier map before the shard's first, as that window's first
        # message closes them in one pass (an observation source may cover some after the
        # earlier map's last message: scene-graph agent poses)
        close_windows(acc, stop)
    if acc.pending and acc.pending.day != first_day:
        acc.close_day()
    out = shard
    join_timers(out.nodes, acc.nodes, shard.deferred.drift, out.config.stable_move_tolerance)
    src = acc.entries.canonical_order()
    dst = destinations(out, acc, src)
    # the shard's accumulators are empty (its days are held), so the earlier entries that a
    # single pass would have moved into one entry combine as such a move does
    add_entries(out, acc, src, dst, observation="max")
    early_rows = np.unique(dst)
    held = out.deferred
    assert held is not None
    for day in held.days:
        _cover(out, day.pending, early_rows)
        day.live = np.union1d(day.live, early_rows)
    _cover(out, out.pending, early_rows)
    if acc.pending:  # the same local day as the shard's first: its windows come first
        row_map = np.full(acc.entries.capacity, -1, np.int64)
        row_map[src] = dst
        carried = acc.pending.relabelled(row_map)
        if held.days:
            carried.extend(held.days[0].pending)
            held.days[0].pending = carried
        else:
            carried.extend(out.pending)
            out.pending = carried
    out.observation.join(acc.observation)
    adopt_redirects(out, acc)  # ownership moves re-label the held days and the pending day
    bind_early_cells(out, early_rows, held.first_stable)
    _replay(out, held)
    out.accepted += acc.accepted
    for reason, count in acc.dropped.items():
        out.dropped[reason] = out.dropped.get(reason, 0) + count
    if acc.log_time_ns is not None:
        out.log_time_ns = max(out.log_time_ns or acc.log_time_ns, acc.log_time_ns)
    if out.open_window is not None:  # what a single pass would have forgotten by now
        out.observation.prune(int(window_start_ns(out.open_window, out.window_ns)))
    out.rebuild_routes()
    return out


def _cover(out: MapState, day: PendingDay, rows: I64) -> None:
    """Record, in the day's robot-covered windows, the entries of ``rows`` (the earlier map's:
    a single pass had them all along, the shard perhaps not yet) that the robot observed;
    pairs the shard recorded already are merged by the pending day."""
    if not day or rows.size == 0:
        return
    xy = out.entries.xyz[rows, :2]
    for slot, (window, fixed) in enumerate(zip(day.windows, day.fixed, strict=True)):
        if fixed:
            continue  # every entry was observed: the global block counts it
        seen = out.observation.coverage(xy, window, out.window_ns, out.config)
        mask = seen > 0
        if mask.any():
            day.add_observed(slot, rows[mask], seen[mask])


def _first_window(shard: MapState) -> int:
    """The shard's first recorded window (its open window when it recorded none)."""
    assert shard.deferred is not None
    assert shard.open_window is not None
    day = shard.deferred.days[0].pending if shard.deferred.days else shard.pending
    return int(day.windows[0]) if day else int(shard.open_window)


def _first_day(shard: MapState) -> int | None:
    """The local day of the shard's first recorded window, else of its open window (a shard
    inside one window has closed none; its window still falls on a day); None: no window."""
    assert shard.deferred is not None
    if shard.deferred.days:
        return shard.deferred.days[0].pending.day
    if shard.pending or shard.open_window is None:
        return shard.pending.day
    return shard.window_day(int(shard.open_window))


def _replay(out: MapState, held: DeferredDays) -> None:
    """Score and absorb the held days in time order; the shard's last day stays pending."""
    last = out.pending
    out.deferred = None
    days: list[HeldDay] = held.days
    for day in days:
        out.pending = day.pending
        out.close_day(rows=np.intersect1d(day.live, out.entries.live_rows()))
    out.pending = last if last else PendingDay(out.params.values)
