"""The map state: everything needed to continue a build and to answer queries.

:class:`MapState` bundles the entry store, the temporal accumulators (entry row ``e`` is row
``e`` of :class:`~aion_cli.engine.temporal.accumulators.TemporalState`) and the pending day,
the node table with its stability timers, the redirect table φ, the latest graph, the open
window, pending robot poses and fixed-sensor intervals, and the drop counters.
:meth:`MapState.to_arrays` turns it into plain numpy arrays plus a JSON-serialisable ``meta``
dict (no objects, no pickle); entries are exported in canonical order (cells by key, then nodes
by id), so equal maps give equal arrays whatever their in-memory row layout.
:func:`merge_states` combines two maps of disjoint time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aion_cli.engine.closing import open_window_record
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, NODE, EntryStore
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.nodes import NodeTable, Redirects
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.routing import RouteTable
from aion_cli.engine.state_arrays import map_state_from_arrays, map_state_to_arrays
from aion_cli.engine.temporal import components as fremen_components
from aion_cli.engine.temporal import model as temporal_model
from aion_cli.engine.temporal import query_state
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar import DAY_NS
from aion_cli.engine.temporal.components import FremenComponents
from aion_cli.engine.temporal.groups import entry_groups, sorted_group_keys
from aion_cli.engine.temporal.held_days import DeferredDays
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.provisional import ProvisionalScores
from aion_cli.engine.types import F64, I64, U64, GraphSnapshot
from aion_cli.engine.windows import window_centre_ns, window_ns
from aion_cli.errors import PartMapError

DROP_REASONS = ("nan", "out_of_range", "before_window")
_StateKey = tuple[int, int, int | None, int, int]


@dataclass
class MapState:
    """A map under construction or loaded from a file (see the module docstring).

    ``writable``: the state may be continued and saved. A query on a state that is not
    (a map loaded for ``predict``, ``plan``, ``export``) absorbs the pending day in place
    instead of into a copy."""

    config: ModelConfig
    entries: EntryStore
    temporal: TemporalState
    pending: PendingDay
    nodes: NodeTable = field(default_factory=NodeTable)
    redirects: Redirects = field(default_factory=Redirects)
    observation: ObservationSource = field(default_factory=ObservationSource)
    graph: GraphSnapshot | None = None
    open_window: int | None = None
    log_time_ns: int | None = None
    #: the earliest log time a Mapper was fed (not in a map file; ``Map.from_state``'s span)
    first_time_ns: int | None = field(default=None, compare=False)
    accepted: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DROP_REASONS, 0))
    routes: RouteTable = field(default_factory=RouteTable)
    writable: bool = True
    #: a shard of a parallel build (:mod:`aion_cli.engine.shards`): closed days are held
    #: here, unscored, instead of being scored and absorbed (None: an ordinary map)
    deferred: DeferredDays | None = None
    #: FreMEn components read from the map file, for a query's state read without its
    #: Fourier sums (``TemporalState.fourier_loaded`` false; ``engine.temporal.components``)
    components: FremenComponents | None = field(default=None, repr=False, compare=False)
    params: TemporalParams = field(init=False, repr=False, compare=False)
    _view: tuple[_StateKey, TemporalState] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    _predictor: tuple[_StateKey, temporal_model.Predictor] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    _provisional: tuple[_StateKey, ProvisionalScores | None] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    #: the pooling's prior strengths the map file stores for this state's query view
    #: (``engine.temporal.pool_priors``), keyed as the view
    _priors: tuple[_StateKey, PoolPriors] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    _days: dict[int, int] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.params = TemporalParams.from_config(self.config)

    @classmethod
    def empty(cls, config: ModelConfig) -> MapState:
        entries = EntryStore.empty(config.bins)
        params = TemporalParams.from_config(config)
        temporal = temporal_model.empty_state(params, entries.capacity)
        return cls(config, entries, temporal, PendingDay(params.values))

    def __repr__(self) -> str:
        """One line (``Map.state`` in a notebook): the generated repr printed every array and
        the config, 160 kB for the bundled sample's 151 entries."""
        kind = self.entries.kind[: self.entries.n]
        nodes, cells = int(np.count_nonzero(kind == NODE)), int(np.count_nonzero(kind == CELL))
        return (
            f"<MapState: {nodes + cells:,} entries ({nodes:,} nodes, {cells:,} cells), "
            f"{self.accepted:,} detections accepted, {self.bins} direction bins"
            f"{'' if self.writable else ', read for queries'}>"
        )

    @property
    def bins(self) -> int:
        return self.config.bins

    @property
    def window_ns(self) -> int:
        return window_ns(self.config.window_s)

    # -- entry lifecycle (keeps the temporal rows in step) ----------------------------------
    def allocate(self, kind: int, keys: I64, node_ids: U64, xyz: F64) -> I64:
        """New empty entries (and empty temporal rows); returns their rows."""
        rows = self.entries.allocate(kind, keys, node_ids, xyz)
        if self.temporal.n_rows < self.entries.capacity:
            self.temporal.resize(self.entries.capacity)
        return rows

    def move(self, src: I64, dst: I64) -> None:
        """Move entries ``src`` into ``dst`` (adding; ``dst`` may repeat) and delete ``src``.

        Every count, open-window count, speed sum and temporal accumulator of ``src`` is added
        to ``dst`` (observations: the larger of the two, see ``temporal.accumulators``), and
        the pending day's windows follow; pairs are applied in the caller's order, which
        callers make canonical so the floating-point result does not depend on the row layout.
        """
        if len(src) == 0:
            return
        self.entries.add_into(src, dst)
        self.temporal.add_rows(src, dst, observation="max")
        self.pending.remap(np.asarray(src, np.int64), np.asarray(dst, np.int64))
        if self.deferred is not None:
            self.deferred.remap(np.asarray(src, np.int64), np.asarray(dst, np.int64))
        self.delete(src)

    def delete(self, rows: I64) -> None:
        self.temporal.zero_rows(rows)
        self.entries.delete(rows)

    def node_entry_rows(self, node_ids: U64) -> I64:
        """Entry rows of the given node ids (-1 where the node has no entry)."""
        ids, rows = self.entries.node_index()
        if len(ids) == 0:
            return np.full(len(node_ids), -1, np.int64)
        pos = np.minimum(np.searchsorted(ids, node_ids), len(ids) - 1)
        return np.where(ids[pos] == node_ids, rows[pos], -1).astype(np.int64)

    def rebuild_routes(self) -> None:
        """Rebuild the key -> row index from live cells and redirects (after ownership changes)."""
        cells = self.entries.cell_rows()
        red_rows = self.node_entry_rows(self.redirects.nodes)
        keys = np.concatenate([self.entries.key[cells], self.redirects.keys])
        rows = np.concatenate([cells, red_rows])
        self.routes = RouteTable.build(keys, rows)

    # -- the temporal model -----------------------------------------------------------------
    def groups(self, rows: I64) -> tuple[I64, int]:
        """Pooling group of each entry (room, else neighbourhood) and the number of groups."""
        places = self.graph.places if self.graph is not None else None
        ent = self.entries
        return entry_groups(
            ent.kind[rows],
            ent.node_id[rows],
            ent.xyz[rows],
            places.ids if places is not None else np.zeros(0, np.uint64),
            places.parent if places is not None else np.zeros(0, np.uint64),
            self.config.pool_size,
        )

    def place_group_keys(self) -> tuple[U64, I64] | None:
        """The current graph's place ids (sorted) and the group key of each
        (:func:`~aion_cli.engine.temporal.groups.group_keys`); None without a graph."""
        if self.graph is None:
            return None
        return sorted_group_keys(self.graph.places, self.config.pool_size)

    def window_day(self, window: int) -> int:
        """The local day (``timezone``) of a window, by its centre (remembered for the last
        windows asked: a build asks for each window several times as it closes). A window
        not asked before brings the days of the windows of about a day from it on, in one
        vectorised call of the same elementwise calendar (issue 15: a build asks for each
        next window in turn, one calendar call per window before)."""
        days = self._days
        day = days.get(window)
        if day is None:
            if len(days) >= 4096:
                days.clear()
            ahead = np.arange(window, window + min(max(DAY_NS // self.window_ns, 1), 256))
            found = self.params.calendar.day(window_centre_ns(ahead, self.window_ns))
            days.update(zip(ahead.tolist(), found.tolist(), strict=True))
            day = days[window]
        return day

    def record_window(
        self,
        window: int,
        fixed: bool,
        observed: I64,
        count_rows: I64,
        counts: F64,
        exposure: F64 | None = None,
        fixed_share: float = 1.0,
    ) -> None:
        """One closed window for the temporal model (a window of a new day first closes the
        pending day: see :mod:`aion_cli.engine.temporal.model`); ``exposure``: the share of
        the window each of ``observed`` was observed in (default whole); ``fixed_share``:
        the share of a fixed sensor's window its logs recorded."""
        day = self.window_day(window)
        if self.pending and self.pending.day != day:
            self.close_day()
        self.pending.add_window(
            day, window, fixed, observed, count_rows, counts, exposure, fixed_share
        )

    def recorded_anything(self) -> bool:
        """Whether any window was recorded (closed) yet."""
        return bool(self.pending) or self.closed_a_day()

    def closed_a_day(self) -> bool:
        """Whether any day was closed (scored and absorbed): windows in the accumulators."""
        t = self.temporal
        return bool(t.glob.n[0] > 0) or bool(t.obs.n[: t.high_water].any())

    def close_day(self, rows: I64 | None = None) -> None:
        """Score the pending day against the model before it, then absorb it; a shard
        (:attr:`deferred`) holds it instead. ``rows``: the live entries that pool the
        forecasts (default: those live now)."""
        if not self.pending:
            return
        if self.deferred is not None:
            self.deferred.hold(self.pending, self.entries.live_rows(), self.place_group_keys())
            self.pending = PendingDay(self.params.values)
            return
        if rows is None:
            rows = self.entries.live_rows()
        groups, n_groups = self.groups(rows)
        temporal_model.close_pending(
            self.params, self.temporal, self.pending, rows, groups, n_groups, self.window_ns
        )

    def query_temporal(self) -> TemporalState:
        """The accumulators as queries see them: pending day and open window absorbed,
        unscored (in place when the state is not ``writable``, else a cached copy)."""
        if self.deferred is not None:
            raise PartMapError(
                "this is a part map (aion build --part): its closed days are held apart, "
                "unscored, for aion merge, so it answers no query, neither a forecast nor "
                "what was observed",
                hint="aion merge PART.aion [PART2.aion ...] -o MAP.aion scores its days into a map",
            )
        key = self._view_key()
        if self._view is not None and self._view[0] == key:
            return self._view[1]
        provisional = self.provisional_scores()  # before the view absorbs the pending day
        priors = self._priors if self._priors is not None and self._priors[0] == key else None
        view = query_state.query_view(
            self.params,
            self.temporal,
            self.pending,
            open_window_record(self),
            self.window_ns,
            in_place=not self.writable,
        )
        if provisional is not None:
            provisional.add_into(view)
        if not self.writable:  # the open window now counts as closed for this state's queries
            self.entries.clear_window()
            key = self._view_key()
        self._view = (key, view)
        if priors is not None:  # the stored priors are this view's
            self._priors = (key, priors[1])
        return view

    def provisional_scores(self) -> ProvisionalScores | None:
        """The pending day's day-ahead scores as closing it now would add them, which queries
        choose families by (:mod:`aion_cli.engine.temporal.provisional`). None for a part
        map, without a pending day, and for a query's state read without its Fourier sums
        from a map that stores none (an older map: it chooses as it was written)."""
        if self.deferred is not None or not self.pending:
            return None
        key = self._view_key()
        if self._provisional is not None and self._provisional[0] == key:
            return self._provisional[1]
        if not self.temporal.fourier_loaded:
            return None
        rows = self.entries.live_rows()
        groups, n_groups = self.groups(rows)
        scores = ProvisionalScores.of_pending(
            self.params, self.temporal, self.pending, rows, groups, n_groups, self.window_ns
        )
        self._provisional = (key, scores)
        return scores

    def scored_temporal(self) -> TemporalState:
        """The accumulators with the pending day's provisional scores added to copies of
        their scores (what queries choose families by)."""
        provisional = self.provisional_scores()
        return self.temporal if provisional is None else provisional.applied_to(self.temporal)

    def predictor(self) -> tuple[I64, temporal_model.Predictor]:
        """Live entries in canonical order and their forecasts (cached while the state is
        unchanged, so many query times cost one preparation)."""
        view = self.query_temporal()
        key = self._view_key()
        rows = self.entries.canonical_order()
        if self._predictor is None or self._predictor[0] != key:
            groups, n_groups = self.groups(rows)
            stored = None if view.fourier_loaded else self.components
            priors = self._priors[1] if self._priors and self._priors[0] == key else None
            if priors is not None and not priors.fits(rows.size, n_groups):
                priors = None
            self._predictor = (
                key,
                temporal_model.Predictor.of(
                    self.params, view, rows, groups, n_groups, stored, priors
                ),
            )
        return rows, self._predictor[1]

    def forecast_components(self, order: I64) -> FremenComponents:
        """The FreMEn components a query of the entries ``order`` (canonical) will use,
        computed from the state as the query sees it (``engine.temporal.components``)."""
        groups, n_groups = self.groups(order)
        flow, direction, map_flow = query_state.choose(
            self.params, self.scored_temporal(), order, groups, n_groups
        )
        name = self.params.flow[map_flow]
        map_family = name if self.config.reconcile and name != "static" else None
        total, bins = fremen_components.needed(self.params, flow, direction, map_family)
        parts = [self.pending.consolidated()] if self.pending else []
        open_window = open_window_record(self)
        if open_window is not None:
            parts.append(open_window)
        return fremen_components.compute(
            self.params, self.temporal, parts, order, total, bins, self.window_ns
        )

    def _view_key(self) -> _StateKey:
        """What the cached query view, forecasts and provisional scores depend on: the
        accumulators, the pending day, the open window, the detections taken, and the graph
        (its rooms pool the forecasts)."""
        return (
            self.temporal.generation,
            len(self.pending.windows),
            self.open_window,
            self.accepted,
            id(self.graph),
        )

    def windows_observed(self, rows: I64, open_window: bool = False) -> F64:
        """Windows in which each entry was observed so far (pending day included; a robot
        window for the share of it the entry was in range, ``ModelConfig.exposure``); with
        ``open_window`` the open window too, as queries count it (closed now), so a summary's
        count is the denominator of the flows the map predicts."""
        out: F64 = self.temporal.windows_observed(rows)
        days = [self.pending.consolidated()] if self.pending else []
        if open_window and (record := open_window_record(self)) is not None:
            days.append(record)
        for day in days:  # each own window for the share observed, as the accumulators add it
            fixed = day.fixed_windows()
            own, _, weight = day.own_pairs()
            share = np.bincount(own, weight, self.temporal.n_rows)
            out = out + fixed + share[rows]
        return out

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(
        self, lazy: bool = False, priors: bool = True
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Plain arrays and a JSON-serialisable meta dict (config, counters, window, graph):
        :func:`~aion_cli.engine.state_arrays.map_state_to_arrays` (``priors=False``: without
        the forecast priors, for a copy that is not written)."""
        return map_state_to_arrays(self, lazy, priors)

    @classmethod
    def from_arrays(
        cls,
        arrays: Mapping[str, np.ndarray],
        meta: dict[str, Any],
        writable: bool = True,
        copy: bool = True,
        forecast_only: bool = False,
        stored_forecasts: bool = True,
        stored_priors: bool = True,
    ) -> MapState:
        """Inverse of :meth:`to_arrays`; :class:`MapCorruptError` for inconsistent input
        (:func:`~aion_cli.engine.state_arrays.map_state_from_arrays`)."""
        return map_state_from_arrays(
            cls, arrays, meta, writable, copy, forecast_only, stored_forecasts, stored_priors
        )


def merge_states(a: MapState, b: MapState) -> MapState:
    """One map from two maps of disjoint time built with the same config.

    See :mod:`aion_cli.engine.merge` for what is exact and what is approximated.
    """
    return merge_maps(a, b)


__all__ = ["CELL", "DROP_REASONS", "NODE", "MapState", "merge_states"]
