"""The map state: everything needed to continue a build and to answer queries.

:class:`MapState` bundles the entry store, the FreMEn state (entry row ``e`` owns FreMEn rows
``e·(B+1) .. e·(B+1)+B``), the node table with its stability timers, the redirect table φ, the
latest graph, the open window, pending robot poses and fixed-sensor intervals, and the drop
counters. :meth:`MapState.to_arrays` turns it into plain numpy arrays plus a JSON-serialisable
``meta`` dict (no objects, no pickle); entries are exported in canonical order (cells by key,
then nodes by id), so equal maps give equal arrays whatever their in-memory row layout.
:func:`merge_states` combines two maps of disjoint time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, NODE, EntryStore, fremen_rows
from aion_cli.engine.errors import MapCorruptError
from aion_cli.engine.fremen import FremenModel, FremenState, Predictor
from aion_cli.engine.graph_arrays import graph_from_arrays, graph_to_arrays
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.nodes import NodeTable, Redirects
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.pending import PendingUpdates, combine
from aion_cli.engine.routing import RouteTable
from aion_cli.engine.types import F64, I64, U64, BoolA, GraphSnapshot

STATE_VERSION = 1
DROP_REASONS = ("nan", "out_of_range", "before_window")


@dataclass
class MapState:
    """A map under construction or loaded from a file (see the module docstring)."""

    config: ModelConfig
    entries: EntryStore
    fremen_store: FremenState
    nodes: NodeTable = field(default_factory=NodeTable)
    redirects: Redirects = field(default_factory=Redirects)
    observation: ObservationSource = field(default_factory=ObservationSource)
    graph: GraphSnapshot | None = None
    open_window: int | None = None
    log_time_ns: int | None = None
    accepted: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DROP_REASONS, 0))
    routes: RouteTable = field(default_factory=RouteTable)
    pending: PendingUpdates = field(default_factory=PendingUpdates)

    @property
    def fremen(self) -> FremenState:
        """The FreMEn state with every deferred window absorbed (see :meth:`defer_update`)."""
        if self.pending:
            self.flush_fremen()
        return self.fremen_store

    @fremen.setter
    def fremen(self, value: FremenState) -> None:
        if self.pending:
            self.flush_fremen()
        self.fremen_store = value

    def defer_update(self, rows: I64, t_s: F64, values: F64, observed: BoolA) -> None:
        """``model.update(fremen, rows, t_s, values, observed)``, absorbed together with the
        next windows' (one pass over the accumulators for many windows); flushed when enough
        is pending and before anything reads or moves FreMEn rows."""
        if not self.pending.accepts(rows, t_s):
            self.flush_fremen()
        self.pending.add(rows, t_s, values, observed)
        if self.pending.full():
            self.flush_fremen()

    def flush_fremen(self) -> None:
        """Absorb the deferred windows now."""
        calls = self.pending.take()
        if calls:
            self.model.update(self.fremen_store, *combine(calls))

    @classmethod
    def empty(cls, config: ModelConfig) -> MapState:
        entries = EntryStore.empty(config.bins)
        model = FremenModel.from_config(config)
        return cls(config, entries, model.empty(entries.capacity * (config.bins + 1)))

    @property
    def bins(self) -> int:
        return self.config.bins

    @property
    def model(self) -> FremenModel:
        return FremenModel.from_config(self.config)

    # -- entry lifecycle (keeps the FreMEn rows in step) ------------------------------------
    def allocate(self, kind: int, keys: I64, node_ids: U64, xyz: F64) -> I64:
        """New empty entries (and empty FreMEn rows); returns their rows."""
        rows = self.entries.allocate(kind, keys, node_ids, xyz)
        needed = self.entries.capacity * (self.bins + 1)
        if self.fremen_store.n_rows < needed:  # pending row indices stay valid
            self.fremen_store.resize(needed)
        return rows

    def move(self, src: I64, dst: I64) -> None:
        """Move entries ``src`` into ``dst`` (adding; ``dst`` may repeat) and delete ``src``.

        Every count, open-window count, speed sum and FreMEn accumulator of ``src`` is added
        to ``dst``; pairs are applied in the caller's order, which callers make canonical so
        the floating-point result does not depend on the row layout.
        """
        if len(src) == 0:
            return
        self.entries.add_into(src, dst)
        b = self.bins
        self.fremen.add_rows(fremen_rows(src, b).ravel(), fremen_rows(dst, b).ravel())
        self.delete(src)

    def delete(self, rows: I64) -> None:
        self.fremen.zero_rows(fremen_rows(rows, self.bins).ravel())
        self.entries.delete(rows)

    def node_entry_rows(self, node_ids: U64) -> I64:
        """Entry rows of the given node ids (-1 where the node has no entry)."""
        rows = self.entries.node_rows()
        ids = self.entries.node_id[rows]
        order = np.argsort(ids)
        ids, rows = ids[order], rows[order]
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

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(self, lazy: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
        """Plain arrays and a JSON-serialisable meta dict (config, counters, window, graph).

        ``lazy``: the FreMEn members are :class:`RowTake` (gathered block by block when
        :func:`formats.mapfile.write_map` writes them), so writing needs no second copy of the
        largest part of the state."""
        order = self.entries.canonical_order()
        arrays: dict[str, Any] = self.entries.to_arrays(order)
        fr = fremen_rows(order, self.bins).ravel()
        if lazy:
            arrays.update(self.fremen.rows_to_arrays("fremen_", fr))
        else:
            arrays.update(self.fremen.take(fr).to_arrays("fremen_"))
        # the prediction coefficients, so a loaded map predicts without ranking components
        arrays.update(self.model.predictor(self.fremen, fr, cache=False).to_arrays("fremen_pred_"))
        arrays.update(self.nodes.to_arrays())
        arrays.update(self.redirects.to_arrays())
        arrays.update(self.observation.to_arrays())
        graph_arrays, graph_meta = graph_to_arrays(self.graph)
        arrays.update(graph_arrays)
        meta: dict[str, Any] = {
            "state_version": STATE_VERSION,
            "config": self.config.to_dict(),
            "open_window": self.open_window,
            "log_time_ns": self.log_time_ns,
            "accepted": int(self.accepted),
            "dropped": {k: int(v) for k, v in self.dropped.items()},
            "graph": graph_meta,
        }
        return arrays, meta

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> MapState:
        """Inverse of :meth:`to_arrays`; :class:`MapCorruptError` for inconsistent input."""
        try:
            version = int(meta["state_version"])
            config = ModelConfig.from_dict(meta["config"])
            open_window = meta["open_window"]
            log_time = meta["log_time_ns"]
            accepted = int(meta["accepted"])
            dropped = {str(k): int(v) for k, v in meta["dropped"].items()}
            graph_meta = meta["graph"]
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise MapCorruptError(f"map state metadata is incomplete or invalid: {exc}") from exc
        if version > STATE_VERSION:
            raise MapCorruptError(f"map state version {version} is newer than {STATE_VERSION}")
        entries = EntryStore.from_arrays(arrays, config.bins)
        fremen = FremenState.from_arrays(arrays, "fremen_")
        if (fremen.n_periods, fremen.max_order) != (len(config.periods), config.max_order):
            raise MapCorruptError(
                f"FreMEn state has {fremen.n_periods} periods and order {fremen.max_order}, "
                f"the config says {len(config.periods)} and {config.max_order}"
            )
        if fremen.n_rows != entries.n * (config.bins + 1):
            raise MapCorruptError(
                f"FreMEn state has {fremen.n_rows} rows, expected {entries.n * (config.bins + 1)}"
            )
        model = FremenModel.from_config(config)
        predictor = Predictor.from_arrays(arrays, "fremen_pred_", fremen.n_rows, model)
        fremen.resize(entries.capacity * (config.bins + 1))
        if predictor is not None:
            model.attach_predictor(fremen, predictor)
        try:
            state = cls(
                config=config,
                entries=entries,
                fremen_store=fremen,
                nodes=NodeTable.from_arrays(arrays),
                redirects=Redirects.from_arrays(arrays),
                observation=ObservationSource.from_arrays(arrays),
                graph=graph_from_arrays(arrays, graph_meta),
                open_window=None if open_window is None else int(open_window),
                log_time_ns=None if log_time is None else int(log_time),
                accepted=accepted,
                dropped={**dict.fromkeys(DROP_REASONS, 0), **dropped},
            )
        except (KeyError, ValueError) as exc:
            raise MapCorruptError(f"map state arrays are incomplete or invalid: {exc}") from exc
        state.check_ownership()
        state.rebuild_routes()
        return state

    def check_ownership(self) -> None:
        """:class:`MapCorruptError` unless every key and node has exactly one owner."""
        ent = self.entries
        cell_keys = ent.key[ent.cell_rows()]
        node_ids = ent.node_id[ent.node_rows()]
        problems = []
        if len(np.unique(cell_keys)) != len(cell_keys):
            problems.append("two cell entries share a key")
        if len(np.unique(node_ids)) != len(node_ids):
            problems.append("two node entries share a node id")
        if np.isin(self.redirects.keys, cell_keys).any():
            problems.append("a redirected cell also has an entry")
        if not np.isin(self.redirects.nodes, node_ids).all():
            problems.append("a redirect points at a node without an entry")
        if problems:
            raise MapCorruptError(f"map state is inconsistent: {'; '.join(problems)}")


def merge_states(a: MapState, b: MapState) -> MapState:
    """One map from two maps of disjoint time built with the same config.

    See :mod:`aion_cli.engine.merge` for what is exact and what is approximated.
    """
    return merge_maps(a, b)


__all__ = ["CELL", "DROP_REASONS", "NODE", "MapState", "merge_states"]
