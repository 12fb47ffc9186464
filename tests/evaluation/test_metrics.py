"""Metrics against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aion_cli.evaluation import metrics as m

hist8 = arrays(np.float64, 8, elements=st.floats(0.0, 100.0)).filter(lambda a: a.sum() > 1e-3)


def test_identical_distributions_have_zero_distance() -> None:
    p = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    assert m.js_divergence(p, 2 * p) == pytest.approx(0.0, abs=1e-12)
    assert m.bhattacharyya_distance(p, p) == pytest.approx(0.0, abs=1e-12)
    assert m.wasserstein_linear(p, p) == pytest.approx(0.0)
    assert m.wasserstein_circular(p, p) == pytest.approx(0.0)
    assert m.chi_square_distance(p, p) == 0.0


def test_disjoint_distributions_reach_the_known_maximum() -> None:
    p = np.array([1.0, 0, 0, 0])
    q = np.array([0, 0, 1.0, 0])
    assert m.js_divergence(p, q) == pytest.approx(1.0)
    assert m.bhattacharyya_distance(p, q) == pytest.approx(-math.log(m.BHATTACHARYYA_EPS))


def test_js_of_half_overlap_is_hand_computed() -> None:
    # p = (1, 0), q = (0.5, 0.5): m = (0.75, 0.25)
    # KL(p||m) = log2(1/0.75); KL(q||m) = 0.5 log2(0.5/0.75) + 0.5 log2(0.5/0.25)
    expected = 0.5 * math.log2(4 / 3) + 0.5 * (0.5 * math.log2(2 / 3) + 0.5 * math.log2(2))
    assert m.js_divergence([1.0, 0.0], [0.5, 0.5]) == pytest.approx(expected)


def test_wasserstein_moves_mass_by_its_distance() -> None:
    p = np.array([1.0, 0, 0, 0, 0, 0, 0, 0])
    q = np.array([0, 0, 0, 1.0, 0, 0, 0, 0])
    assert m.wasserstein_linear(p, q) == pytest.approx(3.0)
    # On a circle of 8 bins, bin 0 -> bin 7 is one step, not seven.
    r = np.array([0, 0, 0, 0, 0, 0, 0, 1.0])
    assert m.wasserstein_linear(p, r) == pytest.approx(7.0)
    assert m.wasserstein_circular(p, r) == pytest.approx(1.0)
    assert m.wasserstein_circular(p, q, bin_width=45.0) == pytest.approx(135.0)


@settings(max_examples=60, deadline=None)
@given(hist8, hist8, st.integers(0, 7))
def test_circular_wasserstein_is_rotation_invariant(p: np.ndarray, q: np.ndarray, k: int) -> None:
    assert m.wasserstein_circular(np.roll(p, k), np.roll(q, k)) == pytest.approx(
        m.wasserstein_circular(p, q), abs=1e-9
    )
    assert m.wasserstein_circular(p, q) <= m.wasserstein_linear(p, q) + 1e-9
    assert 0.0 <= m.js_divergence(p, q) <= 1.0


def test_rotated_direction_field_gives_the_known_angle() -> None:
    rng = np.random.default_rng(3)
    field = rng.uniform(-math.pi, math.pi, 200)
    assert m.mean_angular_displacement_deg(field, field + math.radians(30)) == pytest.approx(30.0)
    assert m.mean_angular_displacement_deg(field, field + math.pi) == pytest.approx(180.0)


def test_circular_correlation_of_a_rotated_field_is_one() -> None:
    rng = np.random.default_rng(4)
    field = rng.vonmises(0.0, 1.0, 300)
    assert m.circular_correlation(field, field + 0.7) == pytest.approx(1.0)
    assert m.circular_correlation(field, -field) == pytest.approx(-1.0)
    independent = rng.uniform(-math.pi, math.pi, 300)
    assert abs(m.circular_correlation(field, independent)) < 0.2


def test_nll_of_uniform_model_is_log_two_pi() -> None:
    probs = np.full((5, 8), 0.125)
    nll = m.heading_nll(probs, np.arange(5))
    assert nll == pytest.approx(np.full(5, math.log(2 * math.pi)))


def test_nll_floors_zero_probabilities() -> None:
    probs = np.array([[1.0, 0, 0, 0, 0, 0, 0, 0]])
    assert np.isfinite(m.heading_nll(probs, [3]))[0]
    confident = m.heading_nll(probs, [0])[0]
    assert confident == pytest.approx(-math.log(8 / (2 * math.pi)), abs=1e-6)


def test_chi_square_is_hand_computed() -> None:
    assert m.chi_square_distance([1.0, 3.0, 0.0], [3.0, 1.0, 0.0]) == pytest.approx(2.0)


def test_negative_histogram_is_rejected() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        m.js_divergence([1.0, -1.0], [0.5, 0.5])


def test_activity_ranks_rates_when_told_how_long_each_hour_was_observed() -> None:
    """Hours observed 1, 1 and 0.5 (place-windows): a forecast of one rate (6 per unit) ranks
    nothing, though its counts (6, 6, 3) follow the exposure; a forecast of rates 5, 10, 6
    against true rates 10, 20, 8 ranks d = (1, 0, -1): rho = 1 - 6·2 / (3·8) = 0.5, where
    the counts alone (5, 10, 3 against 10, 20, 4) would rank perfectly. Deviance and MAE
    stay on the counts."""
    flat = m.activity_scores([10.0, 20.0, 5.0], [6.0, 6.0, 3.0], [1.0, 1.0, 0.5])
    assert math.isnan(flat["spearman"])
    assert flat["mae"] == pytest.approx((4 + 14 + 2) / 3)
    assert m.activity_scores([10.0, 20.0, 5.0], [6.0, 6.0, 3.0])["spearman"] > 0  # counts
    varied = m.activity_scores([10.0, 20.0, 4.0], [5.0, 10.0, 3.0], [1.0, 1.0, 0.5])
    assert varied["spearman"] == pytest.approx(0.5)
    assert m.activity_scores([10.0, 20.0, 4.0], [5.0, 10.0, 3.0])["spearman"] == pytest.approx(1.0)
