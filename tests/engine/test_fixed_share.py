"""A fixed sensor's window counts by the share of it the logs recorded.

The known answers: people pass one place at exactly one detection every 6 s (100 per full
ten-minute window). A sensor that records from 6 minutes into the first window to 4 minutes
into the fourth sees 40, 100, 100 and 40: its map must say 100 a window (280 detections in 2.8
windows of recording), where whole windows said 70 (the paper's rule, ``exposure = false``).
A four-minute log alone is four minutes of watching: 40 detections make 100 a window, not 40.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.types import Trajectory
from aion_cli.errors import MapCorruptError
from tests.engine.engine_builders import T0, T0_DAY_END, S, check_invariants, detections

W = 600 * S
PLACE = np.array([1.0, 1.0, 0.0])
CFG = ModelConfig(window_s=600.0)


def test_a_window_is_cut_to_the_spans_that_reach_into_it() -> None:
    source = ObservationSource()
    spans = (np.array([100, 1300, 3100]), np.array([1250, 1400, 3200]))
    source.add_fixed_windows(np.array([0, 1, 2, 5]), 600, spans)
    starts, ends = source.merged_fixed()
    np.testing.assert_array_equal(starts, [100, 1300, 3100])
    np.testing.assert_array_equal(ends, [1250, 1400, 3200])
    share = source.fixed_share(np.array([0, 1, 2, 3, 5]), 600, CFG)
    # window 0 from 100 s, 1 whole, 2 holds 1200-1250 and 1300-1400, 3 none, 5 a sixth
    np.testing.assert_allclose(share, [500 / 600, 1.0, 150 / 600, 0.0, 100 / 600])
    # the windows observed are the same as before: exactly those overlapped
    mask = source.fixed_mask(np.array([0, 1, 2, 3, 5]), 600)
    np.testing.assert_array_equal(mask, share > 0)
    # without exposure every overlapped window is whole, as in the paper
    whole = source.fixed_share(np.array([0, 2, 3]), 600, CFG.replace(exposure=False))
    np.testing.assert_array_equal(whole, [1.0, 1.0, 0.0])


def test_a_window_no_span_reaches_stays_whole() -> None:
    source = ObservationSource()
    source.add_fixed_windows(np.array([4, 9]), 600, (np.array([2450]), np.array([2500])))
    np.testing.assert_allclose(source.fixed_share(np.array([4, 9]), 600, CFG), [50 / 600, 1.0])


@settings(max_examples=60, deadline=None)
@given(
    windows=st.lists(st.integers(0, 40), min_size=1, max_size=25),
    spans=st.lists(st.tuples(st.integers(0, 25_000), st.integers(1, 3_000)), max_size=8),
)
def test_shares_add_up_to_the_time_recorded(
    windows: list[int], spans: list[tuple[int, int]]
) -> None:
    """Σ share × Δ is the time the windows hold within the spans, plus every window no span
    reaches, whole; each share in (0, 1]."""
    delta = 600
    w = np.unique(np.array(windows, np.int64))
    lo = np.array([a for a, _ in spans], np.int64)
    hi = np.array([a + n for a, n in spans], np.int64)
    source = ObservationSource()
    source.add_fixed_windows(w, delta, (lo, hi) if spans else None)
    share = source.fixed_share(w, delta, CFG)
    assert np.all((share > 0) & (share <= 1.0))
    # a window at a time (the build's usual call, a scalar walk) gives the same shares
    one = np.concatenate([source.fixed_share(w[k : k + 1], delta, CFG) for k in range(w.size)])
    np.testing.assert_allclose(one, share, rtol=0, atol=1e-15)
    covered = np.zeros(41 * delta, bool)  # second by second
    for a, b in zip(lo.tolist(), hi.tolist(), strict=True):
        covered[a:b] = True
    expected = 0
    for k in w.tolist():
        inside = int(covered[k * delta : (k + 1) * delta].sum())
        expected += inside if inside else delta
    assert float(share.sum()) * delta == pytest.approx(expected)


def _recording_map(start_s: int, end_s: int, exposure: bool = True) -> Mapper:
    """A fixed sensor recording ``[T0 + start_s, T0 + end_s)``, one detection every 6 s at
    ``PLACE`` while it records (100 per full window)."""
    m = Mapper(CFG.replace(exposure=exposure, families=("static",)))
    m.set_fixed_sensor(T0 + start_s * S, T0 + end_s * S)
    seconds = np.arange(start_s, end_s, 6)
    m.add_detections(detections(T0 + seconds * S, np.repeat(PLACE[None, :], seconds.size, 0)))
    m.advance(T0 + (end_s // 600 + 1) * W)
    check_invariants(m.state)
    return m


@pytest.mark.parametrize("exposure", [True, False])
def test_windows_recorded_in_part_give_the_true_rate(exposure: bool) -> None:
    state = _recording_map(360, 3 * 600 + 240, exposure).state
    table = historical_table(state)
    assert float(table.flow[0]) == pytest.approx(100.0 if exposure else 70.0)
    # the static forecast is the historical flow (the issue-12 invariant), to 1e-9
    predicted = predict_table(state, T0 + 2 * 3600 * S)
    np.testing.assert_allclose(predicted.flow, table.flow, rtol=1e-9, atol=0)


@pytest.mark.parametrize("exposure", [True, False])
def test_a_log_shorter_than_a_window_is_its_own_time(exposure: bool) -> None:
    """Four minutes inside one window: 40 detections are 100 a window (rounded to one
    window of watching they were 40, as whole windows have them)."""
    table = historical_table(_recording_map(180, 420, exposure).state)
    assert float(table.flow[0]) == pytest.approx(100.0 if exposure else 40.0)


def test_day_scores_expect_the_rate_times_the_share_recorded() -> None:
    """Three days of a sensor recording the first half of every window, people at exactly
    100 per full window: the day-ahead static forecast expects 50 in each window, so its
    log-likelihood is 50 log 50 − 50 a window and its Pearson χ² ~0."""
    days = 3
    windows = days * 144
    m = Mapper(CFG.replace(families=("static",)))
    starts = T0 + np.arange(windows, dtype=np.int64) * W
    for s in starts.tolist():
        m.set_fixed_sensor(s, s + W // 2)
    seconds = np.concatenate([k * 600 + np.arange(0, 300, 6) for k in range(windows)])
    m.add_detections(detections(T0 + seconds * S, np.repeat(PLACE[None, :], seconds.size, 0)))
    m.advance(T0 + windows * W)
    m.state.close_day()
    table = historical_table(m.state)
    assert float(table.flow[0]) == pytest.approx(100.0)
    row = int(m.state.entries.live_rows()[0])
    tmp = m.state.temporal
    static = m.state.params.flow.index("static")
    scored = windows - (T0_DAY_END - T0) // W  # the first day has nothing before it
    assert float(tmp.flow_scored[row]) == scored  # whole windows: one Pearson term each
    assert float(tmp.flow_score[row, static]) == pytest.approx(
        scored * (50 * np.log(50.0) - 50), rel=1e-6
    )
    assert float(tmp.flow_chi2[row, static]) / scored < 0.5
    assert float(tmp.glob.n[0]) == pytest.approx(windows / 2)


def test_pending_day_keeps_the_recorded_shares_and_round_trips() -> None:
    day = PendingDay(3)
    day.add_window(0, 10, True, [], [1], np.ones((1, 3)), fixed_share=0.25)
    day.add_window(0, 11, True, [], [], np.zeros((0, 3)))
    day.add_window(0, 12, False, np.array([1]), [], np.zeros((0, 3)), fixed_share=0.0)
    merged = day.consolidated()
    assert merged.fixed_share is not None
    np.testing.assert_array_equal(merged.fixed_share, [0.25, 1.0, 1.0])
    np.testing.assert_array_equal(merged.count_weights(), [0.25])  # 0.25 of λ expected
    arrays, meta = day.to_arrays("p_", np.arange(5))
    back = PendingDay.from_arrays(arrays, "p_", meta, 3, 5).consolidated()
    assert back.fixed_share is not None
    np.testing.assert_array_equal(back.fixed_share, merged.fixed_share)
    whole = PendingDay(3)
    whole.add_window(0, 10, True, [], [], np.zeros((0, 3)))
    arrays, meta = whole.to_arrays("p_", np.arange(5))
    assert "p_fixed_share" not in arrays  # a whole day stores no shares
    assert PendingDay.from_arrays(arrays, "p_", meta, 3, 5).consolidated().fixed_share is None


@pytest.mark.parametrize("bad", [[0.0, 1.0], [1.5, 1.0], [np.nan, 1.0], [0.5], [1.0, 0.5]])
def test_bad_recorded_shares_are_refused(bad: list[float]) -> None:
    """Out of (0, 1], one too few, or a share below 1 on a window no fixed sensor covered."""
    day = PendingDay(3)
    day.add_window(0, 10, True, [], [], np.zeros((0, 3)), fixed_share=0.5)
    day.add_window(0, 11, False, np.array([1]), [], np.zeros((0, 3)))
    arrays, meta = day.to_arrays("p_", np.arange(5))
    arrays["p_fixed_share"] = np.array(bad)
    with pytest.raises(MapCorruptError):
        PendingDay.from_arrays(arrays, "p_", meta, 3, 5)
    with pytest.raises(ValueError, match="share"):
        PendingDay(3).add_window(0, 10, True, [], [], np.zeros((0, 3)), fixed_share=bad[0] * 0)


def test_a_place_a_robot_glimpsed_keeps_the_one_window_floor_beside_a_short_fixed_log() -> None:
    """A fixed sensor records 3 minutes (0.3 of a window) with one person at A; later a robot
    glances at B, 40 m away, for ten seconds (its exposure floored at 0.2) and sees 3 people.
    A, watched only by the fixed sensor, is its own time: 1 / 0.3. B was watched 0.3 + 0.2 of
    a window; a robot's glimpse never claims more than it saw: 3 / max(0.5, 1) = 3, not 6."""
    far = PLACE + np.array([40.0, 0.0, 0.0])
    m = Mapper(CFG.replace(families=("static",)))
    m.set_fixed_sensor(T0, T0 + 180 * S)
    m.add_trajectory(
        Trajectory(T0 + 2 * W + np.arange(0, 11, 1, dtype=np.int64) * S, np.tile(far, (11, 1)))
    )
    m.add_detections(detections(np.array([T0 + 10 * S]), PLACE[None, :]))
    m.add_detections(detections(T0 + 2 * W + np.array([2, 5, 8]) * S, np.tile(far, (3, 1))))
    m.advance(T0 + 4 * W)
    table = historical_table(m.state)
    xy = table.xyz[:, :2]
    at_a = int(np.flatnonzero(np.linalg.norm(xy - PLACE[:2], axis=1) < 0.5)[0])
    at_b = int(np.flatnonzero(np.linalg.norm(xy - far[:2], axis=1) < 0.5)[0])
    assert float(table.flow[at_a]) == pytest.approx(1 / 0.3)
    assert float(table.flow[at_b]) == pytest.approx(3.0)
