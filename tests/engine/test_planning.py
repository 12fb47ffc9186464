"""Planner: hand-checked paths, the temporal corridor choice, time dependence, errors, and
A* against scipy's Dijkstra on random graphs."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.nav_graph import NavGraph, NavGraphError
from aion_cli.engine.node_ids import node_label
from aion_cli.engine.planning import (
    NodeCosts,
    PlanResult,
    arc_costs,
    evaluate_path_cost,
    plan,
)
from aion_cli.engine.types import GraphSnapshot, Layer
from aion_cli.errors import InputError, NoPathError, UnknownNodeError

P = ord("p") << 56
CFG = ModelConfig()


def pid(i: int) -> int:
    return P | i


def graph_of(xyz: Sequence[Sequence[float]], edges: list[tuple[int, int]]) -> NavGraph:
    ids = np.array([pid(i) for i in range(len(xyz))], dtype=np.uint64)
    return NavGraph.build(ids, np.array(xyz, dtype=float), np.array(edges).reshape(-1, 2))


def rows(result: PlanResult) -> list[int]:
    return result.path.tolist()


# -- corridor pair -----------------------------------------------------------------------------
# The short branch S(0) -- A1(1) -- A2(2) -- A3(3) -- G(4) along y = 0 (length 8); the long
# branch S -- B1(5) -- B2(6) -- G with B1 = (0, 4), B2 = (8, 4) (length 4 + 8 + 4 = 16).
CORRIDOR_XYZ = [[0, 0, 0], [2, 0, 0], [4, 0, 0], [6, 0, 0], [8, 0, 0], [0, 4, 0], [8, 4, 0]]
CORRIDOR_EDGES = [(0, 1), (1, 2), (2, 3), (3, 4), (0, 5), (5, 6), (6, 4)]
SHORT = [0, 1, 2, 3, 4]
LONG = [0, 5, 6, 4]


def corridor_costs(theta: float, busy: bool = True) -> NodeCosts:
    """A concentrated (entropy 0, κ = 1) flow of 20 detections/window along the short branch's
    interior nodes, in direction ``theta``; nothing elsewhere."""
    m = len(CORRIDOR_XYZ)
    flow = np.zeros(m)
    angle = np.full(m, np.nan)
    conc = np.zeros(m)
    entropy = np.full(m, np.nan)
    if busy:
        flow[1:4] = 20.0
        angle[1:4] = theta
        conc[1:4] = 1.0
        entropy[1:4] = 0.0
    return NodeCosts(entropy, flow, angle, conc)


def test_hand_checked_shortest_path_and_totals() -> None:
    # 0 -> 3 directly is 5 m (3-4-5 triangle) but there is no such edge; via 1 costs 3 + 4 = 7,
    # the detour via 2 and 4 costs 1 + 5 + sqrt(13) = 9.61.
    g = graph_of(
        [[0, 0, 0], [3, 0, 0], [0, 1, 0], [3, 4, 0], [0, 6, 0]],
        [(0, 1), (1, 3), (0, 2), (2, 4), (4, 3)],
    )
    res = plan(g, pid(0), pid(3), depart_s=100.0, speed=2.0, node_cost=None, config=CFG)
    assert rows(res) == [0, 1, 3]
    assert res.path_ids.tolist() == [pid(0), pid(1), pid(3)]
    assert res.length_m == pytest.approx(7.0)
    assert res.cost == pytest.approx(7.0)
    assert res.duration_s == pytest.approx(3.5)
    np.testing.assert_allclose(res.arrival_s, [100.0, 101.5, 103.5])
    assert res.expanded >= 3
    # Make node 1 expensive (entropy 1, busy): c_t(1) = 0.5 + 1 = 1.5 so both edges via 1 cost
    # d * (1 + 0.75): 12.25 in total > the detour's 9.61 (cost = its length).
    costs = NodeCosts(
        np.array([np.nan, 1.0, np.nan, np.nan, np.nan]),
        np.array([0, 50.0, 0, 0, 0]),
        np.full(5, np.nan),
        np.zeros(5),
    )
    res2 = plan(g, pid(0), pid(3), 100.0, 2.0, lambda t: costs, CFG)
    assert rows(res2) == [0, 2, 4, 3]
    assert res2.cost == pytest.approx(6.0 + math.sqrt(13.0))
    assert res2.length_m == pytest.approx(6.0 + math.sqrt(13.0))
    assert evaluate_path_cost(g, [0, 1, 3], 100.0, 2.0, lambda t: costs, CFG) == pytest.approx(
        12.25
    )


def test_entropy_costs_in_proportion_to_how_busy_a_place_is() -> None:
    """A place nobody walks adds nothing however spread its (prior-dominated) directions are:
    at night in an empty building the plan is the distance-only one. Busy, its entropy costs
    in full: c_t = (w_entropy * H + w_flow) * f, so half as busy costs half."""
    from aion_cli.engine.planning import node_terms

    scale = CFG.plan_flow_scale
    costs = NodeCosts(
        np.array([1.0, 1.0, 1.0, 0.0]),
        np.array([0.0, scale, scale / 2, scale]),
        np.zeros(4),
        np.zeros(4),
    )
    c_t, _weight, _angle = node_terms(costs, 4, CFG)
    w_e, w_f = CFG.plan_w_entropy, CFG.plan_w_flow
    np.testing.assert_allclose(c_t, [0.0, w_e + w_f, (w_e + w_f) / 2, w_f])
    # nearly empty (0.01 of the scale), fully spread: the detour around it is not taken
    g = graph_of(
        [[0, 0, 0], [3, 0, 0], [0, 1, 0], [3, 4, 0], [0, 6, 0]],
        [(0, 1), (1, 3), (0, 2), (2, 4), (4, 3)],
    )
    quiet = NodeCosts(np.ones(5), np.full(5, scale / 100), np.zeros(5), np.zeros(5))
    res = plan(g, pid(0), pid(3), 0.0, 1.0, lambda t: quiet, CFG)
    assert rows(res) == [0, 1, 3]
    assert res.cost == pytest.approx(7.0 * (1.0 + (w_e + w_f) / 100))


def test_opposing_busy_flow_sends_temporal_plan_around_distance_plan_through() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    against = corridor_costs(theta=math.pi)  # people walk towards -x; we go +x
    temporal = plan(g, pid(0), pid(4), 0.0, 1.0, lambda t: against, CFG)
    distance = plan(g, pid(0), pid(4), 0.0, 1.0, None, CFG)
    assert rows(distance) == SHORT
    assert distance.cost == pytest.approx(8.0)
    assert rows(temporal) == LONG
    assert temporal.cost == pytest.approx(16.0)  # nothing on the long branch: cost = length
    # Short branch by hand: busy f = 1, c_t = w_flow = 1 at interior nodes, opposing penalty
    # w_d * 1 * 1 * 1 = 2. Edges S-A1 and A3-G: 2 * (1 + 0.5 + 1) = 5; interior edges:
    # 2 * (1 + 1 + 2) = 8. Total 5 + 8 + 8 + 5 = 26.
    short_cost = evaluate_path_cost(g, SHORT, 0.0, 1.0, lambda t: against, CFG)
    assert short_cost == pytest.approx(26.0)
    assert evaluate_path_cost(g, temporal.path, 0.0, 1.0, lambda t: against, CFG) == (
        pytest.approx(temporal.cost)
    )
    assert evaluate_path_cost(g, SHORT, 0.0, 1.0, None, CFG) == pytest.approx(8.0)


def test_aligned_flow_keeps_the_short_branch() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    along = corridor_costs(theta=0.0)
    # Aligned: no directional penalty, only c_t (w_flow * 1 at the interior nodes):
    # 2*1.5 + 2*2 + 2*2 + 2*1.5 = 14 < the 16 m long branch.
    res = plan(g, pid(0), pid(4), 0.0, 1.0, lambda t: along, CFG)
    assert rows(res) == SHORT
    assert res.cost == pytest.approx(14.0)
    assert rows(plan(g, pid(0), pid(4), 0.0, 1.0, None, CFG)) == SHORT
    # Walking the other way (G -> S) the same flow is opposing: go around.
    back = plan(g, pid(4), pid(0), 0.0, 1.0, lambda t: along, CFG)
    assert rows(back) == LONG[::-1]


def test_crossing_flow_costs_half_the_direction_weight() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    cross = corridor_costs(theta=math.pi / 2)
    cfg = CFG.replace(plan_w_flow=0.0)  # isolate the directional term
    # interior pen = 2 * (1 - cos(pi/2)) / 2 = 1 -> edges 2*(1+0.5), 2*(1+1), 2*(1+1), 2*(1+0.5)
    assert evaluate_path_cost(g, SHORT, 0.0, 1.0, lambda t: cross, cfg) == pytest.approx(14.0)


def test_busy_only_at_some_times_changes_the_path_by_arrival_time() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    quiet, busy = corridor_costs(math.pi, busy=False), corridor_costs(math.pi)
    calls: list[float] = []

    def rush_from_600(t_s: float) -> NodeCosts:
        calls.append(t_s)
        return busy if 600.0 <= t_s < 1200.0 else quiet

    def go(depart: float) -> list[int]:
        return rows(plan(g, pid(0), pid(4), depart, 1.0, rush_from_600, CFG))

    assert go(0.0) == SHORT
    assert go(900.0) == LONG
    assert go(1500.0) == SHORT
    # Departing at 590 s the corridor nodes are reached at 592..596 s (before the rush)...
    assert go(590.0) == SHORT
    # ...departing at 599 s they are reached at 601..605 s: the arrival time decides, not the
    # departure time (node costs evaluated at the departure would have said "quiet").
    calls.clear()
    assert go(599.0) == LONG
    assert set(calls) <= {599.0, 600.0}
    assert len(calls) == len(set(calls))  # one evaluation per time bucket


def test_time_bucket_is_configurable() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    busy = corridor_costs(math.pi)
    calls: list[float] = []

    def fn(t_s: float) -> NodeCosts:
        calls.append(t_s)
        return busy

    plan(g, pid(0), pid(4), 10.0, 1.0, fn, CFG, time_bucket_s=2.0)
    assert calls[0] == 10.0
    assert all(t % 2.0 == 0 for t in calls)
    assert len(calls) > 3


def test_time_buckets_are_the_maps_windows_aligned_to_the_unix_epoch() -> None:
    """A 700 s window does not divide the model epoch (2020-01-06, 1,578,268,800 s after
    1970, 500 s past a multiple of 700): the buckets must still start where the map's windows
    start, at UNIX multiples of 700 s, not at model-second multiples of 700."""
    from aion_cli.engine.windows import EPOCH_NS

    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    busy = corridor_costs(math.pi)
    calls: list[float] = []

    def fn(t_s: float) -> NodeCosts:
        calls.append(t_s)
        return busy

    epoch_s = EPOCH_NS // 10**9
    depart = 1000.0  # model seconds; the UNIX windows start at model seconds 200 + 700 k
    plan(g, pid(0), pid(4), depart, 0.01, fn, CFG.replace(window_s=700.0))
    assert calls[0] == depart
    later = sorted(set(calls[1:]))
    assert later, "a walk of 800 s crosses at least one window"
    assert later[0] == 1600.0  # the next window, not model second 1400
    assert all((epoch_s + round(t)) % 700 == 0 for t in later)


def test_bucket_tables_hold_eight_bytes_per_arc() -> None:
    """A slow walk on a large graph crosses many buckets, each with a table over every arc,
    all kept for the search: the hot loop's arc costs are a packed float64 array (a list
    held a float object and a pointer per arc: 1.6 GB instead of 0.9 GB on 10^5 places at
    0.02 m/s)."""
    from aion_cli.engine.planning import _BucketTables

    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    tables = _BucketTables(g, lambda t: corridor_costs(math.pi), CFG, 0.0, 1.0, 600.0)
    src_half, dst_half, full = tables.get(0)
    assert not isinstance(full, list)
    assert memoryview(full).itemsize == 8
    assert len(full) == len(g.arcs.length)
    np.testing.assert_array_equal(np.asarray(full), g.arcs.length * (1 + src_half + dst_half))


def test_start_equals_goal() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    res = plan(g, pid(2), pid(2), 5.0, 1.0, lambda t: corridor_costs(0.0), CFG)
    assert rows(res) == [2]
    assert res.cost == 0.0
    assert res.length_m == 0.0
    np.testing.assert_allclose(res.arrival_s, [5.0])


def test_disconnected_graph_names_components() -> None:
    g = graph_of(
        [[0, 0, 0], [1, 0, 0], [2, 0, 0], [10, 0, 0], [11, 0, 0]], [(0, 1), (1, 2), (3, 4)]
    )
    with pytest.raises(NoPathError) as err:
        plan(g, pid(0), pid(4), 0.0, 1.0, None, CFG)
    msg = str(err.value)
    assert "2 disconnected components" in msg
    assert "p0 is in a component of 3 node(s)" in msg
    assert "p4 is in a component of 2 node(s)" in msg
    # the graph has edges of its own: the hint names the goals the start reaches, and says
    # nothing of plan_connect_radius, which only joins a graph without edges (said before)
    assert err.value.hint == "pick a goal in the start's component: p1, p2"
    with pytest.raises(NoPathError) as back:  # from the two-node part: p3 alone beside it
        plan(g, pid(3), pid(0), 0.0, 1.0, None, CFG)
    assert back.value.hint == "pick a goal in the start's component: p4"


def test_no_path_in_a_graph_without_edges_names_the_radius_to_rebuild_with() -> None:
    """A scene graph without place edges is joined within plan_connect_radius (2.5 m): places
    4 m apart stay apart, and the only remedy is a map built with a larger radius."""
    snap = GraphSnapshot(
        t_ns=0,
        places=Layer(
            np.array([pid(0), pid(1)], dtype=np.uint64),
            np.array([[0, 0, 0], [4, 0, 0]], dtype=float),
            np.zeros(2, dtype=np.uint64),
        ),
        edges=np.zeros((0, 2), dtype=np.int64),
    )
    nav = NavGraph.from_snapshot(snap, CFG.plan_connect_radius)
    with pytest.raises(NoPathError) as err:
        plan(nav, pid(0), pid(1), 0.0, 1.0, None, CFG)
    hint = err.value.hint or ""
    assert "plan_connect_radius = 2.5 m" in hint
    assert "aion build --config" in hint
    wider = NavGraph.from_snapshot(snap, 4.5)  # the rebuild it advises finds the path
    assert plan(wider, pid(0), pid(1), 0.0, 1.0, None, CFG).length_m == pytest.approx(4.0)


def test_unknown_node_and_bad_speed() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    with pytest.raises(UnknownNodeError, match="p99") as err:
        plan(g, pid(0), pid(99), 0.0, 1.0, None, CFG)
    assert err.value.hint is not None
    assert "p0" in err.value.hint
    for speed in (0.0, -1.0, math.nan):
        with pytest.raises(InputError, match="speed"):
            plan(g, pid(0), pid(4), 0.0, speed, None, CFG)


def test_node_cost_of_wrong_shape_is_reported() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    with pytest.raises(Exception, match=r"shape \(7,\)"):
        plan(g, pid(0), pid(4), 0.0, 1.0, lambda t: NodeCosts.zeros(3), CFG)


def test_evaluate_path_cost_rejects_non_edges() -> None:
    g = graph_of(CORRIDOR_XYZ, CORRIDOR_EDGES)
    with pytest.raises(NavGraphError, match="not an edge"):
        evaluate_path_cost(g, [0, 2], 0.0, 1.0, None, CFG)


def test_graph_build_dedupes_and_connects_when_edgeless() -> None:
    g = graph_of([[0, 0, 0], [1, 0, 0], [0, 0, 5]], [(0, 1), (1, 0), (1, 1), (0, 1)])
    assert g.edges.tolist() == [[0, 1]]
    snap = GraphSnapshot(
        t_ns=0,
        places=Layer(
            np.array([pid(0), pid(1), pid(2), pid(3)], dtype=np.uint64),
            np.array([[0, 0, 0], [2, 0, 0], [4, 0, 0], [4, 9, 0]], dtype=float),
            np.zeros(4, dtype=np.uint64),
        ),
        edges=np.zeros((0, 2), dtype=np.int64),
    )
    nav = NavGraph.from_snapshot(snap, CFG.plan_connect_radius)  # 2.5 m
    assert nav.edges.tolist() == [[0, 1], [1, 2]]
    assert nav.index_of(pid(3)) == 3
    assert nav.nearest([4.2, 8.0, 0.0]) == 3
    assert node_label(pid(12)) == "p12"
    with pytest.raises(NavGraphError, match="outside"):
        NavGraph.build([pid(0)], [[0.0, 0.0, 0.0]], [[0, 3]])
    with pytest.raises(NavGraphError, match="finite"):
        NavGraph.build([pid(0), pid(1)], [[0.0, 0.0, 0.0], [np.nan, 0, 0]], [[0, 1]])


def test_static_costs_are_at_least_the_distance() -> None:
    rng = np.random.default_rng(3)
    xyz = rng.uniform(0, 10, size=(40, 3))
    g = NavGraph.build(np.arange(40), xyz, np.array([(i, (i * 7 + 3) % 40) for i in range(40)]))
    costs = NodeCosts(rng.random(40), rng.random(40) * 30, rng.uniform(-4, 4, 40), rng.random(40))
    c = arc_costs(g, costs, CFG)
    assert np.all(c >= g.arcs.length - 1e-12)
    upper = 1 + CFG.plan_w_entropy + CFG.plan_w_flow + CFG.plan_w_direction
    assert np.all(c <= g.arcs.length * upper + 1e-12)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(min_value=2, max_value=25),
    seed=st.integers(min_value=0, max_value=2**31 - 1),
    density=st.floats(min_value=0.05, max_value=0.5),
)
def test_astar_equals_dijkstra_on_static_costs(n: int, seed: int, density: float) -> None:
    rng = np.random.default_rng(seed)
    xyz = rng.uniform(-5, 5, size=(n, 3))
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)])
    edges = pairs[rng.random(len(pairs)) < density]
    g = NavGraph.build(np.arange(n, dtype=np.uint64) + P, xyz, edges.reshape(-1, 2))
    costs = NodeCosts(
        np.where(rng.random(n) < 0.2, np.nan, rng.random(n)),
        rng.random(n) * 20,
        np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-math.pi, math.pi, n)),
        rng.random(n),
    )
    weights = arc_costs(g, costs, CFG)
    # scipy drops explicit zeros; costs are > 0 for distinct random points.
    matrix = csr_matrix((weights, (g.arcs.src, g.arcs.dst)), shape=(n, n))
    expected = dijkstra(matrix, directed=True, indices=0)[n - 1]
    for fn in (lambda t: costs, None):
        if fn is None:
            expected = dijkstra(
                csr_matrix((g.arcs.length, (g.arcs.src, g.arcs.dst)), shape=(n, n)),
                directed=True,
                indices=0,
            )[n - 1]
        if math.isinf(expected):
            with pytest.raises(NoPathError):
                plan(g, pid(0), pid(n - 1), 0.0, 1.0, fn, CFG)
            continue
        res = plan(g, pid(0), pid(n - 1), 0.0, 1.0, fn, CFG)
        assert res.cost == pytest.approx(expected, rel=1e-9)
        assert evaluate_path_cost(g, res.path, 0.0, 1.0, fn, CFG) == pytest.approx(res.cost)
        assert res.path[0] == 0
        assert res.path[-1] == n - 1


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(min_value=2, max_value=20),
    seed=st.integers(min_value=0, max_value=2**31 - 1),
    bucket=st.floats(min_value=0.3, max_value=5.0),
)
def test_time_dependent_plan_cost_matches_its_path_evaluation(
    n: int, seed: int, bucket: float
) -> None:
    """With costs changing every ``bucket`` seconds the search mixes buckets along arcs; the
    cost it reports must be what evaluate_path_cost charges for the same path, and never
    less than the path's length."""
    rng = np.random.default_rng(seed)
    xyz = rng.uniform(-5, 5, size=(n, 3))
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)])
    edges = pairs[rng.random(len(pairs)) < 0.4]
    g = NavGraph.build(np.arange(n, dtype=np.uint64) + P, xyz, edges.reshape(-1, 2))

    def fn(t_s: float) -> NodeCosts:
        r = np.random.default_rng(round(t_s * 1000) % 2**31)
        return NodeCosts(r.random(n), r.random(n) * 20, r.uniform(-4, 4, n), r.random(n))

    try:
        res = plan(g, pid(0), pid(n - 1), 3.7, 1.3, fn, CFG, time_bucket_s=bucket)
    except NoPathError:
        return
    again = evaluate_path_cost(g, res.path, 3.7, 1.3, fn, CFG, time_bucket_s=bucket)
    assert again == pytest.approx(res.cost, rel=1e-9)
    assert res.cost >= res.length_m - 1e-9
    np.testing.assert_allclose(
        np.diff(res.arrival_s) * 1.3, np.linalg.norm(np.diff(xyz[res.path], axis=0), axis=1)
    )
