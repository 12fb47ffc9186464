"""MapState persistence: round trip, continuing a build, loading, the query view (merges:
``test_state_merge``)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.compare import plain
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.types import Mesh, Trajectory
from aion_cli.errors import MapCorruptError, MapFileError, MapVersionError
from tests.engine.engine_builders import (
    T0,
    T0_DAY_END,
    S,
    check_invariants,
    detections,
    graph,
    pending_counts,
)
from tests.engine.state_logs import (
    CFG,
    DAY,
    HOUR,
    Step,
    W,
    assert_same_state,
    fixed_sensor_log,
    run_steps,
)


def _reload(m: Mapper) -> Mapper:
    arrays, meta = m.state.to_arrays()
    meta = json.loads(json.dumps(meta))  # meta must survive JSON
    return Mapper(CFG, MapState.from_arrays(arrays, meta))


def _plain(arrays: dict[str, Any]) -> dict[str, np.ndarray]:
    """Every member as a numpy array (temporal members are streamed row blocks)."""
    return plain(arrays)


def test_round_trip_is_exact_and_plain() -> None:
    # two days: the first absorbed, the second pending (the last day of a build waits)
    m = run_steps(fixed_sensor_log(T0, seed=1, move=0.6) + fixed_sensor_log(T0 + 8 * W, seed=11))
    assert m.state.pending
    assert m.state.temporal.glob.n[0] > 0
    m.add_trajectory(Trajectory(np.array([T0 + 20 * W]), np.array([[1.0, 2.0, 0.0]])))
    g = graph(T0 + 15 * W, [0, 1], np.array([[0, 0, 0], [1, 1, 1.0]]))
    mesh = Mesh(np.zeros((3, 3)), np.array([[0, 1, 2]], np.int32), np.ones((3, 3)))
    m.add_graph(type(g)(g.t_ns, g.places, np.array([[0, 1]]), mesh=mesh, layer_name="mesh_places"))
    arrays, meta = m.state.to_arrays()
    json.dumps(meta)
    for name, value in _plain(arrays).items():
        assert value.dtype != object, name
    again = MapState.from_arrays(arrays, json.loads(json.dumps(meta)))
    arrays2, meta2 = again.to_arrays()
    assert meta2 == meta
    assert meta["pending_day"] == m.state.pending.day
    assert sorted(arrays2) == sorted(arrays)
    assert again.pending.windows == m.state.pending.windows
    order, order2 = m.state.entries.canonical_order(), again.entries.canonical_order()
    np.testing.assert_array_equal(
        again.windows_observed(order2), m.state.windows_observed(order)
    )
    np.testing.assert_array_equal(pending_counts(again)[order2], pending_counts(m.state)[order])
    assert again.graph is not None
    assert again.graph.layer_name == "mesh_places"
    check_invariants(again)
    # equal maps give equal arrays whatever their in-memory row layout (state.py)
    plain, plain2 = _plain(arrays), _plain(arrays2)
    assert plain["pending_cnt_values"].sum() > 0
    for name in plain:
        np.testing.assert_array_equal(plain2[name], plain[name], err_msg=name)


@pytest.mark.parametrize("cut", [3, 6, 9])
def test_building_a_then_b_equals_building_both_at_once(cut: int) -> None:
    steps = fixed_sensor_log(T0, seed=2, move=0.6) + fixed_sensor_log(T0 + 8 * W, seed=3)
    whole = run_steps(steps)
    first = run_steps(steps[:cut])
    continued = run_steps(steps[cut:], _reload(first))
    assert_same_state(whole.state, continued.state)
    check_invariants(continued.state)


def _three_days() -> list[Step]:
    """A log on T0's day, one in the morning of the next day (its nodes move halfway) and one
    on the day after: the middle day is closed, scored against the first, when the third
    one starts."""
    return (
        fixed_sensor_log(T0, seed=21)
        + fixed_sensor_log(T0_DAY_END + 8 * HOUR, seed=22, windows=12, move=0.6)
        + fixed_sensor_log(T0_DAY_END + DAY + 8 * HOUR, seed=23, windows=4)
    )


@pytest.mark.parametrize("cut", [15, 23])  # in the middle of the second day; at its end
def test_a_map_saved_mid_day_and_continued_closes_the_day_exactly_as_a_single_pass(
    cut: int,
) -> None:
    steps = _three_days()
    whole = run_steps(steps)
    first = run_steps(steps[:cut])
    assert first.state.pending.day == (T0_DAY_END + 8 * HOUR) // DAY  # saved mid-day
    assert first.state.temporal.flow_scored.sum() == 0  # nothing scored yet
    continued = run_steps(steps[cut:], _reload(first))
    tmp = whole.state.temporal
    assert tmp.flow_scored.sum() > 0  # the second day was scored
    assert tmp.dir_scored.sum() > 0
    assert whole.state.pending.day == (T0_DAY_END + DAY + 8 * HOUR) // DAY
    assert_same_state(whole.state, continued.state)
    check_invariants(continued.state)


def test_from_arrays_rejects_corrupt_input() -> None:
    closed = run_steps(fixed_sensor_log(T0, seed=6, windows=2)).state
    closed.close_day()  # the counts move from the pending day into the (sparse) accumulators
    counted, closed_meta = closed.to_arrays()
    counted = _plain(counted)
    assert len(counted["temporal_cnt_index"]) > 1
    broken = {**counted, "temporal_cnt_profile": counted["temporal_cnt_profile"][:-1]}
    with pytest.raises(MapCorruptError, match="temporal_cnt_profile"):
        MapState.from_arrays(broken, closed_meta)
    unordered = {**counted, "temporal_cnt_index": counted["temporal_cnt_index"][::-1].copy()}
    with pytest.raises(MapCorruptError, match="out of order or range"):
        MapState.from_arrays(unordered, closed_meta)
    real = {**counted, "temporal_cnt_fourier": counted["temporal_cnt_fourier"].real.copy()}
    with pytest.raises(MapCorruptError, match="complex"):
        MapState.from_arrays(real, closed_meta)
    negative = {
        **counted, "temporal_cnt_profile": -counted["temporal_cnt_profile"].astype(np.float64)
    }
    with pytest.raises(MapCorruptError, match="negative"):
        MapState.from_arrays(negative, closed_meta)
    arrays, meta = run_steps(fixed_sensor_log(T0, seed=6, windows=2)).state.to_arrays()
    arrays = _plain(arrays)
    missing = {k: v for k, v in arrays.items() if k != "node_ids"}
    with pytest.raises(MapCorruptError):
        MapState.from_arrays(missing, meta)
    no_counts = {k: v for k, v in arrays.items() if k != "temporal_cnt_profile"}
    with pytest.raises(MapCorruptError, match="missing: temporal_cnt_profile"):
        MapState.from_arrays(no_counts, meta)
    no_pending = {k: v for k, v in arrays.items() if k != "pending_cnt_values"}
    with pytest.raises(MapCorruptError, match="pending day incomplete"):
        MapState.from_arrays(no_pending, meta)
    assert len(arrays["pending_cnt_entry"]) > 0
    far = {**arrays, "pending_cnt_entry": arrays["pending_cnt_entry"] + len(arrays["entry_kind"])}
    with pytest.raises(MapCorruptError, match="pending day"):
        MapState.from_arrays(far, meta)
    with pytest.raises(MapCorruptError, match="pending day"):
        MapState.from_arrays(arrays, {**meta, "pending_day": None})
    with pytest.raises(MapCorruptError):
        MapState.from_arrays(arrays, {k: v for k, v in meta.items() if k != "config"})
    with pytest.raises(MapVersionError, match="newer aion") as new:  # not "corrupt": upgrade
        MapState.from_arrays(arrays, {**meta, "state_version": 99})
    assert "pip install -U aion" in str(new.value.hint)
    with pytest.raises(MapFileError, match="older") as old:
        MapState.from_arrays(arrays, {**meta, "state_version": 1})
    assert "aion build" in str(old.value.hint)


@pytest.mark.parametrize("writable", [True, False])
def test_loaded_map_predicts_like_the_built_one(writable: bool) -> None:
    m = run_steps(_three_days())
    arrays, meta = m.state.to_arrays()
    loaded = MapState.from_arrays(arrays, json.loads(json.dumps(meta)), writable=writable)
    assert loaded.pending  # the last day waits in the map ...
    for t in (T0 + 3 * DAY, T0 + 3 * DAY + 7 * HOUR):
        a, b = predict_table(m.state, t), predict_table(loaded, t)
        np.testing.assert_allclose(b.flow, a.flow, rtol=1e-12, atol=0)
        np.testing.assert_allclose(b.rate, a.rate, rtol=1e-12, atol=0)
        np.testing.assert_allclose(b.flow_var, a.flow_var, rtol=1e-12, atol=0)
        np.testing.assert_array_equal(b.flow_family, a.flow_family)
        np.testing.assert_array_equal(b.direction_family, a.direction_family)
    h_a, h_b = historical_table(m.state), historical_table(loaded)
    np.testing.assert_allclose(h_b.flow, h_a.flow, rtol=1e-12, atol=0)
    np.testing.assert_allclose(h_b.rate, h_a.rate, rtol=1e-12, atol=0)
    # ... and a query absorbs it, scored provisionally (engine.temporal.provisional): in place
    # for a read-only map, in a copy otherwise; the built map's own scores stay as they were
    assert bool(loaded.pending) == writable
    assert m.state.pending
    provisional = m.state.provisional_scores()
    assert provisional is not None
    assert provisional.rows.size > 0
    expected = m.state.temporal if writable else m.state.scored_temporal()
    np.testing.assert_array_equal(
        np.sort(loaded.temporal.flow_scored[loaded.entries.live_rows()]),
        np.sort(expected.flow_scored[m.state.entries.live_rows()]),
    )
    before = m.state.temporal.flow_scored[provisional.rows]
    assert (m.state.scored_temporal().flow_scored[provisional.rows] > before).all()


def test_from_arrays_rejects_broken_ownership() -> None:
    arrays, meta = run_steps(fixed_sensor_log(T0, seed=7, windows=2)).state.to_arrays()
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
    assert not again.pending
    assert len(historical_table(again)) == 0
    assert len(predict_table(again, T0)) == 0


def test_advancing_to_the_end_of_a_then_continuing_equals_one_pass() -> None:
    a_steps = fixed_sensor_log(T0, seed=8, move=0.6)
    b_steps = fixed_sensor_log(T0 + 9 * W, seed=9)
    whole = run_steps(a_steps + b_steps)
    first = run_steps(a_steps)
    first.advance(T0 + 6 * W + W // 3)  # what a build does at the end of a log
    assert first.state.open_window == (T0 + 6 * W) // W
    continued = run_steps(b_steps, _reload(first))
    assert_same_state(whole.state, continued.state)
    assert len(whole.state.redirects) > 0


def test_queries_do_not_change_what_a_build_learns() -> None:
    """A query absorbs the pending day and the open window into a view (unscored); the map
    goes on as if nobody had asked."""
    steps = _three_days()
    quiet = run_steps(steps).state
    m = Mapper(CFG)
    seen = 0
    for k, step in enumerate(steps):
        step(m)
        if k % 5 == 2:
            historical_table(m.state)
            predict_table(m.state, T0 + 3 * DAY)
            seen += bool(m.state.pending)
    assert seen > 0  # some queries saw a pending day
    assert_same_state(quiet, m.state)


def test_the_query_view_equals_the_map_with_its_day_closed() -> None:
    m = run_steps(fixed_sensor_log(T0, seed=31) + fixed_sensor_log(T0 + 8 * W, seed=32))
    m.advance(T0 + 14 * W)  # the open window closes too: the view only absorbs the day
    state = m.state
    assert state.pending
    view = historical_table(state)
    closed = _reload(m).state
    closed.close_day()  # scores the day against the one before, then absorbs it
    assert not closed.pending
    assert closed.temporal.flow_scored.sum() > 0
    table = historical_table(closed)
    np.testing.assert_array_equal(table.ids, view.ids)
    np.testing.assert_allclose(table.flow, view.flow, rtol=1e-12, atol=0)
    np.testing.assert_allclose(table.rate, view.rate, rtol=1e-12, atol=0)
    assert state.pending  # the built map still holds its day


def test_pending_day_holds_windows_in_order_and_follows_moves() -> None:
    day = PendingDay(values=3)
    assert not day
    day.add_window(5, 100, False, [4, 2], [2], [[1, 0, 2]])
    day.add_window(5, 102, True, [], [2, 7], [[0, 1, 0], [3, 0, 0]])
    with pytest.raises(ValueError, match="increasing"):
        day.add_window(5, 102, False, [1], [], np.zeros((0, 3)))
    with pytest.raises(ValueError, match="pending day"):
        day.add_window(6, 200, False, [1], [], np.zeros((0, 3)))
    day.add_window(5, 103, False, [2, 4, 2], [4, 4], [[1, 1, 1], [0, 0, 1]])
    assert day.windows == [100, 102, 103]
    assert day.fixed == [False, True, False]
    np.testing.assert_array_equal(day.entries(), [2, 4, 7])
    got = day.consolidated()
    np.testing.assert_array_equal(np.c_[got.obs_entry, got.obs_slot], [[2, 0], [2, 2], [4, 0],
                                                                         [4, 2]])
    np.testing.assert_array_equal(np.c_[got.cnt_entry, got.cnt_slot], [[2, 0], [2, 1], [4, 2],
                                                                         [7, 1]])
    np.testing.assert_array_equal(got.cnt_values, [[1, 0, 2], [0, 1, 0], [1, 1, 2], [3, 0, 0]])
    day.remap(np.array([4, 7]), np.array([2, 9]))  # 4 moved into 2, 7 into 9
    got = day.consolidated()
    np.testing.assert_array_equal(np.c_[got.obs_entry, got.obs_slot], [[2, 0], [2, 2]])
    np.testing.assert_array_equal(np.c_[got.cnt_entry, got.cnt_slot], [[2, 0], [2, 1], [2, 2],
                                                                         [9, 1]])
    np.testing.assert_array_equal(got.cnt_values, [[1, 0, 2], [0, 1, 0], [1, 1, 2], [3, 0, 0]])
    # persistence: rows are written as positions and read back into the loaded rows
    position = np.full(10, -1, np.int64)
    position[[2, 9]] = [1, 0]
    arrays, meta = day.to_arrays("p_", position)
    again = PendingDay.from_arrays(arrays, "p_", meta, 3, entries=2)
    again.relabel(np.array([30, 20]))
    back = again.consolidated()
    assert again.day == 5
    assert again.windows == [100, 102, 103]
    np.testing.assert_array_equal(np.c_[back.cnt_entry, back.cnt_slot], [[20, 0], [20, 1],
                                                                          [20, 2], [30, 1]])
    np.testing.assert_array_equal(back.cnt_values, [[1, 0, 2], [0, 1, 0], [1, 1, 2], [3, 0, 0]])
    with pytest.raises(MapCorruptError):
        PendingDay.from_arrays(arrays, "p_", meta, 3, entries=1)  # a position out of range
    day.clear()
    assert not day
    assert day.day is None


@pytest.mark.parametrize("source", ["fixed", "robot"])
def test_a_query_sees_the_open_window_as_closing_it_would_record_it(source: str) -> None:
    rng = np.random.default_rng(41)
    cfg = CFG.replace(sensor_range=3.0)
    m = Mapper(cfg)
    if source == "fixed":
        m.set_fixed_sensor(T0, T0 + 5 * W + W // 2)
    else:
        poses = np.c_[np.linspace(0.0, 6.0, 12), np.zeros(12), np.zeros(12)]
        m.add_trajectory(Trajectory(T0 + np.arange(12) * (W // 2) + S, poses))
    for w in range(6):
        n = int(rng.integers(3, 12))
        xyz = np.c_[rng.uniform(0, 6, (n, 2)), np.zeros(n)]
        m.add_detections(detections(T0 + w * W + S + np.sort(rng.integers(0, W - S, n)), xyz))
    state = m.state
    assert state.open_window == T0 // W + 5
    assert state.entries.window_totals(state.entries.live_rows()).sum() > 0
    view = historical_table(state)
    arrays, meta = state.to_arrays()
    closed = Mapper(cfg, MapState.from_arrays(arrays, meta))
    closed.advance(T0 + 6 * W)  # records window 5 (log time reached its end) ...
    closed.state.close_day()  # ... and absorbs the day
    table = historical_table(closed.state)
    np.testing.assert_array_equal(table.ids, view.ids)
    np.testing.assert_allclose(table.flow, view.flow, rtol=1e-12, atol=0)
    np.testing.assert_allclose(table.rate, view.rate, rtol=1e-12, atol=0)
    assert state.open_window == T0 // W + 5  # the built map is unchanged


def test_a_new_graph_is_seen_by_the_next_query_though_nothing_else_changed() -> None:
    """The rooms pool the forecasts: a scene graph that only regroups the places into rooms
    must reach the next query, not a forecast cached for the previous graph."""
    import dataclasses

    from aion_cli.engine.types import Layer
    from tests.engine.engine_builders import pid

    state = run_steps(_three_days()).state
    assert state.graph is not None
    t = T0_DAY_END + DAY + 12 * HOUR
    before = predict_table(state, t)
    places = state.graph.places
    rooms = np.where(places.xyz[:, 0] < 2.0, 1, 2).tolist()  # two rooms, split by x
    regrouped = Layer(places.ids, places.xyz, pid(rooms, "R"))
    state.graph = dataclasses.replace(state.graph, places=regrouped)
    after = predict_table(state, t)
    arrays, meta = state.to_arrays()
    fresh = predict_table(MapState.from_arrays(arrays, json.loads(json.dumps(meta))), t)
    assert not np.array_equal(after.rate, before.rate)  # the rooms changed the forecast
    np.testing.assert_allclose(after.rate, fresh.rate, rtol=1e-12, atol=0)
