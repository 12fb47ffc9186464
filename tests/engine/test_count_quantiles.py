"""flow_p10 / flow_p90 without scipy.stats: scipy's numbers, for any number of rows.

``engine.temporal.quantiles.count_quantiles`` sums log-pmf terms with numpy and leaves to
scipy only the rows where its rounding could decide (a CDF within the row's margin of q),
large means and parameters scipy refuses. Before, more than 1,000 rows went to scipy.stats
whole (its import alone ~0.9 s CPU): a full ``predict --format json`` of a bigger map. The
known answer is scipy.stats' own ``poisson.ppf`` / ``nbinom.ppf`` of the moment-matched
distribution, computed here.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import special, stats

from aion_cli.engine.temporal import choice
from aion_cli.engine.temporal.quantiles import MAX_MEAN, count_quantiles


def _scipy(mu: np.ndarray, var: np.ndarray, q: float) -> np.ndarray:
    """The q-quantile by scipy.stats: negative binomial (p = mean / variance) where the
    variance exceeds the mean by more than 1e-9 of it, Poisson otherwise; 0 for a zero mean,
    NaN for an unknown one."""
    out = np.full(mu.shape, np.nan)
    known = np.isfinite(mu) & np.isfinite(var) & (mu >= 0)
    out[known & (mu == 0)] = 0.0
    over = known & (mu > 0) & (var > mu * (1.0 + 1e-9))
    poisson = known & (mu > 0) & ~over
    out[poisson] = stats.poisson.ppf(q, mu[poisson])
    p = mu[over] / var[over]
    out[over] = stats.nbinom.ppf(q, mu[over] * p / (1.0 - p), p)
    return out


@pytest.fixture
def to_scipy(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """How many rows each call left to scipy (``choice.count_quantiles``)."""
    rows: list[int] = []
    exact = choice.count_quantiles

    def counted(mean: np.ndarray, variance: np.ndarray, q: float) -> np.ndarray:
        rows.append(int(np.size(mean)))
        return exact(mean, variance, q)

    monkeypatch.setattr(choice, "count_quantiles", counted)
    return rows


def _random_rows(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Means of people per window (mostly small, some up to past MAX_MEAN) and variances
    from Poisson to hugely over-dispersed, with the edge rows: zero, NaN and infinite means,
    infinite and zero variances, a mean whose negative binomial n underflows to 0."""
    mu = np.concatenate([rng.exponential(1.0, n // 2), rng.exponential(30.0, n // 4),
                         10.0 ** rng.uniform(-12.0, 5.3, n - n // 2 - n // 4)])
    ratio = np.where(rng.random(n) < 0.4, 1.0, 1.0 + 10.0 ** rng.uniform(-10.0, 4.0, n))
    var = mu * ratio
    var[rng.random(n) < 0.03] = 0.0
    mu[:6] = [0.0, np.nan, np.inf, 5.0, 1e-300, 2.0 * MAX_MEAN]
    var[:6] = [1.0, 1.0, 1.0, np.inf, 1e300, 2.0 * MAX_MEAN]
    return mu, var


@pytest.mark.parametrize("q", [0.1, 0.9, 0.5, 0.99])
def test_thousands_of_rows_give_scipys_quantiles(q: float, to_scipy: list[int]) -> None:
    mu, var = _random_rows(np.random.default_rng(7), 20_000)
    np.testing.assert_array_equal(count_quantiles(mu, var, q), _scipy(mu, var, q))
    assert sum(to_scipy) < 0.1 * mu.size  # most of them without scipy


@pytest.mark.parametrize("q", [0.1, 0.9])
def test_rows_whose_cdf_passes_through_q_give_scipys_quantiles(
    q: float, to_scipy: list[int]
) -> None:
    """Means at which the CDF at some k is q (scipy's pdtri / nbdtrin), and a little either
    side (relative 1e-16 to 1e-6): those within the margin go to scipy, the others must
    agree with it all the same."""
    rel = np.concatenate([[0.0], np.outer([-1.0, 1.0], 10.0 ** np.arange(-16, -5.5, 0.5)).ravel()])
    mus, variances = [], []
    for k in (0, 1, 2, 5, 13, 80, 1000, 30000):
        m = special.pdtri(k, q)
        mus.append(m * (1 + rel))
        variances.append(m * (1 + rel))
        for c in (1.5, 30.0, 1 + 1e-8):
            m = special.nbdtrin(k, q, 1.0 / c) * (c - 1.0)
            mus.append(m * (1 + rel))
            variances.append(m * (1 + rel) * c)
    mu, var = np.concatenate(mus), np.concatenate(variances)
    np.testing.assert_array_equal(count_quantiles(mu, var, q), _scipy(mu, var, q))
    assert 0 < sum(to_scipy) < mu.size  # the nearest went to scipy, not all


def test_many_rows_import_no_scipy_stats() -> None:
    code = (
        "import sys; import numpy as np; "
        "from aion_cli.engine.temporal.quantiles import count_quantiles as c; "
        "mu = np.random.default_rng(1).exponential(2.0, 5000); "
        "c(mu, mu * 1.5, 0.1); c(mu, mu, 0.9); "
        "print('scipy.stats' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"
