"""Temporal ownership transfer: bind after stability, move, release, redirects, conservation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.nearest import nearest_nodes
from aion_cli.engine.nodes import NodeTable
from aion_cli.engine.query import historical_table
from aion_cli.engine.spatial_hash import keys_for_points
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.model import empty_state
from aion_cli.engine.temporal.params import TemporalParams
from tests.engine.engine_builders import (
    DAY_NS,
    T0,
    T0_DAY_END,
    S,
    check_invariants,
    closed_counts,
    detections,
    feed_detect,
    graph,
    open_counts,
    pending_counts,
    pid,
)

CFG = ModelConfig(stability_s=30.0, window_s=600.0, cell_size=0.5)
W = 600 * S


def _one_node_mapper(at: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Mapper:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 10**6 * S)
    m.add_graph(graph(T0, [0], [at]))
    return m


def _cell_rows(m: Mapper) -> np.ndarray:
    return m.state.entries.cell_rows()


def _totals(state: MapState) -> tuple[float, float, float]:
    """Detections absorbed (Σ cnt_profile), held in the pending day, and in the open window,
    over live entries."""
    rows = state.entries.live_rows()
    return (
        float(closed_counts(state, rows).sum()),
        float(pending_counts(state)[rows].sum()),
        float(open_counts(state)[rows].sum()),
    )


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
    m.add_graph(graph(T0, [0, 1, 2], np.array([[0, 0, 0], [2.0, 0, 0], [0, 0, 3.0]])))
    pts = [[1.2, 0.1, 0.1], [0.1, 0.1, 3.1], [5.0, 5.0, 0.0], [0.1, 0.1, 1.8]]
    m.add_detections(detections(T0 + S, pts))
    m.add_graph(graph(T0 + 31 * S, [0, 1, 2], np.array([[0, 0, 0], [2.0, 0, 0], [0, 0, 3.0]])))
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
    before = _totals(st_)
    m.add_graph(graph(T0 + 50 * S, [], np.zeros((0, 3))))
    assert len(st_.entries.node_rows()) == 0
    assert len(st_.redirects) == 0
    home = keys_for_points(np.array([[2.1, 0.1, 0.0]]), 0.5)[0]
    rows = _cell_rows(m)
    cell = rows[st_.entries.key[rows] == home]
    assert len(cell) == 1
    assert st_.entries.counts[cell[0]].sum() == 5  # 3 released + 2 already there
    assert _totals(st_) == before
    assert open_counts(st_)[cell[0], 4] == 5  # the open window's counts moved with it
    # a detection in the formerly redirected cell now makes a new cell entry
    m.add_detections(detections(T0 + 51 * S, [[2.8, 0.4, 0.0]]))
    assert len(_cell_rows(m)) == 2
    check_invariants(st_)


_TEMPORAL = ("cnt_fourier", "cnt_profile", "flow_score", "flow_chi2", "flow_scored",
             "dir_score", "dir_scored")


def _temporal_row(m: Mapper, row: int) -> dict[str, np.ndarray]:
    tmp = m.state.temporal
    out = {name: getattr(tmp, name)[row].copy() for name in _TEMPORAL}
    for name in ("n", "fourier", "profile", "first", "last"):
        out["obs_" + name] = getattr(tmp.obs, name)[row].copy()
    return out


def test_binding_moves_the_cells_accumulators_and_frees_its_row() -> None:
    m = _one_node_mapper()
    m.add_detections(detections(T0 + S, [[2.3, 0.3, 0.0]] * 5))  # far from p0: stays a cell
    m.add_detections(detections(T0_DAY_END + S, [[2.3, 0.3, 0.0]] * 2))  # the next day
    m.advance(T0_DAY_END + DAY_NS + S)  # both days closed: the second scored on the first
    st_ = m.state
    cell = int(_cell_rows(m)[0])
    before = _temporal_row(m, cell)
    assert before["cnt_profile"][4, 22] == 5  # heading 0 -> bin 4, 22:20 UTC on a weekday
    assert before["cnt_profile"][4, 0] == 2  # 00:00 UTC the next (week)day
    assert before["cnt_profile"].sum() == 7
    assert before["flow_scored"] > 0  # the second day was scored
    assert before["dir_scored"] == 2
    t = T0_DAY_END + DAY_NS + 2 * S
    m.add_graph(graph(t, [0], [[2.0, 0.0, 0.0]]))  # moves: timer restarts
    m.add_graph(graph(t + 31 * S, [0], [[2.0, 0.0, 0.0]]))
    assert len(_cell_rows(m)) == 0
    node = int(st_.node_entry_rows(pid([0]))[0])
    after = _temporal_row(m, node)
    for name, value in before.items():  # the node had nothing: it now has the cell's exactly
        np.testing.assert_array_equal(after[name], value, err_msg=name)
    assert cell not in st_.entries.live_rows()
    assert st_.temporal.cnt_profile[cell].sum() == 0
    assert st_.temporal.flow_scored[cell] == 0
    check_invariants(st_)


def test_binding_keeps_the_observation_block_with_more_windows() -> None:
    """Cells bound into one node were seen over the same time: the node keeps the block with
    the most windows (a sum would divide its rate by the number of cells), counts add."""
    m = Mapper(CFG)  # no source: an entry is observed in the windows with its detections
    a, b = [0.3, 0.3, 0.0], [-0.3, 0.3, 0.0]  # two cells within the bind radius of (0, 0)
    for w, (na, nb) in enumerate([(2, 1), (3, 0), (1, 4)]):
        if na:
            m.add_detections(detections(T0 + w * W + S, [a] * na))
        if nb:
            m.add_detections(detections(T0 + w * W + 2 * S, [b] * nb))
    m.advance(T0_DAY_END)  # the day is over: absorbed
    st_ = m.state
    key_a, key_b = keys_for_points(np.array([a, b]), CFG.cell_size)
    rows, _ = st_.routes.lookup(np.array([key_a, key_b]))
    row_a, row_b = int(rows[0]), int(rows[1])
    np.testing.assert_array_equal(st_.temporal.obs.n[[row_a, row_b]], [3, 2])
    obs_a = _temporal_row(m, row_a)
    counts = st_.temporal.cnt_profile[[row_a, row_b]].sum(axis=0)
    t = T0_DAY_END + 10 * S
    m.add_graph(graph(t, [0], [[0.0, 0.0, 0.0]]))
    m.add_graph(graph(t + 31 * S, [0], [[0.0, 0.0, 0.0]]))  # stable: both cells bind
    assert len(_cell_rows(m)) == 0
    node = int(st_.node_entry_rows(pid([0]))[0])
    for name in ("obs_n", "obs_fourier", "obs_profile", "obs_first", "obs_last"):
        np.testing.assert_array_equal(_temporal_row(m, node)[name], obs_a[name], err_msg=name)
    np.testing.assert_array_equal(st_.temporal.cnt_profile[node], counts)
    assert counts.sum() == 11
    table = historical_table(st_)
    k = int(np.flatnonzero(table.ids == "p0")[0])
    assert table.flow[k] == pytest.approx(11 / 3)  # 11 detections over A's 3 windows
    check_invariants(st_)


def test_the_pending_days_windows_follow_a_moved_cell() -> None:
    """Bound on the day the windows were recorded: the held counts follow the cell into its
    node, and the node is observed in the union of its cells' windows (exact)."""
    m = Mapper(CFG)
    a, b = [0.3, 0.3, 0.0], [-0.3, 0.3, 0.0]
    m.add_detections(detections(T0 + S, [a] * 2))  # window 0: A
    m.add_detections(detections(T0 + W + S, [a, b, b]))  # window 1: A and B
    m.add_detections(detections(T0 + 2 * W + S, [b] * 3))  # window 2: B
    m.add_graph(graph(T0 + 3 * W + 10 * S, [0], [[0.0, 0.0, 0.0]]))  # closes windows 0..2
    st_ = m.state
    assert len(st_.pending.windows) == 3
    cells = _cell_rows(m)
    np.testing.assert_array_equal(st_.windows_observed(cells), [2, 2])
    m.add_graph(graph(T0 + 3 * W + 41 * S, [0], [[0.0, 0.0, 0.0]]))  # binds both
    assert len(_cell_rows(m)) == 0
    node = st_.node_entry_rows(pid([0]))
    day = st_.pending.consolidated()
    np.testing.assert_array_equal(np.unique(day.cnt_entry), node)
    np.testing.assert_array_equal(np.unique(day.obs_entry), node)
    np.testing.assert_array_equal(pending_counts(st_)[node[0], 4], 8)
    np.testing.assert_array_equal(st_.windows_observed(node), [3])  # {0, 1} ∪ {1, 2}
    check_invariants(st_)
    m.advance(T0_DAY_END)
    assert not st_.pending
    tmp = st_.temporal
    np.testing.assert_array_equal(tmp.obs.n[node], [3])
    profile = np.zeros(tmp.n_bins)
    profile[22] = 3
    np.testing.assert_array_equal(tmp.obs.profile[node[0]], profile)
    np.testing.assert_array_equal(tmp.cnt_profile[node[0], 4, 22], 8)
    check_invariants(st_)


def test_add_rows_keeps_the_larger_observation_or_adds() -> None:
    params = TemporalParams.from_config(ModelConfig(periods=(86400.0,), max_order=1))
    state = empty_state(params, 4)
    state.touch(np.arange(4))
    state.obs.n[:] = [1, 3, 3, 0]
    state.obs.first[:] = [10.0, 20.0, 30.0, np.nan]
    state.obs.last[:] = [11.0, 21.0, 31.0, np.nan]
    state.cnt_profile[:, 0, 0] = [1, 2, 4, 8]
    state.flow_scored[:] = [1, 1, 1, 0]
    maxed = state.copy()
    maxed.add_rows([1, 2], [0, 0], observation="max")
    # row 0 keeps the block with the most windows; rows 1 and 2 tie: the first source wins
    assert maxed.obs.n[0] == 3
    assert (maxed.obs.first[0], maxed.obs.last[0]) == (20.0, 21.0)
    assert maxed.cnt_profile[0, 0, 0] == 7
    assert maxed.flow_scored[0] == 3
    maxed.add_rows([3], [0], observation="max")  # an unobserved source changes no observation
    assert maxed.obs.n[0] == 3
    assert maxed.cnt_profile[0, 0, 0] == 15
    added = state.copy()
    added.add_rows([1, 2], [0, 0], observation="add")
    assert added.obs.n[0] == 7
    assert (added.obs.first[0], added.obs.last[0]) == (10.0, 31.0)
    assert added.cnt_profile[0, 0, 0] == 7


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



@pytest.mark.parametrize("same_ids", [True, False])
def test_node_timers_measure_moves_from_the_reference_away_from_the_origin(
    same_ids: bool,
) -> None:
    """Nodes far from the origin: moved 0.2 m or exactly 0.25 m (within 0.25 m of their
    reference: "farther than" restarts) they keep their timer, moved 0.3 m they restart it,
    whether the snapshot has exactly the table's nodes (its fast path) or one more."""
    ref = np.array([[10.0, 5.0, 1.0], [-40.0, 12.0, 0.0], [3.0, -7.0, 2.0]])
    table, _ = NodeTable().updated(pid([1, 2, 4]), ref, 100, 0.25)
    moved = ref + np.array([[0.2, 0.0, 0.0], [0.0, -0.3, 0.0], [0.0, 0.0, 0.25]])
    ids, xyz = pid([1, 2, 4]), moved
    if not same_ids:
        ids, xyz = pid([1, 2, 4, 3]), np.vstack([moved, [[0.0, 0.0, 0.0]]])
    table, _ = table.updated(ids, xyz, 200, 0.25)
    at = np.searchsorted(table.ids, pid([1, 2, 4]))
    np.testing.assert_array_equal(table.stable_since_ns[at], [100, 200, 100])
    np.testing.assert_array_equal(table.ref_xyz[at], [ref[0], moved[1], ref[2]])

def test_nearest_nodes_skips_other_floors() -> None:
    nodes = np.array([[0.1, 0, 3.0], [0.5, 0, 0.0], [9, 9, 0]])
    pts = np.array([[0, 0, 0.2], [0, 0, 2.9], [4, 4, 0]])
    np.testing.assert_array_equal(nearest_nodes(pts, nodes, 1.0, 1.0), [1, 0, -1])
    assert nearest_nodes(pts, np.zeros((0, 3)), 1.0, 1.0).tolist() == [-1, -1, -1]


def test_nearest_nodes_bounds_are_inclusive() -> None:
    """A node exactly bind_radius away horizontally, or exactly vertical_tolerance above,
    binds ("within", "at most"); a hair beyond does not."""
    nodes = np.array([[10.0, 0.0, 1.0], [0.0, 20.0, 1.5]])
    pts = np.array([[10.0, 0.75, 1.0], [0.0, 20.0, 1.0], [10.0, 0.75 + 1e-9, 1.0],
                    [0.0, 20.0, 1.0 - 1e-9]])
    np.testing.assert_array_equal(nearest_nodes(pts, nodes, 0.75, 0.5), [0, 1, -1, -1])


# -- property test: random detections, graph updates, moves and removals --------------------
POOL = np.array([[0, 0, 0], [1.5, 0, 0], [0, 1.5, 0], [1.5, 1.5, 0], [0.5, 0.5, 3.0]], float)

op = st.one_of(
    st.tuples(st.just("detect"), st.integers(1, 30), st.integers(0, 10**6)),
    # toggle one pool node's presence (or none: -1) and shift every node by an offset
    st.tuples(st.just("graph"), st.integers(-1, 4), st.sampled_from([0.0, 0.0, 0.1, 2.0])),
    st.tuples(st.just("wait"), st.integers(1, 400), st.just(0)),
)


@given(st.lists(op, min_size=3, max_size=14))
@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_invariants_hold_for_any_sequence(ops: list[tuple[str, int, float]]) -> None:
    cfg = ModelConfig(stability_s=10.0, window_s=60.0, cell_size=0.5, bind_radius=1.0)
    m = Mapper(cfg)
    start = T0_DAY_END - 300 * S  # five minutes before midnight: many sequences close a day
    m.set_fixed_sensor(start, start + 10**5 * S)
    present = np.ones(len(POOL), bool)
    m.add_graph(graph(start, list(range(len(POOL))), POOL))
    t = start
    accepted = 0
    walked = np.zeros(2)  # Σ cos, Σ sin of the accepted detections' headings (while known)
    for kind, a, b in ops:
        t += 7 * S
        st_ = m.state
        nodes_before = len(st_.entries.node_rows())
        if kind == "detect":
            taken, turned = feed_detect(m, t, int(a), b)
            accepted += taken
            walked += turned  # NaN from a drop on: stop checking
        elif kind == "graph":
            if int(a) >= 0:
                present[int(a)] = ~present[int(a)]
            idx = np.flatnonzero(present)
            m.advance(t)  # close windows first: the graph update itself must conserve
            before = _totals(st_)
            observed = st_.temporal.glob.n[0]
            m.add_graph(graph(t, idx.tolist(), POOL[idx] + float(b)))
            assert _totals(st_) == before  # binds, moves and releases move counts exactly
            assert st_.temporal.glob.n[0] == observed
        else:
            t += int(a) * S
            m.advance(t)
        assert m.state.accepted == accepted
        check_invariants(m.state)
        if np.isfinite(walked).all():  # the heading sums move with the counts, exactly
            ent = m.state.entries
            live = ent.live_rows()
            kept = [ent.heading_cos[live].sum(), ent.heading_sin[live].sum()]
            np.testing.assert_allclose(kept, walked, rtol=0, atol=1e-9)
        if len(m.state.redirects):
            event("cells bound")
        if kind == "graph" and len(m.state.entries.node_rows()) < nodes_before:
            event("node state released")
        if m.state.temporal.glob.n[0] > 0:
            event("a day closed")
        if m.state.pending and m.state.temporal.glob.n[0] > 0:
            event("a day closed and the next one pending")


def test_a_place_the_robot_watched_empty_counts_those_windows() -> None:
    """A robot parked beside place p0 for ten windows, four people there in the ninth: p0's
    entry is observed in all ten (it has one from the first window the robot observed it
    in, once the place was stable), so its
    historical flow is 4 detections over 10 windows. Its entry once began with its first
    detection: 2 windows observed, 2.0 per window, five times too high. Under a fixed
    sensor the windows count for every entry anyway, so no empty entry is made there."""
    from aion_cli.engine.types import Trajectory

    m = Mapper(CFG)
    m.add_graph(graph(T0, [0, 1], [[0.0, 0.0, 0.0], [40.0, 0.0, 0.0]]))  # p1: out of range
    t = T0 + np.arange(0, 10 * W, 10 * S, dtype=np.int64)
    m.add_trajectory(Trajectory(t, np.tile([1.0, 0.0, 0.0], (len(t), 1))))
    m.add_detections(detections(T0 + 8 * W + S, [[0.3, 0.3, 0.0]] * 4))
    m.advance(T0 + 10 * W)
    st_ = m.state
    p0, p1 = st_.node_entry_rows(pid([0, 1])).tolist()
    assert p0 >= 0
    assert p1 == -1  # stable too, never observed (the robot is 39 m away): no entry, no NaN
    assert st_.windows_observed(np.array([p0])).tolist() == [10.0]
    table = historical_table(st_)
    at = {int(i): k for k, i in enumerate(table.node_id)}
    assert table.flow[at[int(pid([0])[0])]] == pytest.approx(0.4)
    check_invariants(st_)

    fixed = _one_node_mapper()  # a fixed sensor: the node gets an entry with its first bind
    fixed.advance(T0 + 3 * W)
    assert fixed.state.node_entry_rows(pid([0]))[0] == -1
