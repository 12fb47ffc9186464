"""The spread's coverage (``evaluation.spread``): counts drawn from a known distribution are
judged against that distribution's band, and the coverage must be the band's 80 % within a
binomial tolerance (fixed seeds); a band too narrow or too wide for its counts must read so.

Tolerance: the PIT share of n independent counts has a standard deviation of at most
sqrt(0.8 · 0.2 / n) (that of a binomial share; the expected PIT of a count varies less than
a draw of it), so ``TOLERANCE_SIGMAS`` of those bound it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.temporal.choice import count_cdf
from aion_cli.evaluation.spread import entry_positions, pair_counts, spread_coverage, spread_of

TOLERANCE_SIGMAS = 4.0


def tolerance(n: int) -> float:
    return TOLERANCE_SIGMAS * math.sqrt(0.8 * 0.2 / n)


@pytest.mark.parametrize("rate", [0.3, 2.0, 7.0, 40.0])
def test_poisson_counts_fill_their_poisson_band(rate: float) -> None:
    n = 5_000
    y = np.random.default_rng(7).poisson(rate, n)
    cover = spread_coverage(y, np.full(n, rate), np.full(n, rate))
    assert cover["counts"] == n
    assert cover["pit"] == pytest.approx(0.8, abs=tolerance(n))
    # the printed band, whole counts included, holds at least its 80 % and each tail at most
    # its 10 %
    assert cover["inside"] >= 0.8 - tolerance(n)
    assert cover["below"] <= 0.1 + tolerance(n)
    assert cover["above"] <= 0.1 + tolerance(n)
    assert cover["inside"] + cover["below"] + cover["above"] == pytest.approx(1.0)


def test_a_small_mean_holds_more_than_80_percent_in_its_band_yet_reads_calibrated() -> None:
    """μ = 0.05: p10 = p90 = 0, a band that holds e^-0.05 = 95 % of counts; the PIT still
    reads 80 %."""
    n = 20_000
    y = np.random.default_rng(3).poisson(0.05, n)
    cover = spread_coverage(y, np.full(n, 0.05), np.full(n, 0.05))
    assert cover["inside"] == pytest.approx(math.exp(-0.05), abs=4 * math.sqrt(0.05 / n))
    assert cover["pit"] == pytest.approx(0.8, abs=tolerance(n))


def test_overdispersed_counts_against_their_negative_binomial_and_against_poisson() -> None:
    """Negative binomial counts of mean 6 and variance 4 · 6: the band of that variance holds
    80 %, Poisson's (variance 6) is too narrow and holds far less."""
    n, mu, phi = 5_000, 6.0, 4.0
    p = 1.0 / phi
    y = np.random.default_rng(11).negative_binomial(mu * p / (1.0 - p), p, n)
    right = spread_coverage(y, np.full(n, mu), np.full(n, phi * mu))
    narrow = spread_coverage(y, np.full(n, mu), np.full(n, mu))
    assert right["pit"] == pytest.approx(0.8, abs=tolerance(n))
    assert narrow["pit"] < 0.6
    assert narrow["below"] > 0.15
    assert narrow["above"] > 0.15


def test_a_band_too_wide_reads_above_80_percent() -> None:
    n = 5_000
    y = np.random.default_rng(5).poisson(10.0, n)
    wide = spread_coverage(y, np.full(n, 10.0), np.full(n, 90.0))
    assert wide["pit"] > 0.9


def test_hand_checked_values() -> None:
    # Poisson μ = 2: P(N ≤ 1) = 3 e^-2; a count of 0 has PIT uniform on [0, e^-2], of which
    # e^-2 - 0.1 lies in [0.1, 0.9]
    assert count_cdf(1, 2.0, 2.0) == pytest.approx(3 * math.exp(-2))
    assert count_cdf(-1, 2.0, 2.0) == 0.0
    assert count_cdf(0, 0.0, 0.0) == 1.0
    assert math.isnan(float(count_cdf(0, math.nan, 1.0)))
    one = spread_coverage([0], [2.0], [2.0])
    assert one["pit"] == pytest.approx((math.exp(-2) - 0.1) / math.exp(-2))
    assert one["inside"] == 1.0  # P(N = 0) = 0.135 ≥ 0.1: p10 of Poisson(2) is 0
    # Poisson μ = 3: P(N = 0) = e^-3 < 0.1, so p10 = 1 and a count of 0 lies below the
    # band, its PIT [0, e^-3] wholly outside [0.1, 0.9]
    three = spread_coverage([0], [3.0], [3.0])
    assert (three["below"], three["inside"], three["pit"]) == (1.0, 0.0, 0.0)
    # NaN means are left out; nothing judged gives no share
    assert spread_coverage([3, 1], [math.nan, 1.0], [1.0, 1.0])["counts"] == 1
    assert spread_coverage([], [], [])["pit"] is None


def test_pair_counts_conserve_the_detections_of_the_pairs() -> None:
    place = np.array([0, 1, 2, 0, 1, 2])
    window = np.array([0, 0, 0, 1, 1, 1])
    det_place = np.array([0, 0, 2, 1, -1, 1, 2])
    det_window = np.array([0, 0, 1, 1, 0, -1, 0])
    counts = pair_counts(place, window, 2, det_place, det_window)
    assert counts.tolist() == [2.0, 0.0, 1.0, 0.0, 1.0, 1.0]
    assert pair_counts(place, window, 2, np.array([-1]), np.array([0])).tolist() == [0.0] * 6


def test_poisson_corridor_end_to_end() -> None:
    """A map learnt from a week of a fixed sensor over a corridor where people appear at
    uniform random places, a Poisson number per hour, judged on a day more of the same: every
    cell's window count is Poisson, so the map's band (its forecast and dispersion, the
    detections routed to its cells as a build routes them) holds 80 % of them."""
    from tests.engine.temporal_data import DAY, HOUR, MONDAY, S, corridor

    def rate(_d: int, _h: int) -> float:
        return 120.0

    days = 7
    state = corridor(days, rate, seed=1).state
    rows, predictor = state.predictor()
    rng = np.random.default_rng(99)
    t_parts, xy_parts = [], []
    start = MONDAY + days * DAY
    for h in range(24):
        n = int(rng.poisson(rate(days, h)))
        t_parts.append(start + h * HOUR + rng.integers(0, HOUR, n))
        xy_parts.append(rng.uniform((0.0, 0.0), (10.0, 2.0), size=(n, 2)))
    t = np.concatenate(t_parts)
    xyz = np.column_stack([np.concatenate(xy_parts), np.zeros(t.size)])
    positions = entry_positions(state, rows, xyz)
    assert (positions >= 0).all()  # every place a cell the week saw
    assert entry_positions(state, rows, np.array([[500.0, 500.0, 0.0]])).tolist() == [-1]
    window_ns = state.window_ns
    windows = np.arange(start // window_ns, (start + DAY) // window_ns)
    place = np.tile(np.arange(rows.size), windows.size)
    window = np.repeat(np.arange(windows.size), rows.size)
    centres = windows[window] * window_ns + window_ns // 2
    expected = predictor.flows(place, centres)
    variance = predictor.variances(place, state.params.calendar.profile_bin(centres), expected)
    starts = windows * window_ns
    cover = spread_of(
        state, rows, xyz, t // window_ns - windows[0], (place, window, windows.size),
        (expected, variance), (starts, starts),
    )
    pairs = cover["place_windows"]
    assert pairs["counts"] == rows.size * windows.size
    assert pairs["pit"] == pytest.approx(0.8, abs=tolerance(pairs["counts"]))
    assert cover["hours"]["counts"] == 24
    assert S == 10**9  # the helper's unit, as the windows above assume
