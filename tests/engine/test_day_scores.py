"""A closed day's scores against their definition, window by window: per flow family
Σ_w [n_w log max(λ_w, ε) − max(λ_w, ε)] (Poisson) and Σ_w min((n_w − λ_w)² / λ_w, K²) over
windows with detections plus Σ λ_w over the empty ones (Pearson), λ_w the family's forecast
from the model before the day. The scoring sums λ in closed form where it can (per profile
bin; FreMEn from the day's Fourier sums where the floor cannot bite) — the brute force here
evaluates every window."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.absorption import slot_times
from aion_cli.engine.temporal.forecast import Forecaster, PoolStats
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.scoring import PEARSON_CAP, score_day

S = 1_000_000_000
WINDOW_NS = 600 * S
DAY_WINDOWS = 144
START = int(datetime(2026, 11, 2, tzinfo=UTC).timestamp()) * S  # a Monday
ONE = np.zeros(1, np.int64)


def _day(t_ns: np.ndarray, counts: np.ndarray, values: int) -> DayWindows:
    """A fixed sensor's windows at ``t_ns``, ``counts[w]`` detections in the last value bin."""
    has = np.flatnonzero(counts > 0)
    cnt = np.zeros((has.size, values))
    cnt[:, -1] = counts[has]
    return DayWindows(
        np.floor_divide(t_ns, WINDOW_NS), np.ones(t_ns.size, bool), np.zeros(0, np.int64),
        np.zeros(0, np.int64), np.zeros(has.size, np.int64), has.astype(np.int64), cnt,
    )  # fmt: skip


def _windows(first_day: int, days: int) -> np.ndarray:
    out: np.ndarray = START + first_day * 86400 * S + np.arange(days * DAY_WINDOWS) * WINDOW_NS
    return out + WINDOW_NS // 2


@pytest.mark.parametrize(("seed", "rush"), [(0, True), (1, True), (2, False)])
def test_day_scores_are_the_window_by_window_sums(seed: int, rush: bool) -> None:
    """Five days of rush hours (zero at night, so FreMEn dips below the floor and its sums
    are taken window by window) or of a gentle daily wave on a busy base (FreMEn stays far
    above the floor: the closed form from the day's Fourier sums), then a sixth day of
    Poisson counts scored: every enabled family's score and χ² equal the brute-force sums."""
    rng = np.random.default_rng(seed)
    params = TemporalParams.from_config(ModelConfig())
    state = temporal.empty_state(params, 1)
    t = _windows(0, 5)
    hour = (t - START) // (3600 * S) % 24
    rate = np.where((hour >= 8) & (hour < 10) | (hour >= 17) & (hour < 19), 6.0, 0.0)
    if not rush:
        rate = 40.0 + 10.0 * np.cos(2 * np.pi * hour / 24.0)
    temporal.learn(params, state, _day(t, rng.poisson(rate), params.values), ONE, ONE, 1,
                   WINDOW_NS)  # fmt: skip
    t6 = _windows(5, 1)
    n6 = rng.poisson(np.where(((t6 - START) // (3600 * S) % 24) >= 7, 2.5, 0.0)).astype(float)
    n6[::37] += 30.0  # a few bursts, capped in χ²
    day6 = _day(t6, n6, params.values)
    fc = Forecaster(params, state, ONE, ONE, PoolStats.of(params, state, ONE, ONE, 1))
    t_s, h = slot_times(params, day6, WINDOW_NS)
    floor = params.config.rate_floor
    e = np.zeros(t6.size, np.int64)
    expected_score, expected_chi2 = [], []
    for name in params.flow:
        lam = np.maximum(fc.flow(name, e, h, t_s), floor)
        expected_score.append(float(np.sum(n6 * np.log(lam) - lam)))
        pearson = np.minimum((n6 - lam) ** 2 / lam, PEARSON_CAP)
        expected_chi2.append(float(np.sum(np.where(n6 > 0, pearson, lam))))
    bound = float(fc.flow_bound(f"fremen{params.max_order}", ONE)[0])
    assert (bound < floor) == rush  # which way the FreMEn sums are taken
    before_score, before_chi2 = state.flow_score[0].copy(), state.flow_chi2[0].copy()
    before_scored = float(state.flow_scored[0])
    score_day(params, state, day6, ONE, ONE, 1, WINDOW_NS)
    on = np.asarray(params.flow_enabled)
    got_score = state.flow_score[0] - before_score
    got_chi2 = state.flow_chi2[0] - before_chi2
    np.testing.assert_allclose(got_score[on], np.array(expected_score)[on], rtol=1e-9)
    np.testing.assert_allclose(got_chi2[on], np.array(expected_chi2)[on], rtol=1e-9)
    np.testing.assert_array_equal(got_score[~on], 0.0)
    assert float(state.flow_scored[0]) - before_scored == DAY_WINDOWS
