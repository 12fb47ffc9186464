"""The Mapper: builds a map state from detections, scene graphs and robot poses.

Data flow (all numpy arrays; a Python loop runs per window or per graph update, never per
detection or per entry)::

    DetectionBatch --drop non-finite ("nan") / unhashable ("out_of_range") / already-closed
                     window ("before_window")--> group by window (epoch-aligned, Δ = window_s)
      -> a later window closes the open one (closing.close_windows)
      -> hash key floor(p/δ) (spatial_hash) -> RouteTable: live cell or redirect φ -> entry row
         (one searchsorted; unseen keys become new cell entries in one np.unique)
      -> direction bin floor((θ+π)/(2π/B)) mod B -> np.bincount on row·B+bin (entries)
    GraphSnapshot --> node table / stability timers, node entries follow their nodes, vanished
                      nodes release their state to hash cells (ownership) -> bind check
    Trajectory / set_fixed_sensor --> observation masks when windows close (observation)

Choices:

* **NaN headings** count for activity (``nodir``) but not for a direction bin or the speed
  descriptor; NaN speeds only skip the speed descriptor. Non-finite positions are dropped and
  counted as ``"nan"``, positions outside the hashable range as ``"out_of_range"``; robot
  poses of either kind are dropped (:meth:`Mapper.add_trajectory`).
* **Empty windows**: when time jumps over windows with no detections, the whole run is closed
  at once; every recorded window goes to the temporal model with who observed it (an observed
  empty window is a real zero, an unobserved one teaches nothing). An entry with detections in
  a window counts as observed in it.
* **Binding and temporal rows**: entry ``e`` is row ``e`` of the temporal accumulators.
  Binding adds the cell's counts, accumulators and scores into the node's
  (``TemporalState.add_rows``; the observation with more windows is kept, since both were seen
  over the same time), re-labels the cell's windows still held for the current day, then
  zeroes and frees the cell's row; releasing does the same in the other direction.
* **Graphs close windows**: a graph at time t means log time reached t, so ``add_graph`` first
  closes the windows ending at or before t (as ``advance`` does); detections stamped in a
  closed window that arrive later are dropped as ``"before_window"``.
* **When binding is checked**: on ``add_graph`` and ``advance`` (at their times), and at the
  end of every window that is recorded when windows close (one with detections or covered by
  an observation source; before that window is recorded), whatever closes it.
* **Times**: every time given to the Mapper (detections, graphs, poses, fixed-sensor spans,
  ``advance``) must lie in ``MIN_TIME_NS .. MAX_TIME_NS`` (1900-01-01 .. 2261-01-01 UTC, as
  ``--time``), else :class:`InputError`: window arithmetic stays exact in int64, and a far
  time costs nothing but its recorded windows (``advance`` to 2261 visits only those).
* **Continuing a build**: the open window stays open at the end of a log and is persisted, so
  building from log A, saving, loading and continuing with log B gives the same state as
  building from A+B at once with the same graphs, detections and observation sources. An
  ``advance`` to the end of A adds one bind check that a single pass does not make; it changes
  the result only if a cell that appeared after A's last closed window could bind at A's end
  and the next graph then moves or removes that node (tested: the usual case is equal).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.closing import close_windows
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, direction_bins
from aion_cli.engine.grouping import split_by_key
from aion_cli.engine.ownership import apply_graph, bind_cells
from aion_cli.engine.spatial_hash import (
    cell_centres,
    hashable_indices,
    pack_keys_unchecked,
    packable_mask,
)
from aion_cli.engine.state import DROP_REASONS, MapState
from aion_cli.engine.types import I64, DetectionBatch, GraphSnapshot, Trajectory
from aion_cli.engine.windows import window_index, window_ns
from aion_cli.errors import ConfigError, InputError

MIN_TIME_NS: int = -2_208_988_800 * 1_000_000_000
"""Earliest time the Mapper accepts, 1900-01-01T00:00Z (as ``--time``)."""
MAX_TIME_NS: int = 9_183_110_400 * 1_000_000_000
"""Latest time the Mapper accepts, 2261-01-01T00:00Z: times are int64 nanoseconds (which end
on 2262-04-11), and the margin keeps window and calendar arithmetic exact."""
TIME_RANGE_TEXT = "1900-01-01 .. 2261-01-01 UTC"

#: Per-row code of :meth:`Mapper.add_detections` for an accepted detection (a dropped
#: one has the index of its reason in ``DROP_REASONS``).
ACCEPTED = -1


def check_time(t_ns: int, what: str) -> None:
    """:class:`InputError` for a time outside ``MIN_TIME_NS .. MAX_TIME_NS``."""
    if not MIN_TIME_NS <= int(t_ns) <= MAX_TIME_NS:
        raise InputError(
            f"{what} at {int(t_ns)} ns lies outside {TIME_RANGE_TEXT}",
            hint="times are nanoseconds since 1970 (UTC); fix or drop the bad stamps",
        )


class Mapper:
    """Incremental map builder over one :class:`MapState` (new, or loaded to continue)."""

    def __init__(self, config: ModelConfig, state: MapState | None = None) -> None:
        if state is not None and state.config != config:
            raise ConfigError(
                "the map was built with different model parameters",
                hint="build with the map's own config (stored in its manifest)",
            )
        self._state = state if state is not None else MapState.empty(config)
        self._delta = window_ns(config.window_s)

    @property
    def state(self) -> MapState:
        return self._state

    # -- inputs -----------------------------------------------------------------------------
    def add_detections(
        self, batch: DetectionBatch, codes: npt.NDArray[np.int8] | None = None
    ) -> dict[str, int]:
        """Accumulate a batch; returns how many detections were dropped, per reason.

        ``codes`` (optional, one int8 per row) receives per row :data:`ACCEPTED` or the index
        in ``DROP_REASONS`` of why the row was dropped, so a caller can count per source.
        :class:`InputError` when a time lies outside ``MIN_TIME_NS .. MAX_TIME_NS``."""
        st = self._state
        drops = dict.fromkeys(DROP_REASONS, 0)
        if codes is None:
            codes = np.empty(len(batch), dtype=np.int8)
        codes[:] = ACCEPTED
        if len(batch) == 0:
            return drops
        t_first, t_last = int(batch.t_ns.min()), int(batch.t_ns.max())
        check_time(t_first, "a detection")
        check_time(t_last, "a detection")
        self._fed_at(t_first)
        ijk, finite, hashable = hashable_indices(batch.xyz, st.config.cell_size)
        first_window = t_first // self._delta  # floor, as window_index
        if np.count_nonzero(hashable) == len(batch) and (
            st.open_window is None or first_window >= st.open_window
        ):  # the usual batch (issue 15): every row accepted, nothing to count or select
            if st.open_window is None:
                st.open_window = first_window
            for reason in DROP_REASONS:
                st.dropped[reason] = st.dropped.get(reason, 0)
            self._accumulate_by_window(batch, ijk, None, (first_window, t_last))
            return drops
        window = window_index(batch.t_ns, self._delta)
        if st.open_window is None and hashable.any():
            st.open_window = int(window[hashable].min())
        opened = st.open_window if st.open_window is not None else 0
        late = hashable & (window < opened)
        keep = hashable & ~late
        drops["nan"] = int(len(batch) - np.count_nonzero(finite))
        drops["out_of_range"] = int(np.count_nonzero(finite) - np.count_nonzero(hashable))
        drops["before_window"] = int(np.count_nonzero(late))
        for reason, count in drops.items():
            st.dropped[reason] = st.dropped.get(reason, 0) + count
        codes[~finite] = DROP_REASONS.index("nan")
        codes[finite & ~hashable] = DROP_REASONS.index("out_of_range")
        codes[late] = DROP_REASONS.index("before_window")
        if keep.all():
            self._accumulate_by_window(batch, ijk, window)
        elif keep.any():
            self._accumulate_by_window(batch.select(keep), ijk[keep], window[keep])
        return drops

    def add_graph(self, snapshot: GraphSnapshot) -> None:
        """A new scene graph at log time ``t``: windows ending at or before ``t`` close first
        (they are over), then node timers, moves and releases, then a bind check at ``t``."""
        st = self._state
        check_time(int(snapshot.t_ns), "a scene graph")
        if st.open_window is not None:
            close_windows(st, int(snapshot.t_ns) // self._delta)  # window_index, in int
        apply_graph(st, snapshot)
        self._fed_at(int(snapshot.t_ns))
        st.log_time_ns = _later(st.log_time_ns, int(snapshot.t_ns))
        bind_cells(st, st.log_time_ns)

    def begin_session(self, t_ns: int) -> int:
        """Another scene-graph session's graph comes at log time ``t_ns`` (its node ids are
        its own, the same ids at other places): windows ending at or before ``t_ns`` close
        first (they are over, on the places they saw), then every node entry is released to
        the hash cell at its node's position and the graph is forgotten
        (:func:`aion_cli.engine.rebind.release_all`, as ``aion merge`` of two sessions'
        maps and ``--lineage different`` release them), for the cells to bind to the new
        session's places as those turn stable; returns how many were released."""
        from aion_cli.engine.rebind import release_all

        st = self._state
        check_time(int(t_ns), "a scene graph")
        if st.open_window is not None:
            close_windows(st, int(t_ns) // self._delta)
        return release_all(st)

    def add_trajectory(self, trajectory: Trajectory) -> None:
        """Robot poses for the observation masks (any time order, before windows close).
        Poses beyond the spatial hash's range are dropped as non-finite ones are (they say
        nothing of what was seen: no cell lies within ``sensor_range`` of them, and their
        distances overflowed to inf)."""
        xy = np.asarray(trajectory.xyz, dtype=np.float64).reshape(-1, 3)[:, :2]
        near = packable_mask(np.column_stack([xy, np.zeros(len(xy))]), self._state.config.cell_size)
        if len(near) == len(trajectory) and not near.all():
            trajectory = Trajectory(np.asarray(trajectory.t_ns)[near], trajectory.xyz[near])
        if len(trajectory):
            check_time(int(np.min(trajectory.t_ns)), "a robot pose")
            check_time(int(np.max(trajectory.t_ns)), "a robot pose")
        self._state.observation.add_trajectory(trajectory)
        if len(trajectory):
            self._start_at(int(np.min(trajectory.t_ns)))
            self._fed_at(int(np.min(trajectory.t_ns)))

    def set_fixed_sensor(self, start_ns: int, end_ns: int) -> None:
        """Everything is observed in windows overlapping ``[start_ns, end_ns)``, each for the
        share of it the interval covers (``ModelConfig.exposure``; whole without it)."""
        check_time(int(start_ns), "a fixed-sensor interval")
        check_time(int(end_ns), "a fixed-sensor interval")
        self._state.observation.set_fixed_sensor(int(start_ns), int(end_ns))
        if int(end_ns) > int(start_ns):
            self._start_at(int(start_ns))

    def set_fixed_windows(self, windows: I64, within: tuple[I64, I64] | None = None) -> None:
        """Everything is observed in the given windows (sorted window indices); ``within``:
        the spans ``[start, end)`` of log time the sensor recorded, which cut a window a log
        starts or ends inside to the part recorded (``ObservationSource.add_fixed_windows``)."""
        w = np.asarray(windows, np.int64)
        if w.size:
            check_time(int(w.min()) * self._delta, "a fixed-sensor window")
            check_time((int(w.max()) + 1) * self._delta, "a fixed-sensor window")
        self._state.observation.add_fixed_windows(w, self._delta, within)
        if w.size:
            self._start_at(int(w.min()) * self._delta)

    def start_at(self, t_ns: int) -> None:
        """The map starts at ``t_ns`` unless a source or a record started it earlier, as an
        observation source starting there starts it (:meth:`_start_at`): a time shard of a
        parallel build starts where one pass, which adds every robot pose before the
        stream, starts, also when the part holds none of those poses."""
        check_time(int(t_ns), "a map start")
        self._start_at(int(t_ns))

    def _fed_at(self, t_ns: int) -> None:
        """Log time ``t_ns`` was fed (a detection, graph, pose or :meth:`advance`): the
        state's ``first_time_ns`` is the earliest, the start of the span ``Map.from_state``
        records (a build records its logs')."""
        first = self._state.first_time_ns
        self._state.first_time_ns = t_ns if first is None else min(first, t_ns)

    def _start_at(self, t_ns: int) -> None:
        """An observation source starts at ``t_ns``: before anything was recorded, the map
        starts there too, so the observed windows before the first detection count (as
        observed-empty windows) instead of being skipped."""
        st = self._state
        window = int(window_index(np.int64(t_ns), self._delta))
        if st.open_window is None:
            st.open_window = window
            return
        if window >= st.open_window or st.recorded_anything():
            return
        if st.entries.window_rows().size:
            return  # the open window holds detections: it cannot move
        st.open_window = window

    def advance(self, t_ns: int) -> None:
        """Log time reached ``t_ns``: close every window ending at or before it (ownership is
        checked at each recorded window's end), then check ownership at ``t_ns``.

        Costs O(recorded windows) however far ``t_ns`` lies: only windows with detections or
        covered by an observation source are visited (:func:`close_windows`).
        :class:`InputError` for a time outside ``MIN_TIME_NS .. MAX_TIME_NS``."""
        check_time(int(t_ns), "log time")
        st = self._state
        target = int(window_index(np.int64(t_ns), self._delta))
        if st.open_window is None:
            st.open_window = target
        close_windows(st, target)
        self._fed_at(int(t_ns))
        st.log_time_ns = _later(st.log_time_ns, int(t_ns))
        bind_cells(st, st.log_time_ns)

    # -- internals --------------------------------------------------------------------------
    def _accumulate_by_window(
        self,
        batch: DetectionBatch,
        ijk: I64,
        window: I64 | None,
        span: tuple[int, int] | None = None,
    ) -> None:
        """Accumulate window by window, closing the open window before a later one starts.
        ``window``: each row's window (None: from the times); ``span``: the first row's window
        and the last time, when known (a batch inside one window needs no more)."""
        st = self._state
        if span is not None and span[0] == span[1] // self._delta:  # one window
            close_windows(st, span[0])
            self._accumulate(batch, ijk)
            st.log_time_ns = _later(st.log_time_ns, span[1])
            return
        if window is None:
            window = window_index(batch.t_ns, self._delta)
        if window.min() == window.max():
            groups = [(int(window[0]), np.arange(len(window)))]
        else:
            groups = [(int(window[idx[0]]), idx) for idx in split_by_key(window)]
        whole = len(groups) == 1
        for w, idx in groups:
            close_windows(st, w)
            part = batch if whole else batch.select(idx)
            self._accumulate(part, ijk if whole else ijk[idx])
            st.log_time_ns = _later(st.log_time_ns, int(part.t_ns.max()))

    def _accumulate(self, batch: DetectionBatch, ijk: I64) -> None:
        st = self._state
        rows = self._route(pack_keys_unchecked(ijk), ijk)
        bins = direction_bins(batch.heading, st.config.bins)
        st.entries.accumulate(rows, bins, batch.speed, batch.heading)
        st.accepted += len(batch)

    def _route(self, keys: I64, ijk: I64) -> I64:
        """Entry rows for hash keys, creating cell entries for keys never seen."""
        st = self._state

        def create(new_keys: I64) -> I64:
            centres = cell_centres(new_keys, st.config.cell_size)
            return st.allocate(CELL, new_keys, np.zeros(len(new_keys), np.uint64), centres)

        return st.routes.route(keys, ijk, create)


def _later(current: int | None, t_ns: int) -> int:
    return t_ns if current is None else max(current, t_ns)
