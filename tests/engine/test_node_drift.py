"""A shard's node timers joined onto the map before it: exactly the timers one pass gives, or
refused (aion_cli/engine/node_drift.py). The truth is one pass's own node table: the earlier
graphs and the shard's graphs fed to ``NodeTable.updated`` in one sequence."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.node_drift import (
    NodeDrift,
    approximate_timers,
    join_timers,
    timer_verdicts,
    timers_blocker,
)
from aion_cli.engine.nodes import NodeTable

TOL = 0.25
S = 10**9


def table_after(graphs: list[tuple[np.ndarray, np.ndarray, int]], start: NodeTable | None = None):
    """The node table after ``graphs`` (ids, xyz, t_ns), from ``start`` or empty."""
    table = start if start is not None else NodeTable()
    for ids, xyz, t in graphs:
        table, _ = table.updated(ids, xyz, t, TOL)
    return table


def shard_of(graphs: list[tuple[np.ndarray, np.ndarray, int]]) -> tuple[NodeTable, NodeDrift]:
    """The shard's own table and drift, as apply_graph keeps them."""
    ids, xyz, t = graphs[0]
    table, _ = NodeTable().updated(ids, xyz, t, TOL)
    drift = NodeDrift.start(table, t)
    for ids, xyz, t in graphs[1:]:
        table, _ = table.updated(ids, xyz, t, TOL)
        drift.observe(table, t)
    return table, drift


def ids_of(*values: int) -> np.ndarray:
    return np.array(values, np.uint64)


def test_drift_keeps_the_box_until_the_first_restart() -> None:
    t0 = 100 * S
    first = table_after([(ids_of(1, 2, 3), np.zeros((3, 3)), t0)])
    drift = NodeDrift.start(first, t0)
    moved = np.array([[0.1, 0, 0], [0.3, 0, 0], [0, 0, 0]])
    second = table_after([(ids_of(1, 2), moved[:2], t0 + S)], first)
    drift.observe(second, t0 + S)
    np.testing.assert_array_equal(drift.restart_ns, [-1, t0 + S, t0 + S])
    np.testing.assert_array_equal(drift.restart_xyz[1], [0.3, 0, 0])  # moved: its new reference
    assert np.isnan(drift.restart_xyz[2]).all()  # left the graph
    np.testing.assert_array_equal(drift.high[0], [0.1, 0, 0])
    third = table_after([(ids_of(1, 2), np.array([[-0.2, 0, 0], [9, 9, 9]]), t0 + 2 * S)], second)
    drift.observe(third, t0 + 2 * S)
    np.testing.assert_array_equal(drift.low[0], [-0.2, 0, 0])
    np.testing.assert_array_equal(drift.high[0], [0.1, 0, 0])
    np.testing.assert_array_equal(drift.restart_xyz[1], [0.3, 0, 0])  # the first restart stays
    np.testing.assert_array_equal(drift.high[1], [0.0, 0, 0])  # nothing after it widens the box


def test_a_node_that_drifts_out_of_the_earlier_reference_is_refused() -> None:
    """The shard never restarts the node (each step 0.2 m from its first position at most),
    one pass does (0.4 m from the earlier reference): the old approximation kept the earlier
    timer silently; the exact join refuses."""
    t0 = 1000 * S
    earlier = table_after([(ids_of(7), np.zeros((1, 3)), 0)])
    graphs = [
        (ids_of(7), np.array([[0.2, 0, 0]]), t0),
        (ids_of(7), np.array([[0.4, 0, 0]]), t0 + S),
    ]
    one_pass = table_after(graphs, table_after([(ids_of(7), np.zeros((1, 3)), 0)]))
    assert one_pass.stable_since_ns[0] == t0 + S  # one pass restarted at the second graph
    later, drift = shard_of(graphs)
    assert later.stable_since_ns[0] == t0  # the shard did not
    reason = timers_blocker(later, earlier, drift, TOL)
    assert reason is not None
    assert "1 place(s)" in reason
    approx = table_after(graphs)  # the shard's table, joined the old way
    kept = approximate_timers(approx, earlier, TOL)
    assert kept[0]  # the approximation took the earlier timer: not one pass's
    assert approx.stable_since_ns[0] != one_pass.stable_since_ns[0]


coordinate = st.floats(-0.6, 0.6, allow_nan=False).map(lambda v: round(v, 2))
step = st.lists(
    st.one_of(st.none(), st.tuples(coordinate, coordinate)), min_size=3, max_size=3
)  # per graph and node: absent, or an (x, y) position


@settings(max_examples=300, deadline=None)
@given(earlier=st.lists(step, min_size=1, max_size=4), shard=st.lists(step, min_size=1, max_size=6))
def test_joined_timers_are_one_pass_or_refused(
    earlier: list[list[tuple[float, float] | None]], shard: list[list[tuple[float, float] | None]]
) -> None:
    """Three nodes moving about, appearing and leaving, in an earlier map's graphs and then a
    shard's: whenever the join is not refused, every node's timer and reference equal one
    pass's; counted, the refusals are the cases the approximation got wrong or that only
    each node's whole history could decide."""

    def graphs(steps: list[list[tuple[float, float] | None]], t_start: int):
        out = []
        for k, nodes in enumerate(steps):
            ids = [i for i, p in enumerate(nodes) if p is not None]
            xyz = np.array([[*nodes[i], 0.0] for i in ids]).reshape(-1, 3)
            out.append((np.array(ids, np.uint64), xyz, t_start + k * S))
        return out

    early = graphs(earlier, 0)
    late = graphs(shard, 100 * S)
    if len(late[0][0]) == 0:
        return  # a shard whose first graph is empty has no drift to judge
    one_pass = table_after(early + late)
    before = table_after(early)
    later, drift = shard_of(late)
    verdicts = timer_verdicts(later, before, drift, TOL)
    blocked = timers_blocker(later, before, drift, TOL)
    assert (blocked is None) == (not verdicts.unknown.any())
    if blocked is not None:
        return
    join_timers(later, before, drift, TOL)
    np.testing.assert_array_equal(later.ids, one_pass.ids)
    np.testing.assert_array_equal(later.stable_since_ns, one_pass.stable_since_ns)
    np.testing.assert_array_equal(later.ref_xyz, one_pass.ref_xyz)


def test_a_round_trip_keeps_the_drift() -> None:
    t0 = 5 * S
    _, drift = shard_of(
        [
            (ids_of(1, 4), np.array([[0, 0, 0], [1, 1, 1.0]]), t0),
            (ids_of(4), np.array([[1.1, 1, 1.0]]), t0 + S),
        ]
    )
    arrays, meta = drift.to_arrays("x_")
    back = NodeDrift.from_arrays(arrays, meta, "x_")
    assert back.t0_ns == t0
    for name in ("ids", "first_xyz", "low", "high", "restart_ns", "restart_xyz"):
        np.testing.assert_array_equal(getattr(back, name), getattr(drift, name))
