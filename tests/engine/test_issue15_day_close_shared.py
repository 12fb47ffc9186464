"""Issue 15, stop 66: a day close computes its slots' e^{−iωt} once and κ's distinct pairs
without sorting complex numbers; each gives exactly what it replaced, bit for bit.

* ``direction_prior._distinct_pairs`` against ``np.unique(count + 1j * share,
  return_counts=True)``, the code before it: same pairs, same order, same counts (κ's
  estimate itself, with ln Γ(κ p) once per distinct share, against one ln Γ call per
  argument: ``test_issue15_stream_paths``).
* ``FremenParts.use_rotations``: the day's table taken as the rotation table gives every
  pair the rows :meth:`_rotation_table` computed from the pairs' own distinct times; times
  that are not strictly increasing are not taken.
* Whole days of a fixed sensor and a robot (own pairs with exposures) scored and absorbed
  with the shared table and with the table computed per call: every accumulator and score
  equal to the bit.
"""

from __future__ import annotations

from datetime import UTC, datetime
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.direction_prior import _distinct_pairs
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.fremen_parts import FremenParts
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows

S = 1_000_000_000
WINDOW_NS = 600 * S
START = int(datetime(2026, 11, 2, tzinfo=UTC).timestamp()) * S  # a Monday


@given(seed=st.integers(0, 2**31 - 1), size=st.integers(0, 400), whole=st.booleans())
@settings(max_examples=80, deadline=None)
def test_distinct_pairs_are_numpys_unique_of_the_complex_pairs(
    seed: int, size: int, whole: bool
) -> None:
    rng = np.random.default_rng(seed)
    count = rng.integers(1, 12, size).astype(np.float64)
    if not whole:  # fractional counts (a grid's) as well, some repeated
        count += np.where(rng.random(size) < 0.4, rng.choice([0.25, 0.5, 1e-9], size), 0.0)
        count += np.where(rng.random(size) < 0.2, rng.uniform(0, 1, size), 0.0)
    share = rng.choice(rng.dirichlet(np.ones(6)), size) if size else np.zeros(0)
    share = np.clip(share, 1e-12, None)
    pairs, times = np.unique(count + 1j * share, return_counts=True)
    got_count, shares, of_share, got_times = _distinct_pairs(count, share)
    assert got_count.tobytes() == pairs.real.copy().tobytes()
    assert shares[of_share].tobytes() == pairs.imag.copy().tobytes()
    assert shares.tolist() == np.unique(share).tolist()
    assert got_times.dtype == times.dtype
    assert got_times.tolist() == times.tolist()


def _parts(omega: np.ndarray) -> FremenParts:
    parts = FremenParts.__new__(FremenParts)
    parts.params = SimpleNamespace(omega=omega)  # type: ignore[assignment]
    parts._times = (np.zeros(0), np.zeros((0, omega.size), complex))
    return parts


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=50, deadline=None)
def test_a_days_table_gives_the_rows_computed_from_the_pairs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    params = TemporalParams.from_config(ModelConfig())
    t_s = np.cumsum(rng.uniform(1.0, 900.0, int(rng.integers(1, 150)))) + rng.uniform(0, 1e8)
    table = np.exp(-1j * np.multiply.outer(t_s, params.omega))
    pair_t = t_s[rng.integers(0, t_s.size, int(rng.integers(1, 300)))]
    fresh = _parts(params.omega)
    want, want_at = fresh._rotation_table(pair_t)
    shared = _parts(params.omega)
    shared.use_rotations(t_s, table)
    got, got_at = shared._rotation_table(pair_t)
    assert got is table
    assert got[got_at].tobytes() == want[want_at].tobytes()


def test_times_not_strictly_increasing_are_not_taken() -> None:
    params = TemporalParams.from_config(ModelConfig())
    t_s = np.array([10.0, 20.0, 20.0, 30.0])
    parts = _parts(params.omega)
    parts.use_rotations(t_s, np.exp(-1j * np.multiply.outer(t_s, params.omega)))
    assert parts._times[0].size == 0


def _days(rng: np.random.Generator, params: TemporalParams, entries: int, days: int,
          fixed: bool) -> DayWindows:
    """``days`` days of windows: a fixed sensor's (every entry observed in every window,
    the last slot of each day recorded in part) or a robot's (each entry observed in some
    windows, for a part of some), Poisson counts spread over the value bins."""
    n = days * 144
    windows = START // WINDOW_NS + np.arange(n)
    if fixed:
        obs_e, obs_s, weight = (np.zeros(0, np.int64),) * 2 + (None,)
    else:
        seen = rng.random((entries, n)) < 0.3
        obs_e, obs_s = (a.astype(np.int64) for a in np.nonzero(seen))
        weight = np.where(rng.random(obs_e.size) < 0.3, rng.uniform(0.05, 1.0, obs_e.size), 1.0)
    hour = (np.arange(n) % 144) // 6
    busy = np.where((hour >= 8) & (hour < 19), 3.0, 0.05)
    lam = np.outer(rng.uniform(0.1, 2.0, entries), busy)
    counts = rng.poisson(lam)
    if not fixed:
        counts = counts * seen
    cnt_e, cnt_s = (a.astype(np.int64) for a in np.nonzero(counts))
    values = np.zeros((cnt_e.size, params.values))
    bins = rng.integers(0, params.values, cnt_e.size)
    values[np.arange(cnt_e.size), bins] = counts[cnt_e, cnt_s]
    share = np.where(np.arange(n) % 144 == 143, 0.5, 1.0) if fixed else None
    return DayWindows(windows, np.full(n, fixed), obs_e, obs_s, cnt_e, cnt_s, values,
                      weight, share)  # fmt: skip


def _learned(days: DayWindows, params: TemporalParams, entries: int) -> Any:
    state = temporal.empty_state(params, entries)
    rows = np.arange(entries)
    temporal.learn(params, state, days, rows, rows % 3, 3, WINDOW_NS)
    return state


@pytest.mark.parametrize("fixed", [True, False])
def test_whole_days_with_the_shared_table_equal_the_table_per_call(
    fixed: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    params = TemporalParams.from_config(ModelConfig())
    days = _days(np.random.default_rng(66), params, 40, 4, fixed)
    shared = _learned(days, params, 40)
    monkeypatch.setattr(Forecaster, "use_rotations", lambda self, t_s, table: None)
    per_call = _learned(days, params, 40)
    a, b = shared.__getstate__(), per_call.__getstate__()
    assert a.keys() == b.keys()
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, np.ndarray):
            assert x.tobytes() == y.tobytes(), key
        elif hasattr(x, "fourier"):  # the observation blocks
            for part in ("n", "fourier", "profile", "first", "last"):
                assert getattr(x, part).tobytes() == getattr(y, part).tobytes(), (key, part)
        else:
            assert x == y, key
    assert float(np.abs(shared.flow_score).sum()) > 0.0  # days were scored
