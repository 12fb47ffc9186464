"""Navigational-node bookkeeping for ownership transfer: the node table and the redirect table.

:class:`NodeTable` holds the nodes of the latest graph sorted by id, with the log time since
which each has been *stable* (present and within ``stable_move_tolerance`` of its reference
position) — the τ timer of DESIGN.md §4. :class:`Redirects` is φ: sorted cell keys -> node ids.
Which node a cell binds to is :mod:`aion_cli.engine.nearest`'s.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.grouping import insert_sorted
from aion_cli.engine.types import F64, I64, U64, BoolA

if TYPE_CHECKING:
    from aion_cli.engine.nearest import BindIndex


_TIME_MIN = int(np.iinfo(np.int64).min)
_TIME_MAX = int(np.iinfo(np.int64).max)


@dataclass(frozen=True)
class QuietCheck:
    """A bind check that planned no bind (``ownership.plan_binds``), as much of it as
    decides that answer: the node table's stable set is the same at every log time in
    ``[start_ns, end_ns)`` (:meth:`NodeTable.stable_span`, with ``stability_ns``), and with
    that set and the bind parameters ``params`` (radius, vertical tolerance) no cell of
    the entry store's ``cells_version`` binds (``cells_version`` None: no node was stable,
    so no cell of any version binds). A later check on the same table that
    :meth:`covers` has the same answer, found without looking at a node or a cell
    (issue 15: a build checks twice per window, at the window's end and at its graph, and
    most checks see the stable nodes and the cells of the check before)."""

    since: I64
    """The table's ``stable_since_ns`` array the check saw (compared by identity)."""
    stability_ns: int
    params: tuple[float, float]
    start_ns: int
    end_ns: int
    cells_version: int | None

    def covers(
        self,
        since: I64,
        stability_ns: int,
        params: tuple[float, float],
        t_ns: int,
        cells_version: int,
    ) -> bool:
        """Whether a check at ``t_ns`` of the cells of ``cells_version`` (timers ``since``)
        would find what this one found: nothing to bind."""
        return (
            since is self.since
            and self.start_ns <= t_ns < self.end_ns
            and stability_ns == self.stability_ns
            and params == self.params
            and (self.cells_version is None or cells_version == self.cells_version)
        )


@dataclass
class NodeTable:
    """Nodes of the latest graph: ``ids`` sorted, positions, reference positions, stable-since."""

    ids: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))
    xyz: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    ref_xyz: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    stable_since_ns: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    bind_index: BindIndex | None = field(default=None, compare=False, repr=False)
    """Memo of the bind checks (:class:`BindIndex`); carried over by :meth:`updated`, since
    it checks on every use that the stable nodes and the cells are the ones it saw."""
    entry_at: tuple[I64, U64, I64] | None = field(default=None, compare=False, repr=False)
    """Memo of where node entries lie in :attr:`ids`: (entry rows, their node ids, their
    positions), every one present. Carried over while the ids stay these (a graph that
    moved or only repeated the same nodes), and used only for the same rows and ids
    (``ownership.apply_graph`` compares them: a live graph's node entries rarely change
    between two of its updates, and comparing costs less than searching)."""
    quiet: QuietCheck | None = field(default=None, compare=False, repr=False)
    """Memo of the last bind check on this table that planned no bind
    (``ownership.plan_binds``). Whoever changes the table's arrays in place must set it to
    None (``node_drift`` does; a table's other changes make a new table)."""

    def __len__(self) -> int:
        return len(self.ids)

    def updated(
        self, ids: U64, xyz: F64, t_ns: int, move_tolerance: float
    ) -> tuple[NodeTable, BoolA]:
        """The table after a snapshot with nodes ``ids``/``xyz`` at ``t_ns``.

        New nodes start their stability timer at ``t_ns``; a node farther than
        ``move_tolerance`` (3D) from its reference position restarts it there. Duplicate ids
        keep their first row. Returns the new table and a mask over *this* table's rows of the
        nodes that are gone.
        """
        ids = np.asarray(ids, dtype=np.uint64)
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        if self._unchanged_by(ids, xyz, move_tolerance):
            return self._same(xyz), np.zeros(len(self), bool)
        if len(ids) == len(self) and np.array_equal(ids, self.ids):
            return self._moved(xyz, t_ns, move_tolerance), np.zeros(len(self), bool)
        uniq, first = np.unique(ids, return_index=True)
        pos = xyz[first]
        old_at = np.searchsorted(self.ids, uniq)
        old_at_c = np.minimum(old_at, max(len(self.ids) - 1, 0))
        known = np.zeros(len(uniq), bool)
        if len(self):
            known = (old_at < len(self.ids)) & (self.ids[old_at_c] == uniq)
        ref = pos.copy()
        since = np.full(len(uniq), np.int64(t_ns))
        if known.any():
            prev_ref = self.ref_xyz[old_at_c[known]]
            still = np.linalg.norm(pos[known] - prev_ref, axis=1) <= move_tolerance
            kept = np.flatnonzero(known)[still]
            ref[kept] = prev_ref[still]
            since[kept] = self.stable_since_ns[old_at_c[known]][still]
        gone = ~np.isin(self.ids, uniq)
        return NodeTable(uniq, pos, ref, since, self.bind_index), gone

    def _unchanged_by(self, ids: U64, xyz: F64, move_tolerance: float) -> bool:
        """Whether a snapshot of nodes ``ids``/``xyz`` leaves this table as it is: the same
        ids in the same (sorted, unique) order at the same positions, every node within
        ``move_tolerance`` of its reference (a static map's graph, resent every update:
        :meth:`updated` then skips its sort and searches, issue 15)."""
        return (
            len(ids) == len(self)
            and np.array_equal(ids, self.ids)
            and np.array_equal(xyz, self.xyz)
            and bool(np.all(np.linalg.norm(xyz - self.ref_xyz, axis=1) <= move_tolerance))
        )

    def _moved(self, xyz: F64, t_ns: int, move_tolerance: float) -> NodeTable:
        """The table after a snapshot of exactly its nodes (the same sorted ids) at positions
        ``xyz`` (a live graph's optimisation moved some): what the general path of
        :meth:`updated` gives then, without its sort and searches."""
        pos = xyz.copy()
        still = np.linalg.norm(pos - self.ref_xyz, axis=1) <= move_tolerance
        ref = np.where(still[:, None], self.ref_xyz, pos)
        since = np.where(still, self.stable_since_ns, np.int64(t_ns)).astype(np.int64)
        return NodeTable(self.ids.copy(), pos, ref, since, self.bind_index, self.entry_at)

    def _same(self, xyz: F64) -> NodeTable:
        """A copy of this table (positions ``xyz``, equal to its own), memo kept."""
        since = self.stable_since_ns.copy()
        quiet = self.quiet
        if quiet is not None and quiet.since is self.stable_since_ns:  # the same timers
            quiet = dataclasses.replace(quiet, since=since)
        return NodeTable(
            self.ids.copy(),
            xyz.copy(),
            self.ref_xyz.copy(),
            since,
            self.bind_index,
            self.entry_at,
            quiet,
        )

    def stable_mask(self, t_ns: int, stability_ns: int) -> BoolA:
        """Nodes stable for at least ``stability_ns`` at log time ``t_ns``."""
        out: BoolA = (np.int64(t_ns) - self.stable_since_ns) >= stability_ns
        return out

    def stable_span(self, stable: BoolA, stability_ns: int) -> tuple[int, int]:
        """The log times ``[start, end)`` around a time whose :meth:`stable_mask` is
        ``stable`` at which the mask is that same one: from the time the last of those nodes
        became stable to the time the next other node becomes stable (a node is stable from
        its ``stable_since_ns + stability_ns`` on)."""
        ready = self.stable_since_ns + np.int64(stability_ns)
        start = int(ready[stable].max()) if stable.any() else _TIME_MIN
        end = _TIME_MAX if stable.all() else int(ready[~stable].min())
        return start, end

    def to_arrays(self, prefix: str = "node_") -> dict[str, np.ndarray]:
        return {
            f"{prefix}ids": self.ids.copy(),
            f"{prefix}xyz": self.xyz.copy(),
            f"{prefix}ref_xyz": self.ref_xyz.copy(),
            f"{prefix}stable_since_ns": self.stable_since_ns.copy(),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "node_") -> NodeTable:
        return cls(
            np.asarray(arrays[f"{prefix}ids"], dtype=np.uint64),
            np.asarray(arrays[f"{prefix}xyz"], dtype=np.float64).reshape(-1, 3),
            np.asarray(arrays[f"{prefix}ref_xyz"], dtype=np.float64).reshape(-1, 3),
            np.asarray(arrays[f"{prefix}stable_since_ns"], dtype=np.int64),
        )


def _holds_any(table: I64, new_keys: I64) -> bool:
    """Whether the sorted ``table`` holds any of the sorted ``new_keys``: each compared with
    the key just before its place (``side="right"`` puts it after an equal one)."""
    at = np.searchsorted(table, new_keys, side="right")
    after = at > 0
    return bool(np.any(table[at[after] - 1] == new_keys[after]))


#: pending redirects :class:`Redirects` keeps apart before merging them into its sorted table
#: (at least; ``4 · √n`` for a table of n keys: an add costs the pending keys plus its share
#: of the merge, O(√n) per key instead of a copy of the whole table)
PENDING = 256


class Redirects:
    """φ: cell ``keys`` (sorted, unique) -> owning ``nodes`` (node ids).

    Adds go to a small sorted table of pending redirects, merged into the main one when it
    passes :data:`PENDING` keys (or ``4 · √n``) or when ``keys`` / ``nodes`` are read: an add
    had copied the whole table (``insert_sorted``, O(n) per bind), and :meth:`lookup` and
    :meth:`add`'s check search both tables. The keys are unique, so the merged table is the
    one adding every key into the main table gives (docs/BENCHMARKS.md, stop 66)."""

    def __init__(self, keys: I64 | None = None, nodes: U64 | None = None) -> None:
        self._keys: I64 = np.zeros(0, np.int64) if keys is None else keys
        self._nodes: U64 = np.zeros(0, np.uint64) if nodes is None else nodes
        self._pending_keys: I64 = np.zeros(0, np.int64)
        self._pending_nodes: U64 = np.zeros(0, np.uint64)

    @property
    def keys(self) -> I64:
        """The redirected keys, sorted (the pending ones merged in first)."""
        self._merge()
        return self._keys

    @keys.setter
    def keys(self, value: I64) -> None:
        self._merge()
        self._keys = value

    @property
    def nodes(self) -> U64:
        """The node each of :attr:`keys` is redirected to."""
        self._merge()
        return self._nodes

    @nodes.setter
    def nodes(self, value: U64) -> None:
        self._merge()
        self._nodes = value

    def __len__(self) -> int:
        return len(self._keys) + len(self._pending_keys)

    def _merge(self) -> None:
        """Merge the pending redirects into the main table (keys unique: no ties)."""
        if len(self._pending_keys) == 0:
            return
        at = np.searchsorted(self._keys, self._pending_keys)
        self._keys = insert_sorted(self._keys, at, self._pending_keys)
        self._nodes = insert_sorted(self._nodes, at, self._pending_nodes)
        self._pending_keys = np.zeros(0, np.int64)
        self._pending_nodes = np.zeros(0, np.uint64)

    def add(self, keys: I64, nodes: U64) -> None:
        """Record new redirects (keys must not be redirected already: ``ValueError``, the
        table left as it was).

        The new keys, sorted (stably), go where they belong in the pending table, which is
        merged into the main one once it is large (:data:`PENDING`): the main table is not
        copied at every bind (issue 15: a live graph binds cells at most of its updates,
        against tens of thousands of redirects). A repeated key is looked for only where it
        could be: among the new keys, sorted, side by side, and in each table at the key
        just before each new key's place (:func:`_holds_any`), so the check costs O(new
        keys · log table) instead of a pass over the whole table at every bind."""
        new_keys = np.asarray(keys, dtype=np.int64)
        new_nodes = np.asarray(nodes, dtype=np.uint64)
        if new_keys.size > 1 and not bool(np.all(new_keys[1:] >= new_keys[:-1])):
            order = np.argsort(new_keys, kind="stable")
            new_keys, new_nodes = new_keys[order], new_nodes[order]
        if bool(np.any(new_keys[1:] == new_keys[:-1])) or any(
            _holds_any(table, new_keys) for table in (self._keys, self._pending_keys)
        ):
            raise ValueError("a cell key was redirected twice")
        at = np.searchsorted(self._pending_keys, new_keys)
        self._pending_keys = insert_sorted(self._pending_keys, at, new_keys)
        self._pending_nodes = insert_sorted(self._pending_nodes, at, new_nodes)
        if len(self._pending_keys) > max(PENDING, 4 * math.isqrt(len(self._keys))):
            self._merge()

    def drop_nodes(self, node_ids: U64) -> None:
        """Forget every redirect to the given nodes."""
        keep = ~np.isin(self.nodes, node_ids)
        self._keys, self._nodes = self._keys[keep], self._nodes[keep]

    def lookup(self, keys: I64) -> tuple[U64, BoolA]:
        """Node ids for ``keys`` and a found mask (0 where not redirected)."""
        out = np.zeros(len(keys), np.uint64)
        found = np.zeros(len(keys), bool)
        for table, nodes in ((self._keys, self._nodes), (self._pending_keys, self._pending_nodes)):
            if len(table) == 0:
                continue
            pos = np.minimum(np.searchsorted(table, keys), len(table) - 1)
            hit = table[pos] == keys
            out[hit] = nodes[pos[hit]]
            found |= hit
        return out, found

    def to_arrays(self, prefix: str = "redirect_") -> dict[str, np.ndarray]:
        return {f"{prefix}keys": self.keys.copy(), f"{prefix}nodes": self.nodes.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "redirect_") -> Redirects:
        out = cls()
        out.add(
            np.asarray(arrays[f"{prefix}keys"], dtype=np.int64),
            np.asarray(arrays[f"{prefix}nodes"], dtype=np.uint64),
        )
        return out
