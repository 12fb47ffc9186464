"""Window-count quantiles of a few entries without importing ``scipy.stats``.

``choice.count_quantiles`` (negative binomial where over-dispersed, Poisson otherwise) imports
``scipy.stats``, which costs most of a second: more than a ``predict --top 10`` on a map of
10^5 entries takes in all. :func:`count_quantiles` gives the same numbers for a few rows: the
smallest k whose CDF reaches q, from cumulative sums of log-pmf terms (relative error about
k·1e-16). Where the CDF passes within :data:`MARGIN` of q at the answer or just before it —
where that error could decide — and for many rows, large means or a CDF that does not reach q
within the terms summed, the rows go to ``choice.count_quantiles`` itself, so the result is
scipy's wherever the two could differ.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64

MARGIN = 1e-9
"""A CDF this close to q is left to scipy (the sums here are accurate to ~1e-12)."""
MAX_ROWS = 1000
"""More rows than this go to scipy at once (its import then costs less than the loop)."""
MAX_MEAN = 1e5
"""Means above this go to scipy (the sums would need too many terms)."""


def _smallest_k(log_terms: F64, q: float) -> float | None:
    """The smallest k with Σ_{j≤k} exp(log_terms[j]) ≥ q, or None when undecided."""
    cdf = np.cumsum(np.exp(log_terms))
    k = int(np.searchsorted(cdf, q, side="left"))
    if k >= cdf.size:
        return None
    if abs(cdf[k] - q) <= MARGIN or (k > 0 and abs(cdf[k - 1] - q) <= MARGIN):
        return None
    return float(k)


def _terms(mu: float, var: float, over: bool) -> F64:
    """log pmf(0..K) of the moment-matched count distribution, K well past the q-quantile."""
    sd = math.sqrt(max(var, mu))
    top = int(mu + 40.0 * sd + 50.0)
    j = np.arange(1, top + 1, dtype=np.float64)
    if over:
        p = mu / var
        n = mu * p / (1.0 - p)
        steps = np.log(j - 1.0 + n) - np.log(j) + math.log1p(-p)
        start = n * math.log(p)
    else:
        steps = math.log(mu) - np.log(j)
        start = -mu
    return np.concatenate([[start], start + np.cumsum(steps)])


def count_quantiles(mean: npt.ArrayLike, variance: npt.ArrayLike, q: float) -> F64:
    """``choice.count_quantiles(mean, variance, q)`` (same values), without scipy for a few
    rows with clear answers (see the module docstring)."""
    mu = np.asarray(mean, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    out = np.full(mu.shape, np.nan)
    known = np.isfinite(mu) & np.isfinite(var) & (mu >= 0)
    out[known & (mu <= 0)] = 0.0
    pos = np.flatnonzero((known & (mu > 0)).reshape(-1))
    flat_out, flat_mu, flat_var = out.reshape(-1), mu.reshape(-1), var.reshape(-1)
    undecided: list[int] = []
    if pos.size > MAX_ROWS:
        undecided = pos.tolist()
    else:
        for i in pos.tolist():
            m, v = float(flat_mu[i]), float(flat_var[i])
            if m > MAX_MEAN:
                undecided.append(i)
                continue
            k = _smallest_k(_terms(m, v, v > m * (1.0 + 1e-9)), q)
            if k is None:
                undecided.append(i)
            else:
                flat_out[i] = k
    if undecided:
        from aion_cli.engine.temporal.choice import count_quantiles as exact

        rows = np.asarray(undecided, dtype=np.int64)
        flat_out[rows] = exact(flat_mu[rows], flat_var[rows], q)
    return out
