"""engine.fremen against independently known answers.

The reference is a plain per-state Python loop written here from the definition (complex sums per
observation, the 1.5 T span gate, prediction 2|γ|cos(ωt − φ) over the strongest components, the
prequential order errors and the biased argmin), not from the vectorized code.
"""

from __future__ import annotations

import cmath
import itertools
import math

import numpy as np
import pytest

from aion_cli.engine import fremen
from aion_cli.engine.config import DAY_S, WEEK_S, ModelConfig, default_periods
from aion_cli.engine.errors import ConfigError, MapCorruptError
from aion_cli.engine.fremen import (
    EPOCH_NS,
    PRIOR,
    FremenModel,
    FremenState,
    merge_states,
    predict_directions,
    to_model_seconds,
)

PERIODS = default_periods()


@pytest.fixture(autouse=True, params=[(1 << 21, 1 << 16), (7, 3)], ids=["blocks", "tiny-blocks"])
def block_sizes(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """Run every test with the default row blocks of scoring and freezing, and with tiny ones
    (one row per scoring block, three rows per freezing block)."""
    score_cells, rank_rows = request.param
    monkeypatch.setattr(fremen, "_SCORE_CELLS", score_cells)
    monkeypatch.setattr(fremen, "_RANK_ROWS", rank_rows)


class LoopState:
    """One FreMEn state, updated one observation at a time with Python complex numbers."""

    def __init__(
        self,
        periods: tuple[float, ...],
        max_order: int,
        span_factor: float,
        stride: int = 1,
        rank_period: float = DAY_S,
    ) -> None:
        self.periods = periods
        self.stride = stride
        self.rank_period = rank_period
        self.frozen_epoch: int | None = None
        self.frozen: tuple[float, list[complex]] | None = None  # (mean, gammas) at epoch start
        self.omega = [2 * math.pi / p for p in periods]
        self.max_order = max_order
        self.span_factor = span_factor
        self.n = 0
        self.sum_s = 0.0
        self.se = [0j] * len(periods)
        self.e = [0j] * len(periods)
        self.first = math.inf
        self.last = -math.inf
        self.err = [0.0] * (max_order + 1)
        self.err_n = 0

    def gammas(self) -> list[complex]:
        mu = self.sum_s / self.n
        span = self.last - self.first
        return [
            (self.se[k] - mu * self.e[k]) / self.n
            if span >= self.span_factor * self.periods[k]
            else 0j
            for k in range(len(self.periods))
        ]

    def predict(self, t: float, order: int) -> float:
        if self.n == 0:
            return 0.5
        return self._predict(self.sum_s / self.n, self.gammas(), t, order)

    def _predict(self, mu: float, g: list[complex], t: float, order: int) -> float:
        strongest = sorted(range(len(g)), key=lambda k: -abs(g[k]))[:order]
        p = mu
        for k in strongest:
            p += 2 * abs(g[k]) * math.cos(self.omega[k] * t - cmath.phase(g[k]))
        return min(1.0, max(0.0, p))

    def add(self, t: float, s: float) -> None:
        epoch = math.floor(t / self.rank_period)
        if epoch != self.frozen_epoch:  # the model that forecasts this epoch: its start state
            self.frozen_epoch = epoch
            self.frozen = (self.sum_s / self.n, self.gammas()) if self.n else None
        k = self.stride
        full = 64 if k == 1 else k * math.ceil(64 / k)  # a young row scores every observation
        if self.frozen is not None and (self.n < full or self.n % k == 0):
            weight = 1 if self.n < full else k  # then every k-th, standing for k observations
            mu, g = self.frozen
            for m in range(self.max_order + 1):
                self.err[m] += weight * abs(s - self._predict(mu, g, t, m))
            self.err_n += weight
        self.n += 1
        self.sum_s += s
        for k, w in enumerate(self.omega):
            self.se[k] += s * cmath.exp(1j * w * t)
            self.e[k] += cmath.exp(1j * w * t)
        self.first = min(self.first, t)
        self.last = max(self.last, t)

    def chosen(self, bias: float) -> int:
        if self.err_n == 0:
            return 0
        mean = [e / self.err_n for e in self.err]
        best = 0
        for m in range(1, self.max_order + 1):
            if mean[m] < mean[best] - bias:
                best = m
        return best


def _signal(rng: np.random.Generator, t: np.ndarray, kind: int) -> np.ndarray:
    """Row signals in [0, 1]: noise, daily, daily + half-daily, weekly-ish."""
    noise = rng.normal(0, 0.08, t.size)
    base = [
        0.3 + 0 * t,
        0.4 + 0.35 * np.cos(2 * np.pi * t / DAY_S - 0.7),
        0.3 + 0.25 * np.cos(2 * np.pi * t / DAY_S + 2.0) + 0.2 * np.cos(4 * np.pi * t / DAY_S),
        0.5 + 0.3 * np.cos(2 * np.pi * t / (WEEK_S / 4) + 1.0),
    ][kind % 4]
    return np.clip(base + noise, 0.0, 1.0)


@pytest.mark.parametrize("stride", [1, 3, 8])
def test_vectorized_model_equals_plain_loop_on_irregular_data(stride: int) -> None:
    rng = np.random.default_rng(7)
    model = FremenModel(
        PERIODS, max_order=4, span_factor=1.5, order_bias=0.002, score_stride=stride
    )
    n_rows = 8
    # irregular window times over 12 days, fed in batches of varying size
    t_all = np.sort(rng.uniform(0, 12 * DAY_S, 420)) + 3 * WEEK_S
    values = np.stack([_signal(rng, t_all, kind) for kind in range(n_rows)])
    observed = rng.random(values.shape) < 0.7
    observed[5, :200] = False  # a row that starts late
    observed[6] = False  # a row never observed
    state = model.empty(n_rows + 2)  # two rows never touched by update
    rows = np.arange(n_rows)
    cuts = [0, 1, 7, 50, 51, 180, 300, 420]
    for a, b in itertools.pairwise(cuts):
        model.update(state, rows, t_all[a:b], values[:, a:b], observed[:, a:b])

    loops = [LoopState(PERIODS, 4, 1.5, stride) for _ in range(n_rows + 2)]
    for i in range(n_rows):
        for w in np.flatnonzero(observed[i]):
            loops[i].add(float(t_all[w]), float(values[i, w]))

    np.testing.assert_allclose(state.order_err, [lp.err for lp in loops], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(state.order_n, [lp.err_n for lp in loops])
    assert model.chosen_order(state).tolist() == [lp.chosen(0.002) for lp in loops]
    chosen_set = set(model.chosen_order(state).tolist())
    assert 0 in chosen_set  # the data exercise the choice
    assert max(chosen_set) >= 2
    # the weighted count stands for every observation after the row's first day (a day has no
    # earlier model to forecast it), give or take stride - 1 at either end
    day = np.floor(t_all / DAY_S)
    first_day = np.array([day[o].min() if o.any() else np.inf for o in observed])
    later = (observed & (day[None, :] > first_day[:, None])).sum(axis=1)
    assert np.all(state.order_n[:n_rows] >= later - (stride - 1))
    assert np.all(state.order_n[:n_rows] <= later + stride - 1)
    assert np.all(later[:6] > 100)  # the bound is not vacuous

    amp, phase = model.spectrum(state)
    for i, lp in enumerate(loops):
        if lp.n:
            g = lp.gammas()
            np.testing.assert_allclose(amp[i], [abs(x) for x in g], atol=1e-9)
            big = amp[i] > 1e-6
            ref_phase = np.array([cmath.phase(x) for x in g])
            np.testing.assert_allclose(
                np.exp(1j * phase[i][big]), np.exp(1j * ref_phase[big]), atol=1e-9
            )
        else:
            assert np.all(amp[i] == 0)

    t_query = 3 * WEEK_S + 12 * DAY_S + rng.uniform(0, 5 * DAY_S, 30)
    chosen = model.chosen_order(state)
    pred = model.predict(state, t_query)
    for i, lp in enumerate(loops):
        ref = [lp.predict(float(t), int(chosen[i])) for t in t_query]
        np.testing.assert_allclose(pred[i], ref, atol=1e-9)
    for times in (t_query[:1], t_query[:3]):  # the few-times evaluation paths
        np.testing.assert_allclose(model.predict(state, times), pred[:, : times.size], atol=1e-12)
    for order in (0, 1, 3, 31):
        pred = model.predict(state, t_query, rows=[1, 2, 3], order=order)
        refs = [[loops[i].predict(float(t), order) for t in t_query] for i in (1, 2, 3)]
        np.testing.assert_allclose(pred, refs, atol=1e-9)
    assert np.all(model.predict(state, t_query, rows=[6, 8]) == PRIOR)


def test_known_daily_period_is_found_with_amplitude_and_phase() -> None:
    model = FremenModel(PERIODS)
    t = 2 * WEEK_S + np.arange(7 * 144) * 600.0  # one week of 10-minute windows
    phi = 1.0
    s = 0.5 + 0.3 * np.cos(2 * np.pi * t / DAY_S - phi)
    state = model.empty(1)
    model.update(state, [0], t, s[None], np.ones((1, t.size), bool))
    amp, phase = model.spectrum(state)
    k_day = PERIODS.index(DAY_S)
    assert int(np.argmax(amp[0])) == k_day
    assert amp[0, k_day] == pytest.approx(0.15, abs=1e-9)
    assert phase[0, k_day] == pytest.approx(phi, abs=1e-9)
    others = np.delete(amp[0], k_day)
    assert np.all(others < 1e-9)
    assert model.chosen_order(state)[0] >= 1
    t_future = 5 * WEEK_S + np.arange(0, DAY_S, 900.0)
    np.testing.assert_allclose(
        model.predict(state, t_future)[0],
        0.5 + 0.3 * np.cos(2 * np.pi * t_future / DAY_S - phi),
        atol=1e-9,
    )


def _random_stream(seed: int, n_rows: int, n_win: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 9 * DAY_S, n_win))
    values = rng.random((n_rows, n_win))
    observed = rng.random((n_rows, n_win)) < 0.6
    return t, values, observed


def _assert_states_equal(a: FremenState, b: FremenState, orders: bool = True) -> None:
    fields = ["n", "sum_s", "sum_se", "sum_e", "t_first", "t_last"]
    fields += ["order_err", "order_n"] if orders else []
    for name in fields:
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-11, atol=1e-9)


@pytest.mark.parametrize("stride", [1, 8])
def test_one_batch_of_windows_equals_single_window_updates(stride: int) -> None:
    model = FremenModel(PERIODS, max_order=3, score_stride=stride)
    t, values, observed = _random_stream(3, 40, 240)  # ~144 observations a row
    rows = np.arange(40)
    batch, single = model.empty(40), model.empty(40)
    model.update(batch, rows, t, values, observed)
    for w in range(t.size):
        model.update(single, rows, t[w : w + 1], values[:, w : w + 1], observed[:, w : w + 1])
    _assert_states_equal(batch, single)
    assert batch.order_n.sum() > 0


def test_update_of_a_row_subset_leaves_other_rows_untouched() -> None:
    model = FremenModel(PERIODS)
    t, values, observed = _random_stream(4, 6, 30)
    state = model.empty(10)
    model.update(state, [7, 2, 9], t, values[:3], observed[:3])
    ref = model.empty(3)
    model.update(ref, [0, 1, 2], t, values[:3], observed[:3])
    _assert_states_equal(state.take([7, 2, 9]), ref)
    assert np.all(state.take([0, 1, 3, 4, 5, 6, 8]).n == 0)


def test_merge_of_disjoint_time_states_equals_one_state_fed_both() -> None:
    model = FremenModel(PERIODS)
    t, values, observed = _random_stream(5, 12, 120)
    rows = np.arange(12)
    early, late, both = model.empty(12), model.empty(12), model.empty(12)
    model.update(early, rows, t[:70], values[:, :70], observed[:, :70])
    model.update(late, rows, t[70:], values[:, 70:], observed[:, 70:])
    model.update(both, rows, t, values, observed)
    merged = merge_states(early, late)
    _assert_states_equal(merged, both, orders=False)
    np.testing.assert_allclose(merged.order_err, early.order_err + late.order_err)
    tq = np.linspace(9 * DAY_S, 11 * DAY_S, 17)
    for order in (0, 2, 4):
        np.testing.assert_allclose(
            model.predict(merged, tq, order=order), model.predict(both, tq, order=order), atol=1e-9
        )
    # add_rows is the same merge, row by row
    stacked = FremenState.concat([early, late])
    stacked.add_rows(np.arange(12, 24), np.arange(12))
    _assert_states_equal(stacked.take(rows), merged)


def test_span_gate_ignores_weekly_period_until_one_and_a_half_weeks() -> None:
    model = FremenModel(PERIODS)
    t = np.arange(3 * 144) * 600.0  # three days
    s = 0.5 + 0.4 * np.cos(2 * np.pi * t / WEEK_S)
    state = model.empty(1)
    model.update(state, [0], t, s[None], np.ones((1, t.size), bool))
    amp, _ = model.spectrum(state)
    span = t[-1] - t[0]
    for k, period in enumerate(PERIODS):
        if 1.5 * period > span:
            assert amp[0, k] == 0.0, period
    assert amp[0, PERIODS.index(DAY_S)] > 0
    # with every order, the prediction is the mean plus the admitted components only
    loop = LoopState(PERIODS, 0, 1.5)
    for ti, si in zip(t, s, strict=True):
        loop.add(float(ti), float(si))
    tq = np.array([4 * DAY_S, 5.3 * DAY_S])
    np.testing.assert_allclose(
        model.predict(state, tq, order=31)[0], [loop.predict(x, 31) for x in tq], atol=1e-9
    )
    # after 11 days the weekly period is admitted and is the strongest
    t2 = np.arange(3 * 144, 11 * 144) * 600.0
    s2 = 0.5 + 0.4 * np.cos(2 * np.pi * t2 / WEEK_S)
    model.update(state, [0], t2, s2[None], np.ones((1, t2.size), bool))
    amp, _ = model.spectrum(state)
    assert int(np.argmax(amp[0])) == PERIODS.index(WEEK_S)


def test_predictions_are_clamped_to_unit_interval() -> None:
    model = FremenModel(PERIODS, max_order=1)
    t = np.arange(4 * 144) * 600.0
    s = 0.5 + 0.8 * np.cos(2 * np.pi * t / DAY_S)  # the true signal leaves [0, 1]
    state = model.empty(1)
    model.update(state, [0], t, s[None], np.ones((1, t.size), bool))
    tq = np.arange(0, DAY_S, 300.0) + 10 * DAY_S
    p = model.predict(state, tq, order=1)[0]
    np.testing.assert_allclose(p, np.clip(0.5 + 0.8 * np.cos(2 * np.pi * tq / DAY_S), 0, 1), 1e-9)
    assert p.min() == 0.0
    assert p.max() == 1.0


def test_chosen_order_prefers_lower_order_within_bias() -> None:
    model = FremenModel(PERIODS, max_order=3, order_bias=0.01)
    state = model.empty(4)
    state.order_n[:] = 10
    state.order_err[:] = np.array(
        [
            [1.0, 0.95, 0.5, 0.4],  # 2 beats 0 by 0.05, 3 beats 2 by only 0.01 -> 2
            [1.0, 0.95, 0.92, 0.91],  # 1 beats 0 by 0.005 (no), 2 by 0.008 (no), 3 by 0.009
            [1.0, 1.2, 1.1, 0.85],  # 3 beats 0 by 0.015 -> 3
            [0.0, 0.0, 0.0, 0.0],
        ]
    )
    assert model.chosen_order(state).tolist() == [2, 0, 3, 0]


def test_row_ops_and_array_round_trip() -> None:
    model = FremenModel(PERIODS)
    t, values, observed = _random_stream(6, 5, 60)
    state = model.empty(5)
    model.update(state, np.arange(5), t, values, observed)
    again = FremenState.from_arrays(state.to_arrays("fremen/"), "fremen/")
    _assert_states_equal(again, state)
    grown = state.copy()
    grown.resize(8)
    assert grown.n_rows == 8
    assert np.all(grown.take([5, 6, 7]).n == 0)
    _assert_states_equal(grown.take(np.arange(5)), state)
    grown.resize(2)
    _assert_states_equal(grown, state.take([0, 1]))
    state.zero_rows([1])
    assert model.predict(state, [0.0, 5.0], rows=[1]).tolist() == [[PRIOR, PRIOR]]
    arrays = state.to_arrays("f/")
    del arrays["f/sum_e"]
    with pytest.raises(MapCorruptError):
        FremenState.from_arrays(arrays, "f/")
    arrays = state.to_arrays("f/")
    arrays["f/t_last"] = np.zeros(3)
    with pytest.raises(MapCorruptError):
        FremenState.from_arrays(arrays, "f/")


def test_update_rejects_bad_input() -> None:
    model = FremenModel(PERIODS)
    state = model.empty(3)
    ones = np.ones((2, 2), bool)
    with pytest.raises(ValueError, match="non-decreasing"):
        model.update(state, [0, 1], [10.0, 5.0], np.zeros((2, 2)), ones)
    with pytest.raises(ValueError, match="unique"):
        model.update(state, [1, 1], [1.0, 2.0], np.zeros((2, 2)), ones)
    with pytest.raises(ValueError, match="shape"):
        model.update(state, [0, 1], [1.0, 2.0], np.zeros((2, 3)), ones)
    with pytest.raises(ValueError, match="finite"):
        model.update(state, [0, 1], [1.0, 2.0], np.full((2, 2), np.nan), ones)
    # NaN in an unobserved cell is ignored
    model.update(state, [0, 1], [1.0, 2.0], np.full((2, 2), np.nan), ~ones)
    assert np.all(state.n == 0)


def test_predict_directions_floors_and_renormalises() -> None:
    model = FremenModel(PERIODS, max_order=0)
    state = model.empty(4)
    t = np.arange(10) * 600.0
    fractions = np.array([0.7, 0.3, 0.0, 0.0])
    model.update(state, np.arange(4), t, np.repeat(fractions[:, None], 10, 1), np.ones((4, 10)))
    p = predict_directions(model, state, np.array([[0, 1, 2, 3]]), [1e6, 2e6], floor=0.01)
    expected = np.maximum(fractions, 0.01) / np.maximum(fractions, 0.01).sum()
    np.testing.assert_allclose(p[0, :, 0], expected)
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    assert p.shape == (1, 4, 2)


def test_model_seconds_are_relative_to_monday_2020_01_06() -> None:
    assert EPOCH_NS == 1_578_268_800 * 10**9
    ns = np.array([EPOCH_NS, EPOCH_NS + 1, EPOCH_NS + 86_400 * 10**9 + 500], np.int64)
    np.testing.assert_allclose(to_model_seconds(ns), [0.0, 1e-9, 86_400 + 5e-7], rtol=0, atol=1e-12)
    model = FremenModel.from_config(ModelConfig())
    assert model.n_periods == 31
    assert model.max_order == 4


@pytest.mark.parametrize("stride", [1, 3, 8])
def test_mean_only_model_scores_order_zero_like_the_loop(stride: int) -> None:
    model = FremenModel(PERIODS, max_order=0, score_stride=stride)
    t, values, observed = _random_stream(8, 5, 240)
    state = model.empty(5)
    model.update(state, np.arange(5), t[:30], values[:, :30], observed[:, :30])
    model.update(state, np.arange(5), t[30:], values[:, 30:], observed[:, 30:])
    loops = [LoopState(PERIODS, 0, 1.5, stride) for _ in range(5)]
    for i, lp in enumerate(loops):
        for w in np.flatnonzero(observed[i]):
            lp.add(float(t[w]), float(values[i, w]))
    np.testing.assert_allclose(state.order_err[:, 0], [lp.err[0] for lp in loops], rtol=1e-9)
    np.testing.assert_array_equal(state.order_n, [lp.err_n for lp in loops])
    assert model.chosen_order(state).tolist() == [0] * 5


@pytest.mark.parametrize("stride", [1, 3, 8])
def test_mean_only_dense_updates_score_like_sparse_ones(stride: int) -> None:
    model = FremenModel(PERIODS, max_order=0, score_stride=stride)
    t, values, _ = _random_stream(9, 4, 200)
    dense, sparse = model.empty(4), model.empty(4)
    every = np.ones(values.shape, bool)
    model.update(dense, np.arange(4), t[:20], values[:, :20], every[:, :20])
    model.update(dense, np.arange(4), t[20:100], values[:, 20:100], every[:, 20:100])
    model.update(dense, np.arange(4), t[100:], values[:, 100:], every[:, 100:])  # past start
    almost = every.copy()
    almost[:, 0] = False  # sparse path: first window unobserved, fed on its own
    almost[:, 150] = False  # and one unobserved window after the start, fed on its own
    for a, b in ((0, 1), (0, 20), (20, 150), (150, 151), (150, 200)):
        observed = every if (a, b) in ((0, 1), (150, 151)) else almost
        model.update(sparse, np.arange(4), t[a:b], values[:, a:b], observed[:, a:b])
    _assert_states_equal(dense, sparse)
    loops = [LoopState(PERIODS, 0, 1.5, stride) for _ in range(4)]
    for i, lp in enumerate(loops):
        for w in range(t.size):
            lp.add(float(t[w]), float(values[i, w]))
    assert dense.order_n.tolist() == [lp.err_n for lp in loops]
    assert dense.order_n.min() > 100  # most windows lie after the first day: scored
    np.testing.assert_allclose(dense.order_err[:, 0], [lp.err[0] for lp in loops], rtol=1e-9)


@pytest.mark.parametrize("stride", [1, 3])
def test_orders_above_the_number_of_periods_use_every_period(stride: int) -> None:
    periods = (DAY_S, DAY_S / 2)
    model = FremenModel(periods, max_order=4, score_stride=stride)
    t, values, observed = _random_stream(10, 3, 300)
    state = model.empty(3)
    model.update(state, np.arange(3), t, values, observed)
    loops = [LoopState(periods, 4, 1.5, stride) for _ in range(3)]
    for i, lp in enumerate(loops):
        for w in np.flatnonzero(observed[i]):
            lp.add(float(t[w]), float(values[i, w]))
    np.testing.assert_allclose(state.order_err, [lp.err for lp in loops], rtol=1e-9)
    np.testing.assert_allclose(state.order_err[:, 3], state.order_err[:, 2])
    tq = np.array([10 * DAY_S, 10.3 * DAY_S])
    np.testing.assert_allclose(
        model.predict(state, tq, order=4), model.predict(state, tq, order=2), atol=0
    )


@pytest.mark.parametrize("kind", ["phases", "aligned", "sparse-tail"])
@pytest.mark.parametrize("stride", [3, 8])
def test_stride_on_dense_windows_with_rows_at_every_phase(stride: int, kind: str) -> None:
    """Dense blocks where the rows' counts sit at every phase modulo the stride (each row
    scores at a different window of a block), after a sparse start, or all at the same phase,
    or sparse windows again at the end; 16 days, so the last updates start with every period
    admitted by the span gate (first / last no longer tracked). Against the loop."""
    model = FremenModel(PERIODS, max_order=4, score_stride=stride)
    rng = np.random.default_rng(11)
    n_rows = 20
    t = np.sort(rng.uniform(0, 16 * DAY_S, 200))
    values = np.stack([_signal(rng, t, kind) for kind in range(n_rows)])
    observed = np.ones(values.shape, bool)
    for i in range(0 if kind == "aligned" else n_rows):
        observed[i, : i % 11] = False  # rows start late by 0..10 windows
    if kind == "sparse-tail":
        observed[:, 150:] = rng.random((n_rows, 50)) < 0.7
    state = model.empty(n_rows)
    rows = np.arange(n_rows)
    for a, b in itertools.pairwise([0, 13, 14, 90, 150, 200]):
        model.update(state, rows, t[a:b], values[:, a:b], observed[:, a:b])
    loops = [LoopState(PERIODS, 4, 1.5, stride) for _ in range(n_rows)]
    for i, lp in enumerate(loops):
        for w in np.flatnonzero(observed[i]):
            lp.add(float(t[w]), float(values[i, w]))
    np.testing.assert_allclose(state.order_err, [lp.err for lp in loops], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(state.order_n, [lp.err_n for lp in loops])
    assert model.chosen_order(state).tolist() == [lp.chosen(0.002) for lp in loops]


def test_score_stride_defaults_and_config() -> None:
    assert FremenModel(PERIODS).score_stride == 1  # direct callers keep every observation
    config = ModelConfig()
    assert config.score_stride == 8
    assert FremenModel.from_config(config).score_stride == 8
    assert FremenModel.from_config(config.replace(score_stride=1)).score_stride == 1
    for bad in (0, 1025, 2.0, True):
        with pytest.raises(ConfigError, match="score_stride"):
            ModelConfig(score_stride=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="score_stride"):
        FremenModel(PERIODS, score_stride=0)


def test_cached_predictor_follows_every_change_of_the_state() -> None:
    """Whole-state predictions rank the components once and cache them; any update, row
    operation or resize must invalidate that cache (predictions equal a fresh state's)."""
    model = FremenModel(PERIODS, max_order=4, score_stride=3)
    t, values, observed = _random_stream(21, 6, 300)
    state = model.empty(6)
    model.update(state, np.arange(6), t[:200], values[:, :200], observed[:, :200])
    tq = np.array([9.5 * DAY_S, 10.1 * DAY_S])

    def fresh() -> np.ndarray:  # the same state without any cache
        return model.predict(state.copy(), tq)

    first = model.predict(state, tq)
    assert state.predictor_cache is not None  # whole-state request: cached
    np.testing.assert_array_equal(first, fresh())
    model.update(state, np.arange(6), t[200:], values[:, 200:], observed[:, 200:])
    after = model.predict(state, tq)
    assert not np.array_equal(after, first)
    np.testing.assert_array_equal(after, fresh())
    state.add_rows([0], [1])
    np.testing.assert_array_equal(model.predict(state, tq, rows=[1, 2]), fresh()[[1, 2]])
    state.zero_rows([2])
    assert np.all(model.predict(state, tq, rows=[2]) == PRIOR)
    state.resize(8)
    np.testing.assert_array_equal(model.predict(state, tq), fresh())
    other = FremenModel(PERIODS, max_order=4, order_bias=0.5)  # a model choosing other orders
    np.testing.assert_array_equal(other.predict(state, tq), other.predict(state.copy(), tq))


def test_attached_predictor_predicts_like_the_state() -> None:
    model = FremenModel(PERIODS, max_order=4)
    t, values, observed = _random_stream(22, 5, 250)
    state = model.empty(5)
    model.update(state, np.arange(5), t, values, observed)
    tq = np.linspace(9 * DAY_S, 11 * DAY_S, 7)
    pred = model.predictor(state, [3, 4])  # a few rows: computed, not cached
    assert pred.n_rows == 2
    loaded = state.copy()
    model.attach_predictor(loaded, model.predictor(state))
    np.testing.assert_array_equal(model.predict(loaded, tq), model.predict(state.copy(), tq))
    with pytest.raises(ValueError, match="does not fit"):
        model.attach_predictor(model.empty(2), model.predictor(state))


def test_resize_copies_only_the_used_rows() -> None:
    model = FremenModel(PERIODS, max_order=2)
    t, values, observed = _random_stream(23, 4, 60)
    state = model.empty(6)
    model.update(state, np.arange(4), t, values, observed)
    before = state.copy()
    assert state.high_water == 4  # rows 4, 5 were never written
    state.resize(40)
    _assert_states_equal(state.take(np.arange(4)), before.take(np.arange(4)))
    empty = model.empty(36)
    _assert_states_equal(state.take(np.arange(4, 40)), empty)
    assert np.all(state.rank_epoch[4:] == fremen.STALE)
    assert np.isnan(state.t_first[4:]).all()
