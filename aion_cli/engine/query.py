"""Answering questions about a map: per-entry tables of flow descriptors.

* :func:`historical_table` — what was seen: each entry's detections per observed window and the
  raw proportions of its direction bins (the open window included, as closing it now would
  record it: ``MapState.query_temporal``).
* :func:`predict_table` — what is expected at a time: each entry's chosen temporal families
  (``engine.temporal``), with the predictive variance of the window count. With every temporal
  family switched off (``families = ["static"]``) its flows equal the historical table's
  exactly, and its histograms too when the direction prior is off (``direction_prior = 0``).
* :func:`aggregate_table` — places summed into rooms or buildings with the latest graph's
  parents (``hierarchy.aggregate``); per-bin rates, flows and speed sums add.

Rows: every live entry (unbound cells, then node entries, in canonical order), plus every place
of the latest graph that has no entry yet (zero flow). Ids print as spark_dsg NodeSymbols
(``p12`` = ``(ord('p') << 56) | 12``) for nodes and ``c<key>`` for hash cells. Flow quantities
per entry are additive: ``rate[E, B]`` expected directed detections per window per bin,
``flow[E]`` all expected detections per window (detections without a heading included),
``flow_var[E]`` the variance of the window count.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine import descriptors
from aion_cli.engine.descriptors import Descriptors, PooledHeadings
from aion_cli.engine.entries import CELL, NODE
from aion_cli.engine.grouping import contained
from aion_cli.engine.hierarchy import aggregate
from aion_cli.engine.node_ids import node_labels
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.model import Prediction, Predictor
from aion_cli.engine.temporal.quantiles import count_quantiles
from aion_cli.engine.types import F64, U64, GraphSnapshot

ROOM = 2
BUILDING = 3
StrA = npt.NDArray[np.str_]


@dataclass(frozen=True)
class EntryTable:
    """One row per entry. ``kind`` 0 cell, 1 node, 2 room, 3 building; ``layer`` names the
    layer ("cells", the graph's place layer name, "rooms", "buildings"); ``node_id`` is 0 for
    cells; ``rate``/``flow``/``speed_sum``/``speed_n`` are the additive quantities the
    descriptors were computed from, with ``heading_cos``/``heading_sin`` (the per-bin sums of
    the headings' unit vectors: where in each bin the flow goes; None: the bins' centres);
    ``placed``, where given, places the bins instead (the entries' own sums, their group's or
    the map's where they have none: :class:`descriptors.PooledHeadings`, picked for the rows
    described only; ``bin_cos``/``bin_sin`` every row's; not additive, so rooms sum
    ``heading_*``). ``key`` is a cell's spatial-hash key (−1 for other
    rows);
    ``ids`` (``c<key>`` for cells, spark_dsg symbols such as ``p12`` otherwise) are formatted
    on first use, since turning 10^5 integers into strings costs more than the prediction."""

    key: npt.NDArray[np.int64]
    node_id: U64
    kind: npt.NDArray[np.int8]
    layer: StrA
    xyz: F64
    rate: F64
    flow: F64
    speed_sum: F64
    speed_n: F64
    window_s: float
    flow_var: F64
    flow_family: StrA
    direction_family: StrA
    heading_cos: F64 | None = None
    heading_sin: F64 | None = None
    placed: PooledHeadings | None = None
    total_dispersion: float = 1.0
    """How bursty the map's window totals are (φ_T, ``Predictor.phi_total``): what
    :func:`aggregate_table` widens a sum of places' variances by (1: the places' counts
    taken as independent, as in a historical table, which has no spread)."""
    level_variance: float = 0.0
    """How much a day's level varies around the forecast's (``Predictor.level_variance``):
    :func:`aggregate_table` adds it times a group's summed flow squared (0: no such term)."""

    def __len__(self) -> int:
        return len(self.kind)

    @cached_property
    def descriptors(self) -> Descriptors:
        """Every row's descriptors (flow, direction histogram, entropy, ...), computed on
        first use from the additive quantities."""
        return self.descriptors_of(None)

    def descriptors_of(self, rows: npt.NDArray[np.int64] | None) -> Descriptors:
        """The descriptors of rows ``rows`` only (None: every row), row by row as
        :attr:`descriptors` computes them: ``predict --top 10`` of a map of 10^5 entries
        describes ten."""
        pick: slice | npt.NDArray[np.int64] = slice(None) if rows is None else rows  # views
        hc: F64 | None
        hs: F64 | None
        if self.placed is not None:
            hc, hs = self.placed.rows(rows)
        else:
            hc = None if self.heading_cos is None else self.heading_cos[pick]
            hs = None if self.heading_sin is None else self.heading_sin[pick]
        return _descriptors(
            self.rate[pick], self.flow[pick], self.speed_sum[pick], self.speed_n[pick],
            self.window_s, hc, hs,
        )

    def flow_quantile(self, q: float) -> F64:
        """The q-quantile of the number of detections in a window (negative binomial with
        the predicted mean and variance; NaN where unknown, e.g. historical tables)."""
        return count_quantiles(self.flow, self.flow_var, q)

    @cached_property
    def bin_cos(self) -> F64 | None:
        """Every row's placed cos sums (``placed``), None without them."""
        return None if self.placed is None else self.placed.rows()[0]

    @cached_property
    def bin_sin(self) -> F64 | None:
        """Every row's placed sin sums (``placed``), None without them."""
        return None if self.placed is None else self.placed.rows()[1]

    @cached_property
    def ids(self) -> StrA:
        """Display ids: ``c<key>`` for cells, the node symbol otherwise."""
        is_cell = self.kind == CELL
        cells = np.char.add("c", self.key[is_cell].astype(str))
        nodes = node_symbol(self.node_id[~is_cell])
        width = max((a.dtype.itemsize // 4 for a in (cells, nodes) if a.size), default=1)
        out: StrA = np.empty(len(self.kind), dtype=f"<U{width}")
        out[is_cell] = cells
        out[~is_cell] = nodes
        return out


def node_symbol(node_ids: npt.ArrayLike) -> StrA:
    """spark_dsg NodeSymbol strings: category character + index (``p12``); see
    :func:`aion_cli.engine.node_ids.node_labels`."""
    out: StrA = node_labels(node_ids)
    return out


def historical_table(state: MapState) -> EntryTable:
    """Descriptors of what was observed, per entry (see the module docstring)."""
    rows, predictor = state.predictor()
    return _entry_table(state, rows, predictor, predictor.historical())


def predict_table(state: MapState, t_ns: int) -> EntryTable:
    """Descriptors expected at ``t_ns`` (UNIX ns), per entry."""
    rows, predictor = state.predictor()
    return _entry_table(state, rows, predictor, predictor.at(int(t_ns)))


def _entry_table(
    state: MapState, rows: np.ndarray, predictor: Predictor, pred: Prediction
) -> EntryTable:
    rate = np.nan_to_num(pred.flow * pred.directed_share)[:, None] * pred.probabilities
    ent = state.entries
    # the pooling groups the forecast filled the entries' empty bins from (the predictor's own)
    fc = predictor.forecaster
    # gathered once for both uses (PooledHeadings reads them, never writes them): each is a
    # fresh E x B copy, 6.4 MB on a 10^5-entry map
    heading_cos, heading_sin = ent.heading_cos[rows], ent.heading_sin[rows]
    table = _table(
        state,
        rows,
        rate,
        pred.flow,
        ent.speed_sum[rows],
        ent.speed_n[rows],
        pred.variance,
        pred.flow_family,
        pred.direction_family,
        heading_cos,
        heading_sin,
    )
    extra = len(table) - len(rows)  # the graph's places without an entry: no flow
    return replace(
        table,
        placed=PooledHeadings.of(
            heading_cos, heading_sin, fc.groups, len(fc.pool.histogram), extra
        ),
        total_dispersion=predictor.phi_total,
        level_variance=predictor.level_variance,
    )


def aggregate_table(
    table: EntryTable, graph: GraphSnapshot, level: Literal["rooms", "buildings"]
) -> EntryTable:
    """Sum the node rows of ``table`` into the graph's rooms (or buildings, via rooms). A
    group's ``flow_var`` is its places' variances plus their covariance, from how bursty the
    map's window totals are (``table.total_dispersion``, the map's total flow the window's
    reference: :func:`~aion_cli.engine.temporal.totals.sum_variance`) and how much whole
    days differ in level (``table.level_variance``), never less than the independent sum;
    the flows are plain sums."""
    if level not in ("rooms", "buildings"):
        raise ValueError(f"level must be 'rooms' or 'buildings', got {level!r}")
    parent = parent_ids(graph.places.ids, graph.places.parent, table.node_id)
    parent[table.kind != NODE] = 0
    if level == "buildings":
        parent = parent_ids(graph.rooms.ids, graph.rooms.parent, parent)
    target = graph.rooms if level == "rooms" else graph.buildings
    b = table.rate.shape[1]
    parts = [table.rate, table.flow[:, None], table.speed_sum, table.speed_n,
             table.flow_var[:, None]]
    hc, hs = table.heading_cos, table.heading_sin
    headings = hc is not None and hs is not None
    if hc is not None and hs is not None:
        parts += [hc, hs]  # a room's bins: its places' headings
    ids, sums = aggregate(parent, np.nan_to_num(np.concatenate(parts, axis=1)))
    rate, flow = sums[:, :b], sums[:, b]
    speed_sum, speed_n = sums[:, b + 1 : 2 * b + 1], sums[:, 2 * b + 1 : 3 * b + 1]
    historical = bool(np.all(np.isnan(table.flow_var)))
    flow_var = np.full(len(ids), np.nan) if historical else sums[:, 3 * b + 1]
    widened = table.total_dispersion > 1.0 or table.level_variance > 0.0
    if not historical and widened and len(ids):
        flow_var = _grouped_variance(table, parent, ids)
    heading_cos = sums[:, 3 * b + 2 : 4 * b + 2] if headings else None
    heading_sin = sums[:, 4 * b + 2 : 5 * b + 2] if headings else None
    xyz = np.full((len(ids), 3), np.nan)
    if len(target):  # graph layers need not be sorted by id
        order = np.argsort(target.ids)
        at = order[np.minimum(np.searchsorted(target.ids[order], ids), len(target) - 1)]
        known = target.ids[at] == ids
        xyz[known] = target.xyz[at[known]]
    kind = ROOM if level == "rooms" else BUILDING
    return EntryTable(
        key=np.full(len(ids), -1, np.int64),
        node_id=ids,
        kind=np.full(len(ids), kind, np.int8),
        layer=np.full(len(ids), level),
        xyz=xyz,
        rate=rate,
        flow=flow,
        speed_sum=speed_sum,
        speed_n=speed_n,
        window_s=table.window_s,
        flow_var=flow_var,
        flow_family=np.full(len(ids), "aggregate"),
        direction_family=np.full(len(ids), "aggregate"),
        heading_cos=heading_cos,
        heading_sin=heading_sin,
    )


def _grouped_variance(table: EntryTable, parent: U64, ids: U64) -> F64:
    """The variance of each group's (``ids``, sorted) summed count, its places (rows whose
    ``parent`` is the group) correlated as :mod:`~aion_cli.engine.temporal.totals` says."""
    from aion_cli.engine.temporal.totals import sum_variance

    member = parent != 0
    group = np.searchsorted(ids, parent[member])
    return sum_variance(
        table.flow[member], table.flow_var[member], group, len(ids),
        float(np.nansum(table.flow)), table.total_dispersion, table.level_variance,
    )


def parent_ids(ids: U64, parent: U64, children: U64) -> U64:
    """Parent id of each child (0 if the child is unknown or has none)."""
    if len(ids) == 0:
        return np.zeros(len(children), np.uint64)
    order = np.argsort(ids)
    sid, spar = ids[order], parent[order]
    pos = np.minimum(np.searchsorted(sid, children), len(sid) - 1)
    return np.where(sid[pos] == children, spar[pos], np.uint64(0)).astype(np.uint64)


def _descriptors(
    rate: F64,
    flow: F64,
    speed_sum: F64,
    speed_n: F64,
    window_s: float,
    heading_cos: F64 | None = None,
    heading_sin: F64 | None = None,
) -> Descriptors:
    """Descriptors from additive per-window rates; the flow includes undirected detections;
    each bin's direction from the headings' sums where given."""
    windows = np.where(np.isfinite(flow), 1.0, 0.0)
    desc = descriptors.historical(
        rate, speed_sum, speed_n, windows, window_s, heading_cos, heading_sin
    )
    return replace(desc, flow_per_window=flow, flow_per_hour=flow * (3600.0 / window_s))


def places_without_entry(kind: npt.NDArray[np.int8], node_id: U64, place_ids: U64) -> int:
    """How many of the latest graph's places (``place_ids``) hold no entry (``kind`` and
    ``node_id`` per entry row, ``FREE`` rows included and skipped): the rows :func:`_table`
    adds with zero flow and family "none", so ``aion predict`` lists entries plus these."""
    live = node_id[(kind == NODE) | (kind == CELL)]
    return int(np.count_nonzero(~np.isin(place_ids, live)))


def _table(
    state: MapState,
    rows: np.ndarray,
    rate: F64,
    flow: F64,
    speed_sum: F64,
    speed_n: F64,
    flow_var: F64,
    flow_family: StrA,
    direction_family: StrA,
    heading_cos: F64,
    heading_sin: F64,
) -> EntryTable:
    """Entries ``rows`` plus the latest graph's places without an entry (zero flow)."""
    ent, b = state.entries, state.bins
    node_id = ent.node_id[rows]
    kind = ent.kind[rows]
    xyz = ent.xyz[rows]
    graph = state.graph
    place_layer = graph.layer_name if graph is not None else "places"
    if graph is not None and len(graph.places):
        missing = ~contained(node_id, graph.places.ids)  # np.isin without numpy.ma
        k = int(missing.sum())
        node_id = np.concatenate([node_id, graph.places.ids[missing]])
        kind = np.concatenate([kind, np.full(k, NODE, np.int8)])
        xyz = np.concatenate([xyz, graph.places.xyz[missing]])
        rate = np.concatenate([rate, np.zeros((k, b))])
        flow = np.concatenate([flow, np.zeros(k)])
        speed_sum = np.concatenate([speed_sum, np.zeros((k, b))])
        speed_n = np.concatenate([speed_n, np.zeros((k, b))])
        heading_cos = np.concatenate([heading_cos, np.zeros((k, b))])
        heading_sin = np.concatenate([heading_sin, np.zeros((k, b))])
        unknown = len(flow_var) > 0 and bool(np.all(np.isnan(flow_var)))  # historical
        flow_var = np.concatenate([flow_var, np.full(k, np.nan if unknown else 0.0)])
        flow_family = np.concatenate([flow_family, np.full(k, "none")])
        direction_family = np.concatenate([direction_family, np.full(k, "none")])
    is_cell = kind == CELL
    keys = np.concatenate([ent.key[rows], np.full(len(kind) - len(rows), -1, np.int64)])
    keys[~is_cell] = -1
    layer = np.where(is_cell, "cells", place_layer)
    window_s = state.config.window_s
    return EntryTable(
        keys,
        node_id,
        kind,
        layer,
        xyz,
        rate,
        flow,
        speed_sum,
        speed_n,
        window_s,
        flow_var,
        flow_family,
        direction_family,
        heading_cos,
        heading_sin,
    )
