"""Temporal ownership transfer: bind after stability, move, release, redirects, conservation."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, fremen_rows
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.nodes import NodeTable, nearest_nodes
from aion_cli.engine.spatial_hash import keys_for_points
from tests.engine.engine_builders import (
    T0,
    S,
    activity_n,
    activity_sum_s,
    check_invariants,
    detections,
    graph,
    pid,
)

CFG = ModelConfig(stability_s=30.0, window_s=600.0, cell_size=0.5)


def _one_node_mapper(at: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Mapper:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 10**6 * S)
    m.add_graph(graph(T0, [0], [at]))
    return m


def _cell_rows(m: Mapper) -> np.ndarray:
    return m.state.entries.cell_rows()


def test_cell_binds_only_after_the_node_is_stable_for_tau() -> None:
    m = _one_node_mapper()
    m.add_detections(detections(T0 + S, [[0.3, 0.3, 0.0]] * 3))
    m.add_graph(graph(T0 + 10 * S, [0], [[0.05, 0, 0]]))  # within tolerance: timer keeps
    assert len(_cell_rows(m)) == 1
    m.add_graph(graph(T0 + 30 * S, [0], [[0.05, 0, 0]]))
    st_ = m.state
    assert len(_cell_rows(m)) == 0
    row = st_.node_entry_rows(pid([0]))[0]
    assert st_.entries.counts[row].sum() == 3
    key = keys_for_points(np.array([[0.3, 0.3, 0.0]]), 0.5)
    np.testing.assert_array_equal(st_.redirects.keys, key)
    np.testing.assert_array_equal(st_.redirects.nodes, pid([0]))
    # later detections in the redirected cell go straight to the node
    m.add_detections(detections(T0 + 40 * S, [[0.4, 0.2, 0.1]]))
    assert st_.entries.counts[row].sum() == 4
    assert len(_cell_rows(m)) == 0
    check_invariants(st_)


def test_binding_respects_radius_vertical_tolerance_and_nearest() -> None:
    m = Mapper(CFG)
    m.add_graph(graph(T0, [0, 1, 2], [[0, 0, 0], [2.0, 0, 0], [0, 0, 3.0]]))
    pts = [[1.2, 0.1, 0.1], [0.1, 0.1, 3.1], [5.0, 5.0, 0.0], [0.1, 0.1, 1.8]]
    m.add_detections(detections(T0 + S, pts))
    m.add_graph(graph(T0 + 31 * S, [0, 1, 2], [[0, 0, 0], [2.0, 0, 0], [0, 0, 3.0]]))
    st_ = m.state
    # (1.25,.25) -> p1 (0.75 m) not p0 (1.27 m); (.25,.25,3.25) -> p2; (5.25,5.25) unbound;
    # (.25,.25,1.75): p0 is 1.75 m below, p2 1.25 m above -> both beyond 1 m: unbound
    np.testing.assert_array_equal(np.sort(st_.redirects.nodes), pid([1, 2]))
    assert len(_cell_rows(m)) == 2
    check_invariants(st_)


def test_second_cell_adds_to_the_node_never_overwrites() -> None:
    m = _one_node_mapper()
    m.add_detections(detections(T0 + S, [[0.3, 0.3, 0.0]] * 2, heading=[0.0, 0.0]))
    m.add_graph(graph(T0 + 31 * S, [0], [[0.0, 0.0, 0.0]]))
    m.add_detections(detections(T0 + 40 * S, [[-0.4, 0.3, 0.0]] * 5, heading=np.full(5, np.pi / 2)))
    m.add_graph(graph(T0 + 50 * S, [0], [[0.0, 0.0, 0.0]]))
    st_ = m.state
    row = st_.node_entry_rows(pid([0]))[0]
    assert st_.entries.counts[row, 4] == 2  # heading 0 -> bin 4
    assert st_.entries.counts[row, 6] == 5  # heading pi/2 -> bin 6
    assert len(st_.redirects) == 2
    check_invariants(st_)


def test_node_move_keeps_state_and_restarts_its_timer() -> None:
    m = _one_node_mapper()
    m.add_detections(detections(T0 + S, [[0.3, 0.3, 0.0]] * 4))
    m.add_graph(graph(T0 + 31 * S, [0], [[0.0, 0.0, 0.0]]))
    m.add_graph(graph(T0 + 60 * S, [0], [[10.0, 0, 0]]))  # loop closure moves it
    st_ = m.state
    row = st_.node_entry_rows(pid([0]))[0]
    np.testing.assert_array_equal(st_.entries.xyz[row], [10.0, 0, 0])
    assert st_.entries.counts[row].sum() == 4
    m.add_detections(detections(T0 + 61 * S, [[10.3, 0.3, 0.0]]))
    m.add_graph(graph(T0 + 80 * S, [0], [[10.0, 0, 0]]))  # moved 20 s ago: not stable yet
    assert len(_cell_rows(m)) == 1
    m.add_graph(graph(T0 + 90 * S, [0], [[10.0, 0, 0]]))
    assert len(_cell_rows(m)) == 0
    assert st_.entries.counts[row].sum() == 5
    # the old redirect still routes to the node
    m.add_detections(detections(T0 + 95 * S, [[0.3, 0.3, 0.0]]))
    assert st_.entries.counts[row].sum() == 6
    check_invariants(st_)


def test_removed_node_releases_into_the_cell_at_its_last_position() -> None:
    m = _one_node_mapper(at=(2.1, 0.1, 0.0))
    m.add_detections(detections(T0 + S, [[2.8, 0.4, 0.0]] * 3))  # cell (5, 0): binds to p0
    m.add_graph(graph(T0 + 31 * S, [0], [[2.1, 0.1, 0.0]]))
    # p0's own cell (4, 0); no bind check happens before the release
    m.add_detections(detections(T0 + 45 * S, [[2.2, 0.2, 0.0]] * 2))
    st_ = m.state
    assert len(_cell_rows(m)) == 1
    before_n = activity_n(st_)
    m.add_graph(graph(T0 + 50 * S, [], np.zeros((0, 3))))
    assert len(st_.entries.node_rows()) == 0
    assert len(st_.redirects) == 0
    home = keys_for_points(np.array([[2.1, 0.1, 0.0]]), 0.5)[0]
    rows = _cell_rows(m)
    cell = rows[st_.entries.key[rows] == home]
    assert len(cell) == 1
    assert st_.entries.counts[cell[0]].sum() == 5  # 3 released + 2 already there
    assert activity_n(st_) == before_n
    # a detection in the formerly redirected cell now makes a new cell entry
    m.add_detections(detections(T0 + 51 * S, [[2.8, 0.4, 0.0]]))
    assert len(_cell_rows(m)) == 2
    check_invariants(st_)


def test_binding_moves_fremen_rows_and_frees_the_cell_rows() -> None:
    m = _one_node_mapper()
    m.add_detections(detections(T0 + S, [[2.3, 0.3, 0.0]] * 5))  # far from p0
    m.advance(T0 + 700 * S)  # closes the window: the cell learns one observation
    st_ = m.state
    cell = _cell_rows(m)[0]
    act = fremen_rows(np.array([cell]), st_.bins)[0]
    assert st_.fremen.n[act[0]] == 1
    np.testing.assert_allclose(st_.fremen.sum_s[act[0]], 1 - np.exp(-1.0))
    assert st_.fremen.n[act[5]] == 1  # heading 0 -> bin 4 -> row offset 5
    m.add_graph(graph(T0 + 701 * S, [0], [[2.0, 0.0, 0.0]]))  # moves: timer restarts
    m.add_graph(graph(T0 + 731 * S, [0], [[2.0, 0.0, 0.0]]))
    node = st_.node_entry_rows(pid([0]))[0]
    nrows = fremen_rows(np.array([node]), st_.bins)[0]
    assert st_.entries.kind[cell] != CELL or st_.entries.key[cell] != st_.entries.key[node]
    assert st_.fremen.n[nrows[0]] == 1
    np.testing.assert_allclose(st_.fremen.sum_s[nrows[0]], 1 - np.exp(-1.0))
    assert st_.fremen.n[nrows[5]] == 1
    check_invariants(st_)


def test_node_table_timer_rules() -> None:
    table = NodeTable()
    table, gone = table.updated(pid([1, 2]), np.zeros((2, 3)), 100, 0.25)
    assert not gone.any()
    xyz = np.array([[0.2, 0, 0], [1.0, 0, 0], [0, 0, 0]])
    table, gone = table.updated(pid([2, 1, 3]), xyz, 200, 0.25)
    np.testing.assert_array_equal(table.stable_since_ns, [200, 100, 200])  # p1 moved, p2 not
    np.testing.assert_array_equal(table.stable_mask(250, 100), [False, True, False])
    table, gone = table.updated(pid([3]), np.zeros((1, 3)), 300, 0.25)
    np.testing.assert_array_equal(gone, [True, True, False])


def test_nearest_nodes_skips_other_floors() -> None:
    nodes = np.array([[0.1, 0, 3.0], [0.5, 0, 0.0], [9, 9, 0]])
    pts = np.array([[0, 0, 0.2], [0, 0, 2.9], [4, 4, 0]])
    np.testing.assert_array_equal(nearest_nodes(pts, nodes, 1.0, 1.0), [1, 0, -1])
    assert nearest_nodes(pts, np.zeros((0, 3)), 1.0, 1.0).tolist() == [-1, -1, -1]


# -- property test: random detections, graph updates, moves and removals --------------------
POOL = np.array([[0, 0, 0], [1.5, 0, 0], [0, 1.5, 0], [1.5, 1.5, 0], [0.5, 0.5, 3.0]], float)

op = st.one_of(
    st.tuples(st.just("detect"), st.integers(1, 30), st.integers(0, 10**6)),
    # toggle one pool node's presence (or none: -1) and shift every node by an offset
    st.tuples(st.just("graph"), st.integers(-1, 4), st.sampled_from([0.0, 0.0, 0.1, 2.0])),
    st.tuples(st.just("wait"), st.integers(1, 200), st.just(0)),
)


@given(st.lists(op, min_size=3, max_size=14))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_invariants_hold_for_any_sequence(ops: list[tuple[str, int, float]]) -> None:
    cfg = ModelConfig(stability_s=10.0, window_s=60.0, cell_size=0.5, bind_radius=1.0)
    m = Mapper(cfg)
    m.set_fixed_sensor(T0, T0 + 10**5 * S)
    present = np.ones(len(POOL), bool)
    m.add_graph(graph(T0, list(range(len(POOL))), POOL))
    t = T0
    accepted = 0
    for kind, a, b in ops:
        t += 7 * S
        st_ = m.state
        nodes_before = len(st_.entries.node_rows())
        if kind == "detect":
            rng = np.random.default_rng(int(b))
            n = int(a)
            xyz = np.c_[rng.uniform(-1, 3, (n, 2)), rng.choice([0.0, 3.0], n)]
            heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
            drops = m.add_detections(detections(t, xyz, heading, rng.uniform(0, 2, n)))
            accepted += n - sum(drops.values())
        elif kind == "graph":
            if int(a) >= 0:
                present[int(a)] = ~present[int(a)]
            idx = np.flatnonzero(present)
            m.advance(t)  # close windows first: the graph update itself must conserve
            before = (activity_n(st_), activity_sum_s(st_))
            m.add_graph(graph(t, idx.tolist(), POOL[idx] + float(b)))
            np.testing.assert_allclose((activity_n(st_), activity_sum_s(st_)), before)
        else:
            t += int(a) * S
            m.advance(t)
        assert m.state.accepted == accepted
        check_invariants(m.state)
        if len(m.state.redirects):
            event("cells bound")
        if kind == "graph" and len(m.state.entries.node_rows()) < nodes_before:
            event("node state released")
