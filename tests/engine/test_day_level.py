"""How much whole days differ in level (``engine.temporal.day_level``): the between-day
variance that widens the band of a sum of places (an hour, a room, a building).

Known answers: days whose level is drawn from a gamma distribution (mean 1, variance
1/shape) give the sample variance of the drawn levels over their squared mean (the noise of
the windows within a day taken out); Poisson days of one level give none; a level measured
on D days widens the band by the square of the Student-t over the normal 90th percentile
(printed tables: t_{0.9} = 3.078, 1.886, 1.476, 1.372 for 1, 2, 5, 10 degrees of freedom;
z_{0.9} = 1.2816); and the band of a held-out day's hour total holds 80 % of the PIT
(tolerance 4 binomial σ, as in ``tests/engine/test_totals.py``) where the band without the
level term holds far less."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.day_level import (
    add_sums,
    day_sums,
    few_days_widening,
    level_variance,
)
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.totals import sum_variance
from aion_cli.errors import MapCorruptError
from aion_cli.evaluation.spread import spread_coverage
from tests.engine.temporal_data import DAY, HOUR, MONDAY, bursty_corridor

SLOTS, PER_BIN = 144, 6  # a day of 10-minute windows, hour bins
BURST, PASSES = 20, 30.0  # as tests/engine/test_totals.py


def tolerance(n: int) -> float:
    return 4.0 * math.sqrt(0.8 * 0.2 / n)


def _fixed_day(counts: np.ndarray) -> DayWindows:
    """A fixed sensor's day of one entry: ``counts`` detections in each of its slots."""
    seen = np.flatnonzero(counts)
    none = np.zeros(0, np.int64)
    return DayWindows(
        windows=np.arange(SLOTS, dtype=np.int64),
        fixed=np.ones(SLOTS, dtype=bool),
        obs_entry=none,
        obs_slot=none,
        cnt_entry=np.zeros(seen.size, np.int64),
        cnt_slot=seen.astype(np.int64),
        cnt_values=counts[seen].astype(np.float64)[:, None],
    )


def _measured(levels: np.ndarray, seed: int) -> float:
    """ĉ of days at ``levels`` (Poisson windows, an hour-of-day rhythm): the stored sums'
    level variance without the factor a new day's forecast adds, (1 + 1/D) and the t's."""
    rng = np.random.default_rng(seed)
    rate = 2.0 + 10.0 * np.sin(np.pi * np.arange(SLOTS) / SLOTS) ** 2  # per window
    h = np.arange(SLOTS) // PER_BIN
    sums = np.zeros((4, 0))
    for level in levels:
        sums = add_sums(sums, day_sums(_fixed_day(rng.poisson(level * rate)), h, 24))
    days = levels.size
    assert sums[0].max() == days  # every bin seen every day
    return level_variance(sums, 1.0) / ((1.0 + 1.0 / days) * few_days_widening(days))


def test_gamma_day_levels_are_measured_as_their_variance() -> None:
    rng = np.random.default_rng(3)
    levels = rng.gamma(4.0, 0.25, 300)  # variance 0.25 around 1
    sample = levels.var(ddof=1) / levels.mean() ** 2
    assert sample == pytest.approx(0.25, rel=0.2)
    # the noise of a bin's rate (Poisson: ρ / b) is taken out, not counted as level
    assert _measured(levels, seed=4) == pytest.approx(sample, rel=0.05)
    assert _measured(np.ones(300), seed=5) < 0.002  # one level: nothing (Poisson noise only)
    assert level_variance(np.zeros((4, 48)), 1.0) == 0.0  # no day: nothing
    assert level_variance(np.zeros((4, 0)), 1.0) == 0.0  # a map written before the sums


def test_a_level_of_few_days_widens_by_the_t_quantile() -> None:
    z = 1.2816
    for days, t in ((2, 3.078), (3, 1.886), (6, 1.476), (11, 1.372)):
        assert few_days_widening(days) == pytest.approx((t / z) ** 2, rel=2e-3)
    assert few_days_widening(1000) == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("days", [2, 3, 5])
def test_a_level_measured_on_few_days_gives_a_calibrated_band(days: int) -> None:
    """1,000 draws of ``days`` training days and a test day, levels from the gamma: the noon
    hour's forecast is the training days' mean, its variance the Poisson windows' plus the
    level term from the training days' sums alone. Over the draws the band holds 80 % of
    the PIT of the test days' noon totals; without the few-days widening (the t quantile)
    the band is too narrow on two and three days, and without the level term on any."""
    rng = np.random.default_rng(days)
    rate = 2.0 + 10.0 * np.sin(np.pi * np.arange(SLOTS) / SLOTS) ** 2
    h = np.arange(SLOTS) // PER_BIN
    noon = slice(12 * PER_BIN, 13 * PER_BIN)
    draws = 1000
    totals, means, level = np.zeros(draws), np.zeros(draws), np.zeros(draws)
    for r in range(draws):
        levels = rng.gamma(4.0, 0.25, days + 1)
        counts = rng.poisson(levels[:, None] * rate[None, :])
        sums = np.zeros((4, 0))
        for d in range(days):
            sums = add_sums(sums, day_sums(_fixed_day(counts[d]), h, 24))
        level[r] = level_variance(sums, 1.0)
        means[r] = counts[:days, noon].sum(axis=1).mean()
        totals[r] = counts[days, noon].sum()
    band = spread_coverage(totals, means, means + level * means**2)
    assert band["pit"] == pytest.approx(0.8, abs=tolerance(draws))
    unwidened = means + level / few_days_widening(days) * means**2
    if days <= 3:
        assert spread_coverage(totals, means, unwidened)["pit"] < 0.8 - tolerance(draws)
    assert spread_coverage(totals, means, means)["pit"] < 0.3  # Poisson windows alone


def test_hour_totals_of_gamma_days_fall_in_their_band() -> None:
    """Forty days of the bursty corridor at levels drawn from a gamma distribution: the map
    measures the days' level variance as the drawn levels' (the bursts' noise taken out),
    and 500 held-out days at new levels put 80 % of the PIT of their noon hour's total in
    the band widened by it; the band of the windows' burstiness alone holds far less."""
    days, shape = 40, 4.0
    rng = np.random.default_rng(7)
    levels = rng.gamma(shape, 1.0 / shape, days)
    state = bursty_corridor(days, lambda d, _h: PASSES * levels[d], BURST, seed=2).state
    rows, predictor = state.predictor()
    sample = levels.var(ddof=1) / levels.mean() ** 2
    measured = predictor.level_variance / ((1 + 1 / days) * few_days_widening(days))
    assert measured == pytest.approx(sample, rel=0.15)
    # the forecast of a later day's noon hour: its six windows' places
    window_ns = state.window_ns
    start = (MONDAY + (days + 1) * DAY + 12 * HOUR) // window_ns
    centres = (start + np.arange(HOUR // window_ns)) * window_ns + window_ns // 2
    place = np.tile(np.arange(rows.size), centres.size)
    window = np.repeat(np.arange(centres.size), rows.size)
    expected = predictor.flows(place, centres[window])
    variance = predictor.variances(
        place, state.params.calendar.profile_bin(centres[window]), expected
    )
    per_window = np.bincount(window, np.nan_to_num(expected), minlength=centres.size)
    windows_var = sum_variance(
        expected, variance, window, centres.size, per_window, predictor.phi_total
    ).sum()
    mean = float(per_window.sum())
    assert mean == pytest.approx(PASSES * BURST * levels.mean(), rel=0.1)
    # 500 held-out noon hours: each a new day's level, Poisson walkers of BURST detections
    test_levels = np.random.default_rng(8).gamma(shape, 1.0 / shape, 500)
    totals = BURST * np.random.default_rng(9).poisson(PASSES * test_levels)
    n = totals.size
    wide = windows_var + predictor.level_variance * mean * mean
    band = spread_coverage(totals, np.full(n, mean), np.full(n, wide))
    assert band["pit"] == pytest.approx(0.8, abs=tolerance(n))
    narrow = spread_coverage(totals, np.full(n, mean), np.full(n, windows_var))
    assert narrow["pit"] < 0.8 - 3 * tolerance(n)


def test_the_sums_are_stored_and_checked() -> None:
    mapper = bursty_corridor(3, lambda d, _h: PASSES * (1.0 + d), BURST, seed=0)
    state = mapper.state.query_temporal()
    assert state.day_level.shape == (4, 2 * state.n_bins)
    assert state.day_level[0].max() == 3  # three closed days of a fixed sensor
    rows = np.arange(state.n_rows)
    arrays = state.to_arrays("t_", rows)
    shape = (state.n_rows, state.n_values, state.n_periods, state.n_bins)
    families = (state.flow_score.shape[1], state.dir_score.shape[1])
    again = TemporalState.from_arrays(arrays, "t_", *shape, *families)
    np.testing.assert_array_equal(again.day_level, state.day_level)
    older = {k: v for k, v in arrays.items() if k != "t_day_level"}  # a map written before
    assert TemporalState.from_arrays(older, "t_", *shape, *families).day_level.size == 0
    good = arrays["t_day_level"]
    negative = good.copy()
    negative[1, 0] = -1.0
    for bad in (negative, np.full_like(good, np.nan), good[:, :-1], good.astype(np.int64)):
        with pytest.raises(MapCorruptError, match="day_level"):
            TemporalState.from_arrays({**arrays, "t_day_level": bad}, "t_", *shape, *families)


def test_a_map_without_the_sums_keeps_its_bands() -> None:
    """A map written before the sums (read as empty) forecasts rooms and hours as before:
    no level term; adding a map's sums to empty ones gives that map's."""
    sums = np.arange(8.0).reshape(4, 2)
    np.testing.assert_array_equal(add_sums(np.zeros((4, 0)), sums), sums)
    np.testing.assert_array_equal(add_sums(sums, np.zeros((4, 0))), sums)
    mean, var = np.array([2.0, 3.0]), np.array([2.0, 3.0])
    group = np.array([0, 0])
    plain = sum_variance(mean, var, group, 1, 5.0, 1.0)
    np.testing.assert_array_equal(sum_variance(mean, var, group, 1, 5.0, 1.0, 0.0), plain)
    # a level variance of 0.1 adds 0.1 · (2 + 3)² = 2.5 to the group's sum
    np.testing.assert_allclose(sum_variance(mean, var, group, 1, 5.0, 1.0, 0.1), plain + 2.5)


def test_rooms_add_the_level_term_to_their_sums() -> None:
    """``aggregate_table``: a room's variance adds the table's ``level_variance`` times its
    summed flow squared, the flows unchanged (the rooms of ``test_totals``)."""
    from dataclasses import replace

    from aion_cli.engine.query import aggregate_table, historical_table
    from tests.engine.engine_builders import T0, detections
    from tests.engine.test_query import _mapper_with_rooms

    m = _mapper_with_rooms(1)
    m.add_detections(detections(T0 + 1_000_000_000, [[0.1, 0.1, 0]] * 4, heading=np.zeros(4)))
    m.add_detections(detections(T0 + 1_000_000_000, [[9.1, 0.1, 0]] * 6, heading=np.zeros(6)))
    m.advance(T0 + 600 * 1_000_000_000)
    assert m.state.graph is not None
    table = historical_table(m.state)
    table = replace(table, flow_var=3.0 * np.nan_to_num(table.flow))
    plain = aggregate_table(table, m.state.graph, "rooms")
    np.testing.assert_allclose(plain.flow_var, [12, 18])  # φ = 3: 3·4, 3·6
    level = aggregate_table(replace(table, level_variance=0.1), m.state.graph, "rooms")
    np.testing.assert_array_equal(level.flow, plain.flow)
    np.testing.assert_allclose(level.flow_var, [12 + 0.1 * 16, 18 + 0.1 * 36])
