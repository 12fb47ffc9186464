"""The entry store: one row per dynamics holder (an unbound hash cell or a navigational node).

A struct of arrays with amortized capacity (doubling). Rows never move: entry row ``e`` is also
row ``e`` of the temporal accumulators (``engine.temporal``), so deleting an entry just marks
its row ``FREE`` (zeroed, put on a free list and reused by the next new entry) and the two
stores never need a permutation.
Exports use :meth:`EntryStore.canonical_order` (cells by key, then nodes by id), so two maps with
the same entries give the same arrays whatever their internal row layout.

Per entry, cumulative (including the open window) and for the open window only:
``counts[E,B]`` detections per direction bin, ``nodir[E]`` detections without a heading (they
count for activity but not for a direction), ``speed_sum[E,B]`` / ``speed_n[E,B]`` (the motion
descriptor λ: speed samples per bin), ``heading_cos[E,B]`` / ``heading_sin[E,B]`` (the sums of
the unit heading vectors per bin: where in its bin the flow goes, so a corridor along +x, which
the bins' edges split at 0°, is drawn at 0° and not at the bin's centre, 22.5°; cumulative
only). Which windows observed an entry, and its counts per window
over time, live in the temporal model. Accumulation uses ``np.bincount`` on combined
``row·B + bin`` indices: no Python loop per detection.

Closing a window must not cost every entry of the map (issue 15: a 20-day build closes 2,879
windows over ~3,400 entries): ``window_mark`` flags the rows whose open-window counts may be
non-zero (every method that adds to them sets it), so :meth:`EntryStore.window_rows` and
:meth:`EntryStore.clear_window` cost the entries the window touched. The open-window arrays
are written only through this class's methods (a loaded store re-derives the flags).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.grouping import unique_inverse
from aion_cli.engine.types import F64, I64, U64

FREE = -1
CELL = 0
NODE = 1

_PER_BIN = ("counts", "window_counts", "speed_sum", "speed_n", "heading_cos", "heading_sin")
HEADING_SUMS = ("heading_cos", "heading_sin")
"""Per-bin arrays that may be negative, and that maps written before them lack (read as
zeros: those bins are described by their centres)."""
_VERSIONS = itertools.count(1)
"""Numbers for :attr:`EntryStore.cells_version`, never given twice in a process."""
_GROWTH_KEPT = 256
"""Cell allocations :meth:`EntryStore.cells_added_since` remembers (older ones: unknown)."""
_SCALAR = ("nodir", "window_nodir")
ADDITIVE = (*_PER_BIN, *_SCALAR)
"""Every per-entry quantity that moves and merges by addition (``dst += src``)."""


def direction_bins(heading: npt.ArrayLike, bins: int) -> I64:
    """Paper convention ``floor((θ+π)/(2π/B)) mod B``; -1 where the heading is not finite.

    Fast path for the usual batch of finite headings in [-π, π); anything else (NaN, wrapped
    angles, θ just below π where ``θ + π`` rounds up to 2π) goes through
    :func:`descriptors.bin_of`, which handles every case.
    """
    theta = np.asarray(heading, dtype=np.float64)
    x = (theta + np.pi) * (bins / (2.0 * np.pi))
    if x.size and x.min() >= 0.0 and x.max() < bins:  # NaN fails both comparisons
        return x.astype(np.int64)  # truncation == floor for x >= 0
    return bin_of(theta, bins)


def add_rows(array: F64, rows: I64 | slice, values: npt.NDArray[Any]) -> None:
    """``array[rows] += values`` for distinct ``rows`` (or a slice): the same sums, one per
    row. With an index array the rows are gathered by ``take``, added to in place and put
    back: ``array[rows] += values`` gathers them by fancy indexing, three times slower at the
    ~60 rows of a window's detections (issue 15: ~2 against ~7 µs, six times per batch)."""
    if isinstance(rows, slice):
        array[rows] += values
        return
    part = array.take(rows, axis=0)
    part += values
    array[rows] = part


class HeldCounts(Protocol):
    """What :func:`held_detections` reads: an :class:`EntryStore`, or any entries with its
    cumulative ``counts[E,B]`` and ``nodir[E]`` (the DSG export's checks are given such
    entries without a store around them)."""

    @property
    def counts(self) -> F64: ...

    @property
    def nodir(self) -> F64: ...


def held_detections(entries: HeldCounts, rows: I64 | slice) -> F64:
    """The detections each of ``rows`` holds, directed (every direction bin) and undirected,
    the open window's included: the one place that sum is written (``sum()`` of it: the
    detections of all of ``rows``). :meth:`EntryStore.window_totals` is the open window's."""
    out: F64 = entries.counts[rows].sum(axis=1) + entries.nodir[rows]
    return out


@dataclass
class EntryStore:
    """Struct of arrays over entries: ``n`` row slots in use (live or ``FREE``) of ``capacity``.

    ``free`` lists freed slots below ``n`` (ascending).
    """

    bins: int
    n: int
    free: I64
    kind: npt.NDArray[np.int8]
    key: I64
    node_id: U64
    xyz: F64
    counts: F64
    window_counts: F64
    speed_sum: F64
    speed_n: F64
    heading_cos: F64
    heading_sin: F64
    nodir: F64
    window_nodir: F64
    window_mark: npt.NDArray[np.bool_] = field(
        default_factory=lambda: np.zeros(0, bool), compare=False, repr=False
    )
    """Per row slot: the open-window counts may be non-zero (a superset of the rows that
    have detections in the open window; see the module docstring)."""
    cells_version: int = field(
        default_factory=lambda: next(_VERSIONS), compare=False, repr=False
    )
    """A number that no other set of cell rows (in any store of this process) has had:
    renewed whenever rows become or stop being cells (:meth:`allocate`, :meth:`delete`; a
    cell's key and position never change otherwise), so a bind check that found nothing to
    bind knows nothing changed while it and the stable nodes stay the same."""
    nodes_version: int = field(default=0, init=False, compare=False, repr=False)
    """Renewed whenever rows become or stop being node entries (:meth:`allocate` of nodes,
    :meth:`delete` of any node): what :meth:`node_index` keeps its answer for."""
    _node_index: tuple[int, U64, I64] | None = field(
        default=None, init=False, compare=False, repr=False
    )
    """Memo of :meth:`node_index`: the :attr:`nodes_version` it was taken at, ids, rows."""
    _growth: tuple[int, list[tuple[int, I64]]] = field(
        default_factory=lambda: (0, []), init=False, compare=False, repr=False
    )
    """What :meth:`cells_added_since` answers from: a :attr:`cells_version` and the cell rows
    allocated since it, each with the version it gave (no other change of the cell rows
    since that version: :meth:`delete` and allocations of nodes start it again)."""

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled or copied: a version of this process's own (another process numbered
        its stores independently), and no memo taken at another process's version."""
        self.__dict__.update(state)
        self.cells_version = next(_VERSIONS)
        self._node_index = None
        self._growth = (self.cells_version, [])

    def cells_added_since(self, version: int) -> I64 | None:
        """The rows that became cells since :attr:`cells_version` was ``version``, when
        nothing else changed the cell rows since (a cell's key and position never change):
        the cells a bind check made then has not seen. None when that is not known."""
        if version == self.cells_version:
            return np.zeros(0, np.int64)
        base, added = self._growth
        if version == base:
            start = 0
        else:
            given = [v for v, _ in added]
            if version not in given:
                return None
            start = given.index(version) + 1
        return np.concatenate([rows for _, rows in added[start:]])

    def __post_init__(self) -> None:
        self._growth = (self.cells_version, [])
        if len(self.window_mark) != len(self.kind):  # built without flags: derive them
            self.window_mark = np.zeros(len(self.kind), bool)
            self.window_mark[: self.n] = self.window_totals(np.arange(self.n)) != 0

    @classmethod
    def empty(cls, bins: int, capacity: int = 64) -> EntryStore:
        cap = max(int(capacity), 1)
        return cls(
            bins=bins,
            n=0,
            free=np.zeros(0, np.int64),
            kind=np.full(cap, FREE, np.int8),
            key=np.full(cap, -1, np.int64),
            node_id=np.zeros(cap, np.uint64),
            xyz=np.zeros((cap, 3)),
            counts=np.zeros((cap, bins)),
            window_counts=np.zeros((cap, bins)),
            speed_sum=np.zeros((cap, bins)),
            speed_n=np.zeros((cap, bins)),
            heading_cos=np.zeros((cap, bins)),
            heading_sin=np.zeros((cap, bins)),
            nodir=np.zeros(cap),
            window_nodir=np.zeros(cap),
            window_mark=np.zeros(cap, bool),
        )

    @property
    def capacity(self) -> int:
        return len(self.kind)

    # -- growth, creation, deletion ---------------------------------------------------------
    def reserve(self, n_total: int) -> bool:
        """Make room for ``n_total`` row slots (doubling); True if the capacity changed."""
        if n_total <= self.capacity:
            return False
        cap = self.capacity
        while cap < n_total:
            cap *= 2
        for name in self._array_names():
            old = getattr(self, name)
            new = np.zeros((cap, *old.shape[1:]), dtype=old.dtype)
            new[: self.n] = old[: self.n]
            setattr(self, name, new)
        mark = np.zeros(cap, bool)
        mark[: self.n] = self.window_mark[: self.n]
        self.window_mark = mark
        self.kind[self.n :] = FREE
        self.key[self.n :] = -1
        return True

    def allocate(self, kind: int, key: I64, node_id: U64, xyz: F64) -> I64:
        """Create empty entries, reusing freed rows first (lowest first); returns their rows.

        The capacity grows as needed: compare :attr:`capacity` before and after to resize the
        temporal state.
        """
        k = len(key)
        reuse = self.free[:k]
        self.free = self.free[k:]
        fresh = k - len(reuse)
        self.reserve(self.n + fresh)
        rows = np.concatenate([reuse, np.arange(self.n, self.n + fresh, dtype=np.int64)])
        self.n += fresh
        self.kind[rows] = kind
        self.key[rows] = key
        self.node_id[rows] = node_id
        self.xyz[rows] = xyz
        self.cells_version = next(_VERSIONS)
        if kind == NODE:
            self.nodes_version += 1
        if kind == CELL and len(self._growth[1]) < _GROWTH_KEPT:
            self._growth[1].append((self.cells_version, rows.copy()))
        else:
            self._growth = (self.cells_version, [])
        for name in ADDITIVE:
            getattr(self, name)[rows] = 0.0
        return rows

    def delete(self, rows: I64) -> None:
        """Free entries: their rows are zeroed and reused by later :meth:`allocate` calls.

        The owner must also clear the entries' temporal rows (``TemporalState.zero_rows``).
        """
        if len(rows) == 0:
            return
        if bool((self.kind[rows] == NODE).any()):
            self.nodes_version += 1
        for name in self._array_names():
            getattr(self, name)[rows] = 0
        self.window_mark[rows] = False
        self.kind[rows] = FREE
        self.key[rows] = -1
        self.free = np.union1d(self.free, rows).astype(np.int64)
        self.cells_version = next(_VERSIONS)
        self._growth = (self.cells_version, [])

    def live_rows(self) -> I64:
        """Rows holding an entry (cell or node), ascending."""
        return np.flatnonzero(self.kind[: self.n] != FREE).astype(np.int64)

    def cell_rows(self) -> I64:
        return np.flatnonzero(self.kind[: self.n] == CELL).astype(np.int64)

    def node_rows(self) -> I64:
        return np.flatnonzero(self.kind[: self.n] == NODE).astype(np.int64)

    def node_index(self) -> tuple[U64, I64]:
        """The node entries' ids in increasing order and their rows (what a search for the
        entries of node ids needs: ``MapState.node_entry_rows``). Kept while
        :attr:`nodes_version` stays the same: only :meth:`allocate` and :meth:`delete`
        change which rows are nodes (and renew it then), and a node entry's id never
        changes; so the binds of a live graph (issue 15), which delete cells but rarely add
        nodes, no longer sort every node id at each call.
        The arrays are shared: read them, never write."""
        memo = self._node_index
        if memo is not None and memo[0] == self.nodes_version:
            return memo[1], memo[2]
        rows = self.node_rows()
        ids = self.node_id[rows]
        order = np.argsort(ids)
        ids, rows = ids[order], rows[order]
        self._node_index = (self.nodes_version, ids, rows)
        return ids, rows

    def canonical_order(self) -> I64:
        """Live rows ordered cells by key, then nodes by node id (layout-independent)."""
        cells = self.cell_rows()
        nodes = self.node_rows()
        cells = cells[np.argsort(self.key[cells], kind="stable")]
        nodes = nodes[np.argsort(self.node_id[nodes], kind="stable")]
        return np.concatenate([cells, nodes])

    # -- accumulation (hot path) ------------------------------------------------------------
    def accumulate(self, rows: I64, bins: I64, speed: F64, heading: F64 | None = None) -> None:
        """Add one detection per element: entry ``rows``, direction ``bins`` (-1 = no heading)
        of ``heading`` (radians; the unit vectors of directed detections are summed per bin).

        Directed detections go to ``counts``; undirected to ``nodir``. Speeds count only for
        directed detections with a finite speed. Both the cumulative and open-window arrays are
        updated. Vectorized with ``np.bincount`` over compressed row indices.

        A tracker's batch usually has a heading and a speed for every detection (issue 15:
        every batch of the 20-day build logs): then nothing is selected, no undirected count
        is added (adding zeros changes no count: they are sums of non-negative whole numbers,
        never -0.0) and the speed samples per bin are the histogram itself, so the batch costs
        three histograms instead of five (the same sums, tested against the general path).
        """
        if len(rows) == 0:
            return
        b = self.bins
        target: slice | I64
        if self.n * b <= 4 * len(rows):  # dense: histogram over every row slot
            target, local, m = slice(0, self.n), rows, self.n
        else:  # sparse: histogram over the rows this batch touches
            target, local = unique_inverse(rows)
            m = len(target)
        directed = bins >= 0
        every = bool(directed.all())
        flat_dir = local * b + bins if every else local[directed] * b + bins[directed]
        hist = np.bincount(flat_dir, minlength=m * b).reshape(m, b).astype(np.float64)
        add_rows(self.counts, target, hist)
        add_rows(self.window_counts, target, hist)
        self.window_mark[rows] = True
        if not every:
            undirected = np.bincount(local[~directed], minlength=m).astype(np.float64)
            add_rows(self.nodir, target, undirected)
            add_rows(self.window_nodir, target, undirected)
        if heading is not None and flat_dir.size:
            theta = heading if every else heading[directed]
            for name, part in (("heading_cos", np.cos(theta)), ("heading_sin", np.sin(theta))):
                add_rows(getattr(self, name), target, np.bincount(
                    flat_dir, weights=part, minlength=m * b
                ).reshape(m, b))
        sp = speed if every else speed[directed]
        has_speed = np.isfinite(sp)
        if has_speed.all() and flat_dir.size:  # every sample: the histogram counts them
            add_rows(self.speed_sum, target, np.bincount(
                flat_dir, weights=sp, minlength=m * b
            ).reshape(m, b))
            add_rows(self.speed_n, target, hist)
        elif has_speed.any():
            idx = flat_dir[has_speed]
            add_rows(self.speed_sum, target, np.bincount(
                idx, weights=sp[has_speed], minlength=m * b
            ).reshape(m, b))
            add_rows(self.speed_n, target, np.bincount(idx, minlength=m * b).reshape(m, b))

    def window_totals(self, rows: I64) -> F64:
        """Detections of ``rows`` in the open window (directed + undirected)."""
        out: F64 = self.window_counts[rows].sum(axis=1) + self.window_nodir[rows]
        return out

    def window_count_columns(self, rows: I64) -> F64:
        """The open window's counts of ``rows``, what a window close records: the per-bin
        counts and, as the last column, the undirected count (``(len(rows), bins + 1)``,
        ``column_stack`` of the two). Gathered by ``take`` into one array: a 2-D fancy index
        costs about three times as much at a window's ~60 rows (issue 15)."""
        out = np.empty((len(rows), self.bins + 1))
        out[:, : self.bins] = self.window_counts.take(rows, axis=0)
        out[:, self.bins] = self.window_nodir.take(rows)
        return out

    def window_rows(self) -> I64:
        """Live rows with detections in the open window, ascending: the rows a window close
        records counts for. Costs the rows the window touched (``window_mark``), not ``n``.
        Counts are sums of non-negative whole numbers, so a row's total is positive exactly
        where one of its counts is non-zero: tested for that, without the total and its
        stacked copy (about a third less per call at the 20-day build log's ~60 rows).
        ``nonzero`` and ``take`` rather than ``flatnonzero`` and fancy indexing: the same
        rows, in half the time at ~20 marked rows (issue 15: 11 against 23 µs). The bins
        are tested by their sum (a matrix-vector product: positive exactly where a count is,
        as the counts are never negative), not ``any(axis=1)``, numpy's reduction per row
        over the few bins: the same at ~25 rows, a third of it at ~550 (issue 15: 17
        against 52 µs; a window of the 20-day log at 25 people per message)."""
        marked = self.window_mark[: self.n].nonzero()[0].astype(np.int64, copy=False)
        if marked.size == 0:
            return marked
        keep = self.window_counts.take(marked, axis=0) @ np.ones(self.bins) > 0
        keep |= self.window_nodir.take(marked) != 0
        keep &= self.kind.take(marked) != FREE
        out: I64 = marked[keep]
        return out

    def clear_window(self) -> None:
        """Forget the open window's counts (the cumulative arrays already hold them); costs
        the rows the window touched."""
        marked = self.window_mark[: self.n].nonzero()[0]
        self.window_counts[marked] = 0.0
        self.window_nodir[marked] = 0.0
        self.window_mark[marked] = False

    # -- moving state between entries (bind / release) --------------------------------------
    def add_into(self, src: I64, dst: I64) -> None:
        """dst += src for every per-entry quantity (``dst`` may repeat)."""
        for name in ADDITIVE:
            arr = getattr(self, name)
            np.add.at(arr, dst, arr[src])
        self.window_mark[dst[self.window_mark[src]]] = True  # (a repeated dst: any src)

    # -- views and export -------------------------------------------------------------------
    def total_count(self) -> float:
        """Sum of every detection count over live entries (directed + undirected; a freed
        row holds none)."""
        return float(held_detections(self, slice(0, self.n)).sum())

    def to_arrays(self, order: I64, prefix: str = "entry_") -> dict[str, np.ndarray]:
        """Plain arrays of the given live rows, in that order."""
        names = self._array_names()
        return {f"{prefix}{name}": getattr(self, name)[order].copy() for name in names}

    @classmethod
    def from_arrays(
        cls,
        arrays: dict[str, np.ndarray],
        bins: int,
        prefix: str = "entry_",
        adopt: bool = False,
    ) -> EntryStore:
        """Rebuild from :meth:`to_arrays` output; :class:`MapCorruptError` on bad members.

        ``adopt`` (a query's load of members just read, which nothing else holds): members
        that are native, contiguous and writable, of the store's dtype and of at least 64
        rows become the store's arrays as they are, at a capacity of exactly their rows
        (:meth:`reserve` copies them when it grows), instead of being copied into fresh
        arrays (issue 15: 43 MB copied and faulted in per query of a 10^5-entry map)."""
        from aion_cli.engine.entry_arrays import store_from_arrays

        return store_from_arrays(cls, arrays, bins, prefix, adopt)

    @staticmethod
    def _array_names() -> tuple[str, ...]:
        return ("kind", "key", "node_id", "xyz", *_PER_BIN, *_SCALAR)
