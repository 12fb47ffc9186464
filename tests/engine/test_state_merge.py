"""MapState merges: maps of disjoint time merged equal one build of both, configs checked,
released nodes (the logs of ``state_logs.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.compare import differences, pending_sorted, plain
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.query import historical_table
from aion_cli.engine.state import MapState, merge_states
from aion_cli.engine.types import Trajectory
from aion_cli.errors import MapCorruptError
from tests.engine.engine_builders import (
    T0,
    S,
    check_invariants,
    closed_counts,
    detections,
    graph,
    pending_counts,
    pid,
)
from tests.engine.state_logs import CFG, DAY, NODES, W, fixed_sensor_log, run_steps


def test_merging_disjoint_maps_equals_building_from_both() -> None:
    # Exact when both logs touch the same places from their first window on: a map built from
    # one log alone cannot know the observed-empty windows of entries only the other log made.
    spots = np.c_[np.random.default_rng(9).uniform(-1, 8, (40, 2)), np.zeros(40)]
    a_steps = fixed_sensor_log(T0, seed=4, spots=spots)
    b_steps = fixed_sensor_log(T0 + 2 * DAY, seed=5, spots=spots)
    both = run_steps(a_steps + b_steps).state
    # order does not matter
    merged = merge_states(run_steps(b_steps).state, run_steps(a_steps).state)
    check_invariants(merged)
    xa, ma = both.to_arrays()
    xm, mm = merged.to_arrays()
    pa, pm = pending_sorted(plain(xa)), pending_sorted(plain(xm))
    assert ma["accepted"] == mm["accepted"]
    assert ma["open_window"] == mm["open_window"]
    assert ma["pending_day"] == mm["pending_day"] == (T0 + 2 * DAY) // DAY
    exact = ["entry_key", "entry_node_id", "entry_kind", "entry_counts", "entry_nodir",
             "entry_window_counts", "entry_speed_n", "redirect_keys", "redirect_nodes",
             "temporal_glob_n", "temporal_glob_profile", "temporal_obs_n",
             "temporal_obs_profile", "temporal_cnt_profile", "pending_windows",
             "pending_fixed", "pending_obs_entry", "pending_cnt_entry", "pending_cnt_slot",
             "pending_cnt_values"]
    for name in exact:
        np.testing.assert_array_equal(pm[name], pa[name], err_msg=name)
    for name in ["entry_speed_sum", "temporal_glob_fourier", "temporal_glob_first",
                 "temporal_glob_last", "temporal_obs_fourier", "temporal_cnt_fourier"]:
        np.testing.assert_allclose(pm[name], pa[name], rtol=1e-12, atol=0, err_msg=name)
    assert pa["temporal_glob_n"][0] == 6  # the first log's windows; the second's are pending
    assert pa["temporal_cnt_profile"].sum() > 0
    assert len(pa["redirect_keys"]) > 0  # ownership transfer happened in both builds
    assert np.any(pa["entry_kind"] == 0)  # and some cells stayed unbound


def test_a_consuming_merge_equals_the_copying_one_which_leaves_its_inputs_alone() -> None:
    """``merge_maps(..., consume=True)`` (``aion merge``: no copies of the loaded maps) builds
    the same map as the default merge, which must not change either input."""
    spots = np.c_[np.random.default_rng(3).uniform(-1, 8, (40, 2)), np.zeros(40)]
    early_steps = fixed_sensor_log(T0, seed=7, spots=spots)
    late_steps = fixed_sensor_log(T0 + 3 * DAY, seed=8, spots=spots)
    early, late = run_steps(early_steps).state, run_steps(late_steps).state
    before = (early.to_arrays(), late.to_arrays())
    copied = merge_maps(late, early)
    for state, (arrays, meta) in zip((early, late), before, strict=True):
        again, again_meta = state.to_arrays()
        assert again_meta == meta
        assert arrays.keys() == again.keys()
        for name in arrays:
            np.testing.assert_array_equal(np.asarray(again[name]), np.asarray(arrays[name]))
    larger = early if early.entries.n >= late.entries.n else late
    consumed = merge_maps(late, early, consume=True)
    assert consumed is larger  # built in the larger map (engine/merge_rows.py)
    assert differences(copied, consumed) == []
    check_invariants(consumed)


def test_merge_adds_the_fixed_sensor_windows_of_both_maps_for_every_entry() -> None:
    """An entry only the later map has still counts as observed-empty over the earlier map's
    fixed-sensor windows, as a single pass would."""
    early = Mapper(CFG)
    early.set_fixed_sensor(T0, T0 + 3 * W)
    early.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 2))
    early.advance(T0 + 3 * W)
    late = Mapper(CFG)
    late.set_fixed_sensor(T0 + 2 * DAY, T0 + 2 * DAY + 2 * W)
    late.add_detections(detections(T0 + 2 * DAY + S, [[5.1, 5.1, 0]] * 4))
    late.advance(T0 + 2 * DAY + 2 * W)
    merged = merge_states(early.state, late.state)
    assert merged.temporal.glob.n[0] == 3  # the earlier map's day, scored and absorbed
    rows = merged.entries.live_rows()
    np.testing.assert_array_equal(merged.windows_observed(rows), [5, 5])  # 3 + 2 pending
    table = historical_table(merged)
    flows = dict(zip(table.ids.tolist(), table.flow.tolist(), strict=True))
    assert sorted(flows.values()) == pytest.approx([2 / 5, 4 / 5])
    check_invariants(merged)


def test_merge_rejects_different_configs() -> None:
    a = MapState.empty(CFG)
    b = MapState.empty(CFG.replace(cell_size=0.3))
    with pytest.raises(Exception, match="different model parameters"):
        merge_states(a, b)


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
    assert closed_counts(merged, cells).sum() == 2  # the earlier day's, absorbed
    assert pending_counts(merged)[cells].sum() == 2  # the later map's day, still pending
    np.testing.assert_array_equal(np.unique(merged.entries.key[cells]).size, cells.size)
    arrays, meta = merged.to_arrays()
    other = {**meta, "config": cfg.replace(periods=[3600.0]).to_dict()}
    with pytest.raises(MapCorruptError, match="temporal member"):
        MapState.from_arrays(arrays, other)


def test_a_node_that_restarted_in_the_later_map_keeps_its_own_timer() -> None:
    # Two nodes seen in both maps (the same ids), both first seen in the later map where
    # the earlier one left them. p0 stays put: one pass keeps it stable since the earlier
    # map (merged: the earlier timer and reference). p1 is moved away beyond the tolerance
    # and back (a loop closure's correction, then another): one pass restarts it twice and
    # ends re-referenced where the earlier map had it. The merge must keep that restart; it
    # took the earlier timer before, as the two references agree.
    tol = CFG.stable_move_tolerance
    here = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])

    def feed(m: Mapper, start: int, moves: bool) -> None:
        m.set_fixed_sensor(start, start + 2 * W)
        for k in range(7):
            xyz = here.copy()
            if moves and k in (1, 2):
                xyz[1, 0] += 1.2 * tol
            m.add_graph(graph(start + k * 600 * S, [0, 1], xyz))
        m.add_detections(detections(start + S, [[0.2, 0.2, 0], [5.1, 0.1, 0]]))
        m.advance(start + W)

    one = Mapper(CFG)
    feed(one, T0, moves=False)
    feed(one, T0 + DAY, moves=True)
    early, late = Mapper(CFG), Mapper(CFG)
    feed(early, T0, moves=False)
    feed(late, T0 + DAY, moves=True)
    merged = merge_states(early.state, late.state)
    a, b = one.state.nodes, merged.nodes
    np.testing.assert_array_equal(a.ids, b.ids)
    np.testing.assert_array_equal(a.stable_since_ns, b.stable_since_ns)
    np.testing.assert_allclose(a.ref_xyz, b.ref_xyz, rtol=0, atol=1e-12)
    assert a.stable_since_ns[0] < T0 + DAY < a.stable_since_ns[1]  # the cases it is about


def test_entries_of_one_map_merged_into_one_row_count_their_windows_once() -> None:
    """Two places of the earlier map in one hash cell, both gone from the later graph, release
    into that cell: the robot watched both in the same windows, so the cell counts them once
    (their observation folds by the larger, as an ownership move does), not once per place
    (8 here; a merged two-day map of the simulated office said 432 windows observed of 288)."""
    cfg = CFG.replace(stability_s=0.0)

    def build(start: int, nodes: list[int], xyz: list[list[float]], windows: int) -> MapState:
        m = Mapper(cfg)
        t = np.arange(start, start + windows * W, 30 * S)
        m.add_trajectory(Trajectory(t, np.zeros((t.size, 3))))  # parked at the origin
        m.add_graph(graph(start, nodes, np.array(xyz)))
        for w in range(windows):
            m.add_detections(detections(start + w * W + S, [[0.1, 0.1, 0], [0.3, 0.3, 0]]))
        m.advance(start + windows * W)
        return m.state

    early = build(T0, [0, 1], [[0.1, 0.1, 0.0], [0.3, 0.3, 0.0]], windows=3)
    late = build(T0 + DAY, [4], [[6.0, 6.0, 0.0]], windows=2)
    np.testing.assert_array_equal(early.windows_observed(early.entries.node_rows()), [3, 3])
    merged = merge_states(early, late)
    check_invariants(merged)
    rows = merged.entries.live_rows()
    assert merged.entries.counts[rows].sum() + merged.entries.nodir[rows].sum() == 10
    observed = merged.windows_observed(rows, open_window=True)
    # the cell the later map saw them in: the earlier map's 3 windows and its own 2, once each
    np.testing.assert_array_equal(observed, [5])


def test_merged_maps_add_their_counters_and_keep_the_latest_log_time() -> None:
    """Counters of disjoint logs add: detections accepted, and dropped per reason; the log
    time is the later map's."""
    spots = np.c_[np.random.default_rng(4).uniform(-1, 8, (20, 2)), np.zeros(20)]
    early = run_steps(fixed_sensor_log(T0, seed=1, spots=spots)).state
    late = run_steps(fixed_sensor_log(T0 + 2 * DAY, seed=2, spots=spots)).state
    early.dropped.update(nan=2, out_of_range=1, before_window=0)
    late.dropped.update(nan=5, out_of_range=0, before_window=3)
    accepted = early.accepted + late.accepted
    latest = late.log_time_ns
    assert latest is not None
    assert early.log_time_ns is not None
    assert latest > early.log_time_ns
    merged = merge_states(early, late)
    assert merged.dropped == {"nan": 7, "out_of_range": 1, "before_window": 3}
    assert merged.accepted == accepted
    assert merged.log_time_ns == latest  # the map has seen the logs up to the later one's end


def test_a_cell_of_the_earlier_map_binds_to_a_place_the_later_map_made_stable() -> None:
    """One build binds the earlier log's cell at (6.3, 6) to p4 once the later log's graph
    adds p4 there and it turns stable; a merge left it a cell, holding the flow that one
    build gives p4 (``aion merge`` of ordinary maps: predict --historical differed)."""
    late_t = T0 + 2 * DAY
    spot, elsewhere = [6.3, 6.0, 0.0], [0.2, 0.0, 0.0]

    def log(start: int, nodes: list[int], points: list[list[float]]) -> list:
        def batch(w: int) -> object:
            t = start + w * W + 60 * S + np.arange(len(points)) * S
            return detections(t, points, np.zeros(len(points)), np.ones(len(points)))

        return [
            lambda m: m.set_fixed_sensor(start, start + 2 * W),
            lambda m: m.add_graph(graph(start, nodes, np.array(NODES)[nodes])),
            lambda m: m.add_detections(batch(0)),
            lambda m: m.add_detections(batch(1)),
        ]

    early = log(T0, [0, 1, 2, 3], [spot, spot, elsewhere])
    late = log(late_t, [0, 1, 2, 3, 4], [elsewhere])
    both = run_steps(early + late).state
    key = both.redirects.keys[both.redirects.nodes == pid(4)]
    assert key.size == 1  # one build bound the cell to p4
    merged = merge_maps(run_steps(early).state, run_steps(late).state)
    check_invariants(merged)
    assert np.array_equal(merged.redirects.keys[merged.redirects.nodes == pid(4)], key)
    assert differences(merged, both) == []
    p4 = both.node_entry_rows(pid([4]))[0]
    assert closed_counts(both, [p4]).sum() == 4  # the early log's detections at the spot
