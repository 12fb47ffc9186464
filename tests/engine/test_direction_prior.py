"""The direction prior's strength κ estimated from the map (``direction_prior = "auto"``,
:mod:`aion_cli.engine.temporal.direction_prior`): recovered from Dirichlet-multinomial
entries drawn with a known κ, the same to the bit in any entry order, the fallback when too
few entries tell, ln Γ against the standard library's, and the likelihood the search
maximises against its formula term by term."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.direction_prior import (
    FALLBACK,
    GROUP_PRIOR,
    KAPPA_RANGE,
    MIN_ENTRIES,
    entry_prior,
    fitted_kappa,
    group_prior,
    log_gamma,
    marginal_likelihood,
)
from aion_cli.errors import ConfigError


def _entries(kappa: float, entries: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Directed counts of ``entries`` entries whose histograms are Dirichlet(κ·p) draws
    around one parent histogram p, with 2..59 detections each; and p per entry."""
    rng = np.random.default_rng(seed)
    parent = rng.dirichlet(np.full(8, 2.0))
    shares = rng.dirichlet(kappa * parent, entries)
    totals = rng.integers(2, 60, entries)
    counts = np.array([rng.multinomial(n, q) for n, q in zip(totals, shares, strict=True)])
    return counts.astype(np.float64), np.tile(parent, (entries, 1))


@pytest.mark.parametrize("kappa", [0.8, 3.0, 30.0])
def test_a_known_strength_is_recovered(kappa: float) -> None:
    counts, parent = _entries(kappa, 3000, seed=int(kappa * 10))
    assert fitted_kappa(counts, parent) == pytest.approx(kappa, rel=0.15)


def test_a_big_map_is_estimated_from_a_sample_and_still_recovers_it() -> None:
    counts, parent = _entries(5.0, 20_000, seed=3)
    assert fitted_kappa(counts, parent) == pytest.approx(5.0, rel=0.15)


def test_entries_that_agree_with_their_parent_reach_the_upper_bound() -> None:
    parent = np.tile(np.full(8, 1 / 8), (200, 1))
    counts = np.full((200, 8), 5.0)  # every entry exactly its parent's histogram
    assert fitted_kappa(counts, parent) == pytest.approx(KAPPA_RANGE[1], rel=0.02)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([500, 9000]))
def test_the_estimate_is_the_same_to_the_bit_in_any_entry_order(seed: int, n: int) -> None:
    counts, parent = _entries(4.0, n, seed=seed % 1000)
    order = np.random.default_rng(seed).permutation(n)
    assert fitted_kappa(counts[order], parent[order]) == fitted_kappa(counts, parent)


def test_too_few_entries_that_tell_give_the_fallback() -> None:
    counts, parent = _entries(1.0, MIN_ENTRIES - 1, seed=1)
    one_each = np.zeros((500, 8))
    one_each[:, 0] = 1.0  # one detection: says nothing about κ
    assert fitted_kappa(counts, parent) == FALLBACK
    assert fitted_kappa(one_each, np.full((500, 8), 1 / 8)) == FALLBACK


def test_auto_and_a_number_choose_the_strengths() -> None:
    counts, parent = _entries(2.0, 2000, seed=5)
    auto = ModelConfig()
    assert auto.direction_prior == "auto"
    assert group_prior(auto) == GROUP_PRIOR
    assert entry_prior(auto, lambda: (counts, parent)) == fitted_kappa(counts, parent)
    fixed = ModelConfig(direction_prior=7)
    assert group_prior(fixed) == entry_prior(fixed, lambda: (counts, parent)) == 7.0


def test_the_config_takes_auto_or_a_number_and_round_trips() -> None:
    for value in ("auto", 0.0, 12.5):
        config = ModelConfig(direction_prior=value)
        assert ModelConfig.from_toml_text(config.to_toml()).direction_prior == value
    assert ModelConfig.from_dict({"direction_prior": 3}).direction_prior == 3.0
    for bad in ("fast", -1.0, float("nan"), True):
        with pytest.raises(ConfigError, match="direction_prior"):
            ModelConfig(direction_prior=bad)


def test_log_gamma_matches_the_standard_library() -> None:
    x = np.concatenate([np.geomspace(1e-8, 1e7, 4001), np.arange(1.0, 300.0) + 0.5])
    expected = np.array([math.lgamma(v) for v in x])
    assert np.allclose(log_gamma(x), expected, rtol=1e-13, atol=1e-12)


def _plain_likelihood(counts: np.ndarray, parent: np.ndarray, kappa: float) -> float:
    """The module docstring's formula, one term per entry and bin, with the standard
    library's ln Γ, summed correctly rounded."""
    terms = []
    for row, shares in zip(counts, parent, strict=True):
        terms += [math.lgamma(kappa), -math.lgamma(float(row.sum()) + kappa)]
        for n, p in zip(row, shares, strict=True):
            terms += [math.lgamma(n + kappa * p), -math.lgamma(kappa * p)]
    return math.fsum(terms)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 300),
    st.integers(2, 12),
    st.sampled_from([3, 40, 2000]),
    st.floats(np.log(0.5), np.log(100.0)),
)
def test_the_likelihood_equals_its_formula(
    seed: int, entries: int, bins: int, most: int, log_kappa: float
) -> None:
    """Distinct (count, share) pairs and totals weighted by how often they occur, ln Γ of
    κ p once per share, numpy's pairwise sums: the value of the plain sum over every entry
    and bin, to the accuracy of ln Γ (shares repeat, as a group's do for its entries)."""
    rng = np.random.default_rng(seed)
    parents = rng.dirichlet(np.full(bins, 0.7), max(entries // 7, 1))
    parent = np.clip(parents[rng.integers(0, parents.shape[0], entries)], 1e-12, None)
    counts = rng.integers(0, most + 1, (entries, bins)) * (rng.random((entries, bins)) < 0.6)
    counts = counts.astype(np.float64)
    kappa = float(np.exp(log_kappa))
    got = marginal_likelihood(counts, parent, counts.sum(axis=1))(log_kappa)
    want = _plain_likelihood(counts, parent, kappa)
    scale = entries * bins * (1.0 + np.log1p(most + kappa))  # the terms' sizes
    assert got == pytest.approx(want, rel=1e-12, abs=1e-12 * scale)


def _own_direction_shares(direction_prior: float | str) -> np.ndarray:
    """A map of 48 cells in one 4 m neighbourhood, each walked 6 times in one direction of
    its own (cell i: bin i mod 8): the predicted share of each cell's own bin."""
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.query import predict_table
    from tests.engine.engine_builders import T0, S, detections

    config = ModelConfig(window_s=600.0, stability_s=0.0, direction_prior=direction_prior)
    mapper = Mapper(config)
    mapper.set_fixed_sensor(T0, T0 + 600 * S)
    cells = np.arange(48)
    xyz = np.stack([0.25 + 0.5 * (cells % 8), 0.25 + 0.5 * (cells // 8), np.zeros(48)], axis=1)
    bins = cells % 8
    heading = (bins + 0.5) * (2 * np.pi / 8) - np.pi  # each bin's centre
    for k in range(6):
        mapper.add_detections(detections(T0 + (k + 1) * S, xyz, heading))
    mapper.advance(T0 + 600 * S)
    table = predict_table(mapper.state, T0 + 700 * S)
    cell_rows = np.flatnonzero(table.kind == 0)
    assert cell_rows.size == 48
    rates = table.rate[cell_rows, :8]
    own = np.argmax(rates, axis=1)
    shares: np.ndarray = rates[np.arange(48), own] / rates.sum(axis=1)
    return shares


def test_places_that_each_go_their_own_way_keep_their_own_direction() -> None:
    """Every cell walked one way of its own: the estimate finds the cells unlike their
    neighbourhood (κ at its lower bound) and keeps each cell's direction, where a fixed
    κ = 10 pulls six detections most of the way to the neighbourhood's flat histogram:
    (6 + 10/8) / 16 = 0.45 of the own bin."""
    assert np.all(_own_direction_shares("auto") > 0.85)
    assert np.allclose(_own_direction_shares(10.0), (6 + 10 / 8) / 16, atol=0.02)
