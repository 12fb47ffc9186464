"""Which family forecasts each entry, chosen by its day-ahead score, pooled up the hierarchy.

Scores are sums of day-ahead log-likelihoods (higher is better): per flow family the Poisson
log-likelihood of every observed window's count, per direction family the log-probability of
every detection's direction bin, each predicted by the model as it stood before that day.

The choice prefers the simpler family (families are listed simplest first) unless the
evidence is clear: a family replaces the default only if its score beats the default's by more
than ``family_margin`` nats, and — for an entry choosing a time-varying family against
``static``, or against the default its group lent it (its own FreMEn, say, instead of the
group's ``shape``) — only if that family won against ``static`` consistently, day after day
(the stored squared daily gains are over ``static``): it needs two scored days or more (one
day's win shows no
consistency, and a query scores the map's last day as well: see
:mod:`~aion_cli.engine.temporal.provisional`), and its daily gains must pass a
one-sided Student t-test (mean daily gain over its standard error with the sample variance,
n − 1 degrees of freedom; :func:`student_t_sf`), so a few lucky days cannot make an entry's
forecast time-dependent — the fewer the days, the clearer the win must be. The tests of all
entries are judged together at a false-discovery rate of 5 % (:func:`benjamini_hochberg`):
among a thousand entries with no rhythm at all, a plain 5 % test would let some fifty switch by
luck, each forecasting worse than its static histogram; with the rate held, an entry must win
the more clearly the more entries compete, and a map of one entry keeps the plain 5 % test.

Defaults pool evidence up the hierarchy: the map chooses from the sum of all entries' scores
(default ``static``), each group from its members' sums (default: the map's choice), and an
entry from its own scores with the default *borrowed* from its group — ``profile`` (its own
periodic profile, shrunk toward the group's shape by ``profile_prior`` pseudo-detections) when
the group's members together forecast best with their own profiles, ``shape`` (its static rate
times the group's periodic shape) when the group's flow varies in time otherwise, ``static``
when it does not. Summed over a group, a few nats per entry that no entry shows clearly alone
say that its places keep rhythms of their own (a kitchen busy at noon beside a corridor busy
at nine): with ``shape`` as every entry's default those rhythms were lost, and a day-ahead
hourly total over a robot's route fell behind a plain per-place hour-of-day profile
(docs/EVALUATION.md). FreMEn is never borrowed: an entry's own sinusoids are not shrunk toward
its parent, so only its own evidence may choose them. For directions the entry's default is
``static`` (its histogram is already pooled toward the group's), or ``profile`` when its
group's members together forecast their directions better with their hourly histograms by
more than ``family_margin`` nats and their daily gains over ``static``, every (member, day)
one draw, pass the consistency test below (a group's default: the map's choice by the same
rule, as for flows): those shrink toward the static histogram modulated by the
group's hour (:mod:`~aion_cli.engine.temporal.group_shift`), so a place split over cells too
sparse to win alone learns its hours from the group (rules 3, stop 68). Disabled families
(``ModelConfig.families``) never win.

The predictive spread: the Pearson dispersion φ = χ² / windows of the chosen flow family's
day-ahead residuals, pooled toward the map's with 10 pseudo-windows and at least 1 (Poisson);
window counts are then negative binomial with mean λ and variance φ·λ.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pooling import group_sums
from aion_cli.engine.types import F64, I64

CHOICE_RULES = 3
"""The version of the rules that choose a family from the stored scores, recorded with a map's
family counts (``aion info``): queries choose afresh, so a map counted under other rules may
forecast with other families than its counts say. 1: before an entry's own time-varying family
against a borrowed default needed consistent daily gains (2026-12-06); maps without the key.
2: before a group could lend its entries the ``profile`` direction family (stop 68)."""

_DISPERSION_PRIOR = 10.0
_FDR = 0.05
"""The false-discovery rate at which entries may choose a time-varying family over ``static``."""


_SERIES_MAX_DF = 256
"""Up to this many degrees of freedom :func:`student_t_sf` sums the closed form's df / 2 terms;
beyond it (a group's or the map's pooled (member, day) draws reach 10^5) the regularised
incomplete beta function of ``scipy.special``, whose cost does not grow with df."""


def student_t_sf(t: npt.ArrayLike, df: npt.ArrayLike) -> F64:
    """P(T > t) for Student's t with integer ``df`` >= 1 degrees of freedom.

    The closed form of Abramowitz & Stegun 26.7.3–4: with θ = atan(t / √df), P(|T| < t) is
    sin θ · Σ_j c_j cos^{2j} θ (even df) or (2/π)(θ + sin θ · Σ_j c_j cos^{2j+1} θ) (odd df),
    finite sums of df / 2 terms, one vector step per term over the array (no ``scipy.special``
    import on the usual query path). Degrees of freedom above ``_SERIES_MAX_DF`` take
    ``scipy.special.stdtr`` instead: the series' cost is O(max df) over the whole array, and a
    pooled test of 2·10^5 draws cost 0.3 s alone, seconds beside a thousand entries' tests."""
    tt = np.asarray(t, dtype=np.float64)
    nu = np.asarray(df, dtype=np.int64)
    tt, nu = np.broadcast_arrays(tt, nu)
    if np.any(nu < 1):
        raise ValueError("degrees of freedom must be >= 1")
    big = nu > _SERIES_MAX_DF
    if not big.any():
        return _series_sf(tt, nu)
    from scipy.special import stdtr

    out: F64 = np.empty(tt.shape, dtype=np.float64)
    out[big] = np.clip(stdtr(nu[big].astype(np.float64), -tt[big]), 0.0, 1.0)
    small = ~big
    if small.any():
        out[small] = _series_sf(tt[small], nu[small])
    return out


def _series_sf(tt: F64, nu: I64) -> F64:
    """:func:`student_t_sf` by the closed form's finite sums (every ``nu`` >= 1)."""
    theta = np.arctan(tt / np.sqrt(nu))
    sin, cos2 = np.sin(theta), np.cos(theta) ** 2
    odd = nu % 2 == 1
    # odd: Σ_{j>=1} c_j cos^{2j-1}, c_1 = 1, c_{j+1} = c_j (2j) / (2j + 1), up to j = (df-1)/2
    # even: Σ_{j>=0} c_j cos^{2j}, c_0 = 1, c_{j+1} = c_j (2j + 1) / (2j + 2), up to j = (df-2)/2
    last = (nu - 2 - odd) // 2  # the loop's last step for each df: (df-3)/2 odd, (df-2)/2 even
    term = np.where(odd, np.sqrt(cos2), 1.0)
    total = np.where(odd & (nu < 3), 0.0, term)
    for j in range(1, int(nu.max(initial=1)) // 2):
        term = term * cos2 * np.where(odd, 2.0 * j / (2.0 * j + 1.0), (2.0 * j - 1.0) / (2.0 * j))
        total += np.where(j <= last, term, 0.0)
    inner = np.where(odd, (2.0 / np.pi) * (theta + sin * total), sin * total)
    out: F64 = np.clip(0.5 * (1.0 - inner), 0.0, 1.0)
    return out


def benjamini_hochberg(p_values: F64, rate: float = _FDR) -> npt.NDArray[np.bool_]:
    """Which of ``m`` hypotheses to reject with the false-discovery rate held at ``rate``
    (Benjamini & Hochberg 1995): the k smallest p-values, k the largest with p_(k) <= rate·k/m.

    Used so that a thousand entries each tested at 5 % do not let fifty lucky ones through."""
    p = np.asarray(p_values, dtype=np.float64)
    m = p.size
    reject = np.zeros(m, dtype=bool)
    if m == 0:
        return reject
    order = np.argsort(p, kind="stable")
    passing = np.flatnonzero(p[order] <= rate * np.arange(1, m + 1) / m)
    if passing.size:
        reject[order[: passing[-1] + 1]] = True
    return reject


def _choose(
    scores: F64,
    default: I64,
    enabled: npt.NDArray[np.bool_],
    margin: float,
    consistency: tuple[F64, F64, int] | None = None,
) -> I64:
    """Per row: the best enabled family if it beats ``default`` by more than ``margin``
    (``enabled``: bool[F], or bool[rows, F] per row; a row's default is enabled).

    ``consistency`` = (Σ_days gain², days, static index): a row leaving ``static``, or leaving
    any default for a time-varying family other than it, must also win consistently over two
    scored days or more — the family's daily gains over ``static`` pass the one-sided t-test of
    the module docstring, with the false-discovery rate held over all the rows so tested
    (:func:`benjamini_hochberg`). Leaving a borrowed default for ``static`` (the simpler
    family) needs no test.

    Why the borrowed default too (docs/EVALUATION.md, "An entry's own FreMEn against a
    borrowed default"): on Lincoln maps of one to three scored days, entries whose group lent
    them ``shape`` or ``profile`` chose their own FreMEn on one day's win or on erratic daily
    gains, and on each of four held-out splits those entries forecast worse than both
    ``static`` and ``shape`` (Poisson deviance 1.2 to 3.2 times theirs)."""
    masked = np.where(enabled if enabled.ndim == 2 else enabled[None, :], scores, -np.inf)
    rows = np.arange(len(default))
    best = masked.argmax(axis=1)
    gain = masked[rows, best] - masked[rows, default]
    ok = gain > margin
    if consistency is not None:
        gain_sq, days, static = consistency
        # the entry's own choice of a time-varying family, against any default
        own = (best != default) & (best != static)
        ok &= ~own | (days >= 2)  # one day shows no consistency
        tested = np.flatnonzero(((default == static) | own) & (days >= 2))
        p_value = np.ones(len(tested))
        candidate = (best[tested] != static) & ok[tested]
        if candidate.any():
            cand = tested[candidate]
            n = days[cand]
            mean = (scores[cand, best[cand]] - scores[cand, static]) / n
            sum_sq = gain_sq[cand, best[cand]]
            sample_var = np.maximum(sum_sq - n * mean**2, 0.0) / (n - 1)
            t = mean * np.sqrt(n) / np.sqrt(np.maximum(sample_var, 1e-300))
            p_value[candidate] = student_t_sf(t, np.round(n).astype(np.int64) - 1)
        ok[tested] &= benjamini_hochberg(p_value)
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
    fremen_rows: npt.NDArray[np.bool_] | None = None,
) -> tuple[I64, I64, int]:
    """Chosen flow and direction family indices per entry, and the map's own flow choice
    (see the module docstring). ``*_consistency``: (Σ_days gain², days) per entry.
    ``fremen_rows``: the entries that may choose a FreMEn flow family (all when None) — a map
    read for queries without its Fourier sums has FreMEn components for the entries that
    chose FreMEn when it was written, and a map written before a change of these rules (the
    borrowed ``profile``) must not send an entry to a FreMEn forecast it cannot compute: such
    an entry takes its best other family by the same rules. FreMEn is masked only for the
    entries that would choose it without components, so a map written under today's rules
    chooses as with its sums read."""
    margin = params.config.family_margin
    static = params.flow.index("static")
    shape = params.flow.index("shape")
    flow_on, dir_on = params.flow_enabled, params.direction_enabled
    e = len(groups)
    # flow: map -> group -> entry
    map_flow = _choose(flow_score.sum(axis=0, keepdims=True), np.array([static]), flow_on, margin)
    g_scores = group_sums(groups, n_groups, flow_score)
    group_flow = _choose(g_scores, np.full(n_groups, map_flow[0]), flow_on, margin)
    borrowed = np.where(group_flow[groups] == static, static, shape)
    if not flow_on[shape]:
        borrowed = np.full(e, static)
    if "profile" in params.flow and flow_on[params.flow.index("profile")]:
        profile = params.flow.index("profile")
        borrowed = np.where(group_flow[groups] == profile, profile, borrowed)
    fc = None if flow_consistency is None else (*flow_consistency, static)
    flow = _choose(flow_score, borrowed.astype(np.int64), flow_on, margin, fc)
    if fremen_rows is not None:
        # only the entries that choose FreMEn without components lose it (masking it for
        # any other would make its next family the best and could choose that one): again
        # until none does, as the others' joint false-discovery test may move with them
        fremen = np.array([f.startswith("fremen") for f in params.flow])
        blocked = fremen[flow] & ~fremen_rows
        while blocked.any():
            entry_on = flow_on[None, :] & ~(fremen[None, :] & blocked[:, None])
            flow = _choose(flow_score, borrowed.astype(np.int64), entry_on, margin, fc)
            missing = fremen[flow] & ~fremen_rows
            if not missing.any():
                break
            blocked |= missing
    # directions: map -> group (static or profile) -> entry
    dstatic = params.direction.index("static")
    dc = None if dir_consistency is None else (*dir_consistency, dstatic)
    lent = np.full(e, dstatic, np.int64)
    if "profile" in params.direction and dir_on[params.direction.index("profile")]:
        lendable = np.zeros_like(dir_on)
        lendable[[dstatic, params.direction.index("profile")]] = True
        pooled = _pooled_days(dir_score, dir_consistency, groups, n_groups)
        # the map pooled as one group (not the groups' pooled sums: those leave out the days
        # of groups without a member of two scored days, whose gains their scores still hold)
        at_map = _pooled_days(dir_score, dir_consistency, np.zeros(e, np.int64), 1)
        map_dir = _choose(at_map[0], np.array([dstatic]), lendable, margin,
                          None if dc is None else (at_map[1], at_map[2], dstatic))  # fmt: skip
        group_dir = _choose(pooled[0], np.full(n_groups, map_dir[0]), lendable, margin,
                            None if dc is None else (pooled[1], pooled[2], dstatic))  # fmt: skip
        lent = group_dir[groups].astype(np.int64)
    direction = _choose(dir_score, lent, dir_on, margin, dc)
    return flow, direction, int(map_flow[0])


def _pooled_days(
    scores: F64, consistency: tuple[F64, F64] | None, groups: I64, n_groups: int
) -> tuple[F64, F64, F64]:
    """Per group: its members' summed scores, squared daily gains and scored days, so that
    :func:`_choose`'s consistency test on them takes every (member, day) gain as one draw
    (a group lends ``profile`` only if its members' daily gains pass it together).

    A group none of whose members has two scored days counts none: many members' gains on one
    day are one day's evidence, and one day shows no consistency, for a group as for an entry
    (Lincoln trained on two days, the second pending: lent ``profile`` on the first day's
    score, its held-out heading NLL was 1.3886 against static's 1.3876)."""
    f = scores.shape[1]
    g_scores = group_sums(groups, n_groups, scores)
    gain_sq, days = (np.zeros((n_groups, f)), np.zeros(n_groups))
    if consistency is not None:
        gain_sq = group_sums(groups, n_groups, consistency[0])
        days = np.bincount(groups, consistency[1], minlength=n_groups).astype(np.float64)
        most = np.zeros(n_groups)
        np.maximum.at(most, groups, consistency[1])
        days = np.where(most >= 2, days, 0.0)
    return g_scores, gain_sq, days


def dispersion(
    flow_chi2: F64, flow_scored: F64, family: I64, at: I64 | None = None
) -> F64:
    """φ ≥ 1 per entry for its chosen flow family (pooled toward the map's, of every
    entry); ``at``: the positions of the entries ``family`` names (all, in order, if None)."""
    entries = np.arange(len(family)) if at is None else at
    chi2 = flow_chi2[entries, family]
    total_scored = float(flow_scored.sum())
    map_phi = np.ones(flow_chi2.shape[1])
    if total_scored > 0:
        map_phi = np.maximum(flow_chi2.sum(axis=0) / total_scored, 1.0)
    phi = (chi2 + _DISPERSION_PRIOR * map_phi[family]) / (
        flow_scored[entries] + _DISPERSION_PRIOR
    )
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


def count_cdf(count: npt.ArrayLike, mean: npt.ArrayLike, variance: npt.ArrayLike) -> F64:
    """P(N ≤ count) for the window count :func:`count_quantiles` reads its spread from (the
    same negative binomial or Poisson, the same parameters): what a spread's calibration is
    judged with (``evaluation.spread``). 0 below 0; NaN where the mean is unknown."""
    from scipy import stats

    y = np.floor(np.asarray(count, dtype=np.float64))
    mu = np.asarray(mean, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    y, mu, var = np.broadcast_arrays(y, mu, var)
    out = np.full(mu.shape, np.nan)
    known = np.isfinite(mu) & np.isfinite(var) & (mu >= 0) & ~np.isnan(y)
    out[known] = (y[known] >= 0).astype(np.float64)  # a mean of 0: N = 0
    pos = known & (mu > 0) & (y >= 0)
    over = pos & (var > mu * (1.0 + 1e-9))  # count_quantiles' test
    poisson = pos & ~over
    if poisson.any():
        out[poisson] = stats.poisson.cdf(y[poisson], mu[poisson])
    if over.any():
        p = mu[over] / var[over]
        n = mu[over] * p / (1.0 - p)
        out[over] = stats.nbinom.cdf(y[over], n, p)
    return out
