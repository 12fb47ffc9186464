"""Mapper: drops, NaN headings, window closing into FreMEn, observation masks, batching."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import fremen_rows
from aion_cli.engine.errors import ConfigError, CoordinateRangeError
from aion_cli.engine.fremen import to_model_seconds
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.spatial_hash import keys_for_points, unpack_keys
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch, Trajectory
from tests.engine.engine_builders import T0, S, check_invariants, detections, graph

CFG = ModelConfig(window_s=600.0, activity_scale=5.0, sensor_range=8.0)
W = 600 * S


def _row_of(m: Mapper, xyz: list[float]) -> int:
    key = keys_for_points(np.array([xyz]), m.state.config.cell_size)[0]
    rows, found = m.state.routes.lookup(np.array([key]))
    assert found[0]
    return int(rows[0])


def test_drops_are_counted_by_reason_and_never_stored() -> None:
    m = Mapper(CFG)
    xyz = [[0, 0, 0], [np.nan, 0, 0], [0, np.inf, 0], [1e9, 0, 0], [1, 1, 0]]
    drops = m.add_detections(detections(T0 + 2 * W, xyz))
    assert drops == {"nan": 2, "out_of_range": 1, "before_window": 0}
    late = m.add_detections(detections(T0 + W, [[0, 0, 0], [0, 0, 0]]))
    assert late == {"nan": 0, "out_of_range": 0, "before_window": 2}
    st_ = m.state
    assert st_.accepted == 2
    assert st_.entries.total_count() == 2
    assert st_.dropped == {"nan": 2, "out_of_range": 1, "before_window": 2}
    assert m.add_detections(DetectionBatch.empty()) == dict.fromkeys(st_.dropped, 0)


def test_nan_heading_counts_for_activity_not_direction_and_nan_speed_skips_speed() -> None:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 10 * W)
    batch = detections(
        T0 + S,
        [[0.1, 0.1, 0]] * 4,
        heading=[np.nan, 0.0, 0.0, np.pi / 2],
        speed=[1.0, 2.0, np.nan, 4.0],
    )
    m.add_detections(batch)
    row = _row_of(m, [0.1, 0.1, 0])
    ent = m.state.entries
    assert ent.nodir[row] == 1
    np.testing.assert_array_equal(ent.counts[row], [0, 0, 0, 0, 2, 0, 1, 0])
    np.testing.assert_array_equal(ent.speed_n[row], [0, 0, 0, 0, 1, 0, 1, 0])
    np.testing.assert_array_equal(ent.speed_sum[row], [0, 0, 0, 0, 2, 0, 4, 0])
    m.advance(T0 + W)
    fr = fremen_rows(np.array([row]), 8)[0]
    fs = m.state.fremen
    np.testing.assert_allclose(fs.sum_s[fr[0]], 1 - np.exp(-4 / 5))  # all 4 for activity
    np.testing.assert_allclose(fs.sum_s[fr[1:]], [0, 0, 0, 0, 2 / 3, 0, 1 / 3, 0])
    np.testing.assert_array_equal(fs.n[fr[1:]], np.ones(8))


def test_closing_a_run_of_windows_records_real_zeros_only_where_observed() -> None:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 2 * W)  # windows 0 and 1 fixed-observed; later ones not
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 3))
    m.advance(T0 + 5 * W + S)  # closes windows 0..4
    row = _row_of(m, [0.1, 0.1, 0])
    act = fremen_rows(np.array([row]), 8)[0, 0]
    fs = m.state.fremen
    assert fs.n[act] == 2  # window 0 (3 detections) and window 1 (observed empty)
    np.testing.assert_allclose(fs.sum_s[act], 1 - np.exp(-3 / 5))
    centre0 = to_model_seconds(np.array([T0 + W // 2]))[0]
    assert fs.t_first[act] == centre0
    assert fs.t_last[act] == centre0 + 600.0
    assert m.state.entries.windows_observed[row] == 2
    assert m.state.open_window == (T0 + 5 * W) // W


def test_trajectory_decides_which_entries_an_empty_window_observes() -> None:
    m = Mapper(CFG)
    near, far = [0.1, 0.1, 0.0], [50.1, 0.1, 0.0]
    m.add_trajectory(Trajectory(np.array([T0 + 10 * S]), np.array([[0.0, 0.0, 0.0]])))
    m.add_detections(detections(T0 + S, [near, far]))  # both have detections in window 0
    m.add_trajectory(Trajectory(np.array([T0 + W + 10 * S]), np.array([[3.0, 0.0, 0.0]])))
    m.advance(T0 + 3 * W)
    fs = m.state.fremen
    rows = np.array([_row_of(m, near), _row_of(m, far)])
    act = fremen_rows(rows, 8)[:, 0]
    # window 0: both observed (detections); window 1: only the one within 8 m; window 2: none
    np.testing.assert_array_equal(fs.n[act], [2, 1])
    np.testing.assert_array_equal(m.state.entries.windows_observed[rows], [2, 1])
    assert len(m.state.observation.pose_t) == 0  # poses of closed windows are forgotten


def test_long_gaps_are_closed_in_chunks_with_one_observation_per_window() -> None:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 1000 * W)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]]))
    m.add_detections(detections(T0 + 999 * W + S, [[0.1, 0.1, 0]]))
    row = _row_of(m, [0.1, 0.1, 0])
    act = fremen_rows(np.array([row]), 8)[0, 0]
    assert m.state.fremen.n[act] == 999
    np.testing.assert_allclose(m.state.fremen.sum_s[act], 1 - np.exp(-1 / 5))
    assert m.state.open_window == (T0 + 999 * W) // W


def test_one_batch_over_many_windows_equals_one_call_per_window() -> None:
    rng = np.random.default_rng(3)
    n = 400
    t = T0 + rng.integers(0, 5 * W, n)
    xyz = np.c_[rng.uniform(-4, 4, (n, 2)), np.zeros(n)]
    batch = detections(t, xyz, rng.uniform(-np.pi, np.pi, n), rng.uniform(0, 2, n))
    one, many = Mapper(CFG), Mapper(CFG)
    for m in (one, many):
        m.set_fixed_sensor(T0, T0 + 6 * W)
        m.add_graph(graph(T0, [0, 1], [[0, 0, 0], [2, 2, 0]]))
    one.add_detections(batch)  # unsorted, five windows
    order = np.argsort(t, kind="stable")
    for w in range(5):
        sel = order[(t[order] >= T0 + w * W) & (t[order] < T0 + (w + 1) * W)]
        many.add_detections(batch.select(sel))
    a, meta_a = one.state.to_arrays()
    b, meta_b = many.state.to_arrays()
    assert meta_a == meta_b
    for name in a:
        np.testing.assert_allclose(a[name], b[name], rtol=1e-12, atol=1e-12, err_msg=name)
    check_invariants(one.state)


def test_detections_with_no_source_teach_only_their_own_window() -> None:
    m = Mapper(CFG)  # no trajectory, no fixed sensor
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 2))
    m.advance(T0 + 10 * W)
    act = fremen_rows(np.array([_row_of(m, [0.1, 0.1, 0])]), 8)[0, 0]
    assert m.state.fremen.n[act] == 1


def test_bad_inputs() -> None:
    m = Mapper(CFG)
    with pytest.raises(CoordinateRangeError):
        m.add_graph(graph(T0, [0], [[np.nan, 0, 0]]))
    with pytest.raises(ConfigError):
        Mapper(CFG, MapState.empty(CFG.replace(bins=4)))


ATC = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "atc"


def _atc_batch(hour: int) -> DetectionBatch:
    raw = np.loadtxt(ATC / f"atc-1024-{hour}_train.csv", delimiter=",")
    t_ns = np.round(raw[:, 0] * 1e9).astype(np.int64)
    xyz = np.c_[raw[:, 2], raw[:, 3], np.zeros(len(raw))]
    return DetectionBatch.from_arrays(t_ns, xyz, raw[:, 5], raw[:, 4], raw[:, 1].astype(np.int64))


def test_real_atc_hour_counts_match_an_independent_histogram() -> None:
    batch = _atc_batch(10)
    cfg = ModelConfig(cell_size=1.0, window_s=600.0)
    m = Mapper(cfg)
    m.set_fixed_sensor(int(batch.t_ns.min()), int(batch.t_ns.max()) + 1)
    m.add_detections(batch)
    st_ = m.state
    assert st_.accepted == len(batch)
    # reference: per (ix, iy) cell and paper bin, counted without the hash or the mapper
    cells = np.floor(batch.xyz[:, :2]).astype(np.int64)
    bins = np.floor((batch.heading + np.pi) / (np.pi / 4)).astype(np.int64) % 8
    uniq, inverse = np.unique(cells, axis=0, return_inverse=True)
    expected = np.zeros((len(uniq), 8))
    np.add.at(expected, (inverse.ravel(), bins), 1)
    rows = st_.entries.cell_rows()
    got_cells = unpack_keys(st_.entries.key[rows])
    assert np.all(got_cells[:, 2] == 0)
    order = np.lexsort((got_cells[:, 1], got_cells[:, 0]))
    np.testing.assert_array_equal(got_cells[order, :2], uniq)
    np.testing.assert_array_equal(st_.entries.counts[rows[order]], expected)
    assert st_.open_window is not None
    assert len(np.unique(batch.t_ns // (600 * S))) - 1 == int(
        st_.open_window - batch.t_ns.min() // (600 * S)
    )
    check_invariants(st_)
