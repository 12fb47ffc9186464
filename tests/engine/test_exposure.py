"""A robot window counts by the share of it the robot observed each entry in (its exposure).

The known answers: a robot that spends nine tenths of every window beside place A and one
tenth beside place B, where people pass at the same true rate, sees nine times more at A. Its
map must still give both places the same flow per window — the true one — and, with exposure
switched off (the paper's whole windows), the nine-to-one it saw.
"""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.observation import SUBSTEPS, ObservationSource
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.types import Trajectory
from aion_cli.errors import MapCorruptError
from tests.engine.engine_builders import T0, T0_DAY_END, S, check_invariants, detections

W = 600 * S
A, B = np.array([0.0, 0.0, 0.0]), np.array([40.0, 0.0, 0.0])  # 40 m apart, sensor range 8 m
DEFAULT = ModelConfig(window_s=600.0, sensor_range=8.0)
CFG = DEFAULT.replace(exposure_floor=1.0 / SUBSTEPS)  # every share as measured


def _dwelling_robot(windows: int, share_a: float, hz: float = 1.0) -> Trajectory:
    """Poses at ``hz``: at A for the first ``share_a`` of every window, then at B."""
    t = T0 + np.arange(0, windows * W, int(S / hz), dtype=np.int64)
    at_a = (t - T0) % W < share_a * W
    xyz = np.where(at_a[:, None], A, B)
    return Trajectory(t, xyz)


def test_exposure_is_the_share_of_the_window_in_range() -> None:
    source = ObservationSource()
    source.add_trajectory(_dwelling_robot(1, 0.9))
    far = np.array([[100.0, 0.0]])
    points = np.vstack([A[:2], B[:2], far])
    window = T0 // W
    exposure = source.robot_exposure(points, window, W, 8.0)
    np.testing.assert_allclose(exposure, [0.9, 0.1, 0.0], atol=1.0 / SUBSTEPS)
    # the same entries observed as the whole-window test says; whole windows without exposure
    np.testing.assert_array_equal(exposure > 0, source.robot_observed(points, window, W, 8.0))
    whole = CFG.replace(exposure=False)
    np.testing.assert_array_equal(source.coverage(points, window, W, whole), [1, 1, 0])
    # the model's default floor: a tenth of a window counts as a fifth
    np.testing.assert_allclose(source.coverage(points, window, W, DEFAULT), [0.9, 0.2, 0.0])


def test_a_lone_pose_covers_half_a_minute_each_side_and_never_less_than_a_step() -> None:
    source = ObservationSource()
    source.add_trajectory(Trajectory(np.array([T0 + 300 * S]), np.array([A])))
    window = T0 // W
    # steps of 10 s whose middles lie within 30 s of 300 s: 275 ... 325 s, six of sixty
    got = source.robot_exposure(np.array([A[:2]]), window, W, 8.0)
    assert got[0] == pytest.approx(6 / SUBSTEPS)
    # a pose just inside the window, whose nearest step holds another pose out of range
    edge = ObservationSource()
    edge.add_trajectory(
        Trajectory(np.array([T0 + 1 * S, T0 + 4 * S]), np.array([A, B]))  # A, then B
    )
    got = edge.robot_exposure(np.array([A[:2]]), window, W, 8.0)
    assert 1.0 / SUBSTEPS <= got[0] < 1.0


def _dwell_map(exposure: bool, families: tuple[str, ...] | None = None) -> Mapper:
    """12 windows: people pass A and B at 100 detections per full window; the robot sees A
    90 % and B 10 % of every window, so it records 90 and 10 a window."""
    windows = 12
    config = CFG.replace(exposure=exposure)
    m = Mapper(config if families is None else config.replace(families=families))
    m.add_trajectory(_dwelling_robot(windows, 0.9))
    _people(m, windows)
    check_invariants(m.state)
    return m


def _people(m: Mapper, windows: int) -> None:
    """One detection every 6 s at each of A and B, recorded only while the robot is there
    (A for the first 540 s of every window, B for the last 60), in time order."""
    seconds = np.arange(0, windows * 600, 6)
    seen_a = (seconds % 600) < 540
    xyz = np.where(seen_a[:, None], A + 0.1, B + 0.1)
    m.add_detections(detections(T0 + seconds * S, xyz))
    m.advance(T0 + windows * W)


def _at(table: object, place: np.ndarray) -> int:
    xyz = table.xyz[:, :2]  # type: ignore[attr-defined]
    hit = np.flatnonzero(np.linalg.norm(xyz - place[:2] - 0.1, axis=1) < 0.5)
    assert hit.size == 1
    return int(hit[0])


@pytest.mark.parametrize("exposure", [True, False])
def test_places_seen_for_different_shares_of_a_window_get_their_true_rate(
    exposure: bool,
) -> None:
    table = historical_table(_dwell_map(exposure).state)
    flow_a, flow_b = float(table.flow[_at(table, A)]), float(table.flow[_at(table, B)])
    if exposure:  # 540 detections in 5.4 windows' worth of watching; 60 in 0.6
        assert flow_a == pytest.approx(100.0)
        assert flow_b == pytest.approx(100.0)
    else:  # the paper's whole windows: what the robot happened to see
        assert flow_a == pytest.approx(90.0)
        assert flow_b == pytest.approx(10.0)


def test_static_forecast_equals_the_historical_flow_under_exposure() -> None:
    state = _dwell_map(True, ("static",)).state
    history = historical_table(state)
    for hour in (3, 12):
        predicted = predict_table(state, T0 + hour * 3600 * S)
        np.testing.assert_allclose(predicted.flow, history.flow, rtol=1e-9, atol=0)


def test_pending_day_keeps_the_largest_exposure_of_a_pair_and_round_trips() -> None:
    day = PendingDay(3)
    day.add_window(0, 10, False, np.array([1, 2]), np.array([1]), np.ones((1, 3)), [0.5, 0.25])
    day.add_observed(0, np.array([2, 4]), np.array([0.75, 1.0]))
    merged = day.consolidated()
    np.testing.assert_array_equal(merged.obs_entry, [1, 2, 4])
    assert merged.obs_weight is not None
    np.testing.assert_array_equal(merged.obs_weight, [0.5, 0.75, 1.0])
    np.testing.assert_array_equal(merged.count_weights(), [0.5])
    arrays, meta = day.to_arrays("p_", np.arange(5))
    back = PendingDay.from_arrays(arrays, "p_", meta, 3, 5).consolidated()
    assert back.obs_weight is not None
    np.testing.assert_array_equal(back.obs_weight, merged.obs_weight)
    # whole windows only: no weights stored, none read
    whole = PendingDay(3)
    whole.add_window(0, 10, False, np.array([1]), np.zeros(0, np.int64), np.zeros((0, 3)))
    arrays, meta = whole.to_arrays("p_", np.arange(5))
    assert "p_obs_weight" not in arrays
    assert PendingDay.from_arrays(arrays, "p_", meta, 3, 5).consolidated().obs_weight is None


@pytest.mark.parametrize("bad", [[0.0], [1.5], [np.nan], [0.5, 0.5]])
def test_bad_exposures_are_refused(bad: list[float]) -> None:
    day = PendingDay(3)
    with pytest.raises(ValueError, match="exposure"):
        day.add_window(0, 10, False, np.array([1]), np.zeros(0, np.int64), np.zeros((0, 3)), bad)
    good = PendingDay(3)
    good.add_window(0, 10, False, np.array([1]), np.zeros(0, np.int64), np.zeros((0, 3)), [0.5])
    arrays, meta = good.to_arrays("p_", np.arange(5))
    arrays["p_obs_weight"] = np.array(bad)  # out of (0, 1], or one too many
    with pytest.raises(MapCorruptError):
        PendingDay.from_arrays(arrays, "p_", meta, 3, 5)


def test_day_scores_expect_a_rate_times_the_share_watched() -> None:
    """Three days of the dwelling robot, people at exactly 100 detections per full window:
    the day-ahead static forecast of B (watched a tenth of each window, 10 seen) expects 10
    in each window: its log-likelihood is 10 log 10 − 10 a window and its Pearson χ² ~0."""
    windows = 3 * 144
    m = Mapper(CFG.replace(families=("static",)))
    m.add_trajectory(_dwelling_robot(windows, 0.9, hz=0.5))
    _people(m, windows)
    m.state.close_day()
    table = historical_table(m.state)
    tmp = m.state.temporal
    static = m.state.params.flow.index("static")
    first_day = (T0_DAY_END - T0) // W  # the first day's windows: nothing before to forecast
    for place, share in ((A, 0.9), (B, 0.1)):
        assert float(table.flow[_at(table, place)]) == pytest.approx(100.0)
        rows = m.state.entries.live_rows()
        xyz = m.state.entries.xyz[rows, :2]
        r = rows[np.flatnonzero(np.linalg.norm(xyz - place[:2] - 0.1, axis=1) < 0.5)[0]]
        scored = windows - first_day
        assert float(tmp.flow_scored[r]) == scored  # whole windows (test_exposure_counts)
        # Poisson log-likelihood (without log n!) of n = 100·share seen a window against
        # the forecast 100·share: the forecast 100 would score n log 100 − 100·share
        n = 100.0 * share
        score = float(tmp.flow_score[r, static])
        assert score == pytest.approx(scored * (n * np.log(n) - n), rel=1e-6)
        assert float(tmp.flow_chi2[r, static]) / scored < 0.5


def test_the_floor_bounds_what_a_brief_look_can_claim() -> None:
    """With the default floor (a fifth of a window), B's 10 detections a window read as 50,
    not 100: a look shorter than two minutes never claims more than five times what it saw."""
    m = Mapper(DEFAULT)
    m.add_trajectory(_dwelling_robot(12, 0.9))
    _people(m, 12)
    table = historical_table(m.state)
    assert float(table.flow[_at(table, A)]) == pytest.approx(100.0)
    assert float(table.flow[_at(table, B)]) == pytest.approx(50.0)


@pytest.mark.parametrize("floor", [0.0, -0.1, 1.5, float("nan"), "0.2"])
def test_a_bad_floor_is_refused(floor: object) -> None:
    from aion_cli.errors import ConfigError

    with pytest.raises(ConfigError, match="exposure_floor"):
        ModelConfig(exposure_floor=floor)  # type: ignore[arg-type]


def test_a_pending_day_is_stored_in_the_narrowest_exact_types() -> None:
    """Positions, slots and whole counts of the pending day are stored as small unsigned
    integers (a robot's day holds a pair per place it saw in every window) and read back
    equal; counts that are not whole, or too large, stay as they were."""
    from aion_cli.engine.temporal.stored_layout import narrowest_whole

    day = PendingDay(3)
    counts = np.array([[1.0, 0.0, 300.0]])
    day.add_window(0, 10, False, np.array([1, 2]), np.array([1]), counts, [0.5, 0.25])
    arrays, meta = day.to_arrays("p_", np.arange(5))
    assert arrays["p_obs_entry"].dtype == np.uint8
    assert arrays["p_obs_slot"].dtype == np.uint8
    assert arrays["p_cnt_values"].dtype == np.uint16
    back = PendingDay.from_arrays(arrays, "p_", meta, 3, 5).consolidated()
    before = day.consolidated()
    for name in ("obs_entry", "obs_slot", "cnt_entry", "cnt_slot", "cnt_values", "obs_weight"):
        np.testing.assert_array_equal(getattr(back, name), getattr(before, name))
        assert getattr(back, name).dtype == getattr(before, name).dtype
    for kept in (np.array([0.5, 1.0]), np.array([-1, 2]), np.array([2.0**33])):
        assert narrowest_whole(kept) is kept
