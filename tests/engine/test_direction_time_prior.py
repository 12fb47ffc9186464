"""``direction_time_prior = "auto"``: how far an hour's direction histogram may leave the
entry's static one, estimated from the map (``temporal.direction_prior.time_prior``).

With the fixed 50 pseudo-detections a corridor walked east in the morning and west in the
evening (0.8 of the walkers each way) was forecast at 0.383 nats per held-out detection,
worse than each place's own hour-of-day histogram (0.337; the true directions 0.244):
docs/EVALUATION.md, stop 67."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.direction_prior import (
    KAPPA_RANGE,
    TIME_FALLBACK,
    TIME_KAPPA_LOW,
    fitted_kappa,
    time_prior,
)
from aion_cli.errors import ConfigError
from benchmarks.forecast_scenarios import SCENARIOS, run

B = 8


def _per_bin(flip: bool, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """40 entries x 24 hours, 12 directed detections an hour in bins 0 and 4: 0.8 / 0.2
    alternating by the hour (``flip``) or 0.5 / 0.5 every hour; each entry's static
    histogram is half and half."""
    share = np.where(np.arange(24) % 2 == 0, 0.8, 0.2) if flip else np.full(24, 0.5)
    first = rng.binomial(12, np.tile(share, 40))
    counts = np.zeros((first.size, B))
    counts[:, 0], counts[:, 4] = first, 12 - first
    parent = np.zeros_like(counts)
    parent[:, [0, 4]] = 0.5
    return counts, parent


def test_directions_that_keep_to_the_hour_get_a_weak_time_prior() -> None:
    """Hours at 0.8 / 0.2 around a 0.5 / 0.5 histogram: a Beta of that spread has
    κ + 1 = 0.25 / 0.09, κ ≈ 1.8; hours that do not differ from the histogram push κ_t to
    the top of its range (100)."""
    rng = np.random.default_rng(5)
    auto = ModelConfig()
    assert auto.direction_time_prior == "auto"
    varying = time_prior(auto, lambda: _per_bin(True, rng))
    steady = time_prior(auto, lambda: _per_bin(False, rng))
    assert 1.0 < varying < 4.0
    assert steady > 50.0


def test_directions_that_keep_to_the_hour_without_exception_stop_at_one() -> None:
    """Every hour walked one way only (east in the even hours, west in the odd): the
    likelihood keeps rising toward κ_t = 0, so the estimate is the lower end, 1 for κ_t
    (an hour's histogram counts the static one as one detection) where κ's own search
    would stop at 0.5."""
    counts, parent = _per_bin(True, np.random.default_rng(7))
    one_way = np.zeros_like(counts)
    even = (np.arange(counts.shape[0]) % 24) % 2 == 0
    one_way[even, 0], one_way[~even, 4] = 12.0, 12.0
    assert time_prior(ModelConfig(), lambda: (one_way, parent)) == pytest.approx(TIME_KAPPA_LOW)
    assert fitted_kappa(one_way, parent) == pytest.approx(KAPPA_RANGE[0])


def test_a_number_is_kept_and_too_few_bins_fall_back() -> None:
    rng = np.random.default_rng(6)
    assert time_prior(ModelConfig(direction_time_prior=7.5), lambda: _per_bin(True, rng)) == 7.5
    counts, parent = _per_bin(True, rng)
    assert time_prior(ModelConfig(), lambda: (counts[:5], parent[:5])) == TIME_FALLBACK


@pytest.mark.parametrize("value", [0.0, -1.0, "fixed", float("inf")])
def test_other_values_are_refused(value: object) -> None:
    with pytest.raises(ConfigError, match="direction_time_prior"):
        ModelConfig(direction_time_prior=value)  # type: ignore[arg-type]


def test_a_corridor_turning_at_noon_is_forecast_as_well_as_its_hourly_histogram(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Three places, one map entry each, walked east before 13:00 and west after (0.8 of
    the walkers), two training weeks: the held-out week's heading NLL of aion's forecast is
    no worse than each place's own hour-of-day histogram (add-0.5). With the fixed prior of
    50 it was 0.04 nats a detection worse at stop 67; since stop 68 an hour's histogram
    shrinks toward the static one modulated by its group's hour (here the place's own, the
    one cell's neighbourhood: ``temporal.group_shift``), so 50 pseudo-detections of that
    prior reach the hour too."""
    scenario = replace(SCENARIOS["weekly-1cell"], train_days=14)
    auto = run(scenario, tmp_path_factory.mktemp("auto"))
    fixed = run(replace(scenario, config="direction_time_prior = 50.0"),
                tmp_path_factory.mktemp("fixed"))  # fmt: skip
    nll = auto["headings"]
    assert nll["aion"] <= nll["own hour-of-day headings"] + 0.005
    assert fixed["headings"]["aion"] <= nll["own hour-of-day headings"] + 0.005
    assert nll["aion"] > nll["true directions"]  # the floor: nothing beats it but by luck


@pytest.mark.parametrize("kappa_t", [5.0, 20.0])
def test_a_big_maps_profile_bins_are_sampled_without_bias(
    kappa_t: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """2,000 entries x 24 hours, about 3 directed detections an hour each drawn around the
    entry's own static histogram with concentration ``kappa_t``: some 38,000 (entry, hour)
    rows of two detections or more, far over MAX_ENTRIES, but only a few thousand distinct
    count patterns. The sampled estimate stays within a fifth of the estimate from every
    row (which recovers ``kappa_t``). Chosen by the counts alone, each pattern was kept or
    left out whole: 9.8 for 5, 13.5 for 20."""
    import aion_cli.engine.temporal.direction_prior as dp

    rng = np.random.default_rng(1)
    entries, hours = 2000, 24
    static = rng.gamma(0.7, size=(entries, B))
    static /= static.sum(axis=1, keepdims=True)
    parent = np.repeat(static, hours, axis=0)
    hourly = rng.gamma(kappa_t * parent + 1e-9)
    hourly /= hourly.sum(axis=1, keepdims=True)
    counts = np.array([rng.multinomial(n, q) for n, q in
                       zip(rng.poisson(3, entries * hours), hourly, strict=True)], np.float64)
    sampled = fitted_kappa(counts, parent, TIME_FALLBACK, TIME_KAPPA_LOW)
    monkeypatch.setattr(dp, "MAX_ENTRIES", counts.shape[0])
    full = fitted_kappa(counts, parent, TIME_FALLBACK, TIME_KAPPA_LOW)
    assert full == pytest.approx(kappa_t, rel=0.1)
    assert sampled == pytest.approx(full, rel=0.2)
