"""Closing time windows: turn the open window's counts into observations of the temporal model.

Closing the run of windows ``[w0, stop)`` (``w0`` the open window) when time reaches ``stop``:

1. the *recorded* windows are ``w0`` if any entry has detections in it, plus every window some
   observation source covers (robot poses within ``sensor_range``, or a fixed-sensor interval);
   other windows teach nothing and are skipped;
2. ownership is checked at the end of each recorded window, before that window is recorded
   (so a window is recorded on the entry that owns it from then on). The node table does not
   change during a run, so the set of stable nodes only grows: the check is re-run only when it
   has grown;
3. each recorded window goes to the temporal model (``MapState.record_window``): whether a fixed
   sensor covered it (then every entry was observed), otherwise which entries the robot
   observed, plus the entries with detections in ``w0`` (observed whatever the sources say),
   and ``w0``'s counts per direction bin and without a heading; the following windows of the
   run are empty (real zeros where observed);
4. the open-window counts are cleared, poses before ``stop`` are forgotten, and ``stop``
   becomes the open window;
5. a local day is closed (scored against the model before it, then absorbed: see
   ``engine.temporal``) as soon as log time reaches a later day — before the first window of
   the next day is recorded or checked for binds, or at the end of the call when ``stop`` lies
   in a later day — so a build stopped at the end of a day and continued later closes the day
   exactly when a single pass would.

Because bind checks happen only at recorded-window ends (and at graph updates), closing
``[w0, k)`` and later ``[k, stop)`` gives the same state as closing ``[w0, stop)`` at once: a
build can stop anywhere and continue.

Cost: O(recorded windows) per call, whatever the gap between ``w0`` and ``stop``: the recorded
windows come from binary searches over the sorted poses and merged fixed-sensor intervals
(:meth:`ObservationSource.covered_windows`), and only they are visited; a day is closed only
when a recorded window (or ``stop``) lies in a later day, never once per elapsed day.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.nearest import nearest_nodes
from aion_cli.engine.ownership import (
    apply_binds,
    enter_observed_nodes,
    plan_binds,
    stable_nodes,
    unentered_stable_nodes,
)
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.types import F64, I64, U64
from aion_cli.engine.windows import window_centre_ns, window_ns, window_start_ns

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def close_windows(state: MapState, stop: int) -> None:
    """Close every window from the open one up to (not including) window ``stop``.

    Per call: the local days of all recorded windows in one vectorised step, the open
    window's rows with detections once (again only after a bind moved them)."""
    w0 = state.open_window
    if w0 is None or stop <= w0:
        return
    delta = window_ns(state.config.window_s)
    if stop == w0 + 1 and state.observation.pose_t.size == 0:
        _close_one(state, w0, delta)  # a build's usual step, without a robot
        return
    count_rows = state.entries.window_rows()
    recorded = _recorded_windows(state, w0, stop, count_rows)
    if recorded.size <= 4:  # a build's usual step: one window, its day remembered
        days = [state.window_day(w) for w in recorded.tolist()]
    else:
        days = state.params.calendar.day(window_centre_ns(recorded, delta)).tolist()
    segment: list[int] = []
    segment_day: int | None = None
    stable_seen = -1
    waiting = np.zeros(0, np.int64)  # stable nodes the robot has not observed yet: no entry

    def record() -> None:
        nonlocal waiting
        waiting = _record(state, np.array(segment, np.int64), w0, delta, count_rows, waiting)
        segment.clear()

    for w, day in zip(recorded.tolist(), days, strict=True):
        if segment and day != segment_day:  # a day is over: record it and close it
            record()
            state.close_day()
        segment_day = day
        end = int(window_start_ns(w + 1, delta))
        n_stable = int(np.count_nonzero(stable_nodes(state, end)))
        if n_stable != stable_seen:
            stable_seen = n_stable
            plan = plan_binds(state, end)
            newly = unentered_stable_nodes(state, end)
            if plan is not None or not np.array_equal(newly, waiting):
                record()  # the windows before, with the nodes waiting before
                waiting = newly
                if plan is not None:
                    apply_binds(state, plan)
                count_rows = state.entries.window_rows()  # the counts moved with the cells
        segment.append(w)
    record()
    state.entries.clear_window()
    state.open_window = int(stop)
    if state.deferred is None:  # a shard keeps its poses for the join (engine.shards)
        state.observation.prune(int(window_start_ns(stop, delta)))
    if (
        state.pending
        and state.pending.day is not None
        and state.window_day(stop) > state.pending.day
    ):
        state.close_day()  # log time is in a later day: the pending day is over


def _close_one(state: MapState, w0: int, delta: int) -> None:
    """:func:`close_windows` of the single window ``w0`` where no robot pose is pending (a
    build's usual step: one call per window): the same checks, records and state changes in
    the same order, without the general path's per-call set-up (issue 15). Without poses no
    node waits for the robot and none is pruned; ``w0`` is recorded when it has detections
    or a fixed sensor recorded part of it (covered exactly where its share is positive); its
    first bind check always runs (the general path's first check of a call does too)."""
    ent = state.entries
    count_rows = ent.window_rows()
    share = state.observation.fixed_share_of(w0, delta, state.config)
    if count_rows.size or share > 0.0:
        plan = plan_binds(state, (w0 + 1) * delta)  # the window's end (window_start_ns)
        if plan is not None:
            apply_binds(state, plan)
            count_rows = ent.window_rows()  # the counts moved with the cells
        if share > 0.0:  # every entry observed: nothing but the counts to list
            counts = ent.window_count_columns(count_rows)
            none = np.zeros(0, np.int64)
            state.record_window(w0, True, none, count_rows, counts, np.zeros(0), share)
        else:
            _record(state, np.array([w0], np.int64), w0, delta, count_rows, np.zeros(0, np.int64))
    ent.clear_window()
    state.open_window = w0 + 1
    if (
        state.pending
        and state.pending.day is not None
        and state.window_day(w0 + 1) > state.pending.day
    ):
        state.close_day()  # log time is in a later day: the pending day is over


def _closing_timing(state: MapState, stop: int) -> tuple[I64, I64, I64] | None:
    """For :func:`closing_binds` and :func:`closing_entries`: the recorded windows
    :func:`close_windows` up to ``stop`` would close, their end times, and the time from
    which each node is stable; None when it closes none or the map has no node."""
    w0 = state.open_window
    if w0 is None or stop <= w0 or len(state.nodes) == 0:
        return None
    recorded = _recorded_windows(state, w0, stop, state.entries.window_rows())
    if recorded.size == 0:
        return None
    ends = window_start_ns(recorded + 1, state.window_ns)
    ready = state.nodes.stable_since_ns + round(state.config.stability_s * 1e9)
    return recorded, ends, ready


def _recorded_windows(state: MapState, w0: int, stop: int, count_rows: I64) -> I64:
    """The windows closing ``[w0, stop)`` records (step 1 of the module's rules): ``w0`` when
    entries ``count_rows`` have detections in it, and every window a source covers."""
    recorded = state.observation.covered_windows(w0, stop, state.window_ns)
    if count_rows.size and (recorded.size == 0 or recorded[0] != w0):  # w0 is the first
        recorded = np.concatenate([np.array([w0], np.int64), recorded])
    return recorded


def closing_binds(state: MapState, stop: int) -> tuple[I64, U64]:
    """The cells :func:`close_windows` up to ``stop`` would bind (rows, ascending) and the
    ids of the nodes they would go to, with nothing changed: a check at each recorded
    window's end binds a cell the checks before could not to the nearest node stable then
    (the node table does not change during a run, so the stable set only grows: one check
    per time it grows, a few, not one per window)."""
    none = np.zeros(0, np.int64), np.zeros(0, np.uint64)
    cells = state.entries.cell_rows()
    timing = None if cells.size == 0 else _closing_timing(state, stop)
    if timing is None:
        return none
    _, ends, ready = timing
    grows = np.unique(np.searchsorted(ends, ready, side="left"))  # first end each is stable
    cfg = state.config
    out_cells, out_ids = [], []
    for k in grows[grows < ends.size].tolist():
        stable = stable_nodes(state, int(ends[k]))
        hit = nearest_nodes(
            state.entries.xyz[cells],
            state.nodes.xyz[stable],
            cfg.bind_radius,
            cfg.bind_vertical_tolerance,
        )
        bound = hit >= 0
        out_cells.append(cells[bound])
        out_ids.append(state.nodes.ids[stable][hit[bound]])
        cells = cells[~bound]
    if not out_cells:
        return none
    rows, ids = np.concatenate(out_cells), np.concatenate(out_ids)
    order = np.argsort(rows, kind="stable")
    return rows[order], ids[order]


def closing_entries(state: MapState, stop: int) -> U64:
    """The ids of the places :func:`close_windows` up to ``stop`` would give entries because
    the robot observes them stable in a recorded window and they have none
    (:func:`~aion_cli.engine.ownership.enter_observed_nodes`), with nothing changed."""
    none = np.zeros(0, np.uint64)
    timing = None if state.observation.pose_t.size == 0 else _closing_timing(state, stop)
    if timing is None:
        return none
    recorded, ends, ready = timing
    first = np.searchsorted(ends, ready, side="left")  # the first window it waits in
    waiting = np.flatnonzero((state.node_entry_rows(state.nodes.ids) < 0) & (first < ends.size))
    if waiting.size == 0:
        return none
    robot = state.observation.fixed_share(recorded, state.window_ns, state.config) == 0
    entered = np.zeros(waiting.size, bool)
    for k in np.flatnonzero(robot & (np.arange(recorded.size) >= first[waiting].min())).tolist():
        todo = np.flatnonzero(~entered & (first[waiting] <= k))
        if todo.size:
            xy = state.nodes.xyz[waiting[todo], :2]
            entered[todo] = _coverage(state, xy, int(recorded[k])) > 0
        if entered.all():
            break
    out: U64 = state.nodes.ids[waiting[entered]]
    return out


def _record(
    state: MapState, windows: I64, w0: int, delta: int, count_rows: I64, waiting: I64
) -> I64:
    """Record consecutive recorded windows on the current entries (``count_rows``: those
    with detections in ``w0``, ``EntryStore.window_rows``); a stable node of ``waiting``
    (node-table indices) that the robot observes in one of them gets its entry first
    (:func:`~aion_cli.engine.ownership.enter_observed_nodes`). Returns the nodes still
    waiting.

    Costs the entries with detections in ``w0`` plus, for the windows no fixed sensor
    covered, the robot-coverage test over the live entries (and the waiting nodes)."""
    if len(windows) == 0:
        return waiting
    ent = state.entries
    counts = ent.window_count_columns(count_rows)
    none = np.zeros(0, np.int64)
    no_counts = np.zeros((0, counts.shape[1]))
    # a fixed sensor's window counts for the share of it its logs recorded
    shares = state.observation.fixed_share(windows, delta, state.config)
    fixed_mask = (shares > 0).tolist()
    rows, xy = none, np.zeros((0, 2))
    if not all(fixed_mask):
        rows = ent.live_rows()
        xy = ent.xyz[rows, :2]
    for w, fixed, share in zip(windows.tolist(), fixed_mask, shares.tolist(), strict=True):
        observed, exposure = none, np.zeros(0)
        if not fixed and (waiting.size or len(rows)):
            # one coverage test per window over the waiting nodes and the live entries
            k = waiting.size
            points = np.concatenate([state.nodes.xyz[waiting, :2], xy]) if k else xy
            seen = _coverage(state, points, w)
            mask = seen > 0
            observed, exposure = rows[mask[k:]], seen[k:][mask[k:]]
            if mask[:k].any():  # their new entries are observed in this window too
                waiting = enter_observed_nodes(state, waiting, mask[:k])
                before, rows = rows, ent.live_rows()
                xy = ent.xyz[rows, :2]
                new = np.setdiff1d(rows, before)
                observed, exposure = _joined(
                    observed, exposure, new, _coverage(state, ent.xyz[new, :2], w)
                )
        if w == w0:
            if not fixed:  # detections where no pose reached: the window counts whole
                extra = np.setdiff1d(count_rows, observed)
                observed, exposure = _joined(observed, exposure, extra, np.ones(extra.size))
            state.record_window(int(w), fixed, observed, count_rows, counts, exposure, share)
        else:
            state.record_window(int(w), fixed, observed, none, no_counts, exposure, share)
    return waiting


def _joined(rows: I64, shares: F64, more: I64, more_shares: F64) -> tuple[I64, F64]:
    """Observed entries ``rows`` and ``more`` (none of them in ``rows``) in row order, each
    with its share of the window."""
    if more.size == 0:
        return rows, shares
    joined, share = np.concatenate([rows, more]), np.concatenate([shares, more_shares])
    order = np.argsort(joined, kind="stable")
    return joined[order], share[order]


def _coverage(state: MapState, xy: F64, window: int) -> F64:
    """Per point, the share of ``window`` the robot observed it in (``ModelConfig.exposure``;
    without it 1 wherever a pose in the window was in range), 0 where none was."""
    return state.observation.coverage(xy, window, state.window_ns, state.config)


def open_window_record(state: MapState) -> DayWindows | None:
    """The open window as closing it now would record it (:func:`_record`): observed by every
    entry under a fixed sensor, else by the robot and where detections are (None: nothing
    would be recorded). Queries absorb it so the latest detections count."""
    w = state.open_window
    if w is None:
        return None
    entries = state.entries
    rows = entries.live_rows()
    counts = entries.window_count_columns(rows)
    seen = counts.sum(axis=1) > 0
    share = float(state.observation.fixed_share(np.array([w]), state.window_ns, state.config)[0])
    fixed = share > 0
    observed = np.zeros(0, np.int64)
    if not fixed:
        cover = _coverage(state, entries.xyz[rows, :2], w)
        in_view = (cover > 0) | seen
        observed = rows[in_view]
        exposure = np.where(cover > 0, cover, 1.0)[in_view]
    if not fixed and observed.size == 0:
        return None
    return DayWindows(
        np.array([w], np.int64),
        np.array([fixed]),
        observed,
        np.zeros(observed.size, np.int64),
        rows[seen],
        np.zeros(int(seen.sum()), np.int64),
        counts[seen],
        None if fixed or bool(np.all(exposure == 1.0)) else exposure,
        None if share >= 1.0 or not fixed else np.array([share]),
    )
