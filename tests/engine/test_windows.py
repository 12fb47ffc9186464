"""Epoch-aligned windows and observation masks (trajectory and fixed sensor)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.types import Trajectory
from aion_cli.engine.windows import window_centre_ns, window_index, window_ns, window_start_ns
from aion_cli.errors import ConfigError, InputError

S = 1_000_000_000
DELTA = window_ns(600.0)


def test_windows_are_aligned_to_the_unix_epoch() -> None:
    t = np.array([0, 599 * S, 600 * S, 1_700_000_123 * S, -1])
    np.testing.assert_array_equal(window_index(t, DELTA), [0, 0, 1, 2_833_333, -1])
    assert window_start_ns(2_833_333, DELTA) == 1_699_999_800 * S
    assert window_centre_ns(1, DELTA) == 900 * S


def test_window_length_must_be_positive() -> None:
    with pytest.raises(ConfigError):
        window_ns(1e-12)


def _poses(t_s: list[float], xy: list[tuple[float, float]]) -> Trajectory:
    xyz = np.array([[x, y, 5.0] for x, y in xy])
    return Trajectory(np.array(t_s, dtype=np.float64).astype(np.int64) * S, xyz)


def test_trajectory_observes_entries_within_sensor_range_horizontally() -> None:
    obs = ObservationSource()
    obs.add_trajectory(_poses([10.0, 20.0], [(0.0, 0.0), (100.0, 0.0)]))
    entries = np.array([[7.9, 0.0], [0.0, -8.1], [95.0, 3.0], [50.0, 0.0]])
    np.testing.assert_array_equal(obs.observed(entries, 0, DELTA, 8.0), [True, False, True, False])
    # the next window has no poses: nothing observed there
    np.testing.assert_array_equal(obs.observed(entries, 1, DELTA, 8.0), [False] * 4)


def test_an_entry_exactly_at_sensor_range_is_observed() -> None:
    """README: "an entry is observed in a window when the robot came this close": at exactly
    sensor_range it did (the k-d tree's bound is strict: such entries went unobserved)."""
    obs = ObservationSource()
    obs.add_trajectory(_poses([10.0], [(1.0, 2.0)]))
    entries = np.array([[9.0, 2.0], [1.0, -6.0], [-7.0, 2.0], [9.0 + 1e-9, 2.0]])
    truth = np.hypot(entries[:, 0] - 1.0, entries[:, 1] - 2.0) <= 8.0
    np.testing.assert_array_equal(truth, [True, True, True, False])
    np.testing.assert_array_equal(obs.observed(entries, 0, DELTA, 8.0), truth)


def test_poses_count_only_in_their_own_window() -> None:
    obs = ObservationSource()
    obs.add_trajectory(_poses([1300.0], [(0.0, 0.0)]))  # window 2
    entries = np.zeros((1, 2))
    assert not obs.observed(entries, 1, DELTA, 8.0)[0]
    assert obs.observed(entries, 2, DELTA, 8.0)[0]
    np.testing.assert_array_equal(obs.covered_windows(0, 10, DELTA), [2])
    obs.prune(3 * DELTA)
    assert len(obs.pose_t) == 0


def test_non_finite_poses_are_ignored_and_order_is_restored() -> None:
    obs = ObservationSource()
    xyz = np.array([[0, 0, 0], [np.nan, 0, 0], [1, 1, 1.0]])
    obs.add_trajectory(Trajectory(np.array([5 * S, 1 * S, 3 * S]), xyz))
    np.testing.assert_array_equal(obs.pose_t, [3 * S, 5 * S])


def test_fixed_sensor_covers_every_overlapping_window() -> None:
    obs = ObservationSource()
    obs.set_fixed_sensor(700 * S, 1900 * S)  # windows 1, 2, 3
    np.testing.assert_array_equal(obs.covered_windows(0, 10, DELTA), [1, 2, 3])
    np.testing.assert_array_equal(obs.covered_windows(2, 3, DELTA), [2])
    entries = np.array([[1e4, 1e4]])
    assert obs.observed(entries, 3, DELTA, 8.0)[0]
    assert not obs.observed(entries, 4, DELTA, 8.0)[0]
    with pytest.raises(InputError):
        obs.set_fixed_sensor(10, 5)


def test_observation_arrays_round_trip() -> None:
    obs = ObservationSource()
    obs.add_trajectory(_poses([1.0, 2.0], [(0.0, 1.0), (2.0, 3.0)]))
    obs.set_fixed_sensor(0, 10)
    again = ObservationSource.from_arrays(obs.to_arrays())
    for name, value in obs.to_arrays().items():
        np.testing.assert_array_equal(again.to_arrays()[name], value)


def _covered_by_hand(
    intervals: list[tuple[int, int]], pose_t: list[int], first: int, stop: int
) -> list[int]:
    """Window w is covered when a pose lies in [wΔ, (w+1)Δ) or a non-empty interval [s, e)
    overlaps it (s < (w+1)Δ and e > wΔ): the definition, window by window."""
    out = []
    for w in range(first, stop):
        lo, hi = w * DELTA, (w + 1) * DELTA
        posed = any(lo <= t < hi for t in pose_t)
        fixed = any(s < e and s < hi and e > lo for s, e in intervals)
        if posed or fixed:
            out.append(w)
    return out


_EDGES = st.integers(-3, 40).map(lambda k: k * DELTA // 2) | st.integers(-2 * DELTA, 20 * DELTA)


@given(
    intervals=st.lists(st.tuples(_EDGES, _EDGES).map(sorted).map(tuple), max_size=6),
    pose_t=st.lists(st.integers(-2 * DELTA, 20 * DELTA), max_size=5),
    first=st.integers(-4, 12),
    length=st.integers(1, 14),
)
@settings(max_examples=300, deadline=None)
def test_covered_windows_are_the_windows_an_interval_or_a_pose_touches(
    intervals: list[tuple[int, int]], pose_t: list[int], first: int, length: int
) -> None:
    """Against the definition, for intervals that overlap, touch, nest, are empty ([s, s)
    covers nothing) or end on a window's edge, with and without poses."""
    obs = ObservationSource()
    for s, e in intervals:
        obs.set_fixed_sensor(s, e)
    if pose_t:
        obs.add_trajectory(Trajectory(np.array(pose_t, np.int64), np.zeros((len(pose_t), 3))))
    stop = first + length
    expected = _covered_by_hand(intervals, pose_t, first, stop)
    np.testing.assert_array_equal(obs.covered_windows(first, stop, DELTA), expected)
    windows = np.arange(first, stop)
    fixed = _covered_by_hand(intervals, [], first, stop)
    np.testing.assert_array_equal(obs.fixed_mask(windows, DELTA), np.isin(windows, fixed))
    for w in windows.tolist():
        assert obs.fixed_covers(w, DELTA) == (w in fixed)


def test_an_empty_fixed_sensor_interval_covers_no_window() -> None:
    obs = ObservationSource()
    obs.set_fixed_sensor(700 * S, 700 * S)  # inside window 1, zero length
    assert obs.covered_windows(0, 5, DELTA).size == 0
    assert not obs.fixed_covers(1, DELTA)
    assert obs.to_arrays()["obs_fixed_start"].size == 0


def test_one_interval_declared_whole_or_in_touching_parts_saves_the_same() -> None:
    whole, parts = ObservationSource(), ObservationSource()
    whole.set_fixed_sensor(100 * S, 4000 * S)
    parts.set_fixed_sensor(1500 * S, 4000 * S)  # out of order, touching, one nested
    parts.set_fixed_sensor(100 * S, 1500 * S)
    parts.set_fixed_sensor(200 * S, 300 * S)
    for name, value in whole.to_arrays().items():
        np.testing.assert_array_equal(parts.to_arrays()[name], value)
    np.testing.assert_array_equal(parts.merged_fixed()[0], [100 * S])
    np.testing.assert_array_equal(parts.merged_fixed()[1], [4000 * S])
