"""HeadingEstimator: known answers for each rule of DESIGN.md §4 (velocity, differencing a
track within and across calls, minimum displacement, pose yaw) and quaternion yaw."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.heading import HeadingEstimator
from aion_cli.errors import ConfigError
from aion_cli.formats.detections.frame import FrameDetections, quat_yaw

S = 1_000_000_000


def yaw_quat(a: float) -> list[float]:
    return [0.0, 0.0, math.sin(a / 2), math.cos(a / 2)]


@pytest.mark.parametrize("a", [0.0, 0.3, -1.2, math.pi / 2, 3.0, -3.0])
def test_yaw_of_a_yaw_only_quaternion(a: float) -> None:
    assert quat_yaw(np.array([yaw_quat(a)]))[0] == pytest.approx(a)
    # Scale does not matter (unnormalised quaternions from sloppy publishers).
    assert quat_yaw(np.array([yaw_quat(a)]) * 3.0)[0] == pytest.approx(a)


def test_yaw_of_unset_quaternion_is_nan_and_roll_pitch_are_ignored() -> None:
    got = quat_yaw(np.array([[0.0, 0.0, 0.0, 0.0], [np.nan, 0, 0, 1], [1.0, 0.0, 0.0, 0.0]]))
    assert np.isnan(got[0])
    assert np.isnan(got[1])
    assert got[2] == pytest.approx(0.0)  # 180° roll, no yaw


def test_velocity_gives_heading_and_speed() -> None:
    est = HeadingEstimator()
    b = est.estimate([0, 0], np.zeros((2, 3)), [[0.0, 1.0, 0.0], [-3.0, -4.0, 9.0]], [0.5, 0.5])
    assert b.heading[0] == pytest.approx(math.pi / 2)
    assert b.speed[0] == pytest.approx(1.0)
    assert b.heading[1] == pytest.approx(math.atan2(-4.0, -3.0))
    assert b.speed[1] == pytest.approx(5.0)  # horizontal speed


def test_yaw_is_the_fallback_without_velocity_or_track() -> None:
    est = HeadingEstimator()
    vel = [[np.nan] * 3, [0.0, 0.0, 0.0]]  # unknown, and zero (standing: no direction)
    b = est.estimate([0, 0], np.zeros((2, 3)), vel, [0.7, np.nan])
    assert b.heading[0] == pytest.approx(0.7)
    assert np.isnan(b.heading[1])
    assert np.isnan(b.speed).all()
    np.testing.assert_array_equal(b.track_id, [-1, -1])


def test_track_walking_plus_x_has_heading_zero() -> None:
    est = HeadingEstimator()
    xyz = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    b = est.estimate([0, S, 2 * S], xyz, None, [2.0, 2.0, 2.0], [7, 7, 7])
    assert b.heading[0] == pytest.approx(2.0)  # first sighting: pose yaw
    np.testing.assert_allclose(b.heading[1:], [0.0, 0.0])
    np.testing.assert_allclose(b.speed[1:], [1.0, 1.0])
    assert np.isnan(b.speed[0])


def test_rows_of_interleaved_tracks_and_unsorted_times() -> None:
    est = HeadingEstimator()
    t = [2 * S, 0, S, 0, 2 * S]
    xyz = [[0, -4, 0], [0, 0, 0], [-1, 0, 0], [0, 0, 0], [-2, 0, 0]]
    k = [3, 3, 8, 8, 8]
    b = est.estimate(t, xyz, None, None, k)
    assert b.heading[0] == pytest.approx(-math.pi / 2)
    assert b.speed[0] == pytest.approx(2.0)
    np.testing.assert_allclose(b.heading[[2, 4]], [math.pi, math.pi])
    assert np.isnan(b.heading[[1, 3]]).all()
    np.testing.assert_array_equal(b.t_ns, t)  # order kept


def test_differencing_across_calls() -> None:
    est = HeadingEstimator()
    first = est.estimate([0], [[5.0, 5.0, 0.0]], None, None, [42])
    assert np.isnan(first.heading[0])
    second = est.estimate([S // 2], [[5.0, 4.0, 1.0]], None, None, [42])
    assert second.heading[0] == pytest.approx(-math.pi / 2)
    assert second.speed[0] == pytest.approx(2.0)
    assert len(est) == 1


def test_small_moves_keep_the_previous_heading_until_the_minimum_displacement() -> None:
    est = HeadingEstimator(min_displacement=0.05)
    est.estimate([0, S], [[0, 0, 0], [1, 0, 0]], None, None, [1, 1])  # heading 0
    steps = [[1.0, 0.02 * i, 0.0] for i in range(1, 4)]
    b = est.estimate([S + i * S // 10 for i in range(1, 4)], steps, None, None, [1, 1, 1])
    np.testing.assert_allclose(b.heading[:2], [0.0, 0.0])  # 0.02, 0.04 m: keep heading 0
    assert b.heading[2] == pytest.approx(math.pi / 2)  # 0.06 m from the reference
    assert b.speed[2] == pytest.approx(0.06 / 0.3)


def test_a_stale_track_starts_over() -> None:
    est = HeadingEstimator(max_gap_s=5.0)
    est.estimate([0, S], [[0, 0, 0], [1, 0, 0]], None, None, [1, 1])
    b = est.estimate([20 * S], [[0.0, 3.0, 0.0]], None, [1.25], [1])
    assert b.heading[0] == pytest.approx(1.25)  # not differenced over 19 s: yaw
    assert np.isnan(b.speed[0])


def test_velocity_beats_differencing_and_sets_the_previous_heading() -> None:
    est = HeadingEstimator()
    b = est.estimate(
        [0, S, 2 * S],
        [[0, 0, 0], [1, 0, 0], [1.01, 0, 0]],
        [[np.nan] * 3, [0.0, -2.0, 0.0], [np.nan] * 3],
        None,
        [4, 4, 4],
    )
    assert b.heading[1] == pytest.approx(-math.pi / 2)
    assert b.speed[1] == pytest.approx(2.0)
    assert b.heading[2] == pytest.approx(-math.pi / 2)  # moved 0.01 m: previous kept


def test_to_batch_from_frame_detections() -> None:
    z = np.zeros(2, np.int64)
    det = FrameDetections(
        np.array([0, S]), np.array([[0.0, 0, 0], [0, 1, 0]]), np.full((2, 3), np.nan),
        np.full(2, np.nan), np.array([9, 9]), z, ("map",), z, 1,
    )
    b = HeadingEstimator().to_batch(det)
    assert b.heading[1] == pytest.approx(math.pi / 2)
    np.testing.assert_array_equal(b.track_id, [9, 9])


def test_bad_parameters() -> None:
    with pytest.raises(ConfigError, match="min_displacement"):
        HeadingEstimator(min_displacement=-1.0)


def test_stale_tracks_are_pruned_without_changing_results() -> None:
    pruned = HeadingEstimator(max_gap_s=5.0, prune_above=1)
    kept = HeadingEstimator(max_gap_s=5.0)
    calls = [
        ([0, 0], [[0, 0, 0], [5, 5, 0]], [1, 2]),
        ([S, S], [[1, 0, 0], [5, 6, 0]], [1, 2]),
        ([10 * S], [[2, 0, 0]], [3]),  # tracks 1 and 2 are now stale
        ([11 * S, 11 * S], [[1, 1, 0], [3, 0, 0]], [1, 3]),
    ]
    for t, xyz, k in calls:
        a = pruned.estimate(t, xyz, None, None, k)
        b = kept.estimate(t, xyz, None, None, k)
        np.testing.assert_array_equal(a.heading, b.heading)
        np.testing.assert_array_equal(a.speed, b.speed)
    assert len(kept) == 3
    assert len(pruned) == 2  # track 2 forgotten
