"""MapState persistence: round trip, continuing a build, merging maps of disjoint time."""

from __future__ import annotations

import json
from collections.abc import Callable

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import fremen_rows
from aion_cli.engine.errors import MapCorruptError
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.state import MapState, merge_states
from aion_cli.engine.types import Mesh, Trajectory
from tests.engine.engine_builders import T0, S, check_invariants, detections, graph, pid

CFG = ModelConfig(window_s=600.0, stability_s=30.0)
W = 600 * S
DAY = 86400 * S
NODES = [[0, 0, 0], [3, 0, 0], [0, 3, 0], [3, 3, 0], [6, 6, 0.0]]

Step = Callable[[Mapper], None]


def _log(
    start: int, seed: int, windows: int = 6, move: float = 0.0, spots: np.ndarray | None = None
) -> list[Step]:
    """One "log": a graph, a fixed sensor over its span, detections in several windows.

    With ``spots`` every detection is at one of those positions and the first window visits
    all of them (so every entry exists from the log's first window on).
    """
    rng = np.random.default_rng(seed)
    steps: list[Step] = []
    end = start + windows * W
    steps.append(lambda m: m.set_fixed_sensor(start, end))
    steps.append(lambda m: m.add_graph(graph(start, list(range(5)), np.array(NODES))))
    for w in range(windows):
        n = int(rng.integers(5, 60)) if spots is None else int(rng.integers(len(spots), 90))
        t = start + w * W + np.sort(rng.integers(0, W, n))
        if spots is None:
            xyz = np.c_[rng.uniform(-1, 8, (n, 2)), np.zeros(n)]
        else:
            pick = rng.integers(0, len(spots), n)
            if w == 0:
                pick[: len(spots)] = np.arange(len(spots))
            xyz = spots[pick]
        heading = np.where(rng.random(n) < 0.1, np.nan, rng.uniform(-np.pi, np.pi, n))
        batch = detections(t, xyz, heading, rng.uniform(0.2, 2, n))
        steps.append(lambda m, b=batch: m.add_detections(b))
        if w == windows // 2 and move:
            moved = np.array(NODES) + np.array([move, 0, 0])
            g_moved = graph(start + w * W + W // 2, [0, 1, 2, 3], moved[:4])
            steps.append(lambda m, g=g_moved: m.add_graph(g))
    return steps


def _run(steps: list[Step], m: Mapper | None = None) -> Mapper:
    m = m if m is not None else Mapper(CFG)
    for step in steps:
        step(m)
    return m


def _reload(m: Mapper) -> Mapper:
    arrays, meta = m.state.to_arrays()
    meta = json.loads(json.dumps(meta))  # meta must survive JSON
    return Mapper(CFG, MapState.from_arrays(arrays, meta))


def _assert_same(a: MapState, b: MapState, rtol: float = 1e-12) -> None:
    xa, ma = a.to_arrays()
    xb, mb = b.to_arrays()
    assert ma == mb
    assert sorted(xa) == sorted(xb)
    for name in xa:
        assert xa[name].dtype == xb[name].dtype, name
        np.testing.assert_allclose(xa[name], xb[name], rtol=rtol, atol=1e-9, err_msg=name)


def test_round_trip_is_exact_and_plain() -> None:
    m = _run(_log(T0, seed=1, move=0.6))
    m.add_trajectory(Trajectory(np.array([T0 + 10 * W]), np.array([[1.0, 2.0, 0.0]])))
    g = graph(T0 + 7 * W, [0, 1], [[0, 0, 0], [1, 1, 1.0]])
    mesh = Mesh(np.zeros((3, 3)), np.array([[0, 1, 2]], np.int32), np.ones((3, 3)))
    m.add_graph(type(g)(g.t_ns, g.places, np.array([[0, 1]]), mesh=mesh, layer_name="mesh_places"))
    arrays, meta = m.state.to_arrays()
    json.dumps(meta)
    for name, value in arrays.items():
        assert isinstance(value, np.ndarray), name
        assert value.dtype != object, name
    again = MapState.from_arrays(arrays, json.loads(json.dumps(meta)))
    arrays2, meta2 = again.to_arrays()
    assert meta2 == meta
    assert sorted(arrays2) == sorted(arrays)
    for name in arrays:
        np.testing.assert_array_equal(arrays2[name], arrays[name], err_msg=name)
    assert again.graph is not None
    assert again.graph.layer_name == "mesh_places"
    check_invariants(again)


@pytest.mark.parametrize("cut", [3, 6, 9])
def test_building_a_then_b_equals_building_both_at_once(cut: int) -> None:
    steps = _log(T0, seed=2, move=0.6) + _log(T0 + 8 * W, seed=3)
    whole = _run(steps)
    first = _run(steps[:cut])
    continued = _run(steps[cut:], _reload(first))
    _assert_same(whole.state, continued.state)
    check_invariants(continued.state)


def test_merging_disjoint_maps_equals_building_from_both() -> None:
    # Exact when both logs touch the same places from their first window on: a map built from
    # one log alone cannot know the observed-empty windows of entries only the other log made.
    spots = np.c_[np.random.default_rng(9).uniform(-1, 8, (40, 2)), np.zeros(40)]
    a_steps = _log(T0, seed=4, spots=spots)
    b_steps = _log(T0 + 2 * DAY, seed=5, spots=spots)
    both = _run(a_steps + b_steps).state
    merged = merge_states(_run(b_steps).state, _run(a_steps).state)  # order does not matter
    check_invariants(merged)
    xa, ma = both.to_arrays()
    xm, mm = merged.to_arrays()
    assert ma["accepted"] == mm["accepted"]
    assert ma["open_window"] == mm["open_window"]
    exact = ["entry_key", "entry_node_id", "entry_kind", "entry_counts", "entry_nodir",
             "entry_window_counts", "entry_speed_n", "entry_windows_observed",
             "redirect_keys", "redirect_nodes", "fremen_n"]
    for name in exact:
        np.testing.assert_array_equal(xm[name], xa[name], err_msg=name)
    for name in ["entry_speed_sum", "fremen_sum_s", "fremen_sum_se", "fremen_sum_e",
                 "fremen_t_first", "fremen_t_last"]:
        np.testing.assert_allclose(xm[name], xa[name], rtol=1e-9, atol=1e-9, err_msg=name)
    assert np.any(xa["fremen_n"] > 0)
    assert len(xa["redirect_keys"]) > 0  # ownership transfer happened in both builds
    assert np.any(xa["entry_kind"] == 0)  # and some cells stayed unbound


def test_merge_rejects_different_configs() -> None:
    a = MapState.empty(CFG)
    b = MapState.empty(CFG.replace(cell_size=0.3))
    with pytest.raises(Exception, match="different model parameters"):
        merge_states(a, b)


def test_from_arrays_rejects_corrupt_input() -> None:
    arrays, meta = _run(_log(T0, seed=6, windows=2)).state.to_arrays()
    broken = dict(arrays)
    broken["fremen_n"] = broken["fremen_n"][:-1]
    with pytest.raises(MapCorruptError):
        MapState.from_arrays(broken, meta)
    missing = {k: v for k, v in arrays.items() if k != "node_ids"}
    with pytest.raises(MapCorruptError):
        MapState.from_arrays(missing, meta)
    with pytest.raises(MapCorruptError):
        MapState.from_arrays(arrays, {k: v for k, v in meta.items() if k != "config"})
    with pytest.raises(MapCorruptError, match="newer"):
        MapState.from_arrays(arrays, {**meta, "state_version": 99})
    bad_order = dict(arrays)
    bad_order["fremen_pred_order"] = np.full_like(arrays["fremen_pred_order"], 9)
    with pytest.raises(MapCorruptError, match="predictor"):
        MapState.from_arrays(bad_order, meta)
    partial = {k: v for k, v in arrays.items() if k != "fremen_pred_coef"}
    with pytest.raises(MapCorruptError, match="predictor"):
        MapState.from_arrays(partial, meta)


def test_loaded_map_predicts_from_its_stored_predictor_like_the_built_one() -> None:
    m = _run(_log(T0, seed=7, windows=8, move=0.6) + _log(T0 + 2 * DAY, seed=8))
    arrays, meta = m.state.to_arrays()
    loaded = MapState.from_arrays(arrays, json.loads(json.dumps(meta)))
    assert loaded.fremen.predictor_cache is not None  # no ranking needed after a load
    for t in (T0 + 3 * DAY, T0 + 3 * DAY + 7 * 3600 * S):
        a, b = predict_table(m.state, t), predict_table(loaded, t)
        np.testing.assert_array_equal(a.flow, b.flow)
        np.testing.assert_array_equal(a.rate, b.rate)
    # a map written before predictors were stored loads and computes them on demand
    old = {k: v for k, v in arrays.items() if not k.startswith(("fremen_pred_", "fremen_rank_"))}
    again = MapState.from_arrays(old, meta)
    assert again.fremen.predictor_cache is None
    t = T0 + 3 * DAY
    np.testing.assert_array_equal(predict_table(again, t).flow, predict_table(m.state, t).flow)


def test_from_arrays_rejects_broken_ownership() -> None:
    arrays, meta = _run(_log(T0, seed=7, windows=2)).state.to_arrays()
    assert len(arrays["redirect_keys"]) > 0
    dangling = {**arrays, "redirect_nodes": arrays["redirect_nodes"] + np.uint64(1000)}
    with pytest.raises(MapCorruptError, match="without an entry"):
        MapState.from_arrays(dangling, meta)
    cells = np.flatnonzero(arrays["entry_kind"] == 0)
    twin_key = arrays["entry_key"].copy()
    twin_key[cells[1]] = twin_key[cells[0]]
    with pytest.raises(MapCorruptError, match="share a key"):
        MapState.from_arrays({**arrays, "entry_key": twin_key}, meta)


def test_empty_state_round_trips_and_answers_queries() -> None:
    state = MapState.empty(CFG)
    arrays, meta = state.to_arrays()
    again = MapState.from_arrays(arrays, json.loads(json.dumps(meta)))
    assert again.open_window is None
    assert len(historical_table(again)) == 0
    assert len(predict_table(again, T0)) == 0


def test_advancing_to_the_end_of_a_then_continuing_equals_one_pass() -> None:
    a_steps = _log(T0, seed=8, move=0.6)
    b_steps = _log(T0 + 9 * W, seed=9)
    whole = _run(a_steps + b_steps)
    first = _run(a_steps)
    first.advance(T0 + 6 * W + W // 3)  # what a build does at the end of a log
    assert first.state.open_window == (T0 + 6 * W) // W
    continued = _run(b_steps, _reload(first))
    _assert_same(whole.state, continued.state)
    assert len(whole.state.redirects) > 0


def test_merge_releases_nodes_the_later_graph_no_longer_has() -> None:
    cfg = CFG.replace(stability_s=0.0)

    def build(start: int, nodes: list[int]) -> MapState:
        m = Mapper(cfg)
        m.set_fixed_sensor(start, start + 2 * W)
        m.add_graph(graph(start, nodes, np.array(NODES)[nodes]))
        m.add_detections(detections(start + S, [[0.2, 0.2, 0], [3.2, 0.2, 0], [3.3, 0.1, 0]]))
        m.advance(start + W)
        return m.state

    early, late = build(T0, [0, 1]), build(T0 + DAY, [0])
    assert len(early.entries.node_rows()) == 2
    merged = merge_states(early, late)
    check_invariants(merged)
    assert merged.accepted == 6
    np.testing.assert_array_equal(merged.entries.node_id[merged.entries.node_rows()], pid([0]))
    p0 = merged.node_entry_rows(pid([0]))[0]
    assert merged.entries.counts[p0].sum() == 2
    cells = merged.entries.cell_rows()
    assert merged.entries.counts[cells].sum() == 4  # p1's 2 released + the later map's 2 there
    np.testing.assert_array_equal(np.unique(merged.entries.key[cells]).size, cells.size)
    arrays, meta = merged.to_arrays()
    other = {**meta, "config": cfg.replace(periods=[3600.0]).to_dict()}
    with pytest.raises(MapCorruptError, match="periods"):
        MapState.from_arrays(arrays, other)


@pytest.mark.parametrize("limit", [1, 3, 10_000])
def test_deferred_fremen_windows_give_the_state_of_immediate_updates(
    limit: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Closed windows wait in ``MapState.pending`` and are absorbed together; flushing after
    every window (limit 1), every few, or only when something reads the state must give the
    same map, and a reader never sees a window missing."""
    from aion_cli.engine import pending

    steps = _log(T0, seed=12, windows=9, move=0.6) + _log(T0 + DAY + 5 * W, seed=13)
    monkeypatch.setattr(pending, "MAX_PENDING_WINDOWS", 1)
    immediate = _run(steps).state
    midway = _run(steps[:8]).state
    monkeypatch.setattr(pending, "MAX_PENDING_WINDOWS", limit)
    m = Mapper(CFG)
    waited = False
    for step in steps[:8]:
        step(m)
        waited |= bool(m.state.pending)  # (reading ``pending`` does not flush)
    rows = fremen_rows(m.state.entries.live_rows(), CFG.bins).ravel()
    np.testing.assert_array_equal(m.state.fremen.n[rows], midway.fremen.n[rows])
    assert not m.state.pending  # reading the state absorbed every waiting window
    assert midway.fremen.n[rows].sum() > 0
    for step in steps[8:]:
        step(m)
        waited |= bool(m.state.pending)
    assert waited == (limit > 1)
    deferred = m.state
    _assert_same(immediate, deferred)


def test_pending_updates_refuse_a_window_given_twice_for_the_same_rows() -> None:
    from aion_cli.engine.pending import PendingUpdates, combine

    p = PendingUpdates()
    t = np.array([10.0])
    one = np.ones((3, 1))
    p.add(np.array([0, 9, 18]), t, one, one > 0)
    assert p.accepts(np.array([1, 2, 10]), t)  # other rows, same window: joins
    assert not p.accepts(np.array([5, 18]), t)  # row 18 again in window 10: flush first
    assert not p.accepts(np.array([4]), np.array([5.0]))  # an earlier window: flush first
    p.add(np.array([10, 2, 1]), t, 2 * one, one > 0)  # unsorted rows are fine
    p.add(np.array([0]), np.array([20.0, 30.0]), np.array([[3.0, 4.0]]), np.array([[True, False]]))
    rows, times, values, observed = combine(p.take())
    assert rows.tolist() == [0, 1, 2, 9, 10, 18]
    assert times.tolist() == [10.0, 20.0, 30.0]
    assert values[:, 0].tolist() == [1, 2, 2, 1, 2, 1]
    assert values[0].tolist() == [1, 3, 4]
    assert observed[0].tolist() == [True, True, False]
    assert observed[1:, 1:].sum() == 0
    assert not p
