"""The spread of a sum of places (``engine.temporal.totals``): places whose counts are
correlated because one walker is counted by several cells in a window.

Known answers: under the cluster model the totals' dispersion is the clusters' size (every
walker detected ``BURST`` times: a window's total is ``BURST`` times a Poisson count, variance
``BURST`` times its mean), the covariance of two places follows from the thinning (checked by
simulation against the formula), and the band of the window totals holds 80 % of held-out
totals where the places summed as independent hold far fewer (PIT tolerance as in
``tests/evaluation/test_spread.py``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from aion_cli.engine.query import aggregate_table, historical_table
from aion_cli.engine.temporal.shape_prior import overdispersion
from aion_cli.engine.temporal.totals import sum_variance
from aion_cli.evaluation.spread import entry_positions, spread_coverage, spread_of
from tests.engine.temporal_data import DAY, HOUR, MONDAY, S, bursty_corridor

BURST = 20
PASSES = 30.0  # walkers per hour: 5 per 10-minute window, 100 detections


def tolerance(n: int) -> float:
    return 4.0 * math.sqrt(0.8 * 0.2 / n)


def test_a_group_of_one_place_or_a_poisson_map_adds_no_covariance() -> None:
    mean, var = np.array([2.0, 3.0, 5.0]), np.array([4.0, 3.0, 6.0])
    group = np.array([0, 1, 1])
    independent = sum_variance(mean, var, group, 2, 10.0, 1.0)
    np.testing.assert_array_equal(independent, [4.0, 9.0])
    wider = sum_variance(mean, var, group, 2, 10.0, 5.0)
    # hand-checked: group 1 adds (5 - 1) * ((3 + 5)^2 - 3^2 - 5^2) / 10 = 4 * 30 / 10 = 12
    np.testing.assert_allclose(wider, [4.0, 21.0])
    # a place without a forecast counts as 0; a group without places has variance 0
    np.testing.assert_allclose(
        sum_variance([np.nan, 1.0], [np.nan, 1.0], np.array([0, 0]), 2, 10.0, 5.0), [1.0, 0.0]
    )


def test_thinned_clusters_have_the_formulas_covariance() -> None:
    """Clusters of 6 detections, a Poisson number per window, each detection falling at one
    of four places with fixed shares: the variance of the first three places' sum over many
    windows is the formula's, with each place's own variance its sample variance."""
    rng = np.random.default_rng(5)
    windows, size = 200_000, 6
    share = np.array([0.1, 0.2, 0.3, 0.4])
    clusters = rng.poisson(2.0, windows)
    counts = rng.multinomial(clusters * size, share)  # detections per (window, place)
    mean = counts.mean(axis=0)
    total = counts.sum(axis=1)
    phi_total = total.var() / total.mean()
    assert phi_total == pytest.approx(size, rel=0.02)  # E[K^2] / E[K] for K = size
    group = np.array([0, 0, 0, 1])
    predicted = sum_variance(mean, counts.var(axis=0), group, 2, mean.sum(), phi_total)
    observed = counts[:, :3].sum(axis=1).var()
    assert predicted[0] == pytest.approx(observed, rel=0.03)
    assert counts[:, :3].var(axis=0).sum() < 0.6 * observed  # the independent sum: far short


def _bursts(days: range, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Held-out detections as ``bursty_corridor`` makes them: ``PASSES`` walkers an hour, each
    walking 2 m east in 10 s and detected ``BURST`` times (several cells, one window)."""
    rng = np.random.default_rng(seed)
    t_parts, xyz_parts = [], []
    for d in days:
        for h in range(24):
            n = int(rng.poisson(PASSES))
            t0 = MONDAY + d * DAY + h * HOUR + np.sort(rng.integers(0, HOUR - 60 * S, n))
            t_parts.append((t0[:, None] + np.arange(BURST) * (10 * S // BURST)).reshape(-1))
            x = rng.uniform(0.0, 8.0, n)[:, None] + np.linspace(0.0, 2.0, BURST)[None, :]
            y = np.repeat(rng.uniform(0.0, 2.0, n), BURST)
            xyz_parts.append(np.column_stack([x.reshape(-1), y, np.zeros(y.size)]))
    return np.concatenate(t_parts), np.concatenate(xyz_parts)


def test_bursty_window_totals_fall_in_their_band() -> None:
    """A map of four days of the bursty corridor measures its totals' dispersion as the burst
    size, and judged on three days more, the band of each window's total (the map's places
    summed with their covariance) holds 80 % of the totals, as does that of each hour's;
    summed as independent places, the band is far too narrow."""
    days = 4
    state = bursty_corridor(days, lambda _d, _h: PASSES, BURST, seed=3).state
    rows, predictor = state.predictor()
    assert overdispersion(state.query_temporal().window_chi2) == pytest.approx(BURST, rel=0.15)
    assert predictor.phi_total == overdispersion(state.query_temporal().window_chi2)
    t, xyz = _bursts(range(days, days + 3), seed=11)
    positions = entry_positions(state, rows, xyz)
    window_ns = state.window_ns
    start, end = MONDAY + days * DAY, MONDAY + (days + 3) * DAY
    windows = np.arange(start // window_ns, end // window_ns)
    place = np.tile(np.arange(rows.size), windows.size)
    window = np.repeat(np.arange(windows.size), rows.size)
    centres = windows[window] * window_ns + window_ns // 2
    expected = predictor.flows(place, centres)
    variance = predictor.variances(place, state.params.calendar.profile_bin(centres), expected)
    at = t // window_ns - windows[0]
    totals = np.bincount(at[positions >= 0], minlength=windows.size).astype(np.float64)
    mean = np.bincount(window, np.nan_to_num(expected), minlength=windows.size)
    grouped = sum_variance(expected, variance, window, windows.size, mean, predictor.phi_total)
    independent = np.bincount(window, np.nan_to_num(variance), minlength=windows.size)
    correlated = spread_coverage(totals, mean, grouped)
    assert correlated["pit"] == pytest.approx(0.8, abs=tolerance(windows.size))
    assert spread_coverage(totals, mean, independent)["pit"] < 0.8 - tolerance(windows.size)
    starts = windows * window_ns
    hours = spread_of(
        state, rows, xyz, at, (place, window, windows.size), (expected, variance),
        (starts, starts),
    )["hours"]
    assert hours["counts"] == 72
    assert hours["pit"] == pytest.approx(0.8, abs=tolerance(72))


def test_rooms_sum_their_places_with_the_maps_total_dispersion() -> None:
    """``aggregate_table``: a room's variance is its places' plus their covariance from the
    table's ``total_dispersion`` (the map's total flow the reference); 1 keeps the plain sum."""
    from tests.engine.engine_builders import T0, detections
    from tests.engine.test_query import _mapper_with_rooms

    m = _mapper_with_rooms(1)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 4, heading=np.zeros(4)))
    m.add_detections(detections(T0 + S, [[3.1, 0.1, 0]] * 2, heading=np.zeros(2)))
    m.add_detections(detections(T0 + S, [[9.1, 0.1, 0]] * 6, heading=np.zeros(6)))
    m.add_detections(detections(T0 + S, [[50.1, 0.1, 0]] * 5))  # a cell in no room
    m.advance(T0 + 600 * S)
    assert m.state.graph is not None
    table = historical_table(m.state)
    flow = np.nan_to_num(table.flow)
    np.testing.assert_allclose(np.sort(flow[flow > 0]), [2, 4, 5, 6])
    table = replace(table, flow_var=3.0 * flow)  # each place's own variance: φ = 3
    plain = aggregate_table(table, m.state.graph, "rooms")
    np.testing.assert_allclose(plain.flow_var, [18, 18])  # R1: 3·(4 + 2), R2: 3·6
    wide = aggregate_table(replace(table, total_dispersion=5.0), m.state.graph, "rooms")
    np.testing.assert_array_equal(wide.flow, plain.flow)  # the means are unchanged
    # R1 (places of 4 and 2): 18 + (5 - 1)·((4 + 2)^2 - 4^2 - 2^2)/17 = 18 + 64/17; R2: 18
    np.testing.assert_allclose(wide.flow_var, [18 + 64 / 17, 18])


def test_groups_without_places_have_no_variance() -> None:
    """No place in any window (a held-out log of another place: ``evaluate holdout`` judged
    nothing) gives zero variance per group, not a cast error from bincount's int64 zeros."""
    none = np.zeros(0, dtype=np.int64)
    got = sum_variance(np.zeros(0), np.zeros(0), none, 3, 5.0, phi_total=4.0)
    assert got.dtype == np.float64
    assert got.tolist() == [0.0, 0.0, 0.0]
