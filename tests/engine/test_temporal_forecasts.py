"""The temporal model against streams whose answer is known: rhythms learnt, families chosen,
the static invariant, shrinkage, spread."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.temporal.choice import count_quantiles
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor, rush, total_flow


def test_night_flow_is_at_most_5_percent_of_the_rush() -> None:
    mapper = corridor(14, rush)
    after = MONDAY + 14 * DAY
    night = total_flow(mapper, after + 3 * HOUR)
    morning = total_flow(mapper, after + 9 * HOUR)
    assert morning == pytest.approx(300.0 / 6, rel=0.1)  # 300 an hour, 6 windows an hour
    assert night <= 0.05 * morning
    table = predict_table(mapper.state, after + 9 * HOUR)
    temporal = np.isin(table.flow_family, ["shape", "profile"])
    assert temporal.mean() > 0.9  # the cells learnt the rhythm, not a static mean


def test_weekday_only_traffic_leaves_saturday_empty() -> None:
    weekdays = corridor(21, lambda d, h: 120.0 if d % 7 < 5 and 8 <= h < 18 else 0.0)
    after = MONDAY + 21 * DAY  # a Monday
    monday = total_flow(weekdays, after + 9 * HOUR)
    saturday = total_flow(weekdays, after + 5 * DAY + 9 * HOUR)
    assert monday == pytest.approx(20.0, rel=0.15)
    assert saturday <= 0.1 * monday


def test_stationary_traffic_keeps_the_static_family() -> None:
    mapper = corridor(10, lambda d, h: 60.0, cells=(4.0, 2.0))
    table = predict_table(mapper.state, MONDAY + 10 * DAY + 9 * HOUR)
    assert set(np.unique(table.flow_family)) == {"static"}
    assert table.direction_family.tolist().count("static") == len(table)
    assert float(np.nansum(table.flow)) == pytest.approx(10.0, rel=0.05)


def test_a_56_hour_rhythm_is_fremens_not_the_daily_profile() -> None:
    """Period 7 d / 3 = 56 h: in FreMEn's candidate set, invisible to an hour-of-day profile."""
    period_h = 56.0

    def rate(d: int, h: int) -> float:
        phase = 2 * np.pi * (d * 24 + h + 0.5) / period_h
        return 90.0 * (1.0 + np.cos(phase))

    mapper = corridor(21, rate, cells=(2.0, 1.0))
    table = predict_table(mapper.state, MONDAY + 21 * DAY)
    assert all(f.startswith("fremen") for f in table.flow_family.tolist())
    # the forecast follows the rhythm: a peak and a trough 28 h later
    t_peak = MONDAY + round(21 * 24 / period_h + 1) * round(period_h) * HOUR - HOUR // 2
    peak = total_flow(mapper, t_peak)
    trough = total_flow(mapper, t_peak + 28 * HOUR)
    assert peak == pytest.approx(180.0 / 6, rel=0.25)
    assert trough < 0.25 * peak


def test_static_only_predictions_equal_the_historical_map() -> None:
    config = ModelConfig(families=["static"], direction_prior=0.0)
    mapper = corridor(5, rush, config=config, heading=lambda d, h: 0.0 if h < 12 else 3.0)
    state = mapper.state
    hist = historical_table(state)
    for t in (MONDAY + 5 * DAY + 3 * HOUR, MONDAY + 5 * DAY + 9 * HOUR):
        pred = predict_table(state, t)
        np.testing.assert_allclose(pred.flow, hist.flow, rtol=0, atol=1e-9)
        np.testing.assert_allclose(
            pred.descriptors.probabilities, hist.descriptors.probabilities, atol=1e-9
        )
    # and the historical flow is the detections per observed window, counted independently
    rows = state.entries.live_rows()
    counts = state.entries.counts[rows].sum(axis=1) + state.entries.nodir[rows]
    windows = 5 * 144  # a fixed sensor over five days of 10-minute windows
    expected = np.sort(counts / windows)
    np.testing.assert_allclose(np.sort(hist.flow[np.isfinite(hist.flow)]), expected, rtol=1e-12)


def test_a_sparse_entry_borrows_its_neighbourhoods_directions() -> None:
    """One westbound detection in a corridor of eastbound people: the entry's histogram is
    pulled toward its neighbourhood's, by the documented Dirichlet prior."""
    from aion_cli.engine.types import DetectionBatch

    config = ModelConfig(direction_prior=2.0)
    mapper = corridor(2, lambda d, h: 50.0 if 8 <= h < 18 else 0.0, config=config, cells=(3.0, 3.0))
    t = MONDAY + 2 * DAY + HOUR  # after the corridor's days: the open window
    lone = DetectionBatch.from_arrays([t], [[3.9, 3.9, 0.0]], [np.pi - 0.01], [1.0])
    mapper.add_detections(lone)  # a cell of its own in the same 4-m neighbourhood
    state = mapper.state
    rows, predictor = state.predictor()
    entry = int(np.flatnonzero(state.entries.counts[rows].sum(axis=1) == 1)[0])
    fc = predictor.forecaster
    others = np.delete(np.arange(len(rows)), entry)
    group_counts = state.entries.counts[rows[others]].sum(axis=0) + np.eye(8)[7]
    total = state.entries.counts[rows].sum(axis=0)
    p_map = (total + 1.0) / (total.sum() + 8)
    p_group = (group_counts + 2.0 * p_map) / (group_counts.sum() + 2.0)
    expected = (np.eye(8)[7] + 2.0 * p_group) / 3.0
    np.testing.assert_allclose(fc.histogram[entry], expected, rtol=1e-9)
    assert fc.histogram[entry].min() > 0  # never a zero probability
    # mostly the corridor's eastward direction (heading 0 lies on the edge of bins 3 and 4)
    assert fc.histogram[entry][3] + fc.histogram[entry][4] > 0.5
    raw = predictor.historical().probabilities[entry]
    assert raw[7] == 1.0  # what was observed stays what was observed


def test_predictive_quantiles_are_poisson_without_overdispersion() -> None:
    mean = np.array([0.5, 3.0, 12.0])
    np.testing.assert_array_equal(
        count_quantiles(mean, mean, 0.9), stats.poisson.ppf(0.9, mean)
    )
    wide = count_quantiles(mean, 4 * mean, 0.9)
    assert np.all(wide >= stats.poisson.ppf(0.9, mean))
    assert np.isnan(count_quantiles(np.array([np.nan]), np.array([1.0]), 0.5)[0])


def test_spread_brackets_the_predicted_flow() -> None:
    mapper = corridor(7, rush)
    table = predict_table(mapper.state, MONDAY + 7 * DAY + 9 * HOUR)
    p10, p90 = table.flow_quantile(0.1), table.flow_quantile(0.9)
    ok = np.isfinite(table.flow)
    assert np.all(p10[ok] <= table.flow[ok] + 1e-9)
    assert np.all(p90[ok] >= np.floor(table.flow[ok]))
    assert np.all(np.isnan(historical_table(mapper.state).flow_quantile(0.9)))


def test_a_day_after_an_empty_day_does_not_blow_the_spread_up() -> None:
    """An empty observed day, then a steady 600 people an hour on one cell (Lincoln's real
    case: a declared recording span around one busy day). The busy day is scored against a
    forecast at the rate floor, whose Pearson residuals were 10^9: the negative binomial then
    put over 90 % on 0 and printed p10 = p90 = 0 beside a forecast of 49 a window. With each
    window's residual capped the 90th percentile lies above the forecast (the next day may be
    either kind: p10 stays 0), wide but not absurd."""
    mapper = corridor(2, lambda d, h: 600.0 if d == 1 else 0.0, cells=(0.5, 0.5))
    table = predict_table(mapper.state, MONDAY + 2 * DAY + 9 * HOUR)
    ok = np.flatnonzero(np.isfinite(table.flow) & (table.flow > 1.0))
    assert ok.size == 1
    flow = float(table.flow[ok[0]])
    p10, p90 = table.flow_quantile(0.1)[ok[0]], table.flow_quantile(0.9)[ok[0]]
    assert 0.0 <= p10 <= flow <= p90 < 10 * flow


@pytest.mark.parametrize("profile", ["day_weekend", "week"])
def test_a_kind_of_day_never_recorded_follows_the_rhythm_of_the_days_seen(profile: str) -> None:
    """Five weekdays of rush hours, then a forecast for the Saturday after: the profile has
    no Saturday bins of its own (and, by the week, no Saturday at all), so the forecast takes
    the weekdays' hours — empty at night, the rush in the morning — not one flat mean rate
    (which put 03:00 at the level of 09:00)."""
    mapper = corridor(5, rush, config=ModelConfig(profile=profile))
    saturday = MONDAY + 5 * DAY
    night = total_flow(mapper, saturday + 3 * HOUR)
    morning = total_flow(mapper, saturday + 9 * HOUR)
    assert morning == pytest.approx(300.0 / 6, rel=0.15)
    assert night <= 0.05 * morning


@pytest.mark.parametrize("families", [None, ["static", "fremen"]])
def test_an_hour_never_observed_forecasts_the_static_rate(families: list[str] | None) -> None:
    """A sensor that records 08–18 h only, two weeks of a daily rhythm inside those hours:
    at 03:00, an hour no day observed, every entry forecasts its static rate (no scored
    family was ever tried there: FreMEn's sinusoids would swing anywhere), unreconciled, and
    names the static family; at 13:00 the learnt rhythm stands (with FreMEn alone beside
    static, FreMEn's)."""
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    rng = np.random.default_rng(3)
    mapper = Mapper(ModelConfig() if families is None else ModelConfig(families=families))
    window = 600 * 10**9
    days = 14
    windows = [
        np.arange((MONDAY + d * DAY + 8 * HOUR) // window, (MONDAY + d * DAY + 18 * HOUR) // window)
        for d in range(days)
    ]
    mapper.set_fixed_windows(np.concatenate(windows))
    for d in range(days):
        for h in range(8, 18):
            n = int(rng.poisson(80.0 if 11 <= h < 15 else 5.0))
            t = MONDAY + d * DAY + h * HOUR + np.sort(rng.integers(0, HOUR, n))
            xy = rng.uniform((0.0, 0.0), (6.0, 2.0), size=(n, 2))
            head = rng.normal(0.0, 0.3, n)
            mapper.add_detections(
                DetectionBatch.from_arrays(t, np.column_stack([xy, np.zeros(n)]), head, np.ones(n))
            )
    mapper.advance(MONDAY + days * DAY)
    state = mapper.state
    after = MONDAY + days * DAY
    night = predict_table(state, after + 3 * HOUR)
    noon = predict_table(state, after + 13 * HOUR)
    hist = historical_table(state)
    assert set(night.flow_family.tolist()) == {"static"}
    assert set(night.direction_family.tolist()) == {"static"}
    np.testing.assert_allclose(night.flow, hist.flow, rtol=1e-12, atol=1e-12)
    assert set(noon.flow_family.tolist()) != {"static"}  # the rhythm was learnt
    assert total_flow(mapper, after + 13 * HOUR) > 1.5 * float(np.nansum(night.flow))
    # an hour observed on some day is not extrapolated: 17:00 follows the rhythm too
    late = predict_table(state, after + 17 * HOUR)
    assert set(late.flow_family.tolist()) == set(noon.flow_family.tolist())
