"""Window-count quantiles without importing ``scipy.stats``.

``choice.count_quantiles`` (negative binomial where over-dispersed, Poisson otherwise) imports
``scipy.stats``, which costs most of a second: more than a ``predict --top 10`` on a map of
10^5 entries takes in all, and as much again as the rest of a full ``predict --format json``
of a few thousand entries. :func:`count_quantiles` gives the same numbers with numpy: per row,
the smallest k whose CDF reaches q, from cumulative sums of log-pmf terms, all rows at once
(rows of a similar number of terms side by side in a table). Where the CDF passes within the
row's margin of q at the answer or just before it — :data:`MARGIN`, or more where the sums'
rounding could be larger (many terms of large logs: :func:`_margins`) — and for large means,
parameters scipy refuses (an n that underflowed to 0) or a CDF that does not reach q within
the terms summed, the rows go to ``choice.count_quantiles`` itself, so the result is scipy's
wherever the two could differ (tested against scipy on random and on adversarial rows).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import distinct
from aion_cli.engine.types import F64, BoolA

MARGIN = 1e-9
"""A CDF this close to q is left to scipy (the sums here are accurate to ~1e-12 for the
means of people per window, and scipy's CDFs and inverses to better than this)."""
MAX_MEAN = 1e5
"""Means above this go to scipy (the sums would need too many terms)."""
MAX_TERMS = 1 << 18
"""Rows that would need more terms than this (a huge variance) go to scipy."""
_CELLS = 1 << 20
"""Table cells (rows x terms) computed at a time."""
_BUDGET = 1 << 22
"""Table cells of one call at most (about a quarter of a second here): the rows beyond it, those
with the most terms (large means, wide spreads), go to scipy, whose import costs about as much."""
_UNIT = 2.0**-53
"""The unit roundoff of float64."""


def count_quantiles(mean: npt.ArrayLike, variance: npt.ArrayLike, q: float) -> F64:
    """``choice.count_quantiles(mean, variance, q)`` (same values), without scipy for the
    rows with clear answers (see the module docstring)."""
    mu = np.asarray(mean, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    out = np.full(mu.shape, np.nan)
    known = np.isfinite(mu) & np.isfinite(var) & (mu >= 0)
    out[known & (mu <= 0)] = 0.0
    flat_out, flat_mu, flat_var = out.reshape(-1), mu.reshape(-1), var.reshape(-1)
    pos = np.flatnonzero((known & (mu > 0)).reshape(-1))
    undecided = pos
    if 0.0 < q < 1.0:
        small = pos[flat_mu[pos] <= MAX_MEAN]
        k, decided = _smallest_k(flat_mu[small], flat_var[small], q)
        flat_out[small[decided]] = k[decided]
        # sorted, as np.union1d, whose np.unique would import numpy.ma (10-30 ms a query)
        undecided = distinct(np.concatenate([pos[flat_mu[pos] > MAX_MEAN], small[~decided]]))
    if undecided.size:
        from aion_cli.engine.temporal.choice import count_quantiles as exact

        flat_out[undecided] = exact(flat_mu[undecided], flat_var[undecided], q)
    return out


def _smallest_k(mu: F64, var: F64, q: float) -> tuple[F64, BoolA]:
    """Per row (mean ``mu`` > 0, variance ``var``), the smallest k whose CDF reaches ``q``
    and whether it is decided. The rows are grouped by family and by the power of two above
    their number of terms, each group a table of log-pmf terms (a row's extra terms only
    extend its sums: a row's cumulative sums along the table are its own, in order)."""
    k = np.zeros(mu.size)
    decided = np.zeros(mu.size, dtype=bool)
    if mu.size == 0:
        return k, decided
    over = var > mu * (1.0 + 1e-9)  # choice.count_quantiles' test, to the bit
    # Cantelli: P(X >= mean + t sd) <= 1 / (1 + t^2) < 1 - q for this t, so the answer lies
    # below mean + t sd: the terms up to there suffice (else the row is left undecided)
    t = math.sqrt(q / (1.0 - q)) + 1.0
    reach = mu + t * np.sqrt(np.maximum(var, mu))
    fits = reach < MAX_TERMS
    terms = np.where(fits, reach, 0.0).astype(np.int64) + 2
    width = np.int64(1) << np.ceil(np.log2(terms)).astype(np.int64)
    group = width * 2 + over
    order = np.argsort(group, kind="stable")
    order = order[fits[order]]
    order = order[np.cumsum(width[order]) <= _BUDGET]  # the cheapest rows first
    if order.size == 0:
        return k, decided
    bounds = np.flatnonzero(np.diff(group[order])) + 1
    for rows in np.split(order, bounds):
        w = int(width[rows[0]])
        step = max(1, _CELLS // w)
        for a in range(0, rows.size, step):
            chunk = rows[a : a + step]
            log_terms, margin = _table(mu[chunk], var[chunk], bool(over[chunk[0]]), w)
            k[chunk], decided[chunk] = _first_reaching(log_terms, margin, q)
    return k, decided


def _table(mu: F64, var: F64, over: bool, width: int) -> tuple[F64, F64]:
    """log pmf(0 .. width-1) of each row's count distribution (moment-matched negative
    binomial with ``over``, else Poisson), and each row's margin (:func:`_margins`)."""
    j = np.arange(1, width, dtype=np.float64)
    log_j = np.log(j)
    if over:
        p = mu / var  # choice.count_quantiles' parameters, to the bit
        n = mu * p / (1.0 - p)
        log_n = np.log(j[None, :] - 1.0 + n[:, None])
        tail = np.log1p(-p)
        steps = log_n - log_j[None, :] + tail[:, None]
        start = n * np.log(p)
        size = np.abs(log_n).sum(axis=1) + (width - 1) * np.abs(tail)
        ok = (n > 0) & np.isfinite(n) & (p > 0)  # else scipy refuses them (NaN): not here
        start = np.where(ok, start, np.nan)
    else:
        log_mu = np.log(mu)
        steps = log_mu[:, None] - log_j[None, :]
        start = -mu
        size = (width - 1) * np.abs(log_mu)
    size = size + np.abs(start) + log_j.sum()
    out = np.empty((mu.size, width))
    out[:, 0] = start
    np.cumsum(steps, axis=1, out=out[:, 1:])
    out[:, 1:] += start[:, None]
    return out, _margins(size, width)


def _margins(size: F64, width: int) -> F64:
    """How close to q a row's CDF may come before scipy decides: :data:`MARGIN`, or a bound
    of the rounding of its sums when larger. ``size`` bounds the sum of the magnitudes of
    the row's terms (start, logs); each of the ``width`` partial sums of logs is off by at
    most width·u·size, which is also the CDF's relative error through exp, plus width·u for
    its own sum (doubled, and the logs' own errors within ``size``'s slack)."""
    out: F64 = np.maximum(MARGIN, 4.0 * width * _UNIT * (size + 1.0))
    return out


def _first_reaching(log_terms: F64, margin: F64, q: float) -> tuple[F64, BoolA]:
    """Per row, the first index whose cumulative sum of exp(``log_terms``) reaches ``q``, and
    whether it is decided: reached within the row, and neither it nor the one before within
    the row's ``margin`` of ``q`` (the rounding could then decide)."""
    cdf = np.cumsum(np.exp(log_terms), axis=1)
    reached = cdf[:, -1] >= q
    k = np.argmax(cdf >= q, axis=1)
    rows = np.arange(cdf.shape[0])
    at = cdf[rows, k]
    before = np.where(k > 0, cdf[rows, np.maximum(k - 1, 0)], -np.inf)
    decided: BoolA = reached & (np.abs(at - q) > margin) & (np.abs(before - q) > margin)
    return k.astype(np.float64), decided
