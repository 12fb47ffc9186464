"""Which family forecasts each entry, chosen by its day-ahead score, pooled up the hierarchy.

Scores are sums of day-ahead log-likelihoods (higher is better): per flow family the Poisson
log-likelihood of every observed window's count, per direction family the log-probability of
every detection's direction bin, each predicted by the model as it stood before that day.

The choice prefers the simpler family (families are listed simplest first) unless the
evidence is clear: a family replaces the default only if its score beats the default's by more
than ``family_margin`` nats, and — for an entry choosing against ``static`` — only if it won
consistently, day after day: once two or more days were scored, its daily gains must pass a
one-sided Student t-test at the 5 % level (:func:`t_critical`; mean daily gain over its
standard error with the sample variance, n − 1 degrees of freedom), so a few lucky days cannot
make an entry's forecast time-dependent — the fewer the days, the clearer the win must be.

Defaults pool evidence up the hierarchy: the map chooses from the sum of all entries' scores
(default ``static``), each group from its members' sums (default: the map's choice), and an
entry from its own scores with the default *borrowed* from its group — ``shape`` (its static
rate times the group's periodic shape) when the group's flow varies in time, ``static``
otherwise; for directions the entry's default is ``static`` (its histogram is already pooled
toward the group's). Disabled families (``ModelConfig.families``) never win.

The predictive spread: the Pearson dispersion φ = χ² / windows of the chosen flow family's
day-ahead residuals, pooled toward the map's with 10 pseudo-windows and at least 1 (Poisson);
window counts are then negative binomial with mean λ and variance φ·λ.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.types import F64, I64

_DISPERSION_PRIOR = 10.0
_T95 = (
    6.314, 2.920, 2.353, 2.132, 2.015, 1.943, 1.895, 1.860, 1.833, 1.812,
    1.796, 1.782, 1.771, 1.761, 1.753, 1.746, 1.740, 1.734, 1.729, 1.725,
    1.721, 1.717, 1.714, 1.711, 1.708, 1.706, 1.703, 1.701, 1.699, 1.697,
)  # fmt: skip
"""One-sided 95 % quantiles of Student's t with 1..30 degrees of freedom (standard tables)."""


def t_critical(df: npt.ArrayLike) -> F64:
    """One-sided 5 % critical value of Student's t with ``df`` >= 1 degrees of freedom: the
    table up to 30, then the normal quantile 1.645 with the first Cornish–Fisher term
    (z³ + z) / (4 df), which meets the table at 30 (1.696 against 1.697)."""
    d = np.asarray(df, dtype=np.int64)
    table = np.array(_T95)
    tail = 1.645 + 1.524 / np.maximum(d, 1)
    out: F64 = np.where(d <= len(_T95), table[np.clip(d, 1, len(_T95)) - 1], tail)
    return out


def _choose(
    scores: F64,
    default: I64,
    enabled: npt.NDArray[np.bool_],
    margin: float,
    consistency: tuple[F64, F64, int] | None = None,
) -> I64:
    """Per row: the best enabled family if it beats ``default`` by more than ``margin``.

    ``consistency`` = (Σ_days gain², days, static index): against ``static``, a family must
    also win consistently over the scored days — its daily gains pass the one-sided t-test of
    the module docstring — once there are two days or more."""
    masked = np.where(enabled[None, :], scores, -np.inf)
    rows = np.arange(len(default))
    best = masked.argmax(axis=1)
    gain = masked[rows, best] - masked[rows, default]
    ok = gain > margin
    if consistency is not None:
        gain_sq, days, static = consistency
        vs_static = (default == static) & (best != static) & (days >= 2)
        if vs_static.any():
            n = days[vs_static]
            mean = (scores[vs_static, best[vs_static]] - scores[vs_static, static]) / n
            sum_sq = gain_sq[vs_static, best[vs_static]]
            sample_var = np.maximum(sum_sq - n * mean**2, 0.0) / (n - 1)
            t = mean * np.sqrt(n) / np.sqrt(np.maximum(sample_var, 1e-300))
            ok[vs_static] &= t >= t_critical(np.round(n).astype(np.int64) - 1)
    out: I64 = np.where(ok, best, default)
    return out


def choose_families(
    params: TemporalParams,
    flow_score: F64,
    dir_score: F64,
    groups: I64,
    n_groups: int,
    flow_consistency: tuple[F64, F64] | None = None,
    dir_consistency: tuple[F64, F64] | None = None,
) -> tuple[I64, I64, int]:
    """Chosen flow and direction family indices per entry, and the map's own flow choice
    (see the module docstring). ``*_consistency``: (Σ_days gain², days) per entry."""
    margin = params.config.family_margin
    static = params.flow.index("static")
    shape = params.flow.index("shape")
    flow_on, dir_on = params.flow_enabled, params.direction_enabled
    e = len(groups)
    # flow: map -> group -> entry
    map_flow = _choose(flow_score.sum(axis=0, keepdims=True), np.array([static]), flow_on, margin)
    g_scores = np.zeros((n_groups, flow_score.shape[1]))
    np.add.at(g_scores, groups, flow_score)
    group_flow = _choose(g_scores, np.full(n_groups, map_flow[0]), flow_on, margin)
    borrowed = np.where(group_flow[groups] == static, static, shape)
    if not flow_on[shape]:
        borrowed = np.full(e, static)
    fc = None if flow_consistency is None else (*flow_consistency, static)
    flow = _choose(flow_score, borrowed.astype(np.int64), flow_on, margin, fc)
    # directions: entry against static
    dstatic = params.direction.index("static")
    dc = None if dir_consistency is None else (*dir_consistency, dstatic)
    direction = _choose(dir_score, np.full(e, dstatic, np.int64), dir_on, margin, dc)
    return flow, direction, int(map_flow[0])


def dispersion(flow_chi2: F64, flow_scored: F64, family: I64) -> F64:
    """φ ≥ 1 per entry for its chosen flow family (pooled toward the map's)."""
    chi2 = flow_chi2[np.arange(len(family)), family]
    total_scored = float(flow_scored.sum())
    map_phi = np.ones(flow_chi2.shape[1])
    if total_scored > 0:
        map_phi = np.maximum(flow_chi2.sum(axis=0) / total_scored, 1.0)
    phi = (chi2 + _DISPERSION_PRIOR * map_phi[family]) / (flow_scored + _DISPERSION_PRIOR)
    out: F64 = np.maximum(phi, 1.0)
    return out


def count_quantiles(mean: npt.ArrayLike, variance: npt.ArrayLike, q: float) -> F64:
    """The q-quantile of a window count with this mean and variance: negative binomial
    (moment-matched) where over-dispersed, Poisson otherwise; NaN where the mean is unknown."""
    from scipy import stats  # slow to import: only queries that print a spread need it

    mu = np.asarray(mean, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    out = np.full(mu.shape, np.nan)
    known = np.isfinite(mu) & np.isfinite(var) & (mu >= 0)
    zero = known & (mu <= 0)
    out[zero] = 0.0
    pos = known & (mu > 0)
    over = pos & (var > mu * (1.0 + 1e-9))
    poisson = pos & ~over
    if poisson.any():
        out[poisson] = stats.poisson.ppf(q, mu[poisson])
    if over.any():
        p = mu[over] / var[over]
        n = mu[over] * p / (1.0 - p)
        out[over] = stats.nbinom.ppf(q, n, p)
    return out
