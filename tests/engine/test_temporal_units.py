"""The temporal model's parts against independent answers: calendar, FreMEn spectrum,
shrinkage, pending-day bookkeeping, batching independence."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.calendar import Calendar
from aion_cli.engine.temporal.forecast import Forecaster, PoolStats, shrunk_rate
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows, PendingDay
from aion_cli.engine.temporal.spectrum import admitted, top_periods
from aion_cli.engine.windows import to_model_seconds
from aion_cli.errors import ConfigError

S = 1_000_000_000


def ns(*args: int) -> int:
    return int(datetime(*args, tzinfo=UTC).timestamp()) * S


def test_profile_bins_follow_the_local_clock_and_weekends() -> None:
    cal = Calendar("Europe/London", "day_weekend")
    # 2017-06-09 was a Friday; 16:30 UTC is 17:30 British Summer Time
    assert cal.profile_bin([ns(2017, 6, 9, 16, 30)])[0] == 17
    # Saturday 2017-06-10 09:00 BST = 08:00 UTC -> weekend bin 24 + 9
    assert cal.profile_bin([ns(2017, 6, 10, 8, 0)])[0] == 33
    # in winter London is on UTC
    assert cal.profile_bin([ns(2017, 1, 9, 16, 30)])[0] == 16
    # the local day changes at local midnight: 23:30 UTC on June 9 is already June 10 in BST
    assert cal.day([ns(2017, 6, 9, 23, 30)])[0] == cal.day([ns(2017, 6, 10, 12, 0)])[0]
    week = Calendar("UTC", "week")
    assert week.n_bins == 168
    assert week.profile_bin([ns(2026, 11, 2, 0, 0)])[0] == 0  # a Monday
    assert week.profile_bin([ns(2026, 11, 8, 23, 59)])[0] == 167  # the Sunday after
    assert Calendar("+09:00", "day").profile_bin([ns(2012, 10, 24, 0, 20)])[0] == 9


def test_a_change_at_a_utc_half_hour_is_taken_when_it_happens() -> None:
    """St John's leaves summer time on 2026-11-01 at 02:00 NDT = 04:30 UTC (-02:30 to
    -03:30). 04:40 UTC is 01:10 NST, hour bin 1 (a lookup per UTC hour kept -02:30 until
    05:00: 02:10, bin 2); 04:20 UTC is still 01:50 NDT. The spring change, 2026-03-08 at
    02:00 NST = 05:30 UTC: 05:40 UTC is 03:10 NDT (not 02:10, an hour that day has not)."""
    from zoneinfo import ZoneInfo

    cal = Calendar("America/St_Johns", "day")
    zone = ZoneInfo("America/St_Johns")
    times = [ns(2026, 11, 1, 4, 40), ns(2026, 11, 1, 4, 20), ns(2026, 3, 8, 5, 40),
             ns(2026, 3, 8, 5, 20)]
    expected = [datetime.fromtimestamp(t / S, tz=zone).hour for t in times]
    assert expected == [1, 1, 3, 1]
    assert cal.profile_bin(times).tolist() == expected


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"timezone": "Mars/Olympus"}, "unknown time zone"),
        ({"timezone": "+25:00"}, "out of range"),
        ({"profile": "month"}, "profile must be one of"),
        ({"profile_bin_s": 7000.0}, "whole bins"),
        ({"families": ["static", "lstm"]}, "families must be"),
        ({"window_s": 2 * 86400.0}, "at most a day"),
    ],
)
def test_bad_temporal_parameters_are_config_errors(kwargs: dict, fragment: str) -> None:
    with pytest.raises(ConfigError, match=fragment):
        ModelConfig(**kwargs)


def test_config_round_trips_the_new_parameters_through_toml() -> None:
    cfg = ModelConfig(timezone="Asia/Tokyo", families=["static", "profile"], profile="week")
    assert ModelConfig.from_toml_text(cfg.to_toml()) == cfg


@given(
    counts=st.integers(0, 10_000).map(float),
    windows=st.integers(0, 10_000).map(float),
    prior=st.floats(1e-6, 10.0),
    c=st.one_of(st.just(0.0), st.floats(1e-3, 100.0)),
)
@settings(max_examples=200, deadline=None)
def test_shrunk_rate_lies_between_the_own_rate_and_the_prior(
    counts: float, windows: float, prior: float, c: float
) -> None:
    if windows == 0:
        counts = 0.0  # nothing is counted where nothing was observed
    rate = float(shrunk_rate(np.array([counts]), np.array([windows]), np.array([prior]), c)[0])
    if windows == 0:
        assert rate == pytest.approx(prior)
        return
    own = counts / windows
    lo, hi = sorted((own, prior))
    assert lo - 1e-9 * (1 + hi) <= rate <= hi + 1e-9 * (1 + hi)


def _one_entry_state(
    params: TemporalParams, t_ns: np.ndarray, counts: np.ndarray, window_ns: int
) -> TemporalParams:
    """Learn one entry seen in every window (a fixed sensor), counts in the last value bin."""
    state = temporal.empty_state(params, 1)
    windows = np.floor_divide(t_ns, window_ns)
    has = np.flatnonzero(counts > 0)
    values = np.zeros((has.size, params.values))
    values[:, -1] = counts[has]
    day = DayWindows(
        windows, np.ones(windows.size, bool), np.zeros(0, np.int64), np.zeros(0, np.int64),
        np.zeros(has.size, np.int64), has.astype(np.int64), values,
    )
    one = np.zeros(1, np.int64)
    temporal.learn(params, state, day, one, one, 1, window_ns)
    return state


def test_fremen_recovers_a_known_daily_sinusoid_under_uneven_observation() -> None:
    """Rate 4 + 3 cos(2π t / 24 h − 1) = 4 + 2 Re(γ e^{−iωt}) with γ = 1.5 e^{i} for the 24 h
    period, whatever windows were dropped (every third day unobserved)."""
    params = TemporalParams.from_config(ModelConfig())
    window_ns = 600 * S
    start = ns(2026, 11, 2)
    t = start + np.arange(30 * 144) * window_ns + window_ns // 2
    keep = (np.arange(t.size) // 144) % 3 != 2
    t = t[keep]
    t_s = to_model_seconds(t)
    rate = 4.0 + 3.0 * np.cos(2 * np.pi * t_s / 86400.0 - 1.0)
    state = _one_entry_state(params, t, rate, window_ns)
    one = np.zeros(1, np.int64)
    pool = PoolStats.of(params, state, one, one, 1)
    fc = Forecaster(params, state, one, one, pool)
    day = list(params.config.periods).index(86400.0)
    assert fc.period_idx[0, 0] == day
    assert fc.coef_total[0, 0] == pytest.approx(1.5 * np.exp(1j), abs=1e-6)
    assert fc.rate_total[0] == pytest.approx(rate.mean(), rel=1e-9)
    probe = to_model_seconds(np.array([start + 40 * 86400 * S + 5 * 3600 * S]))
    expected = 4.0 + 3.0 * np.cos(2 * np.pi * probe / 86400.0 - 1.0)
    got = fc.flow("fremen1", one, np.zeros(1, np.int64), probe)
    assert got[0] == pytest.approx(expected[0], abs=1e-4)


def test_the_span_gate_and_top_periods() -> None:
    gate = admitted(np.array([0.0, np.nan]), np.array([100.0, np.nan]), np.array([50.0, 200.0]))
    np.testing.assert_array_equal(gate, [[True, False], [False, False]])
    gamma = np.array([[1 + 0j, 3 + 0j, 2 + 0j]])
    idx, valid = top_periods(gamma, np.array([[True, False, True]]), 3)
    np.testing.assert_array_equal(idx[0, :2], [2, 0])
    np.testing.assert_array_equal(valid[0], [True, True, False])


def test_pending_windows_follow_a_moved_entry() -> None:
    pending = PendingDay(values=3)
    pending.add_window(7, 100, False, [1, 2], [1, 2], [[1, 0, 0], [0, 2, 0]])
    pending.add_window(7, 101, False, [2], [2], [[0, 0, 5]])
    pending.remap(np.array([1]), np.array([2]))
    day = pending.consolidated()
    np.testing.assert_array_equal(np.unique(day.obs_entry), [2])
    # the node is observed once per window (a union), its counts are the sums
    assert day.obs_entry.size == 2
    np.testing.assert_array_equal(day.cnt_entry, [2, 2])
    np.testing.assert_array_equal(day.cnt_values, [[1, 2, 0], [0, 0, 5]])
    with pytest.raises(ValueError, match="day"):
        pending.add_window(8, 102, False, [], [], np.zeros((0, 3)))
    with pytest.raises(ValueError, match="increasing"):
        pending.add_window(7, 101, False, [], [], np.zeros((0, 3)))


def test_a_consolidated_day_is_kept_until_its_windows_change() -> None:
    """A map's write asks for the pending day several times: it is consolidated once,
    read-only, and again after every change (a window, an observation, a move, a reload)."""
    pending = PendingDay(values=2)
    pending.add_window(7, 100, False, [1], [1, 1], [[1, 0], [2, 0]])
    first = pending.consolidated()
    assert pending.consolidated() is first
    assert not first.cnt_values.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        first.cnt_values[0, 0] = 9.0
    np.testing.assert_array_equal(first.cnt_values, [[3, 0]])
    pending.add_window(7, 101, False, [3], [3], [[0, 4]])
    second = pending.consolidated()
    assert second is not first
    np.testing.assert_array_equal(second.cnt_entry, [1, 3])
    pending.add_observed(0, np.array([5]))
    third = pending.consolidated()
    np.testing.assert_array_equal(third.obs_entry, [1, 3, 5])
    pending.remap(np.array([3]), np.array([1]))
    fourth = pending.consolidated()
    np.testing.assert_array_equal(fourth.cnt_entry, [1, 1])
    np.testing.assert_array_equal(fourth.cnt_values, [[3, 0], [0, 4]])
    pending.relabel(np.arange(10)[::-1])
    np.testing.assert_array_equal(pending.consolidated().cnt_entry, [8, 8])
    pending.clear()
    assert pending.consolidated().cnt_entry.size == 0


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=25, deadline=None)
def test_consolidated_counts_are_np_add_at_bit_for_bit(seed: int) -> None:
    """Repeated (entry, slot) pairs are summed in their order from 0.0, as ``np.add.at`` on
    zeros sums them, and pairs that do not repeat are only sorted: the same floats, not
    merely close ones."""
    rng = np.random.default_rng(seed)
    pending = PendingDay(values=4)
    parts = []
    for w in range(int(rng.integers(1, 5))):
        n = int(rng.integers(1, 30))
        # repeated rows in a window (as moves make them), or none (the common case)
        rows = rng.integers(0, 6, n) if seed % 2 else rng.permutation(40)[:n]
        vals = rng.random((rows.size, 4)) * 10.0 ** rng.integers(-8, 8, (rows.size, 4))
        pending.add_window(3, 50 + w, False, [], rows, vals)
        parts.append((rows, np.full(rows.size, w), vals))
    rows, slots, vals = (np.concatenate(p) for p in zip(*parts, strict=True))
    keys, inverse = np.unique(rows * 100 + slots, return_inverse=True)
    expected = np.zeros((keys.size, 4))
    np.add.at(expected, inverse, vals)
    day = pending.consolidated()
    assert day.cnt_values.tobytes() == expected.tobytes()
    np.testing.assert_array_equal(day.cnt_entry * 100 + day.cnt_slot, keys)


def test_learning_is_independent_of_how_days_are_batched() -> None:
    """Three days learnt in one call equal the days learnt one by one (scores included)."""
    rng = np.random.default_rng(3)
    params = TemporalParams.from_config(ModelConfig())
    window_ns = 600 * S
    t = ns(2026, 11, 2) + np.arange(3 * 144) * window_ns
    counts = rng.poisson(2.0 + np.sin(np.arange(t.size) / 20.0), t.size).astype(float)
    whole = _one_entry_state(params, t, counts, window_ns)
    parts = temporal.empty_state(params, 1)
    one = np.zeros(1, np.int64)
    for d in range(3):
        sl = slice(d * 144, (d + 1) * 144)
        has = np.flatnonzero(counts[sl] > 0)
        values = np.zeros((has.size, params.values))
        values[:, -1] = counts[sl][has]
        day = DayWindows(
            np.floor_divide(t[sl], window_ns), np.ones(144, bool), np.zeros(0, np.int64),
            np.zeros(0, np.int64), np.zeros(has.size, np.int64), has.astype(np.int64), values,
        )
        temporal.learn(params, parts, day, one, one, 1, window_ns)
    for name in ("cnt_fourier", "cnt_profile", "flow_score", "flow_chi2", "flow_scored"):
        np.testing.assert_allclose(getattr(parts, name), getattr(whole, name), rtol=1e-12)
    assert float(whole.flow_scored[0]) == 2 * 144  # the first day has nothing to be scored by
