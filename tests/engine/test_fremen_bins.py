"""FreMEn's per-value-bin components (the per-bin rates and the direction families) against
answers known by construction: a constant stream has no rhythm in any bin however unevenly it
was observed, and a bin's own sinusoid is recovered with its amplitude and phase."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.forecast import Forecaster, PoolStats
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.windows import to_model_seconds

S = 1_000_000_000
WINDOW_NS = 600 * S
START = int(datetime(2026, 11, 2, tzinfo=UTC).timestamp()) * S  # a Monday
ONE = np.zeros(1, np.int64)


def _learn(params: TemporalParams, t_ns: np.ndarray, values: np.ndarray) -> TemporalState:
    """One entry seen by a fixed sensor in the windows of ``t_ns`` (so its observation is
    the global block) with ``values[w, v]`` detections in value bin v of window w."""
    state = temporal.empty_state(params, 1)
    windows = np.floor_divide(t_ns, WINDOW_NS)
    has = np.flatnonzero(values.sum(axis=1) > 0)
    day = DayWindows(
        windows, np.ones(windows.size, bool), np.zeros(0, np.int64), np.zeros(0, np.int64),
        np.zeros(has.size, np.int64), has.astype(np.int64), values[has],
    )  # fmt: skip
    temporal.learn(params, state, day, ONE, ONE, 1, WINDOW_NS)
    return state


def _forecaster(params: TemporalParams, state: TemporalState) -> Forecaster:
    return Forecaster(params, state, ONE, ONE, PoolStats.of(params, state, ONE, ONE, 1))


def _daytime_windows(days: int) -> np.ndarray:
    """Window centres of 06:00-18:00 UTC on ``days`` days: half of every day unobserved, so
    Σ e^{iωt} over the observed windows is far from 0 at the daily period."""
    t = START + np.arange(days * 144) * WINDOW_NS + WINDOW_NS // 2
    hour = (t - START) // (3600 * S) % 24
    out: np.ndarray = t[(hour >= 6) & (hour < 18)]
    return out


def test_constant_traffic_seen_only_by_day_has_no_rhythm_in_any_bin() -> None:
    """Counts c_v in every observed window: A_v = c_v B exactly, so γ_{v,k} = (A_v − μ_v B) / W
    is 0 at every period although B (the observed windows' phasors) is not — the forecast of
    every bin is its constant at any hour, the unobserved night included."""
    params = TemporalParams.from_config(ModelConfig())
    t = _daytime_windows(14)
    const = np.zeros(params.values)
    const[0], const[3], const[-1] = 2.0, 5.0, 1.0
    state = _learn(params, t, np.tile(const, (t.size, 1)))
    fc = _forecaster(params, state)
    day = list(params.config.periods).index(86400.0)
    assert abs(complex(state.glob.fourier[0, day])) > 0.3 * t.size  # the uneven observation
    np.testing.assert_allclose(fc.coef_total, 0.0, atol=1e-9)
    fc.ensure_bins(ONE, params.max_order)
    np.testing.assert_allclose(fc.coef_bins, 0.0, atol=1e-9)
    night = to_model_seconds(np.array([START + 20 * 86400 * S + 2 * 3600 * S]))
    for family in ("fremen1", params.flow[-2]):  # one period and all of them
        rates = fc.bin_rates(family, ONE, ONE, night)
        np.testing.assert_allclose(rates[0], const, atol=1e-9)
        assert fc.flow(family, ONE, ONE, night)[0] == pytest.approx(const.sum(), abs=1e-9)


def test_each_bins_own_daily_sinusoid_is_recovered() -> None:
    """Bin 0 follows 2 + 1.5 cos(ωt − 1), bin 1 follows 2 − 1.5 cos(ωt − 1) (opposite flows
    whose total is flat), seen over whole days with every third day dropped: per bin
    γ_v = ±0.75 e^{i} at the 24 h period, the total's daily coefficient 0."""
    params = TemporalParams.from_config(ModelConfig())
    t = START + np.arange(30 * 144) * WINDOW_NS + WINDOW_NS // 2
    t = t[(np.arange(t.size) // 144) % 3 != 2]
    wave = 1.5 * np.cos(2 * np.pi * to_model_seconds(t) / 86400.0 - 1.0)
    values = np.zeros((t.size, params.values))
    values[:, 0], values[:, 1] = 2.0 + wave, 2.0 - wave
    state = _learn(params, t, values)
    fc = _forecaster(params, state)
    day = list(params.config.periods).index(86400.0)
    fc.ensure_bins(ONE, 1)
    assert fc.bin_idx[0, 0, 0] == day
    assert fc.bin_idx[0, 1, 0] == day
    assert fc.coef_bins[0, 0, 0] == pytest.approx(0.75 * np.exp(1j), abs=1e-6)
    assert fc.coef_bins[0, 1, 0] == pytest.approx(-0.75 * np.exp(1j), abs=1e-6)
    np.testing.assert_allclose(fc.coef_total[0], 0.0, atol=1e-6)
    probe_ns = START + 40 * 86400 * S + 7 * 3600 * S
    probe = to_model_seconds(np.array([probe_ns]))
    expected = 1.5 * np.cos(2 * np.pi * probe[0] / 86400.0 - 1.0)
    rates = fc.bin_rates("fremen1", ONE, ONE, probe)[0]
    assert rates[0] == pytest.approx(2.0 + expected, abs=1e-4)
    assert rates[1] == pytest.approx(2.0 - expected, abs=1e-4)
    np.testing.assert_allclose(rates[2:], 0.0, atol=1e-9)


def test_orders_beyond_the_admitted_periods_add_nothing() -> None:
    """Ten 10-minute windows span 1.5 h between their centres: with span_factor 1.5 only the
    1 h period is admitted, so fremen2..4 have no further period and must forecast what
    fremen1 does — the constant counts, at any time (an order without a period has γ = 0)."""
    params = TemporalParams.from_config(ModelConfig())
    assert params.config.span_factor == 1.5
    t = START + 8 * 3600 * S + np.arange(10) * WINDOW_NS + WINDOW_NS // 2
    const = np.zeros(params.values)
    const[0], const[-1] = 1.0, 3.0
    state = _learn(params, t, np.tile(const, (t.size, 1)))
    fc = _forecaster(params, state)
    periods = np.array(params.config.periods)
    assert periods[fc._gate[0]].tolist() == [3600.0]
    np.testing.assert_array_equal(fc.coef_total[0, 1:], 0.0)
    later = to_model_seconds(START + np.array([2, 13, 30]) * 3600 * S + 17 * S)
    e, h = np.zeros(3, np.int64), np.zeros(3, np.int64)
    for order in range(1, params.max_order + 1):
        family = f"fremen{order}"
        np.testing.assert_allclose(fc.flow(family, e, h, later), const.sum(), atol=1e-9)
        np.testing.assert_allclose(fc.bin_rates(family, e, h, later), [const] * 3, atol=1e-9)
