"""The spread of a sum of places' window counts (a room, a building, an hour's total).

Places' counts are not independent: one walker is counted by every cell he crosses in a
window, so the variance of a sum is far above the sum of the places' variances (on Lincoln
the band of the hours' totals, places summed as independent, held 0 – 20 % of them where a
calibrated band holds 80 %: docs/EVALUATION.md). The map measures how bursty its *totals*
are: φ_T, the Pearson dispersion of its window totals within each (day, profile bin)
(``TemporalState.window_chi2``, :func:`~aion_cli.engine.temporal.shape_prior.overdispersion`;
two sums that add, so maps merged or continued keep it exactly).

The covariance of two places follows from reading the map's detections in a window as
clusters (a walker's, a group's) that arrive as a Poisson stream and spread their
detections over the places in proportion to the places' means (a thinning of the total):
with N the map's total, mean M and variance φ_T · M, the counts n_p of places with means
μ_p have Cov(n_p, n_q) = μ_p μ_q (φ_T − 1) / M for p ≠ q (the expected number of pairs of
one cluster's detections, M (φ_T − 1), shared out as μ_p μ_q / M²). A group G of places
then has

    Var(Σ_G n_p) = Σ_G Var(n_p) + (φ_T − 1) · ((Σ_G μ_p)² − Σ_G μ_p²) / M,

each place keeping its own measured variance (φ_p μ_p: its own burstiness, calibrated)
and the pairs adding their covariance. It is never narrower than the independent sum
(φ_T ≥ 1), equals it for a group of one place or a Poisson map (φ_T = 1), and for the whole
map is about φ_T · M, the dispersion the map measured. Sums over several windows (an hour)
add the windows' variances: clusters are counted within a window.

φ_T is measured within a day and profile bin, so a whole day busier or quieter than the
forecast is outside that band: a day's level factor, of variance c around the forecast's
(:mod:`~aion_cli.engine.temporal.day_level`), multiplies every place of the day at once, so
a sum of mean S adds c · S² (``level``); an hour adds it once for the sum of its windows,
whose level is the same day's.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64


def sum_variance(
    mean: npt.ArrayLike,
    variance: npt.ArrayLike,
    group: I64,
    n_groups: int,
    reference: npt.ArrayLike,
    phi_total: float,
    level: float = 0.0,
) -> F64:
    """The variance of each group's summed count (module docstring): ``mean`` and
    ``variance`` per place, ``group`` each place's group (0 .. ``n_groups`` − 1, every place
    in one window), ``reference`` the mean total M of the window the map's dispersion
    ``phi_total`` describes (a scalar, or one per group), ``level`` the variance of the
    day's level factor (module docstring: each group adds it times its summed mean squared),
    float64[n_groups]. Places whose mean or variance is not finite count as 0, as in the
    groups' summed means."""
    mu = np.nan_to_num(np.asarray(mean, dtype=np.float64))
    var = np.nan_to_num(np.asarray(variance, dtype=np.float64))
    independent = np.bincount(group, var, minlength=n_groups).astype(np.float64)
    # float64 whatever the input: bincount of no places returns int64 zeros
    total = np.bincount(group, mu, minlength=n_groups).astype(np.float64, copy=False)
    if level > 0.0:
        independent += level * total * total
    if phi_total <= 1.0:
        return independent
    own = np.bincount(group, mu * mu, minlength=n_groups).astype(np.float64, copy=False)
    m = np.broadcast_to(np.asarray(reference, dtype=np.float64), total.shape)
    pairs = np.clip(total * total - own, 0.0, None)  # rounding: never below the independent sum
    covariance = np.divide(
        (phi_total - 1.0) * pairs, m, out=np.zeros_like(total), where=m > 0
    )
    out: F64 = independent + covariance
    return out
