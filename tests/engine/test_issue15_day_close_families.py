"""Issue 15, stop 68: a day close asks every direction family at the same pairs at once
(``Forecaster.directions_at``: the gathers they share made once), the absorption finds a
day's profile cells from the (entry, value) rows it found already (``_profile_keys``), and
κ's estimate gathers the parents of the sampled rows only. Each must give what it replaces to
the bit: each family's full histograms at the asked bins, ``np.unique(keys,
return_inverse=True)`` of the cells' flat keys, and κ of exactly the kept rows."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.temporal import direction_prior
from aion_cli.engine.temporal.absorption import _profile_keys
from aion_cli.engine.temporal.direction_prior import (
    MAX_ENTRIES,
    MIN_ENTRIES,
    fitted_kappa,
    sample_rows,
)
from aion_cli.engine.temporal.direction_scoring import DetectionBins
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.pooling import PoolStats
from aion_cli.engine.windows import to_model_seconds
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor


def _rush(d: int, h: int) -> float:
    return 40.0 if h in (8, 9, 17, 18) else 2.0


def _turning(d: int, h: int) -> float:
    return 0.0 if h < 12 else np.pi / 2  # east in the morning, north in the afternoon


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def _forecaster() -> tuple[Forecaster, Forecaster, dict[str, np.ndarray]]:
    """Two forecasters of the same state (one per way of asking: nothing memoised by one
    serves the other) and pairs of a day with detections in one or two bins."""
    state = corridor(6, _rush, seed=3, heading=_turning).state
    params = state.params
    view = state.query_temporal()
    rows = state.entries.canonical_order()
    groups = np.zeros(rows.size, np.int64)
    pool = PoolStats.of(params, view, rows, groups, 1)
    first, second = (Forecaster(params, view, rows, groups, pool) for _ in range(2))
    rng = np.random.default_rng(1)
    pairs = 600
    t_ns = MONDAY + 6 * DAY + rng.integers(0, 24, pairs) * HOUR + 30 * 60 * 10**9
    counts = np.zeros((pairs, params.bins))
    counts[np.arange(pairs), rng.integers(0, params.bins, pairs)] = rng.integers(1, 5, pairs)
    counts[::4, 1] += 2.0  # a quarter of the pairs with detections in two bins
    counted = DetectionBins.of(counts)
    return first, second, {
        "e": rng.integers(0, rows.size, pairs),
        "h": params.calendar.profile_bin(t_ns),
        "t_s": to_model_seconds(t_ns),
        "pair": counted.pair,
        "bin": counted.bin,
    }


@pytest.mark.parametrize("order", ["as_configured", "reversed", "timed_twice"])
def test_families_asked_together_equal_each_full_histogram_to_the_bit(order: str) -> None:
    fc, reference, p = _forecaster()
    names = list(fc.params.direction)
    assert "static" in names
    assert "profile" in names
    assert sum(n.startswith("fremen") for n in names) >= 2  # two FreMEn share their gathers
    if order == "reversed":
        names = names[::-1]
    elif order == "timed_twice":
        names = [n for n in names if n != "static"] * 2
    got = fc.directions_at(names, p["e"], p["h"], p["t_s"], p["pair"], p["bin"])
    assert len(got) == len(names)
    for name, values in zip(names, got, strict=True):
        full = reference.direction(name, p["e"], p["h"], p["t_s"])
        np.testing.assert_array_equal(_bits(values), _bits(full[p["pair"], p["bin"]]))
        single = reference.direction_at(name, p["e"], p["h"], p["t_s"], p["pair"], p["bin"])
        np.testing.assert_array_equal(_bits(values), _bits(single))
    # each family's values are its own array: writing one leaves the others as they were
    before = [v.copy() for v in got]
    got[0][:] = -1.0
    for values, kept in zip(got[1:], before[1:], strict=True):
        np.testing.assert_array_equal(values, kept)


def test_the_forecasters_directed_sums_are_the_counts_summed_over_the_direction_bins() -> None:
    fc, _, _ = _forecaster()
    b = fc.params.bins
    expected = fc.counts[:, :b].sum(axis=1)
    assert expected.max() > 0
    np.testing.assert_array_equal(_bits(fc.directed), _bits(expected))


@pytest.mark.parametrize(
    ("hours_low", "hours_high", "pairs"),
    [(0, 24, 5_000), (24, 48, 5_000), (7, 8, 300), (0, 48, 40), (13, 14, 1)],
)
def test_profile_keys_are_the_unique_keys_and_their_inverse(
    hours_low: int, hours_high: int, pairs: int
) -> None:
    rng = np.random.default_rng(hours_low * 1000 + pairs)
    n_prof, values = 48, 9
    rows = np.sort(rng.integers(0, 5_000, pairs))
    flat = rows * values + rng.integers(0, values, pairs)
    targets, which = np.unique(flat, return_inverse=True)
    hours = rng.integers(hours_low, hours_high, pairs)
    keys, inverse = _profile_keys(targets, which.reshape(-1), hours, n_prof)
    expected, expected_inverse = np.unique(flat * n_prof + hours, return_inverse=True)
    np.testing.assert_array_equal(keys, expected)
    np.testing.assert_array_equal(inverse, expected_inverse.reshape(-1))
    np.testing.assert_array_equal(keys[inverse], flat * n_prof + hours)


def test_profile_keys_of_a_day_without_counts() -> None:
    empty = np.zeros(0, np.int64)
    keys, inverse = _profile_keys(empty, empty, empty, 48)
    assert keys.size == 0
    assert inverse.size == 0


def test_a_sampled_kappa_reads_each_kept_rows_own_parent(monkeypatch: pytest.MonkeyPatch) -> None:
    """κ from more telling rows than ``MAX_ENTRIES`` is κ from exactly the rows the sample
    keeps, each with its own parent histogram (clipped where it has zeros): the parents are
    gathered for the kept rows only (issue 15, stop 68)."""
    rng = np.random.default_rng(68)
    n = 9_000
    parents = rng.dirichlet(np.full(8, 1.5), 3)
    parents[2, :3] = 0.0  # zeros the estimate clips to 1e-12
    parents[2] /= parents[2].sum()
    group = rng.integers(0, 3, n)
    parent = parents[group]
    totals = rng.integers(0, 40, n)  # some rows of fewer than two detections: not telling
    draws = [
        rng.multinomial(t, rng.dirichlet(6.0 * p + 1e-3))
        for t, p in zip(totals, parent, strict=True)
    ]
    counts = np.array(draws, dtype=np.float64)
    tell = np.flatnonzero(counts.sum(axis=1) >= 2)
    assert tell.size > MAX_ENTRIES
    kept = tell[sample_rows(counts[tell], MAX_ENTRIES, parent[tell])]
    assert MIN_ENTRIES <= kept.size < tell.size
    assert np.unique(group[kept]).size == 3
    whole = fitted_kappa(counts, parent)
    # about MAX_ENTRIES are kept (2,114 here): the second estimate samples nothing
    monkeypatch.setattr(direction_prior, "MAX_ENTRIES", kept.size)
    assert whole == fitted_kappa(counts[kept], parent[kept])
    # and the rows' parents matter: the same rows with the parents shifted by one row differ
    assert whole != fitted_kappa(counts[kept], np.roll(parent[kept], 1, axis=0))


def test_kappa_and_kappa_ts_input_share_one_sample(monkeypatch: pytest.MonkeyPatch) -> None:
    """A pooling chooses the entries κ reads once, and κ_t's input reads the profile bins of
    the very same entries (issue 15, stop 71): κ and κ_t are those estimated from the plain
    inputs, each sample chosen afresh, with one entry sample fewer drawn."""
    from aion_cli.engine.temporal import pooling

    state = corridor(6, _rush, seed=3, heading=_turning).state
    params, view = state.params, state.query_temporal()
    rows = state.entries.canonical_order()
    groups = np.arange(rows.size) % 3
    for module in (direction_prior, pooling):  # a sample is drawn, wherever it is drawn
        monkeypatch.setattr(module, "MAX_ENTRIES", rows.size // 2, raising=False)
    drawn: list[int] = []
    real = direction_prior.sample_rows

    def counted(counts: np.ndarray, about: int, shares: np.ndarray | None = None) -> np.ndarray:
        drawn.append(counts.shape[0])
        return real(counts, about, shares)

    for module in (direction_prior, pooling):
        monkeypatch.setattr(module, "sample_rows", counted, raising=False)
    pool = PoolStats.of(params, view, rows, groups, 3)
    counts = pooling.entry_counts(view, rows)[:, : params.bins]
    parent = pool.histogram[groups]
    tell = np.flatnonzero(counts.sum(axis=1) >= 2)
    assert tell.size > rows.size // 2
    assert drawn.count(tell.size) == 1  # κ's entries, drawn once for κ and κ_t's input
    drawn.clear()
    assert pool.kappa == fitted_kappa(counts, parent)
    per_bin = pooling.per_bin_directed(view, rows, counts, parent, pool.kappa, groups, pool.shift)
    assert drawn.count(tell.size) == 2  # each chose the entries afresh
    assert pool.kappa_t == fitted_kappa(*per_bin, direction_prior.TIME_FALLBACK,
                                        direction_prior.TIME_KAPPA_LOW)
