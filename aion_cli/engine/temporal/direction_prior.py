"""How strongly an entry's direction histogram leans on its parent's: the Dirichlet prior's
strength κ, fixed (``direction_prior = κ``) or estimated from the map (``"auto"``).

Why estimate it: κ says how much entries of one room or neighbourhood differ in their walking
directions. In a corridor whose places all see the same two directions, a place with a few
detections should look like its neighbours (large κ); where each place has its own way
through (a door, a desk, a junction), its own few detections say more (small κ). A fixed κ
is right for one kind of map and wrong for the other: at κ = 10 the simulated office's
predicted histograms were too flat (entropy 0.21 above the truth's), and at κ = 2 the real
Lincoln corridor's held-out heading likelihood was worse (docs/EVALUATION.md).

The estimate (empirical Bayes): each entry's directed counts N_e,b are taken as
Dirichlet-multinomial draws around its parent's histogram p_g,b with concentration κ, and κ
maximises their marginal likelihood

    Σ_e [ln Γ(κ) − ln Γ(N_e + κ) + Σ_b (ln Γ(N_e,b + κ p_b) − ln Γ(κ p_b))]

over :data:`KAPPA_RANGE` (an entry with fewer than two directed detections says nothing
about κ: its term does not depend on it). With fewer than :data:`MIN_ENTRIES` entries that
tell, κ is :data:`FALLBACK`. The entries' terms are summed by distinct value in sorted
order (and a big map's sample is chosen by the entries' counts), so the estimate, and every
forecast and score that uses it, is the same to the bit whichever order a map lists its
entries in (read back, merged, built in parallel).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.types import F64, I64

AUTO = "auto"
"""``direction_prior = "auto"``: κ estimated from the map (the default)."""
FALLBACK = 10.0
"""κ when too few entries tell (and the fixed default before the estimate existed)."""
TIME_FALLBACK = 50.0
"""κ_t (``direction_time_prior = "auto"``) when too few (entry, profile bin) pairs tell: the
fixed default before the estimate existed (stop 67)."""
GROUP_PRIOR = 10.0
"""With ``"auto"``, the groups' own pull toward the map's histogram (pseudo-detections)."""
KAPPA_RANGE = (0.5, 100.0)
"""Bounds of the estimate: above 0 so that no probability is zero, and finite for a map whose
entries all agree with their parents (where the likelihood grows without end)."""
TIME_KAPPA_LOW = 1.0
"""κ_t's lower end (κ's is :data:`KAPPA_RANGE`'s 0.5): an hour's direction histogram counts
the entry's static one as at least one detection. Where directions keep to the hour without
exception (a corridor walked east every morning, west every afternoon) the likelihood rises
toward κ_t = 0 and the estimate sits at this end; at 0.5, a detection against the hour's way
in a day-ahead test cost so much that the scores chose the static histogram for one cell of
ten in ``tests/evaluation/test_grid.py``'s flipping corridor (stop 67's CI run); from 1 none."""
MIN_ENTRIES = 10
"""Entries with at least two directed detections needed for an estimate."""
MAX_ENTRIES = 2048
"""About this many entries enter the estimate, chosen by a hash of their counts, so that a
day's scoring or a query on a big map costs a bounded few milliseconds (on the 20-day
benchmark log, 3,684 entries: 17-20 ms a day close under load, 4 % of the build; the estimate
moves by a few per cent with the sample)."""


def group_prior(config: ModelConfig) -> float:
    """κ of the groups toward the map: the configured number, :data:`GROUP_PRIOR` with auto."""
    value = config.direction_prior
    return GROUP_PRIOR if isinstance(value, str) else float(value)


def entry_prior(
    config: ModelConfig,
    directed: Callable[[], tuple[F64, F64]],
    telling: Callable[[F64, F64], I64] | None = None,
) -> float:
    """κ of entries toward their parents: the configured number, or with ``"auto"`` the
    estimate from ``directed()``: N[e, b] (directed detections) and p[e, b] (each entry's
    parent histogram), gathered only then (a fixed κ needs neither). ``telling``: the
    :func:`telling_rows` of those, when the caller chooses them once for κ_t's input too."""
    value = config.direction_prior
    if isinstance(value, str):
        counts, parent = directed()
        rows = None if telling is None else telling(counts, parent)
        return fitted_kappa(counts, parent, rows=rows)
    return float(value)


def time_prior(config: ModelConfig, per_bin: Callable[[], tuple[F64, F64]]) -> float:
    """κ_t of an entry's time-varying direction histograms toward its static one: the
    configured ``direction_time_prior``, or with ``"auto"`` the estimate from ``per_bin()``:
    N[(e, h), b] (an entry's directed detections in one profile bin) and p[(e, h), b] (the
    entry's static histogram). The same marginal likelihood as κ's, each (entry, profile
    bin) a draw around its entry's histogram: where walking directions keep to the hour (a
    corridor walked east in the morning, west in the evening) κ_t is small and an hour's few
    detections say much; where they do not, κ_t is large and the hour's histogram stays the
    static one. :data:`TIME_FALLBACK` with fewer than :data:`MIN_ENTRIES` pairs that tell."""
    value = config.direction_time_prior
    if isinstance(value, str):
        return fitted_kappa(*per_bin(), fallback=TIME_FALLBACK, low=TIME_KAPPA_LOW)
    return float(value)


def fitted_kappa(
    counts: F64,
    parent: F64,
    fallback: float = FALLBACK,
    low: float = KAPPA_RANGE[0],
    rows: I64 | None = None,
) -> float:
    """The maximum marginal likelihood κ (module docstring) in [``low``, the top of
    :data:`KAPPA_RANGE`], found by golden-section search on ln κ (numpy only: no ``scipy``
    import on a query's path); ``fallback`` with fewer than :data:`MIN_ENTRIES` rows of two
    detections or more. ``rows``: :func:`telling_rows` of ``counts`` and ``parent``, when
    the caller has them."""
    n = row_sums(counts)
    if int(np.count_nonzero(n >= 2)) < MIN_ENTRIES:
        return fallback
    kept = telling_rows(counts, parent, n) if rows is None else rows
    c = np.asarray(counts, np.float64)[kept]
    # the parents' shares of the rows kept only (elementwise: the same values as clipping
    # every telling row first; issue 15: κ_t's rows are an entry's profile bins, ~45,000)
    p = np.clip(np.asarray(parent, np.float64)[kept], 1e-12, None)
    n = n[kept]
    log_likelihood = marginal_likelihood(c, p, n)
    lo, hi = float(np.log(low)), float(np.log(KAPPA_RANGE[1]))
    return float(np.exp(_golden_max(log_likelihood, lo, hi, 0.03)))


def telling_rows(counts: F64, parent: F64, totals: F64 | None = None) -> I64:
    """The rows of ``counts`` that tell κ (two detections or more; ``totals``: their row
    sums, when the caller has them), about :data:`MAX_ENTRIES` of them when there are more,
    chosen by their counts and parent shares (:func:`sample_rows`: the same rows in any
    order). κ_t's input is the profile bins of the very entries κ's estimate reads
    (``pooling.per_bin_directed``): a pooling chooses them once for both (issue 15)."""
    n = row_sums(counts) if totals is None else totals
    kept = np.flatnonzero(n >= 2)
    if kept.size > MAX_ENTRIES:
        # chosen by counts and parent shares (sample_rows), the shares of the telling rows
        c, p = (np.asarray(a, np.float64)[kept] for a in (counts, parent))
        kept = kept[sample_rows(c, MAX_ENTRIES, p)]
    return kept


def marginal_likelihood(counts: F64, parent: F64, totals: F64) -> Callable[[float], float]:
    """The marginal likelihood of the module docstring as a function of ln κ, for rows of
    ``counts`` (whole numbers) around ``parent`` (no zero share) with row sums ``totals``.

    It depends only on how often each (count, parent share) pair and each row total occur:
    evaluated once per distinct value, weighted by how often it occurs (in sorted order, so
    the sums do not depend on the rows' order either). The weighted sums are numpy's
    pairwise sums of the products, not a BLAS dot: OpenBLAS spreads a dot of more than
    10,000 elements over its threads, whose waking and spinning cost ~3 ms of CPU a step
    against 0.3 ms at κ's and κ_G's 14,000-16,000 distinct pairs on a map of 10^4 entries
    (issue 15, stop 71), and whose partial sums made the value's last bits depend on the
    machine's number of cores."""
    row, col = np.nonzero(counts)
    pair_count, shares, of_share, times = _distinct_pairs(counts[row, col], parent[row, col])
    distinct_totals, total_times = np.unique(totals, return_counts=True)
    pair_times, entry_times = times.astype(np.float64), total_times.astype(np.float64)
    entries = float(totals.size)
    k, s, t = pair_count.size, shares.size, distinct_totals.size
    # every ln Γ of a step in one call (it is elementwise: the same values as one call per
    # argument, a quarter of the numpy calls; issue 15: 64 calls per day close before), and
    # ln Γ(κ p) once per distinct share, gathered for the pairs (the same value each pair
    # had: a fifth of the distinct pairs on the 20-day bench log, issue 15)
    at = np.empty(k + s + t + 1)

    def log_likelihood(log_kappa: float) -> float:
        kappa = float(np.exp(log_kappa))
        a = np.multiply(kappa, shares, out=at[k : k + s])
        np.add(pair_count, a[of_share], out=at[:k])
        np.add(distinct_totals, kappa, out=at[k + s : k + s + t])
        at[-1] = kappa
        lg = log_gamma(at)
        of_pairs = lg[:k]
        of_pairs -= lg[k : k + s][of_share]
        of_pairs *= pair_times
        of_entries = np.multiply(entry_times, lg[k + s : k + s + t], out=lg[k + s : k + s + t])
        return float(of_pairs.sum()) - float(of_entries.sum()) + entries * float(lg[-1])

    return log_likelihood


def _distinct_pairs(
    count: F64, share: F64
) -> tuple[F64, F64, npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The distinct (count, share) pairs, sorted by count then share, and how often each
    occurs: what ``np.unique(count + 1j * share, return_counts=True)`` gives (complex values
    sort by real part, then imaginary), from each part's distinct values and one unique of
    integer keys, about twice as fast as sorting the complex values (issue 15: a day close
    estimates κ). Returns the pairs' counts, the distinct shares, each pair's share among
    them (the pairs' shares are ``shares[of_share]``) and the pairs' occurrences."""
    shares, share_at = np.unique(share, return_inverse=True)
    counts, count_at = np.unique(count, return_inverse=True)
    keys, times = np.unique(count_at.reshape(-1) * shares.size + share_at.reshape(-1),
                            return_counts=True)
    of_count, of_share = np.divmod(keys, shares.size)
    return counts[of_count], shares, of_share, times


def _golden_max(f: Callable[[float], float], lo: float, hi: float, tol: float) -> float:
    """The argmax of a unimodal ``f`` on [lo, hi] to within ``tol`` (golden-section search;
    at an end when ``f`` keeps rising toward it)."""
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    x1, x2 = b - ratio * (b - a), a + ratio * (b - a)
    f1, f2 = f(x1), f(x2)
    while b - a > tol:
        if f1 >= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - ratio * (b - a)
            f1 = f(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + ratio * (b - a)
            f2 = f(x2)
    best = (a + b) / 2.0
    ends = ((lo, f(lo)), (hi, f(hi)), (best, f(best)))
    return max(ends, key=lambda end: end[1])[0]


_STIRLING = (1 / 12, -1 / 360, 1 / 1260, -1 / 1680, 1 / 1188)
"""Coefficients of 1/x, 1/x^3, ... in ln Γ(x)'s asymptotic series (error < 1e-13 at x >= 8)."""


def log_gamma(x: F64) -> F64:
    """ln Γ(x) for x > 0, elementwise, in numpy: below 8 shifted up by Γ(x+8) = x(x+1)…(x+7)
    Γ(x), then Stirling's series (absolute error below 1e-12; whole-array arithmetic: a
    likelihood evaluates it on thousands of values a step). The shift's product and its
    logarithm are computed for the arguments below 8 alone, and the series in place (issue
    15: the same operations on every value as over the whole array, a fifth less time at a
    day close's golden-section steps)."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 0:
        scalar: F64 = log_gamma(x.reshape(1)).reshape(())
        return scalar
    small = x < 8.0
    y = np.where(small, x + 8.0, x)
    inverse = 1.0 / y
    square = inverse * inverse
    # Horner's scheme from the last coefficient (0 · square + c is c: the first step is a copy)
    series = np.full_like(y, _STIRLING[-1])
    for coefficient in reversed(_STIRLING[:-1]):
        series *= square
        series += coefficient
    out: F64 = y - 0.5
    out *= np.log(y)
    out -= y
    out += 0.5 * np.log(2.0 * np.pi)
    series *= inverse
    out += series
    if small.any():
        shifted = x[small]
        product = shifted.copy()
        for k in range(1, 8):
            product *= shifted + k
        out[small] -= np.log(product)
    return out


def sample_rows(counts: F64, about: int, shares: F64 | None = None) -> npt.NDArray[np.bool_]:
    """About ``about`` of the rows, chosen by their counts (a hash of the whole numbers) and
    ``shares`` (their parent histograms, a hash of the floats' bits), so the same rows are
    chosen whatever order they come in. With the shares, rows of equal counts are chosen
    apart: κ_t's rows (an entry's few detections in one profile bin) repeat a few thousand
    count patterns, and chosen by counts alone each pattern was kept or left out whole, the
    estimate off by half (a κ_t of 5 estimated 9.8, of 20 estimated 13.5)."""
    whole = np.minimum(counts, 2.0**31).astype(np.uint64)
    primes = np.array([1_000_003, 998_244_353, 1_000_000_007, 2_147_483_647], np.uint64)
    mix = (whole * primes[np.arange(whole.shape[1]) % primes.size]).sum(axis=1, dtype=np.uint64)
    if shares is not None:  # one float per row (a weighted sum), its bits mixed in
        weights = np.sqrt(np.arange(2.0, shares.shape[1] + 2.0))  # irrational: rows apart
        # products, then row_sums' fixed order of additions: not a BLAS matrix-vector
        # product, whose last bits depend on how OpenBLAS splits the rows over the machine's
        # cores (1 against 2 threads: a row or two of 16 columns in 1 size of 40), which
        # chose other rows and fitted another κ
        bits = row_sums(np.asarray(shares, np.float64) * weights).view(np.uint64)
        mix += (bits ^ (bits >> np.uint64(31))) * np.uint64(0x94D049BB133111EB)
    mix = (mix ^ (mix >> np.uint64(29))) * np.uint64(0xBF58476D1CE4E5B9)
    mix ^= mix >> np.uint64(32)
    keep: npt.NDArray[np.bool_] = (mix % np.uint64(counts.shape[0])) < np.uint64(about)
    return keep
