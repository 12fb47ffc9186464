"""Day scoring in blocks: the scores and accumulators do not depend on how many entries,
pairs or rows are evaluated together (the block sizes only bound the temporaries)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.grouping import unique_inverse
from aion_cli.engine.temporal import (
    absorption,
    direction_scoring,
    forecast,
    fremen_parts,
    scoring,
)
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows

S = 1_000_000_000
WINDOW_NS = 600 * S
DAY_WINDOWS = 144


def _days(params: TemporalParams, entries: int, days: int, seed: int) -> DayWindows:
    """Four days of a corridor: a fixed sensor on even days, a robot seeing a random part of
    the entries on odd days; per entry a daily rhythm in its own walking direction."""
    rng = np.random.default_rng(seed)
    first = 20_000_000_000 * S // WINDOW_NS // DAY_WINDOWS * DAY_WINDOWS  # a UTC midnight
    windows = np.arange(first, first + days * DAY_WINDOWS, dtype=np.int64)
    slot = np.arange(windows.size)
    fixed = (slot // DAY_WINDOWS) % 2 == 0
    rhythm = 1.0 + np.cos(2 * np.pi * (slot % DAY_WINDOWS) / DAY_WINDOWS)
    seen = rng.random((entries, windows.size)) < 0.4
    obs_e, obs_s = np.nonzero(seen & ~fixed[None, :])
    rate = rng.uniform(0.05, 0.6, entries)[:, None] * rhythm[None, :]
    has = (rng.random((entries, windows.size)) < rate) & (seen | fixed[None, :])
    cnt_e, cnt_s = np.nonzero(has)
    values = np.zeros((cnt_e.size, params.values))
    main = rng.integers(0, params.bins, entries)
    values[np.arange(cnt_e.size), main[cnt_e]] = rng.integers(1, 6, cnt_e.size)
    values[:, -1] = rng.integers(0, 2, cnt_e.size)
    values[:, (main[cnt_e] + params.bins // 2) % params.bins] += rng.integers(0, 3, cnt_e.size)
    return DayWindows(windows, fixed, obs_e, obs_s, cnt_e, cnt_s, values)


def _learnt(params: TemporalParams, entries: int, days: DayWindows) -> Any:
    state = temporal.empty_state(params, entries)
    rows = np.arange(entries, dtype=np.int64)
    temporal.learn(params, state, days, rows, rows // 5, (entries + 4) // 5, WINDOW_NS)
    return state


ARRAYS = (
    "cnt_fourier", "cnt_profile", "flow_score", "flow_chi2", "flow_scored", "flow_days",
    "flow_gain_sq", "dir_score", "dir_scored", "dir_days", "dir_gain_sq",
)


@pytest.mark.parametrize("sizes", [(7, 5, 3), (1, 1, 1), (64, 33, 2)])
def test_block_sizes_do_not_change_the_learnt_state(
    monkeypatch: pytest.MonkeyPatch, sizes: tuple[int, int, int]
) -> None:
    params = TemporalParams.from_config(ModelConfig())
    days = _days(params, 40, 4, seed=11)
    reference = _learnt(params, 40, days)
    assert float(reference.dir_scored.sum()) > 0  # the directions were scored
    entries, pairs, rows = sizes
    monkeypatch.setattr(scoring, "_ENTRIES", entries)
    monkeypatch.setattr(absorption, "_ROWS", entries)
    monkeypatch.setattr(direction_scoring, "_DIRECTION_PAIRS", pairs)
    monkeypatch.setattr(forecast, "BLOCK", rows)
    monkeypatch.setattr(fremen_parts, "BLOCK", rows)
    blocked = _learnt(params, 40, days)
    for name in ARRAYS:
        np.testing.assert_allclose(
            getattr(blocked, name), getattr(reference, name), rtol=1e-12, atol=1e-12, err_msg=name
        )
    np.testing.assert_array_equal(blocked.cnt_profile, reference.cnt_profile)  # integer sums
    np.testing.assert_array_equal(blocked.obs.n, reference.obs.n)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(min_value=-(2**40), max_value=2**40), max_size=200),
    st.integers(min_value=0, max_value=2**20),
)
def test_unique_equals_numpy_unique(values: list[int], spread: int) -> None:
    keys = np.asarray(values, dtype=np.int64) % (spread + 1)  # a narrow range: no sort
    for k in (keys, np.asarray(values, dtype=np.int64)):  # and a wide one: numpy's
        distinct, inverse = unique_inverse(k)
        expect, expect_inverse = np.unique(k, return_inverse=True)
        np.testing.assert_array_equal(distinct, expect)
        np.testing.assert_array_equal(inverse, expect_inverse.reshape(-1))


def test_pickled_state_sends_only_written_rows_and_arrives_equal() -> None:
    """A learnt state with unwritten capacity pickles to the written rows only and unpickles
    to equal arrays of the full capacity (a parallel build's shards travel this way)."""
    import pickle

    params = TemporalParams(ModelConfig())
    state = _learnt(params, 40, _days(params, 40, 3, seed=11))
    state.resize(400)  # reserved capacity, never written
    assert state.high_water == 40
    copy = pickle.loads(pickle.dumps(state))
    assert copy.n_rows == 400
    assert copy.high_water == 40
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(copy, name), getattr(state, name))
    for block in ("glob", "obs"):
        for f in ("n", "fourier", "profile", "first", "last"):
            np.testing.assert_array_equal(
                getattr(getattr(copy, block), f), getattr(getattr(state, block), f)
            )
    assert len(pickle.dumps(state)) < state.nbytes / 5  # 40 of 400 rows


def test_total_spectrum_is_computed_on_first_use_and_equals_the_eager_one() -> None:
    """``Forecaster`` computes an entry's FreMEn total spectrum only when a FreMEn flow is
    asked for it; the components of any subset, asked in any order, equal those of all
    entries computed at once (bit for bit: every step is row by row)."""
    params = TemporalParams.from_config(ModelConfig())
    state = _learnt(params, 40, _days(params, 40, 4, seed=5))
    rows = np.arange(40, dtype=np.int64)
    groups = rows // 5
    pool = forecast.PoolStats.of(params, state, rows, groups, 8)
    eager = forecast.Forecaster(params, state, rows, groups, pool)
    eager.ensure_total()
    lazy = forecast.Forecaster(params, state, rows, groups, pool)
    assert not lazy._total_done.any()
    h, t_s = np.zeros(3, np.int64), np.full(3, 1.0e6)
    some = np.array([31, 2, 17])
    lazy.flow("static", some, h, t_s)
    lazy.flow("profile", some, h, t_s)
    assert not lazy._total_done.any()  # no FreMEn asked: nothing computed
    got = lazy.flow("fremen2", some, h, t_s)
    assert sorted(np.flatnonzero(lazy._total_done).tolist()) == [2, 17, 31]
    np.testing.assert_array_equal(got, eager.flow("fremen2", some, h, t_s))
    np.testing.assert_array_equal(lazy.coef_total, eager.coef_total)  # the rest on access
    np.testing.assert_array_equal(lazy.period_idx, eager.period_idx)
    assert lazy._total_done.all()
