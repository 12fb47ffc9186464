"""Navigational-node bookkeeping for ownership transfer: the node table and the redirect table.

:class:`NodeTable` holds the nodes of the latest graph sorted by id, with the log time since
which each has been *stable* (present and within ``stable_move_tolerance`` of its reference
position) — the τ timer of DESIGN.md §4. :class:`Redirects` is φ: sorted cell keys -> node ids.
:func:`nearest_nodes` finds, for many cells at once, the nearest node by horizontal distance
that also lies within the vertical tolerance (so floors stay apart). :class:`BindIndex` gives
the same answers for the repeated bind checks of a build (two per window) without redoing
them: it keeps the KD-tree of the stable nodes while they stay the same, and remembers which
cells had no node in reach, so only new cells are queried (issue 15: a fresh tree queried by
every unbound cell at every check was 23 % of a build).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.types import F64, I64, U64, BoolA

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

_CANDIDATES = 8
"""Nearest horizontal candidates checked against the vertical tolerance per cell."""


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
        return NodeTable(self.ids.copy(), pos, ref, since, self.bind_index)

    def _same(self, xyz: F64) -> NodeTable:
        """A copy of this table (positions ``xyz``, equal to its own), memo kept."""
        return NodeTable(
            self.ids.copy(),
            xyz.copy(),
            self.ref_xyz.copy(),
            self.stable_since_ns.copy(),
            self.bind_index,
        )

    def stable_mask(self, t_ns: int, stability_ns: int) -> BoolA:
        """Nodes stable for at least ``stability_ns`` at log time ``t_ns``."""
        out: BoolA = (np.int64(t_ns) - self.stable_since_ns) >= stability_ns
        return out

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


@dataclass
class Redirects:
    """φ: cell ``keys`` (sorted, unique) -> owning ``nodes`` (node ids)."""

    keys: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    nodes: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))

    def __len__(self) -> int:
        return len(self.keys)

    def add(self, keys: I64, nodes: U64) -> None:
        """Record new redirects (keys must not be redirected already)."""
        all_keys = np.concatenate([self.keys, keys.astype(np.int64)])
        all_nodes = np.concatenate([self.nodes, nodes.astype(np.uint64)])
        order = np.argsort(all_keys, kind="stable")
        self.keys, self.nodes = all_keys[order], all_nodes[order]
        if len(self.keys) > 1 and np.any(self.keys[1:] == self.keys[:-1]):
            raise ValueError("a cell key was redirected twice")

    def drop_nodes(self, node_ids: U64) -> None:
        """Forget every redirect to the given nodes."""
        keep = ~np.isin(self.nodes, node_ids)
        self.keys, self.nodes = self.keys[keep], self.nodes[keep]

    def lookup(self, keys: I64) -> tuple[U64, BoolA]:
        """Node ids for ``keys`` and a found mask (0 where not redirected)."""
        if len(self.keys) == 0:
            return np.zeros(len(keys), np.uint64), np.zeros(len(keys), bool)
        pos = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        found = self.keys[pos] == keys
        return np.where(found, self.nodes[pos], np.uint64(0)).astype(np.uint64), found

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


def nearest_nodes(points: F64, node_xyz: F64, radius: float, vertical_tolerance: float) -> I64:
    """Per point, the index of the nearest node horizontally within ``radius`` whose height
    differs by at most ``vertical_tolerance``; -1 where there is none.

    Checks the ``_CANDIDATES`` horizontally nearest nodes per point (one vectorized cKDTree
    query), so a point with more than that many nodes of other floors closer than the nearest
    same-floor node stays unbound.
    """
    if len(points) == 0 or len(node_xyz) == 0:
        return np.full(len(points), -1, np.int64)
    return _query(horizontal_tree(node_xyz), node_xyz, points, radius, vertical_tolerance)


def horizontal_tree(xyz: F64) -> cKDTree:
    """The KD-tree of points' horizontal positions, built the fast way.

    A live graph's nodes move a little at every update, so a build makes one tree per scene
    graph: the sliding-midpoint tree without compaction builds about 3x faster than scipy's
    default (0.4 against 1.2 ms for 5,000 nodes here) and queries as fast. Which tree is
    built does not change an answer: :func:`_query` orders equally distant candidates by
    index itself."""
    from scipy.spatial import cKDTree  # slow to import: only here

    return cKDTree(xyz[:, :2], balanced_tree=False, compact_nodes=False)


def _query(
    tree: cKDTree, node_xyz: F64, points: F64, radius: float, vertical_tolerance: float
) -> I64:
    """:func:`nearest_nodes` with the nodes' horizontal KD-tree already built (each point's
    answer depends only on that point and the nodes, so any subset can be asked alone)."""
    n = len(points)
    if n == 0:
        return np.zeros(0, np.int64)
    k = min(_CANDIDATES, len(node_xyz))
    dist, idx = tree.query(points[:, :2], k=k, distance_upper_bound=radius)
    dist = dist.reshape(n, k)
    idx = idx.reshape(n, k)
    if k > 1:  # equal distances in index order, whatever the tree's traversal gave
        order = np.lexsort((idx, dist), axis=-1)
        dist = np.take_along_axis(dist, order, axis=1)
        idx = np.take_along_axis(idx, order, axis=1)
    found = np.isfinite(dist) & (dist <= radius)
    idx_c = np.where(found, idx, 0)
    dz = np.abs(node_xyz[idx_c, 2] - points[:, None, 2])
    ok = found & (dz <= vertical_tolerance)
    first = np.argmax(ok, axis=1)
    has = ok[np.arange(n), first]
    return np.where(has, idx_c[np.arange(n), first], -1).astype(np.int64)


class BindIndex:
    """:func:`nearest_nodes` for repeated bind checks: equal answers, less work.

    A build checks ownership twice per window and at every scene graph, almost always with
    nearly the same stable nodes and the same cells, nearly all of which have no node in
    reach (they never bind). This memo keeps, for one ``radius`` / ``vertical_tolerance``:

    * the KD-tree of the stable nodes of the last check (rebuilt when they change and a cell
      must be queried);
    * per entry row, the key and position of the cell found there without a node in reach,
      the node set it was found with (a version, bumped whenever the nodes change) and its
      *slack*: how much farther than ``radius`` its horizontally nearest node was, less how
      far the nodes had moved by then from a *reference* set (:attr:`_ref`).

    A cell's answer depends only on its position and the stable nodes. So a cell found
    unbound with the same key and position is unbound again with the same nodes; and when a
    live graph moved the nodes — the same number of them, each at most ``D`` horizontally from
    its reference position, in order — every cell's nearest node is at most ``D`` nearer than
    it was to the reference, so a cell whose slack exceeds ``D`` is still unbound. Only the
    other cells (new, moved, in reach, or with too little slack) are queried. When the nodes
    change otherwise, or ``D`` reaches half of :data:`_SLACK_REACH`, the reference becomes the
    current nodes and every cell is queried again. Answers are exactly those of
    :func:`nearest_nodes` (the binding query is the same; tested).
    """

    def __init__(self) -> None:
        self._reset()
        self.queried = 0
        """Cells queried so far (how much work the memo did not save; for tests)."""

    def _reset(self) -> None:
        """Nothing memoised: no nodes, no tree, no cell known unbound."""
        self._nodes = np.zeros((0, 3))
        self._ref = np.zeros((0, 2))  # reference node positions (horizontal) of the slacks
        self._version = 0  # bumped whenever the nodes change
        self._params: tuple[float, float] | None = None
        self._tree: cKDTree | None = None
        self._forget(0)
        self._none_at: int | None = None  # cells version of the last check that bound none

    def bound_none(self, cells_version: int) -> None:
        """The last check (with :attr:`_nodes`) found no cell to bind among the cells of
        ``cells_version`` (``EntryStore.cells_version``)."""
        self._none_at = cells_version

    def nothing_new(
        self, cells_version: int, node_xyz: F64, radius: float, vertical_tolerance: float
    ) -> bool:
        """Whether a check would bind nothing again: the same stable nodes, bind parameters
        and cells as a check that bound none (a build checks twice at a graph that lands on
        a window's end, and at every window end whether new cells came or not)."""
        return (
            self._none_at == cells_version
            and self._params == (float(radius), float(vertical_tolerance))
            and np.array_equal(node_xyz, self._nodes)
        )

    def __getstate__(self) -> dict[str, int]:
        """A memo travels empty (a parallel build's shard states are pickled): rebuilding it
        costs less than sending the tree and its rows, and unpickling a tree would import
        scipy.spatial in a process that may not need it."""
        return {"queried": self.queried}

    def __setstate__(self, state: dict[str, int]) -> None:
        self._reset()
        self.queried = int(state.get("queried", 0))

    def _forget(self, rows: int) -> None:
        """No cell known unbound (room for ``rows`` entry rows)."""
        self._known = np.zeros(rows, bool)  # per row: a cell found unbound there ...
        self._key = np.full(rows, -1, np.int64)  # ... with this key
        self._xyz = np.full((rows, 3), np.nan)  # ... at this position
        self._seen_at = np.full(rows, -1, np.int64)  # ... with the nodes of this version
        self._slack = np.full(rows, -np.inf)  # ... and this slack (class docstring)

    def _grow(self, top: int) -> None:
        """Room for rows below ``top`` (doubling), keeping what is known."""
        if top <= self._key.size:
            return
        old = (self._known, self._key, self._xyz, self._seen_at, self._slack)
        n = old[1].size
        self._forget(max(top, 2 * n))
        for new, kept in zip(
            (self._known, self._key, self._xyz, self._seen_at, self._slack), old, strict=True
        ):
            new[:n] = kept

    def _displacement(self, node_xyz: F64, params: tuple[float, float]) -> float:
        """How far (horizontally, at most) the nodes are from the reference set; a new
        reference (and every cell forgotten) when they are not the same nodes moved a
        little."""
        if params == self._params and len(node_xyz) == len(self._ref):
            step = node_xyz[:, :2] - self._ref
            moved = float(np.sqrt(np.max(np.einsum("ij,ij->i", step, step), initial=0.0)))
            if moved < 0.5 * _SLACK_REACH:
                return moved
        self._params = params
        self._ref = np.array(node_xyz[:, :2], dtype=np.float64, copy=True)
        self._forget(0)
        return 0.0

    def nearest(
        self,
        rows: I64,
        key_of_row: I64,
        xyz_of_row: F64,
        node_xyz: F64,
        radius: float,
        vertical_tolerance: float,
    ) -> I64:
        """Per cell at entry ``rows`` (distinct; the cell of row ``r`` has key
        ``key_of_row[r]`` and position ``xyz_of_row[r]``), the index into ``node_xyz`` of the
        node it would bind to, or -1: equal to ``nearest_nodes(xyz_of_row[rows], node_xyz,
        radius, vertical_tolerance)``. The per-row arrays are compared as wholes (no gather
        per cell), so a check costs a few passes over the rows plus the cells it queries."""
        rows = np.asarray(rows, np.int64)
        n = rows.size
        if n == 0 or len(node_xyz) == 0:
            return np.full(n, -1, np.int64)
        moved = self._displacement(node_xyz, (float(radius), float(vertical_tolerance)))
        if not np.array_equal(node_xyz, self._nodes):
            self._nodes = np.array(node_xyz, dtype=np.float64, copy=True)
            self._version += 1
            self._tree = None
            self._none_at = None
        top = int(rows.max()) + 1
        self._grow(top)
        same_xyz = self._xyz[:top] == xyz_of_row[:top]
        same = (
            self._known[:top]
            & (self._key[:top] == key_of_row[:top])
            & same_xyz[:, 0]
            & same_xyz[:, 1]
            & same_xyz[:, 2]
            & ((self._seen_at[:top] == self._version) | (self._slack[:top] > moved + _EPS))
        )
        hit = np.full(n, -1, np.int64)
        ask = np.flatnonzero(~same[rows])
        self.queried += int(ask.size)
        if ask.size:
            if self._tree is None:
                self._tree = horizontal_tree(self._nodes)
            at = rows[ask]
            points = xyz_of_row[at]
            found = _query(self._tree, self._nodes, points, radius, vertical_tolerance)
            hit[ask] = found
            unbound = found < 0
            self._known[at] = unbound
            self._key[at] = key_of_row[at]
            self._xyz[at] = points
            self._seen_at[at] = self._version
            reach = radius + _SLACK_REACH
            nearest = np.full(len(at), reach)
            if unbound.any():
                dist, _ = self._tree.query(points[unbound, :2], k=1, distance_upper_bound=reach)
                nearest[unbound] = np.minimum(dist, reach)
            self._slack[at] = np.where(unbound, nearest - radius - moved, -np.inf)
        return hit


_SLACK_REACH = 1.0
"""How far beyond ``bind_radius`` :class:`BindIndex` measures a cell's nearest node (m): the
nodes may move half of it (a live graph's optimisation moves places by millimetres) before
every cell is queried again."""
_EPS = 1e-9
"""Margin (m) on the slack comparison, for the rounding of the distances."""
