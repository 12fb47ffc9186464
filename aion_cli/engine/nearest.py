"""Which node a cell binds to: the nearest stable node in reach, found for many cells at once.

:func:`nearest_nodes` answers, per point, the node nearest horizontally among those within
``radius`` whose height differs by at most ``vertical_tolerance`` (floors stay apart), the
lowest index among equally near ones. The answer is *defined* on candidate pairs
(:func:`_closest`: every pair's distance computed the same way, then the least distance and
index), so any way of finding a superset of the nodes in reach gives the same answer to the
last bit: all pairs at once for small problems (a KD-tree costs more to build than a few
cells against a few hundred nodes cost to compare), a ball query of a KD-tree otherwise.

:class:`BindIndex` gives the same answers for the repeated bind checks of a build (two per
window, and one at every scene graph) without redoing them: it remembers which cells had no
node in reach, so only new cells are queried (issue 15: a fresh tree queried by every unbound
cell at every check was 23 % of a build), and it keeps a grid of squares
(:class:`~aion_cli.engine.square_grid.SquareGrid`) of a *reference* set of the nodes while a live
graph moves them by millimetres, whose squares around a cell hold every node in reach however
they moved (a tree per graph of 5,000 places cost more than the queries; a KD-tree kept
instead, and the ``scipy.spatial`` import it needed, more than the grid).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.engine.square_grid import SquareGrid
from aion_cli.engine.types import F64, I64, BoolA

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

_ALL_PAIRS = 1 << 16
"""Up to this many point-node pairs, every pair is compared (no tree)."""
_POINTS_PER_BLOCK = 1 << 14
"""Points asked of a KD-tree or a grid at a time (bounds the candidate pairs held at once)."""


def distances_from(xyz: npt.ArrayLike, point: npt.ArrayLike) -> F64:
    """3-D distance from ``point`` to every row of ``xyz`` (horizontal when its z is NaN: a
    point typed without a height), finite for any finite input
    (hypot, not the root of a sum of squares, which overflows to inf, with a warning, for a
    typed point such as 1e300,0 and then cannot tell the nearest row)."""
    p = np.asarray(point, dtype=np.float64).reshape(1, 3)
    d = np.asarray(xyz, dtype=np.float64).reshape(-1, 3) - p
    out: F64 = np.hypot(d[:, 0], d[:, 1])
    if not np.isnan(p[0, 2]):  # a point typed as x,y has no height: horizontal distances
        out = np.hypot(out, d[:, 2])
    return out


def nearest_nodes(points: F64, node_xyz: F64, radius: float, vertical_tolerance: float) -> I64:
    """Per point, the index of the node nearest horizontally within ``radius`` whose height
    differs by at most ``vertical_tolerance`` (the lowest index among equally near ones);
    -1 where there is none."""
    n, m = len(points), len(node_xyz)
    if n == 0 or m == 0:
        return np.full(n, -1, np.int64)
    if n * m <= _ALL_PAIRS:
        p, j = all_pairs(n, m)
        return _closest(points, node_xyz, p, j, radius, vertical_tolerance)[0]
    tree = horizontal_tree(node_xyz)
    return _by_tree(tree, points, node_xyz, _widened(radius), radius, vertical_tolerance)


def boxes_in_reach(
    points: F64, low: F64, high: F64, radius: float, vertical_tolerance: float
) -> BoolA:
    """Per point, whether some box [``low[j]``, ``high[j]``] (axis-aligned: every position a
    node had over a time) holds a position within ``radius`` horizontally and
    ``vertical_tolerance`` vertically of it, i.e. whether the node may have reached it there
    (:func:`nearest_nodes`'s reach, a box instead of a point)."""
    n, m = len(points), len(low)
    out = np.zeros(n, bool)
    if n == 0 or m == 0:
        return out
    blocks: list[tuple[int, I64, I64]] = []
    if n * m <= _ALL_PAIRS:
        blocks.append((0, *all_pairs(n, m)))
    else:
        half = float(np.max(np.hypot(high[:, 0] - low[:, 0], high[:, 1] - low[:, 1]))) / 2
        tree = horizontal_tree((low + high) / 2)
        for a in range(0, n, _POINTS_PER_BLOCK):
            blocks.append(
                (a, *_ball_pairs(tree, points[a : a + _POINTS_PER_BLOCK], _widened(radius + half)))
            )
    for a, p, j in blocks:
        xyz = points[a + p]
        gap = np.maximum(np.maximum(low[j] - xyz, xyz - high[j]), 0.0)
        ok = (np.hypot(gap[:, 0], gap[:, 1]) <= radius) & (gap[:, 2] <= vertical_tolerance)
        out[a + p[ok]] = True
    return out


def _by_tree(
    tree: cKDTree,
    points: F64,
    node_xyz: F64,
    reach: float,
    radius: float,
    vertical_tolerance: float,
) -> I64:
    """:func:`_closest` over the pairs within ``reach`` that ``tree`` finds, a block of
    points at a time (the pairs of a dense layer of places, tens per cell, stay a few MB)."""
    hit = np.empty(len(points), np.int64)
    for a in range(0, len(points), _POINTS_PER_BLOCK):
        block = points[a : a + _POINTS_PER_BLOCK]
        p, j = _ball_pairs(tree, block, reach)
        hit[a : a + len(block)] = _closest(block, node_xyz, p, j, radius, vertical_tolerance)[0]
    return hit


def horizontal_tree(xyz: F64) -> cKDTree:
    """The KD-tree of points' horizontal positions (``xyz``: ``[n, 3]``, or ``[n, 2]``
    horizontal already), built the fast way: the sliding-midpoint
    tree without compaction builds about 3x faster than scipy's default (0.4 against 1.2 ms
    for 5,000 nodes here) and queries as fast. Which tree is built changes no answer
    (:func:`_closest` decides)."""
    from scipy.spatial import cKDTree  # slow to import: only here

    return cKDTree(xyz[:, :2], balanced_tree=False, compact_nodes=False)


def _widened(reach: float) -> float:
    """``reach`` with a margin for rounding: a tree's distance of a pair may differ in its
    last bits from :func:`_closest`'s, and a pair in reach must be among the candidates."""
    return reach * (1.0 + 1e-9) + 1e-12


def all_pairs(n: int, m: int) -> tuple[I64, I64]:
    """Every (point, node) pair of ``n`` points and ``m`` nodes."""
    return np.repeat(np.arange(n, dtype=np.int64), m), np.tile(np.arange(m, dtype=np.int64), n)


def _ball_pairs(tree: cKDTree, points: F64, reach: float) -> tuple[I64, I64]:
    """The (point, node) pairs within ``reach`` horizontally of each other (``tree``: the
    nodes' :func:`horizontal_tree`)."""
    found = tree.query_ball_point(points[:, :2], reach, return_sorted=False)
    counts = np.fromiter(map(len, found), dtype=np.int64, count=len(found))
    total = int(counts.sum())
    nodes = np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64, count=total)
    return np.repeat(np.arange(len(points), dtype=np.int64), counts), nodes


def _closest(
    points: F64, node_xyz: F64, p: I64, j: I64, radius: float, vertical_tolerance: float
) -> tuple[I64, F64]:
    """Among the candidate pairs (point ``p``, node ``j``): per point the node of least
    horizontal distance (then least index) within ``radius`` and ``vertical_tolerance``, or
    -1; and every pair's horizontal distance. Every answer of this module is this one,
    whichever candidates were found, as long as they include every node in reach."""
    hit = np.full(len(points), -1, np.int64)
    d = np.hypot(points[p, 0] - node_xyz[j, 0], points[p, 1] - node_xyz[j, 1])
    ok = (d <= radius) & (np.abs(points[p, 2] - node_xyz[j, 2]) <= vertical_tolerance)
    p, j, near = p[ok], j[ok], d[ok]
    if p.size:
        order = np.lexsort((j, near, p))
        p, j = p[order], j[order]
        first = np.ones(p.size, dtype=bool)
        first[1:] = p[1:] != p[:-1]
        hit[p[first]] = j[first]
    return hit, d


def _closest_every_pair(
    points: F64, node_xyz: F64, radius: float, vertical_tolerance: float
) -> tuple[I64, F64]:
    """:func:`_closest` over every (point, node) pair (:func:`all_pairs`), and per point its
    least horizontal distance to any node: the same distances (the same subtractions and
    ``hypot`` per pair) in broadcast ``[points, nodes]`` arrays instead of gathered pairs,
    and per point the nearest node in reach by ``argmin``, whose first least index is the
    lowest index among equally near ones, as there. A bind check's few new cells against
    ~160 nodes (issue 15): about half the time. ``node_xyz`` must not be empty."""
    d = np.hypot(points[:, 0:1] - node_xyz[:, 0], points[:, 1:2] - node_xyz[:, 1])
    ok = (d <= radius) & (np.abs(points[:, 2:3] - node_xyz[:, 2]) <= vertical_tolerance)
    at = np.where(ok, d, np.inf).argmin(axis=1)
    hit: I64 = np.where(ok[np.arange(len(points)), at], at, -1).astype(np.int64)
    least: F64 = d.min(axis=1)
    return hit, least


class BindIndex:
    """:func:`nearest_nodes` for repeated bind checks: equal answers, less work.

    A build checks ownership twice per window and at every scene graph, almost always with
    nearly the same stable nodes and the same cells, nearly all of which have no node in
    reach (they never bind). This memo keeps, for one ``radius`` / ``vertical_tolerance``:

    * a *reference* set of the nodes (:attr:`_ref`, horizontal positions) and its grid,
      built when a query needs it;
    * per entry row, the key and position of the cell found there without a node in reach,
      the node set it was found with (a version, bumped whenever the nodes change) and its
      *slack*: a lower bound of how much farther than ``radius`` the reference nodes are from
      it.

    A cell's answer depends only on its position and the stable nodes. So a cell found
    unbound with the same key and position is unbound again with the same nodes; and when a
    live graph moved the nodes — the same number of them, each at most ``D`` horizontally from
    its reference position, in order — every node is at most ``D`` nearer to a cell than its
    reference was, so a cell whose slack exceeds ``D`` is still unbound, and the nodes in reach
    of a cell are among the reference nodes within ``radius + D`` of it (the reference
    :class:`~aion_cli.engine.square_grid.SquareGrid` lists them; :func:`_closest` measures them
    where they are now). Only the other cells
    (new, moved, in reach, or with too little slack) are queried. When the nodes change
    otherwise, or ``D`` reaches half of :data:`_SLACK_REACH`, the reference becomes the
    current nodes and every cell is queried again. Answers are exactly those of
    :func:`nearest_nodes` (:func:`_closest` decides both; tested).
    """

    def __init__(self) -> None:
        self._reset()
        self.queried = 0
        """Cells queried so far (how much work the memo did not save; for tests)."""

    def _reset(self) -> None:
        """Nothing memoised: no nodes, no grid, no cell known unbound."""
        self._nodes = np.zeros((0, 3))
        self._ref = np.zeros((0, 2))  # reference node positions (horizontal) of the slacks
        self._version = 0  # bumped whenever the nodes change
        self._moved: float | None = None  # _displacement of _nodes (None: not known)
        self._params: tuple[float, float] | None = None
        self._grid: SquareGrid | None = None  # of the reference positions, once _gridded
        self._gridded = False  # (None then: too many squares, every pair is compared)
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
        return self.unbound_at(node_xyz, radius, vertical_tolerance) == cells_version

    def unbound_at(self, node_xyz: F64, radius: float, vertical_tolerance: float) -> int | None:
        """The cells version (``EntryStore.cells_version``) of the last check, when it bound
        none with these stable nodes and bind parameters: every cell it saw is unbound with
        them still, so only cells added since can bind. None otherwise."""
        if (
            self._none_at is not None
            and self._params == (float(radius), float(vertical_tolerance))
            and node_xyz.shape == self._nodes.shape
            and bool((node_xyz == self._nodes).all())  # np.array_equal without its overhead
        ):
            return self._none_at
        return None

    def __getstate__(self) -> dict[str, int]:
        """A memo travels empty (a parallel build's shard states are pickled): rebuilding it
        costs less than sending the grid and its rows."""
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
        reference (its grid and every cell forgotten) when they are not the same nodes moved
        a little."""
        if params == self._params and len(node_xyz) == len(self._ref):
            step = node_xyz[:, :2] - self._ref
            moved = float(np.sqrt(np.max(np.einsum("ij,ij->i", step, step), initial=0.0)))
            if moved < 0.5 * _SLACK_REACH:
                return moved
        self._params = params
        self._ref = np.array(node_xyz[:, :2], dtype=np.float64, copy=True)
        self._grid, self._gridded = None, False
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
        params = (float(radius), float(vertical_tolerance))
        if (
            self._moved is not None
            and params == self._params
            and np.array_equal(node_xyz, self._nodes)
        ):  # the nodes of the last call, from the same reference: its displacement
            moved = self._moved
        else:
            moved = self._displacement(node_xyz, params)
            if not np.array_equal(node_xyz, self._nodes):
                self._nodes = np.array(node_xyz, dtype=np.float64, copy=True)
                self._version += 1
                self._none_at = None
            self._moved = moved
        top = int(rows.max()) + 1
        self._grow(top)
        if 4 * n < top:  # a few rows (the cells new since a check): compared where they are
            same = (
                self._known[rows]
                & (self._key[rows] == key_of_row[rows])
                & (self._xyz[rows] == xyz_of_row[rows]).all(axis=1)
                & ((self._seen_at[rows] == self._version) | (self._slack[rows] > moved + _EPS))
            )
        else:
            same_xyz = self._xyz[:top] == xyz_of_row[:top]
            same = (
                self._known[:top]
                & (self._key[:top] == key_of_row[:top])
                & same_xyz[:, 0]
                & same_xyz[:, 1]
                & same_xyz[:, 2]
                & ((self._seen_at[:top] == self._version) | (self._slack[:top] > moved + _EPS))
            )[rows]
        hit = np.full(n, -1, np.int64)
        ask = np.flatnonzero(~same)
        self.queried += int(ask.size)
        if ask.size:
            at = rows[ask]
            points = xyz_of_row[at]
            found, slack = self._query(points, radius, vertical_tolerance, moved)
            hit[ask] = found
            unbound = found < 0
            self._known[at] = unbound
            self._key[at] = key_of_row[at]
            self._xyz[at] = points
            self._seen_at[at] = self._version
            self._slack[at] = np.where(unbound, slack, -np.inf)
        return hit

    def _query(
        self, points: F64, radius: float, vertical_tolerance: float, moved: float
    ) -> tuple[I64, F64]:
        """The answers for ``points`` and their slacks (for those left unbound): every pair
        compared when there are few, else the pairs of the reference grid, whose squares
        around a point hold every reference node within ``radius`` plus :data:`_SLACK_REACH`
        of it: every node now in reach (at most ``moved`` farther at its reference position)
        and the nearest reference node, which the slack is measured to."""
        nodes = self._nodes
        cap = radius + _SLACK_REACH
        if len(points) * len(nodes) <= _ALL_PAIRS:
            found, least = _closest_every_pair(points, nodes, radius, vertical_tolerance)
            # the nodes now: at most ``moved`` nearer to a cell than their references
            return found, np.minimum(least, cap) - radius - moved
        if not self._gridded:
            self._grid, self._gridded = SquareGrid.of(self._ref, cap), True
        grid, ref = self._grid, self._ref
        found = np.empty(len(points), np.int64)
        least = np.full(len(points), np.inf)  # the nearest reference node, if within cap
        step = _POINTS_PER_BLOCK if grid is not None else max(1, _ALL_PAIRS // len(nodes))
        for a in range(0, len(points), step):
            block = points[a : a + step]
            p, j = all_pairs(len(block), len(nodes)) if grid is None else grid.pairs(block)
            found[a : a + len(block)] = _closest(block, nodes, p, j, radius, vertical_tolerance)[0]
            d = np.hypot(block[p, 0] - ref[j, 0], block[p, 1] - ref[j, 1])
            np.minimum.at(least[a : a + len(block)], p, d)
        # the reference nodes' own distance: the slack as defined (for the cells left unbound)
        slack = np.where(found < 0, np.minimum(least, cap) - radius - _ROUNDING, -np.inf)
        return found, slack


_SLACK_REACH = 1.0
"""How far beyond ``bind_radius`` :class:`BindIndex` measures a cell's nearest node (m): the
nodes may move half of it (a live graph's optimisation moves places by millimetres) before
every cell is queried again."""
_EPS = 1e-9
"""Margin (m) on the slack comparison, for the rounding of the distances."""
_ROUNDING = 1e-9
"""Margin (m) taken off a slack measured to the reference nodes, whose distances may differ in
their last bits from the :func:`_closest` distances of the nodes that moved from them."""
