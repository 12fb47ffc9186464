"""Mapper: drops, NaN headings, window closing into the temporal model, observation masks,
batching."""

from __future__ import annotations

import cmath
import math
from datetime import UTC, datetime

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.spatial_hash import keys_for_points, unpack_keys
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch, Trajectory
from aion_cli.errors import ConfigError, CoordinateRangeError
from tests.engine.engine_builders import (
    T0,
    T0_DAY_END,
    S,
    check_invariants,
    closed_counts,
    detections,
    graph,
    pending_counts,
    temporal_detections,
)
from tests.shared_data import SHARED_DATA

CFG = ModelConfig(window_s=600.0, sensor_range=8.0)
W = 600 * S
EPOCH_NS = 1_578_268_800 * S  # 2020-01-06T00:00:00Z, the model epoch (DESIGN.md §4)
PHASE_ATOL = 1e-9


def _row_of(m: Mapper, xyz: list[float]) -> int:
    key = keys_for_points(np.array([xyz]), m.state.config.cell_size)[0]
    rows, found = m.state.routes.lookup(np.array([key]))
    assert found[0]
    return int(rows[0])


def _centre(window_start_ns: int) -> int:
    return window_start_ns + W // 2


def _profile_bin(t_ns: int) -> int:
    """Hour of the day, +24 on Saturdays and Sundays (the default ``day_weekend`` profile, UTC),
    from the standard library's calendar."""
    when = datetime.fromtimestamp(t_ns // S, tz=UTC)
    return when.hour + (24 if when.weekday() >= 5 else 0)


def _fourier(centres_ns: list[int], weights: list[float] | None = None) -> np.ndarray:
    """Σ_w n_w e^{iω_k t_w} over the default periods, t_w in seconds since the model epoch.

    Phases ω t are ~10^5 rad, so two float64 evaluations agree to ~1e-11 only: compare with
    ``atol=PHASE_ATOL``."""
    weights = weights if weights is not None else [1.0] * len(centres_ns)
    out = []
    for period in CFG.periods:
        omega = 2 * math.pi / period
        out.append(
            sum(n * cmath.exp(1j * omega * (t - EPOCH_NS) / 1e9)
                for n, t in zip(weights, centres_ns, strict=True))
        )
    return np.array(out)


def test_drops_are_counted_by_reason_and_never_stored() -> None:
    m = Mapper(CFG)
    xyz = np.array([[0, 0, 0], [np.nan, 0, 0], [0, np.inf, 0], [1e9, 0, 0], [1, 1, 0]])
    drops = m.add_detections(detections(T0 + 2 * W, xyz))
    assert drops == {"nan": 2, "out_of_range": 1, "before_window": 0}
    late = m.add_detections(detections(T0 + W, [[0, 0, 0], [0, 0, 0]]))
    assert late == {"nan": 0, "out_of_range": 0, "before_window": 2}
    st_ = m.state
    assert st_.accepted == 2
    assert st_.entries.total_count() == 2
    assert temporal_detections(st_) == 2
    assert st_.dropped == {"nan": 2, "out_of_range": 1, "before_window": 2}
    assert m.add_detections(DetectionBatch.empty()) == dict.fromkeys(st_.dropped, 0)


def test_nan_heading_counts_for_flow_not_direction_and_nan_speed_skips_speed() -> None:
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
    values = [0, 0, 0, 0, 2, 0, 1, 0, 1]  # B direction bins, then "no heading"
    m.advance(T0 + W)
    tmp = m.state.temporal
    # the window waits in the pending day (T0's day is not over) ...
    np.testing.assert_array_equal(pending_counts(m.state)[row], values)
    assert tmp.cnt_profile[row].sum() == 0
    np.testing.assert_array_equal(m.state.windows_observed(np.array([row])), [1])
    # ... and is absorbed when log time reaches the next day: n_v at the window's profile bin
    m.advance(T0_DAY_END + S)
    assert not m.state.pending
    h = _profile_bin(T0)
    assert h == 22  # 22:20 UTC on a Tuesday
    expected = np.zeros((9, tmp.n_bins))
    expected[:, h] = values
    np.testing.assert_array_equal(tmp.cnt_profile[row], expected)
    centre = _centre(T0)
    np.testing.assert_allclose(
        tmp.cnt_fourier[row], np.outer(values, _fourier([centre])), rtol=0, atol=PHASE_ATOL
    )
    check_invariants(m.state)


def test_closing_a_run_of_windows_records_real_zeros_only_where_observed() -> None:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 2 * W)  # windows 0 and 1 fixed-observed; later ones not
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 3))
    m.advance(T0 + 5 * W + S)  # closes windows 0..4
    row = _row_of(m, [0.1, 0.1, 0])
    assert m.state.pending.windows == [T0 // W, T0 // W + 1]
    np.testing.assert_array_equal(m.state.windows_observed(np.array([row])), [2])
    assert m.state.open_window == (T0 + 5 * W) // W
    m.advance(T0_DAY_END)  # the day is over: absorbed
    tmp = m.state.temporal
    # a fixed sensor observes every entry: its windows live in the global block
    assert tmp.glob.n[0] == 2
    assert tmp.obs.n[row] == 0
    np.testing.assert_array_equal(tmp.windows_observed(np.array([row])), [2])
    centres = [_centre(T0), _centre(T0 + W)]
    assert tmp.glob.first[0] == (centres[0] - EPOCH_NS) / 1e9
    assert tmp.glob.last[0] == (centres[1] - EPOCH_NS) / 1e9
    profile = np.zeros(tmp.n_bins)
    profile[22] = 2  # both windows are in 22:00-23:00 UTC
    np.testing.assert_array_equal(tmp.glob.profile[0], profile)
    np.testing.assert_allclose(tmp.glob.fourier[0], _fourier(centres), rtol=0, atol=PHASE_ATOL)
    # the count: 3 in window 0, a real zero in window 1
    assert tmp.cnt_profile[row, 4, 22] == 3
    assert tmp.cnt_profile[row].sum() == 3
    np.testing.assert_allclose(
        tmp.cnt_fourier[row, 4], 3 * _fourier(centres[:1]), rtol=0, atol=PHASE_ATOL
    )
    check_invariants(m.state)


def test_trajectory_decides_which_entries_an_empty_window_observes() -> None:
    m = Mapper(CFG.replace(exposure=False))  # windows counted whole: which, not how long
    near, far = [0.1, 0.1, 0.0], [50.1, 0.1, 0.0]
    m.add_trajectory(Trajectory(np.array([T0 + 10 * S]), np.array([[0.0, 0.0, 0.0]])))
    m.add_detections(detections(T0 + S, [near, far]))  # both have detections in window 0
    m.add_trajectory(Trajectory(np.array([T0 + W + 10 * S]), np.array([[3.0, 0.0, 0.0]])))
    m.advance(T0 + 3 * W)
    rows = np.array([_row_of(m, near), _row_of(m, far)])
    # window 0: both observed (detections); window 1: only the one within 8 m; window 2: none
    np.testing.assert_array_equal(m.state.windows_observed(rows), [2, 1])
    assert len(m.state.observation.pose_t) == 0  # poses of closed windows are forgotten
    m.advance(T0_DAY_END)
    tmp = m.state.temporal
    np.testing.assert_array_equal(tmp.obs.n[rows], [2, 1])  # per-entry blocks, no global one
    assert tmp.glob.n[0] == 0
    c0, c1 = _centre(T0), _centre(T0 + W)
    np.testing.assert_array_equal(tmp.obs.first[rows], [(c0 - EPOCH_NS) / 1e9] * 2)
    np.testing.assert_array_equal(
        tmp.obs.last[rows], [(c1 - EPOCH_NS) / 1e9, (c0 - EPOCH_NS) / 1e9]
    )
    np.testing.assert_allclose(
        tmp.obs.fourier[rows[0]], _fourier([c0, c1]), rtol=0, atol=PHASE_ATOL
    )
    np.testing.assert_allclose(tmp.obs.fourier[rows[1]], _fourier([c0]), rtol=0, atol=PHASE_ATOL)
    check_invariants(m.state)


def test_fixed_windows_observe_only_the_windows_with_messages() -> None:
    m = Mapper(CFG)
    w0 = T0 // W
    m.set_fixed_windows(np.array([w0, w0 + 2, w0 + 3]))  # the log recorded nothing in w0+1
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 2))
    m.add_detections(detections(T0 + 3 * W + S, [[0.1, 0.1, 0]]))
    m.advance(T0 + 5 * W)
    assert m.state.pending.windows == [w0, w0 + 2, w0 + 3]
    assert all(m.state.pending.fixed)
    row = _row_of(m, [0.1, 0.1, 0])
    np.testing.assert_array_equal(m.state.windows_observed(np.array([row])), [3])
    m.advance(T0_DAY_END)
    tmp = m.state.temporal
    assert tmp.glob.n[0] == 3
    assert tmp.cnt_profile[row, 4].sum() == 3
    check_invariants(m.state)


def test_long_gaps_are_closed_day_by_day_with_one_observation_per_window() -> None:
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 1000 * W)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]]))
    m.add_detections(detections(T0 + 999 * W + S, [[0.1, 0.1, 0]]))
    row = _row_of(m, [0.1, 0.1, 0])
    st_ = m.state
    assert st_.open_window == (T0 + 999 * W) // W
    # windows 0..998 closed: the local days before window 999's are absorbed, its day waits
    last_day_start = (T0 + 999 * W) // 86_400_000_000_000 * 86_400_000_000_000
    assert st_.pending.windows == list(range(last_day_start // W, (T0 + 999 * W) // W))
    assert st_.temporal.glob.n[0] == 999 - len(st_.pending.windows)
    np.testing.assert_array_equal(st_.windows_observed(np.array([row])), [999])
    assert st_.temporal.cnt_profile[row].sum() == 1  # window 0's detection, absorbed
    assert st_.entries.window_counts[row].sum() == 1  # window 999's is still open
    check_invariants(st_)


def test_one_batch_over_many_windows_equals_one_call_per_window() -> None:
    rng = np.random.default_rng(3)
    n = 400
    start = T0_DAY_END - 2 * W  # the five windows cross midnight: a day closes on the way
    t = start + rng.integers(0, 5 * W, n)
    xyz = np.c_[rng.uniform(-4, 4, (n, 2)), np.zeros(n)]
    batch = detections(t, xyz, rng.uniform(-np.pi, np.pi, n), rng.uniform(0, 2, n))
    one, many = Mapper(CFG), Mapper(CFG)
    for m in (one, many):
        m.set_fixed_sensor(start, start + 6 * W)
        m.add_graph(graph(start, [0, 1], [[0, 0, 0], [2, 2, 0]]))
    one.add_detections(batch)  # unsorted, five windows
    order = np.argsort(t, kind="stable")
    for w in range(5):
        sel = order[(t[order] >= start + w * W) & (t[order] < start + (w + 1) * W)]
        many.add_detections(batch.select(sel))
    a, meta_a = one.state.to_arrays()
    b, meta_b = many.state.to_arrays()
    assert meta_a == meta_b
    assert sorted(a) == sorted(b)
    for name in a:
        np.testing.assert_allclose(a[name], b[name], rtol=1e-12, atol=0, err_msg=name)
    assert one.state.temporal.glob.n[0] == 2  # the two windows before midnight were absorbed
    check_invariants(one.state)


def test_detections_with_no_source_teach_only_their_own_window() -> None:
    m = Mapper(CFG)  # no trajectory, no fixed sensor
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 2))
    m.advance(T0 + 10 * W)  # T0's day is over at T0 + 10 W
    row = _row_of(m, [0.1, 0.1, 0])
    assert not m.state.pending
    assert m.state.temporal.obs.n[row] == 1
    assert m.state.temporal.glob.n[0] == 0
    np.testing.assert_array_equal(closed_counts(m.state, [row])[0, 4], 2)


def test_bad_inputs() -> None:
    m = Mapper(CFG)
    with pytest.raises(CoordinateRangeError):
        m.add_graph(graph(T0, [0], [[np.nan, 0, 0]]))
    with pytest.raises(ConfigError):
        Mapper(CFG, MapState.empty(CFG.replace(bins=4)))


ATC = SHARED_DATA / "atc"
needs_atc = pytest.mark.skipif(
    not (ATC / "atc-1024-10_train.csv").is_file(),
    reason="the ATC data (../shared/data/atc) is not here",
)


def _atc_batch(hour: int) -> DetectionBatch:
    raw = np.loadtxt(ATC / f"atc-1024-{hour}_train.csv", delimiter=",")
    t_ns = np.round(raw[:, 0] * 1e9).astype(np.int64)
    xyz = np.c_[raw[:, 2], raw[:, 3], np.zeros(len(raw))]
    return DetectionBatch.from_arrays(t_ns, xyz, raw[:, 5], raw[:, 4], raw[:, 1].astype(np.int64))


@needs_atc
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
    # the same histogram, over the closed windows (pending day) and the open one
    in_model = pending_counts(st_)[rows[order], :8] + st_.entries.window_counts[rows[order]]
    np.testing.assert_array_equal(in_model, expected)
    assert st_.open_window is not None
    n_windows = len(np.unique(batch.t_ns // (600 * S)))
    assert n_windows - 1 == int(st_.open_window - batch.t_ns.min() // (600 * S))
    assert len(st_.pending.windows) == n_windows - 1
    check_invariants(st_)
