"""engine.descriptors against hand-computed values (paper's bin convention, B = 8)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine import descriptors
from aion_cli.engine.descriptors import (
    Descriptors,
    bin_centres,
    bin_of,
    historical,
)

B = 8
W = math.pi / 4  # bin width for B = 8


def _hist(counts: list[list[float]], windows: list[float] | None = None) -> Descriptors:
    c = np.array(counts, dtype=float)
    zeros = np.zeros_like(c)
    obs = np.ones(len(c)) if windows is None else np.array(windows, dtype=float)
    return historical(c, zeros, zeros, obs, 600.0)


def test_bin_centres_and_edges() -> None:
    np.testing.assert_allclose(bin_centres(B), -math.pi + (np.arange(B) + 0.5) * W)
    assert bin_of(bin_centres(B), B).tolist() == list(range(B))
    below_pi = np.nextafter(math.pi, 0.0)
    above_minus_pi = np.nextafter(-math.pi, 0.0)
    edges = [-math.pi, above_minus_pi, below_pi, math.pi, 0.0, -1e-12, 3 * math.pi, -3.2, 7.0]
    # 7.0 rad = 7 - 2π = 0.7168 rad -> floor((0.7168 + π)/W) = 4
    assert bin_of(edges, B).tolist() == [0, 0, B - 1, 0, 4, 3, 0, B - 1, 4]
    assert bin_of([np.nan, np.inf], B).tolist() == [-1, -1]
    assert bin_of([math.pi / 2 + 1e-9, math.pi / 2 - 1e-9], 4).tolist() == [3, 2]


def test_uniform_histogram_has_entropy_one_and_no_concentration() -> None:
    d = _hist([[3.0] * B], windows=[4.0])
    assert d.entropy[0] == pytest.approx(1.0, abs=1e-12)
    assert d.concentration[0] == pytest.approx(0.0, abs=1e-12)
    assert d.flow_per_window[0] == pytest.approx(24 / 4)
    assert d.flow_per_hour[0] == pytest.approx(6 * 6.0)
    np.testing.assert_allclose(d.probabilities[0], 1 / B)


def test_one_bin_has_entropy_zero_and_its_centre_as_direction() -> None:
    counts = np.zeros((1, B))
    counts[0, 2] = 5.0
    d = _hist(counts.tolist())
    assert d.entropy[0] == pytest.approx(0.0, abs=1e-12)
    assert d.dominant_bin[0] == 2
    assert d.dominant_angle[0] == pytest.approx(-3 * math.pi / 8)  # -π + 2.5·π/4
    assert d.concentration[0] == pytest.approx(1.0)


def test_circular_mean_wraps_at_plus_minus_pi() -> None:
    counts = np.zeros((2, B))
    counts[0, [0, B - 1]] = 1.0  # centres -7π/8 and +7π/8: the mean points at ±π
    counts[1, 0], counts[1, B - 1] = 3.0, 1.0  # weighted towards -7π/8
    d = _hist(counts.tolist())
    assert math.cos(d.mean_angle[0]) == pytest.approx(-1.0)
    assert math.sin(d.mean_angle[0]) == pytest.approx(0.0, abs=1e-12)
    assert d.concentration[0] == pytest.approx(math.cos(math.pi / 8))
    assert d.entropy[0] == pytest.approx(math.log(2) / math.log(B))
    # hand: c = cos(7π/8), s = -sin(π/8)/2 -> atan2(s, c) = -π + atan(tan(π/8)/2)
    assert d.mean_angle[1] == pytest.approx(-math.pi + math.atan(math.tan(math.pi / 8) / 2))
    assert d.dominant_bin[1] == 0
    assert d.dominant_angle[1] == pytest.approx(-7 * math.pi / 8)  # the most frequent bin
    c, s = math.cos(7 * math.pi / 8), -math.sin(math.pi / 8) / 2
    assert d.concentration[1] == pytest.approx(math.hypot(c, s))


def test_a_corridor_walked_both_ways_points_along_the_corridor_not_across() -> None:
    """The dominant direction is where most people walk. In a corridor along +x walked 52 %
    east and 48 % west, with a few crossing north, the circular mean (the mean angle) points
    north, across the corridor: the east and west vectors nearly cancel and the crossers
    decide it. The dominant angle stays east; the concentration says the flow is balanced."""
    east, west, north = 4, 0, 6  # bin centres: -π/8 + π/4·k; bin 4 = [0, π/4), 0 = [-π, -3π/4)
    counts = np.zeros((1, B))
    counts[0, east], counts[0, west], counts[0, north] = 52.0, 48.0, 10.0
    cos = np.zeros((1, B))
    sin = np.zeros((1, B))
    cos[0, east], cos[0, west] = 52.0, -48.0  # headings exactly along ±x
    cos[0, north], sin[0, north] = 0.0, 10.0  # and exactly along +y
    d = historical(counts, np.zeros((1, B)), np.zeros((1, B)), np.array([1.0]), 600.0, cos, sin)
    assert d.dominant_bin[0] == east
    assert d.dominant_angle[0] == pytest.approx(0.0, abs=1e-12)
    # mean vector (4, 10) / 110: 68° from +x, across the corridor, and short
    assert d.mean_angle[0] == pytest.approx(math.atan2(10.0, 4.0))
    assert d.concentration[0] == pytest.approx(math.hypot(4.0, 10.0) / 110.0)


def test_no_flow_and_unobserved_entries() -> None:
    d = _hist([[0.0] * B, [1.0] + [0.0] * (B - 1)], windows=[5.0, 0.0])
    assert d.dominant_bin[0] == -1
    assert math.isnan(d.dominant_angle[0])
    assert math.isnan(d.mean_angle[0])
    assert math.isnan(d.entropy[0])
    assert d.concentration[0] == 0.0
    assert d.flow_per_window[0] == 0.0
    assert math.isnan(d.flow_per_window[1])  # counts but no observed window: unknown rate


def test_mean_speed_only_where_known() -> None:
    counts = np.array([[2.0, 1.0, 0, 0, 0, 0, 0, 0]])
    speed_sum = np.array([[2.6, 0, 0, 0, 0, 0, 0, 0]])
    speed_n = np.array([[2.0, 0, 0, 0, 0, 0, 0, 0]])
    d = historical(counts, speed_sum, speed_n, np.array([1.0]), 600.0)
    assert d.mean_speed[0, 0] == pytest.approx(1.3)
    assert np.all(np.isnan(d.mean_speed[0, 1:]))


def test_per_window_rates_give_the_descriptors_of_the_counts() -> None:
    """Queries feed expected detections per window (rates) with one window: the descriptors
    must equal those of the counts over their W observed windows."""
    counts = np.array([[6.0, 0, 0, 0, 0, 3.0, 0, 3.0], [0.0] * B, [0, 0, 10.0, 0, 0, 0, 0, 0]])
    speed_sum = np.array([[6.0, 0, 0, 0, 0, 1.5, 0, 0]] + [[0.0] * B] * 2)
    speed_n = np.array([[4.0, 0, 0, 0, 0, 1.0, 0, 0]] + [[0.0] * B] * 2)
    windows = np.array([4.0, 2.0, 5.0])
    a = historical(counts, speed_sum, speed_n, windows, 600.0)
    b = historical(counts / windows[:, None], speed_sum, speed_n, np.ones(3), 600.0)
    np.testing.assert_allclose(b.flow_per_window, [3.0, 0.0, 2.0], rtol=1e-12)
    np.testing.assert_allclose(b.flow_per_hour, [18.0, 0.0, 12.0], rtol=1e-12)
    for name in ("flow_per_window", "flow_per_hour", "probabilities", "entropy",
                 "concentration", "dominant_angle", "mean_angle", "mean_speed"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-12,
                                   atol=1e-15, equal_nan=True, err_msg=name)
    np.testing.assert_array_equal(b.dominant_bin, a.dominant_bin)
    assert b.dominant_bin.tolist() == [0, -1, 2]
    np.testing.assert_allclose(b.probabilities[0], [0.5, 0, 0, 0, 0, 0.25, 0, 0.25])
    assert b.mean_speed[0, 0] == pytest.approx(1.5)
    assert b.entropy[2] == pytest.approx(0.0)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(1, 9), st.integers(0, 2**32 - 1))
def test_argmax_columns_equals_numpy_argmax_with_ties(rows: int, cols: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = rng.integers(0, 3, (rows, cols)).astype(np.float64)  # many ties: the first one wins
    np.testing.assert_array_equal(descriptors._argmax_columns(x), np.argmax(x, axis=1))


def test_describing_some_rows_equals_describing_them_among_all() -> None:
    """``predict --top N`` describes only the rows it prints: every descriptor of a row must
    be the same to the bit whichever rows are computed with it (a matrix product of another
    shape may sum a row in another order)."""
    from aion_cli.engine.descriptors import historical

    rng = np.random.default_rng(3)
    for n in (12, 50, 1000, 20_000):  # BLAS took another order on some of these (1-4 rows)
        counts = rng.gamma(0.5, 3.0, size=(n, 8)) * (rng.random((n, 8)) < 0.6)
        speed_sum, speed_n = counts * 1.3, counts
        windows = rng.integers(0, 40, n).astype(float)
        whole = historical(counts, speed_sum, speed_n, windows, 600.0)
        for k in (1, 2, 3, 5, 10):
            rows = rng.choice(n, k, replace=False)
            part = historical(counts[rows], speed_sum[rows], speed_n[rows], windows[rows], 600.0)
            for name in ("flow_per_window", "probabilities", "dominant_bin", "dominant_angle",
                         "mean_angle", "concentration", "entropy", "mean_speed"):
                np.testing.assert_array_equal(getattr(part, name), getattr(whole, name)[rows])
