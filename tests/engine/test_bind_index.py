"""The bind-check memo (:class:`aion_cli.engine.nearest.BindIndex`, issue 15) answers exactly
as :func:`~aion_cli.engine.nearest.nearest_nodes` does for any sequence of checks — cells
added, dropped, reused and moved; node sets changed, repeated, shifted and jittered by
millimetres — while querying only the cells it must."""

from __future__ import annotations

import contextlib
from typing import Any
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from aion_cli.engine import nearest, ownership
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.nearest import BindIndex, nearest_nodes
from tests.engine.engine_builders import T0_DAY_END, S, detections, graph

# -- the bind-check memo --------------------------------------------------------------------


def _points(rng: np.random.Generator, n: int) -> np.ndarray:
    """Cell-like points on two floors around a few nodes (some in reach, most not)."""
    return np.c_[rng.uniform(-4, 4, (n, 2)), rng.choice([0.0, 0.2, 3.0], n)]


def _by_row(rows: np.ndarray, keys: np.ndarray, pts: np.ndarray, seed: int = 0
            ) -> tuple[np.ndarray, np.ndarray]:
    """Per-row key and position arrays holding the cells at ``rows`` (other rows: filler
    an entry store could hold, a node's -1 key and any position)."""
    rng = np.random.default_rng(seed)
    size = int(rows.max(initial=-1)) + 1 + int(rng.integers(0, 4))
    key = np.full(size, -1, np.int64)
    xyz = _points(rng, size)
    key[rows], xyz[rows] = keys, pts
    return key, xyz


def radius_of(s: int) -> float:
    return 1.0 if s % 5 else 2.0


step = st.tuples(
    st.sampled_from(["add", "drop", "reuse", "nodes", "same", "move", "shift", "jitter"]),
    st.integers(0, 2**31 - 1),
)


@given(
    st.integers(0, 2**31 - 1),
    st.lists(step, min_size=1, max_size=25),
    st.sampled_from([0, 40, nearest._ALL_PAIRS]),
)
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_bind_index_answers_equal_nearest_nodes(
    seed: int, steps: list[tuple[str, int]], all_pairs: int
) -> None:
    """Any sequence of checks: cells added (new rows), dropped, rows reused by other cells,
    cells moved in place, node sets changed or repeated: every answer equals a fresh
    ``nearest_nodes`` over all cells and a brute-force search, and cells seen unbound before
    are not queried again. ``all_pairs``: up to how many pairs every pair is compared (0:
    the KD-trees always, the reference grid of moved nodes too; 40: some checks each way).
    The trees and the grid are asked 7 points at a time (blocks)."""
    with (
        mock.patch.object(nearest, "_ALL_PAIRS", all_pairs),
        mock.patch.object(nearest, "_POINTS_PER_BLOCK", 7),
    ):
        _check_sequence(seed, steps)


def _check_sequence(seed: int, steps: list[tuple[str, int]]) -> None:
    rng = np.random.default_rng(seed)
    index = BindIndex()
    nodes = _points(rng, 6)
    rows = np.arange(20, dtype=np.int64)
    keys = rows * 3 + 1
    pts = _points(rng, rows.size)
    next_key = int(keys.max()) + 1
    for kind, s in steps:
        r = np.random.default_rng(s)
        if kind == "add":
            k = int(r.integers(1, 30))
            rows = np.r_[rows, rows.max(initial=-1) + 1 + np.arange(k)]
            keys = np.r_[keys, next_key + np.arange(k)]
            pts = np.r_[pts, _points(r, k)]
            next_key += k
        elif kind == "drop" and rows.size:
            keep = r.random(rows.size) < 0.7
            rows, keys, pts = rows[keep], keys[keep], pts[keep]
        elif kind == "reuse" and rows.size:  # a freed row now holds another cell
            i = int(r.integers(rows.size))
            keys[i], pts[i] = next_key, _points(r, 1)[0]
            next_key += 1
        elif kind == "move" and rows.size:  # same key and row, another position
            i = int(r.integers(rows.size))
            pts[i] = _points(r, 1)[0]
        elif kind == "nodes":
            nodes = _points(r, int(r.integers(0, 12)))
        elif kind == "shift":  # a live graph: some nodes move a little, leave or appear
            nodes = nodes[r.random(len(nodes)) < 0.8].copy()
            moved = r.random(len(nodes)) < 0.4
            nodes[moved, :2] += r.normal(0.0, 0.5, (int(moved.sum()), 2))
            nodes = np.r_[nodes, _points(r, int(r.integers(0, 3)))]
            nodes = nodes[r.permutation(len(nodes))]
        elif kind == "jitter":  # Hydra's optimisation: the same nodes moved by millimetres
            nodes = nodes.copy()
            nodes[:, :2] += r.uniform(-0.003, 0.003, (len(nodes), 2))
            if len(nodes) and rows.size and r.random() < 0.3:
                nodes[0, :2] = pts[0, :2] + [radius_of(s), 0.0]  # exactly at the bind radius
        radius, vtol = (radius_of(s), 1.0 if s % 5 else 0.5)
        order = r.permutation(rows.size)  # callers pass cells in any row order
        key_of_row, xyz_of_row = _by_row(rows, keys, pts, s)
        got = index.nearest(rows[order], key_of_row, xyz_of_row, nodes, radius, vtol)
        want = nearest_nodes(pts[order], nodes, radius, vtol)
        np.testing.assert_array_equal(got, want)
        if len(nodes) and rows.size:
            brute = _brute_force_nearest(pts[order], nodes, radius, vtol)
            np.testing.assert_array_equal(want, brute)
        if kind == "same" and len(nodes) and rows.size:
            before = index.queried
            again = index.nearest(rows[order], key_of_row, xyz_of_row, nodes, radius, vtol)
            np.testing.assert_array_equal(again, want)
            # a repeat asks only the cells that have a node in reach (they would bind)
            assert index.queried - before == int(np.count_nonzero(want >= 0))


def test_bind_index_reuses_the_tree_and_queries_only_new_cells() -> None:
    nodes = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    pts = np.array([[0.2, 0.0, 0.0], [5.0, 5.0, 0.0], [9.5, 0.0, 3.0]])
    rows, keys = np.array([4, 0, 7]), np.array([40, 41, 42])
    index = BindIndex()
    key, xyz = _by_row(rows, keys, pts)
    np.testing.assert_array_equal(index.nearest(rows, key, xyz, nodes, 1.0, 1.0), [0, -1, -1])
    assert index.queried == 3
    # same cells and nodes: only the cell that binds is asked again
    np.testing.assert_array_equal(index.nearest(rows, key, xyz, nodes, 1.0, 1.0), [0, -1, -1])
    assert index.queried == 4
    # the binding cell is gone; one new cell (row 9) near node 1
    rows2, keys2 = np.r_[rows[1:], 9], np.r_[keys[1:], 43]
    key2, xyz2 = _by_row(rows2, keys2, np.r_[pts[1:], [[10.0, 0.5, 0.0]]])
    np.testing.assert_array_equal(index.nearest(rows2, key2, xyz2, nodes, 1.0, 1.0), [-1, -1, 1])
    assert index.queried == 5
    # a node moves: every cell is asked again
    moved = nodes + np.array([[0.0, 0.0, 0.0], [-4.9, 5.0, 0.0]])
    np.testing.assert_array_equal(index.nearest(rows2, key2, xyz2, moved, 1.0, 1.0), [1, -1, -1])
    assert index.queried == 8


def test_nodes_moved_by_millimetres_ask_only_the_cells_near_reach() -> None:
    """A live graph's optimisation moves every node a little: a cell whose nearest node was
    farther than the radius by more than the nodes moved is not asked again; a cell that the
    move brings into reach is (and binds), as a fresh query says."""
    rng = np.random.default_rng(4)
    nodes = np.c_[rng.uniform(-20, 20, (50, 2)), np.zeros(50)]
    pts = np.c_[rng.uniform(-25, 25, (2000, 2)), np.zeros(2000)]
    pts[0, :2] = nodes[7, :2] + [1.0005, 0.0]  # just out of reach (radius 1 m)
    rows, keys = np.arange(2000), np.arange(2000) + 100
    key, xyz = _by_row(rows, keys, pts)
    index = BindIndex()
    first = index.nearest(rows, key, xyz, nodes, 1.0, 1.0)
    np.testing.assert_array_equal(first, nearest_nodes(pts, nodes, 1.0, 1.0))
    assert first[0] == -1
    asked = index.queried
    for step in range(5):
        nodes = nodes.copy()
        nodes[:, :2] += rng.uniform(-0.0002, 0.0002, nodes[:, :2].shape)
        if step == 3:
            nodes[7, 0] += 0.001  # now cell 0 is in reach
        got = index.nearest(rows, key, xyz, nodes, 1.0, 1.0)
        np.testing.assert_array_equal(got, nearest_nodes(pts, nodes, 1.0, 1.0))
        near = int(np.count_nonzero(first >= 0))
        assert index.queried - asked <= near + 5  # the bound cells and the ones at the edge
        asked = index.queried
    assert got[0] == 7


def test_a_bind_check_with_nothing_new_asks_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A check that bound no cell is not redone while the cells and the stable nodes stay the
    same (EntryStore.cells_version): the memo is not even consulted; a new cell is looked
    at again."""
    calls = []
    nearest = BindIndex.nearest

    def counted(self: BindIndex, *args: Any) -> np.ndarray:
        calls.append(1)
        return nearest(self, *args)

    monkeypatch.setattr(BindIndex, "nearest", counted)
    cfg = ModelConfig(stability_s=0.0, cell_size=0.5, bind_radius=1.0)
    m = Mapper(cfg)
    t0 = T0_DAY_END - 3600 * S
    m.add_graph(graph(t0, [1], [[0.0, 0.0, 0.0]]))
    m.add_detections(detections(t0 + S, [[20.0, 20.0, 0.0]]))  # far from the node
    state = m.state
    assert ownership.plan_binds(state, t0 + 2 * S) is None
    index = state.nodes.bind_index
    assert index is not None
    asked, checks = index.queried, len(calls)
    assert ownership.plan_binds(state, t0 + 3 * S) is None
    assert len(calls) == checks  # nothing changed: no look-up at all
    m.add_detections(detections(t0 + 4 * S, [[0.3, 0.1, 0.0]]))  # a new cell near the node
    plan = ownership.plan_binds(state, t0 + 5 * S)
    assert plan is not None
    assert len(plan.cells) == 1
    assert len(calls) == checks + 1
    assert index.queried == asked + 1


def test_bind_index_travels_empty_and_answers_alike() -> None:
    """A pickled memo (a parallel build's shard state) arrives empty, without its grid,
    and gives the same answers as before and as :func:`nearest_nodes`."""
    import pickle

    rng = np.random.default_rng(5)
    nodes = rng.uniform(0, 20, (40, 3))
    cells = rng.uniform(0, 20, (300, 3))
    rows = np.arange(300)
    keys = np.arange(300)
    index = BindIndex()
    before = index.nearest(rows, keys, cells, nodes, 1.5, 0.5)
    copy = pickle.loads(pickle.dumps(index))
    assert copy._grid is None
    assert not copy._known.any()
    np.testing.assert_array_equal(copy.nearest(rows, keys, cells, nodes, 1.5, 0.5), before)
    np.testing.assert_array_equal(before, nearest_nodes(cells, nodes, 1.5, 0.5))


def _brute_force_nearest(points: np.ndarray, nodes: np.ndarray, radius: float,
                         vertical: float) -> np.ndarray:
    """The nearest node within ``radius`` horizontally and ``vertical`` in height, the lowest
    index among equally near ones; -1 where none (a distance matrix, no tree)."""
    d = np.hypot(*(points[:, None, :2] - nodes[None, :, :2]).transpose(2, 0, 1))
    ok = (d <= radius) & (np.abs(points[:, None, 2] - nodes[None, :, 2]) <= vertical)
    d = np.where(ok, d, np.inf)
    best = np.argmin(d, axis=1)  # argmin takes the first (lowest index) of equal minima
    return np.where(np.isfinite(d.min(axis=1)), best, -1)


@pytest.mark.parametrize("order", ["grid", "reversed", "shuffled"])
def test_equally_near_nodes_bind_by_index_whatever_the_tree(order: str) -> None:
    """Cell centres of a 0.5 m hash halfway between the nodes of a 1 m grid are equally near
    to two or four nodes; the answer is the lowest node index, as a brute-force search over
    every node gives, in whatever order the nodes come (and so whatever tree is built), both
    from ``nearest_nodes`` and from the memo."""
    xs = np.arange(0.0, 6.0)
    nodes = np.array([(x, y, 0.0) for x in xs for y in xs])
    if order == "reversed":
        nodes = nodes[::-1].copy()
    elif order == "shuffled":
        nodes = nodes[np.random.default_rng(3).permutation(len(nodes))]
    cells = np.array([(x, y, 0.1) for x in np.arange(0.25, 5.0, 0.25)
                      for y in np.arange(0.25, 5.0, 0.25)])
    expected = _brute_force_nearest(cells, nodes, 1.0, 0.5)
    ties = np.hypot(cells[:, 0] % 1 - 0.5, cells[:, 1] % 1 - 0.5) < 1e-12
    assert ties.sum() >= 16  # four-way ties are asked
    assert (expected[ties] >= 0).all()
    np.testing.assert_array_equal(nearest_nodes(cells, nodes, 1.0, 0.5), expected)
    rows = np.arange(len(cells), dtype=np.int64)
    keys = np.arange(len(cells), dtype=np.int64)
    np.testing.assert_array_equal(
        BindIndex().nearest(rows, keys, cells, nodes, 1.0, 0.5), expected
    )


def test_a_node_moved_into_reach_is_found_through_the_reference_grid() -> None:
    """The reference grid of nodes a live graph moved by millimetres finds the nodes the move
    brought into reach: a node 2 mm out of reach at its reference position, moved 3 mm
    toward a cell, binds it (as a fresh search finds), through the grid."""
    nodes = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 5.0, 0.0]])
    cells = np.array([[1.002, 0.0, 0.0], [3.0, 3.0, 0.0]])
    rows = np.arange(2, dtype=np.int64)
    keys = np.array([7, 8], dtype=np.int64)
    with mock.patch.object(nearest, "_ALL_PAIRS", 0):  # the trees, however small
        index = BindIndex()
        np.testing.assert_array_equal(index.nearest(rows, keys, cells, nodes, 1.0, 0.5), [-1, -1])
        moved = nodes.copy()
        moved[0, 0] += 0.003  # now 0.999 m from the first cell
        got = index.nearest(rows, keys, cells, moved, 1.0, 0.5)
        assert index._grid is not None  # the reference grid, kept
        assert len(index._ref) == 3
        np.testing.assert_array_equal(index._ref[0], nodes[0, :2])
    np.testing.assert_array_equal(got, [0, -1])
    np.testing.assert_array_equal(nearest_nodes(cells, moved, 1.0, 0.5), [0, -1])


@pytest.mark.parametrize("all_pairs", [0, nearest._ALL_PAIRS])
def test_many_nodes_of_another_floor_nearer_do_not_hide_the_floors_own(all_pairs: int) -> None:
    """Twelve nodes of the floor above lie nearer to a cell than its own floor's node, which
    is still in reach: the cell binds to its floor's node (every node in reach is weighed,
    not only the few nearest horizontally)."""
    above = np.c_[np.linspace(-0.1, 0.1, 12), np.zeros(12), np.full(12, 3.0)]
    own = np.array([[0.0, 0.8, 0.0]])
    nodes = np.r_[above, own]
    cell = np.array([[0.0, 0.0, 0.1]])
    with mock.patch.object(nearest, "_ALL_PAIRS", all_pairs):
        np.testing.assert_array_equal(nearest_nodes(cell, nodes, 1.0, 0.5), [12])
        got = BindIndex().nearest(np.array([0]), np.array([5]), cell, nodes, 1.0, 0.5)
    np.testing.assert_array_equal(got, [12])


_quarter = st.integers(-24, 24).map(lambda k: k * 0.25)  # a 0.25 m lattice: many exact ties
_spot = st.tuples(_quarter, _quarter, st.sampled_from([0.0, 0.5, 3.0]))


@given(
    st.lists(_spot, min_size=1, max_size=40),
    st.lists(_spot, min_size=1, max_size=60),
    st.lists(st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)), min_size=1, max_size=3),
    st.sampled_from([0.5, 1.0, 1.75]),
    st.sampled_from([0.25, 1.0]),
    st.booleans(),
)
# a node two squares of the radius away from a cell (0.25 m beyond reach) moves 0.26 m toward
# it: the cell's slack must count that node (the grid's squares cover radius + _SLACK_REACH)
@example([(1.0, 0.0, 0.0)], [(0.25, 0.0, 0.0)], [(-0.26, 0.0)], 0.5, 1.0, False)
@settings(max_examples=200, deadline=None)
def test_the_grid_query_equals_a_brute_force_search(
    nodes: list[tuple[float, float, float]],
    cells: list[tuple[float, float, float]],
    moves: list[tuple[float, float]],
    radius: float,
    vtol: float,
    gridless: bool,
) -> None:
    """The memo's look-up through its grid of squares (or, when the nodes span too many
    squares, every pair) answers each check as a brute-force search over every node does:
    the nearest node in reach, the lowest index among equally near ones (nodes and cells on
    a 0.25 m lattice tie often) — first at the reference positions, then after the nodes
    moved by up to 0.3 m along each axis in a few steps (cells seen unbound are then answered by
    their slack, the others through the grid of the first positions)."""
    node_xyz = np.array(nodes, dtype=np.float64)
    pts = np.array(cells, dtype=np.float64)
    rows = np.arange(len(pts), dtype=np.int64)
    keys = rows + 100
    index = BindIndex()
    with (
        mock.patch.object(nearest, "_ALL_PAIRS", 0),  # never every pair by size: the grid
        mock.patch.object(nearest, "_POINTS_PER_BLOCK", 5),
        mock.patch.object(nearest.SquareGrid, "of", staticmethod(lambda *_: None))
        if gridless
        else contextlib.nullcontext(),
    ):
        for dx, dy in [(0.0, 0.0), *moves]:
            sign = 1.0 - 2.0 * (np.arange(len(node_xyz)) % 2)  # even nodes one way, odd the other
            node_xyz = node_xyz + np.array([dx, dy, 0.0]) * sign[:, None]
            got = index.nearest(rows, keys, pts, node_xyz, radius, vtol)
            np.testing.assert_array_equal(got, _brute_force_nearest(pts, node_xyz, radius, vtol))
    assert (index._grid is None) == gridless

# -- reach of boxes (a place's positions over a time) ---------------------------------------


@pytest.mark.parametrize(("n", "m"), [(300, 40), (5000, 40)])  # all pairs; the KD-tree path
def test_boxes_in_reach_is_reach_of_the_nearest_point_of_each_box(n: int, m: int) -> None:
    """A point is in reach of a box where it is in reach of the box's point nearest it (the
    point clamped into the box, horizontally and vertically apart); a box of one position
    reaches what that node reaches (nearest_nodes)."""
    rng = np.random.default_rng(n)
    pts = _points(rng, n)
    low = np.c_[rng.uniform(-4, 4, (m, 2)), rng.choice([0.0, 3.0], m)]
    high = low + rng.uniform(0, 0.6, (m, 3))
    clamped = np.clip(pts[:, None, :], low[None], high[None])
    horizontal = np.hypot(*(clamped - pts[:, None, :])[..., :2].transpose(2, 0, 1))
    vertical = np.abs(clamped[..., 2] - pts[:, None, 2])
    expected = ((horizontal <= 1.0) & (vertical <= 1.0)).any(axis=1)
    got = nearest.boxes_in_reach(pts, low, high, 1.0, 1.0)
    np.testing.assert_array_equal(got, expected)
    assert 0 < got.sum() < n
    points_only = nearest.boxes_in_reach(pts, low, low, 1.0, 1.0)
    np.testing.assert_array_equal(points_only, nearest_nodes(pts, low, 1.0, 1.0) >= 0)
