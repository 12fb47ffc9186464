"""The pooled shapes' prior: the burstiness φ of window totals and the empirical-Bayes strength,
and what they are for: sparse entries follow a rhythm their map clearly has, even when its
detections come in bursts."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.query import predict_table
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.shape_prior import (
    day_chi2,
    group_shapes,
    overdispersion,
    prior_strength,
)
from aion_cli.engine.types import F64
from aion_cli.errors import MapCorruptError
from tests.engine.temporal_data import DAY, HOUR, MONDAY, bursty_corridor

SLOTS = 144  # a day of 10-minute windows
HOURS = np.arange(SLOTS) // 6


def _fixed_day(totals: F64) -> DayWindows:
    """A fixed sensor's day whose window totals are ``totals`` (one entry holds them all)."""
    slots = np.arange(totals.size)
    has = totals > 0
    values = np.zeros((int(has.sum()), 9))
    values[:, 8] = totals[has]
    none = np.zeros(0, np.int64)
    fixed = np.ones(totals.size, bool)
    return DayWindows(slots, fixed, none, none, slots[has] * 0, slots[has], values)


def _phi(days: list[DayWindows]) -> float:
    return overdispersion(sum((day_chi2(d, HOURS, 24) for d in days), np.zeros(2)))


def _rhythm(level: float = 1.0) -> F64:
    """Expected detections per window by hour: quiet nights, a busy day."""
    out: F64 = level * np.where((HOURS >= 8) & (HOURS < 18), 6.0, 0.2)
    return out


def test_poisson_window_totals_are_not_bursty() -> None:
    rng = np.random.default_rng(1)
    days = [_fixed_day(rng.poisson(_rhythm()).astype(float)) for _ in range(10)]
    assert _phi(days) == pytest.approx(1.0, abs=0.15)


def test_detections_in_clumps_are_as_bursty_as_their_clumps() -> None:
    """Each walker detected 8 times in its window: the variance of a total is 8 times its mean."""
    rng = np.random.default_rng(2)
    days = [_fixed_day(8.0 * rng.poisson(_rhythm() / 8.0)) for _ in range(10)]
    assert _phi(days) == pytest.approx(8.0, rel=0.15)


def test_a_busier_day_is_a_level_not_burstiness() -> None:
    """Cells are (day, bin): a day three times busier than another adds nothing."""
    rng = np.random.default_rng(3)
    days = [_fixed_day(rng.poisson(_rhythm(1.0 + 2.0 * (k % 2))).astype(float)) for k in range(10)]
    assert _phi(days) == pytest.approx(1.0, abs=0.15)


def test_robot_windows_are_judged_by_the_entries_they_saw() -> None:
    """A robot sees 1 to 20 entries a window, each Poisson: the totals vary with what was seen,
    not by bursts (counted per window total alone, φ would be far above 1)."""
    rng = np.random.default_rng(4)
    days = []
    for _ in range(10):
        seen = rng.integers(1, 21, SLOTS)
        obs_slot = np.repeat(np.arange(SLOTS), seen)
        obs_entry = np.concatenate([np.arange(k) for k in seen])
        counts = rng.poisson(_rhythm()[obs_slot] / 4.0).astype(float)
        has = counts > 0
        values = np.zeros((int(has.sum()), 9))
        values[:, 0] = counts[has]
        days.append(
            DayWindows(
                np.arange(SLOTS),
                np.zeros(SLOTS, bool),
                obs_entry,
                obs_slot,
                obs_entry[has],
                obs_slot[has],
                values,
            )
        )
    assert _phi(days) == pytest.approx(1.0, abs=0.15)
    totals = np.array([v[:, 0].sum() for v in [d.cnt_values for d in days]])
    assert totals.min() > 0  # the days did have detections


def test_prior_strength_by_hand() -> None:
    """1/α = Σ[(S − W m)² − φ W m] / Σ (W m)²; c = α φ; bins at their parent's rate: inf."""
    w = np.array([10.0, 10.0, 10.0, 10.0])
    m = np.full(4, 0.5)
    s = np.array([0.0, 10.0, 0.0, 10.0])  # rates 0, 1, 0, 1 around 0.5
    phi = 2.0
    inv_alpha = ((25.0 - 10.0) * 4) / (25.0 * 4)
    assert prior_strength(s, w, m, phi) == pytest.approx(phi / inv_alpha)
    assert prior_strength(w * m, w, m, phi) == float("inf")
    assert prior_strength(s, w, m, 100.0) == float("inf")  # spread no larger than the noise


def test_one_days_spikes_are_shrunk_and_a_rhythm_is_kept() -> None:
    """The map's shape from one bursty day (bursts of 20 detections at random hours of a busy
    day) is shrunk toward flat where a Poisson reading would trust it; a rhythm seen on seven
    days with the same burstiness is kept (its nights at a twentieth of the day)."""
    rng = np.random.default_rng(6)
    w = np.full((1, 24), 60.0)
    hour = np.arange(24)
    busy = (hour >= 8) & (hour < 18)
    one_day = np.where(busy, 20.0 * rng.poisson(1.5, 24), 0.0)[None, :]
    bursty, _ = group_shapes(one_day, w, 20.0)
    poisson, _ = group_shapes(one_day, w, 1.0)
    assert np.ptp(bursty[0, busy]) < 0.5 * np.ptp(poisson[0, busy])
    week = np.where(busy, 20.0 * rng.poisson(10.5, 24), 0.0)[None, :]
    kept, _ = group_shapes(week, 7 * w, 20.0)
    assert kept[0, ~busy].max() < 0.1 * kept[0, busy].mean()


@pytest.mark.parametrize("seed", [1, 4])
def test_sparse_entries_follow_a_bursty_rhythm(seed: int) -> None:
    """Two days of a corridor busy 08-18 h, each person detected 20 times (the sensor starts at
    07:00 on the first day, as a robot's map starts with its first detections). Judged as
    Poisson, one day's spiky hour-of-day shape lost the day-ahead vote in these draws and 25
    and 21 of some 70 cells kept their flat mean all night; judged with the bursts every cell
    follows the rhythm (a bursty rhythm of one day is damped: the night is not yet empty)."""
    mapper = bursty_corridor(2, lambda d, h: 3.0 if 8 <= h < 18 else 0.0, 20, seed, first_hour=7)
    after = MONDAY + 2 * DAY
    night = predict_table(mapper.state, after + 3 * HOUR)
    day = predict_table(mapper.state, after + 11 * HOUR)
    assert "static" not in day.flow_family.tolist()
    periodic = np.isin(day.flow_family, ["shape", "profile"])
    assert periodic.mean() > 0.7  # the rest chose FreMEn
    assert np.all(night.flow[periodic] <= 0.5 * day.flow[periodic])
    assert np.nansum(night.flow) <= 0.5 * np.nansum(day.flow)


def test_bursty_traffic_without_a_rhythm_stays_static() -> None:
    mapper = bursty_corridor(3, lambda d, h: 3.0, 20, seed=0)
    after = MONDAY + 3 * DAY
    night = predict_table(mapper.state, after + 3 * HOUR)
    day = predict_table(mapper.state, after + 11 * HOUR)
    assert set(day.flow_family.tolist()) == {"static"}
    np.testing.assert_allclose(night.flow, day.flow)
    assert overdispersion(mapper.state.query_temporal().window_chi2) > 10.0  # bursts of 20


def test_window_chi2_is_stored_and_checked() -> None:
    mapper = bursty_corridor(2, lambda d, h: 3.0, 20, seed=0)
    state = mapper.state.query_temporal()
    rows = np.arange(state.n_rows)
    arrays = state.to_arrays("t_", rows)
    np.testing.assert_array_equal(arrays["t_window_chi2"], state.window_chi2)
    shape = (state.n_rows, state.n_values, state.n_periods, state.n_bins)
    families = (state.flow_score.shape[1], state.dir_score.shape[1])
    again = TemporalState.from_arrays(arrays, "t_", *shape, *families)
    np.testing.assert_array_equal(again.window_chi2, state.window_chi2)
    older = {k: v for k, v in arrays.items() if k != "t_window_chi2"}  # a map written before
    assert TemporalState.from_arrays(older, "t_", *shape, *families).window_chi2.tolist() == [0, 0]
    for bad in (np.array([1.0, -1.0]), np.array([np.nan, 1.0]), np.zeros(3)):
        with pytest.raises(MapCorruptError, match="window_chi2"):
            TemporalState.from_arrays({**arrays, "t_window_chi2": bad}, "t_", *shape, *families)
    zero = TemporalState.from_arrays({**arrays, "t_window_chi2": np.zeros(2)}, "t_", *shape,
                                     *families)  # fmt: skip
    assert zero.window_chi2.tolist() == [0, 0]  # no cell yet (a map of one window): valid


def test_an_unseen_kind_of_day_takes_the_hours_of_the_days_seen() -> None:
    """Hour of day × weekday / weekend (48 bins), weekdays observed only: every weekend bin
    takes the weekday bin of its hour (the pooled hour equals it, nothing else was seen), the
    weekday bins are the shape computed without kinds, and an hour no kind observed is flat.
    With both kinds observed nothing changes."""
    rng = np.random.default_rng(3)
    hour = np.arange(24)
    busy = (hour >= 8) & (hour < 18)
    weekday_s = np.where(busy, 20.0 * rng.poisson(8.0, 24), 0.0)
    weekday_w = np.full(24, 300.0)
    weekday_w[2] = 0.0  # 02:00 never observed on any day
    weekday_s[2] = 0.0
    s = np.concatenate([weekday_s, np.zeros(24)])[None, :]
    w = np.concatenate([weekday_w, np.zeros(24)])[None, :]
    groups, shape = group_shapes(s, w, 5.0, bins_per_day=24)
    _, without_kinds = group_shapes(s, w, 5.0)
    np.testing.assert_array_equal(shape[:24], without_kinds[:24])
    np.testing.assert_array_equal(shape[24:], shape[:24])
    assert shape[2] == shape[26] == pytest.approx(1.0)  # the flat rate: no kind saw 02:00
    np.testing.assert_allclose(without_kinds[24:], 1.0)  # before: a flat weekend
    assert shape[24 + 3] < 0.05 * shape[24 + 9]  # the weekend's night stays a night
    np.testing.assert_array_equal(groups[0], shape)  # one group: the map's shape
    # both kinds seen at every hour (a quiet weekend): bins_per_day changes nothing
    both_w = np.concatenate([np.full(24, 300.0), np.full(24, 100.0)])[None, :]
    both_s = np.concatenate([weekday_s, np.where(busy, 2.0, 0.0)])[None, :]
    np.testing.assert_array_equal(
        group_shapes(both_s, both_w, 5.0, bins_per_day=24)[1], group_shapes(both_s, both_w, 5.0)[1]
    )
    # 02:00 seen on the weekend only: the weekdays' 02:00 takes it
    both_w[0, 2] = 0.0
    shape = group_shapes(both_s, both_w, 5.0, bins_per_day=24)[1]
    assert shape[2] == shape[26] < 0.05 * shape[9]  # its night, as the weekend saw it


def test_chi2_of_one_cell_by_hand() -> None:
    """χ² = (Σ_s T_s² / m_s) / ρ − Σ T over a (day, bin) cell's observed slots, df = n − 1.
    Hour 1 of a fixed sensor's day: 6 windows, detections 1 and 3 in two of them, ρ = 4 / 6,
    χ² = 10 / (2/3) − 4 = 11 on 5 degrees of freedom (the empty windows were observed).
    A day that recorded only those two windows: ρ = 2, χ² = 10 / 2 − 4 = 1 on 1 — the
    smallest cell that counts."""
    totals = np.zeros(SLOTS)
    totals[[6, 7]] = [1.0, 3.0]
    np.testing.assert_allclose(day_chi2(_fixed_day(totals), HOURS, 24), [11.0, 5.0])
    two = _fixed_day(np.array([1.0, 3.0]))
    np.testing.assert_allclose(day_chi2(two, np.array([1, 1]), 24), [1.0, 1.0])
    one = _fixed_day(np.array([4.0]))
    np.testing.assert_array_equal(day_chi2(one, np.array([1]), 24), [0.0, 0.0])


def test_a_robot_window_that_saw_no_entry_says_nothing() -> None:
    """A robot window (not fixed) in which no entry was observed and nothing detected is not
    a slot of any cell: adding it to a day changes neither χ² nor its degrees of freedom."""
    slots = np.arange(4)
    values = np.zeros((3, 9))
    values[:, 8] = [2.0, 5.0, 1.0]
    seen = DayWindows(slots[:3], np.zeros(3, bool), np.array([0, 0, 1]), slots[:3],
                      np.array([0, 0, 1]), slots[:3], values)  # fmt: skip
    plus_empty = DayWindows(slots, np.zeros(4, bool), seen.obs_entry, seen.obs_slot,
                            seen.cnt_entry, seen.cnt_slot, values)  # fmt: skip
    base = day_chi2(seen, np.zeros(3, np.int64), 24)
    assert base[1] == 2.0  # three robot slots of one hour: df 2
    np.testing.assert_array_equal(day_chi2(plus_empty, np.zeros(4, np.int64), 24), base)


def test_edges_of_the_prior_strength_and_of_an_empty_map() -> None:
    """Bins whose spread is exactly their noise ((S − W m)² = φ W m) give no excess: inf, the
    parent's shape; a map without detections has flat shapes (ones), not 0 / 0; a group
    without detections has the map's shape."""
    assert prior_strength(np.array([2.0]), np.array([1.0]), np.array([1.0]), 1.0) == np.inf
    shapes, r_map = group_shapes(np.zeros((2, 24)), np.ones((2, 24)), 1.0)
    np.testing.assert_array_equal(shapes, 1.0)
    np.testing.assert_array_equal(r_map, 1.0)
    s_g = np.zeros((2, 24))
    s_g[0, 8:18] = 30.0  # a busy group with a day rhythm, and a group with no detections
    shapes, r_map = group_shapes(s_g, np.ones((2, 24)), 1.0)
    assert r_map[12] > 1.0 > r_map[2]
    np.testing.assert_array_equal(shapes[1], r_map)  # the map's shape, not zeros
