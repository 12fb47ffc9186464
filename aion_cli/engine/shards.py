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
Whether a join is exact, and why not: :func:`aion_cli.engine.join_blockers.join_blocker`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.closing import close_windows
from aion_cli.engine.merge import add_entries, adopt_redirects, bind_early_cells, destinations
from aion_cli.engine.node_drift import join_timers
from aion_cli.engine.temporal.held_days import DeferredDays, HeldDay
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.time_text import utc_text
from aion_cli.engine.types import I64
from aion_cli.engine.windows import window_start_ns
from aion_cli.errors import ConfigError

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def start_shard(state: MapState) -> MapState:
    """Make an empty map a shard: its closed days are held for :func:`join_shard`."""
    if state.recorded_anything() or state.open_window is not None:
        raise ValueError("only an empty map can start a shard")
    state.deferred = DeferredDays()
    return state


def _closing_stop(acc: MapState, shard: MapState) -> int | None:
    """The window up to which :func:`join_shard` closes the windows of ``acc``, as the
    shard's first message does in one pass (None: it closes none)."""
    if acc.open_window is None or shard.open_window is None:
        return None
    return max(acc.open_window + 1, _first_window(shard))


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
