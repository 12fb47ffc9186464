"""Distances between distributions and direction fields, defined exactly.

The paper reports these metrics without formulas; every choice is pinned here and in
``docs/EVALUATION.md``:

- Jensen–Shannon divergence in bits (log base 2), so it lies in [0, 1]: 0 for identical
  distributions, 1 for distributions with disjoint support.
- Bhattacharyya distance ``-ln Σ sqrt(p q)``, in [0, ∞); disjoint supports give ∞, which is
  reported as the finite ceiling ``-ln(eps)`` so means stay finite (``BHATTACHARYYA_EPS``).
- Wasserstein-1 on a line (``wasserstein_linear``): ``Σ |CDF_p - CDF_q| · bin width`` over the
  histogram support; on a circle (``wasserstein_circular``): ``min_c Σ |F_p - F_q - c| · width``,
  the circular earth mover's distance, minimised at the weighted median of ``F_p - F_q``.
- Mean angular displacement (degrees) between two direction fields: the mean over paired cells
  of the absolute wrapped angle difference.
- Circular correlation: the Jammalamadaka–SenGupta coefficient
  ``Σ sin(a-ā) sin(b-b̄) / sqrt(Σ sin²(a-ā) Σ sin²(b-b̄))`` with circular means ā, b̄.
- Heading negative log-likelihood of one detection under an 8-bin (B-bin) histogram model read
  as a density over [0, 2π): ``-(log P(bin) + log(B / 2π))``, probabilities floored at
  ``NLL_FLOOR`` and renormalised; a uniform model gives exactly ``log(2π)``.
- Chi-square histogram distance ``Σ (x-y)² / (x+y)`` over bins where ``x+y > 0``.
- Activity of a series of counts ``y`` against forecasts ``μ`` (``activity_scores``, e.g.
  detections per hour): Spearman rank correlation, Poisson deviance
  ``2 Σ [y ln(y/μ) − (y − μ)]`` (μ floored at 1e-9) and mean absolute error, over the
  entries whose forecast is finite.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]

BHATTACHARYYA_EPS = 1e-12
NLL_FLOOR = 1e-9


def normalize(p: npt.ArrayLike, axis: int = -1) -> F64:
    """Rows scaled to sum 1; an all-zero row stays all zero."""
    arr = np.asarray(p, dtype=np.float64)
    if np.any(arr < 0) or not np.all(np.isfinite(arr)):
        raise ValueError("distributions must be finite and non-negative")
    total = arr.sum(axis=axis, keepdims=True)
    return np.divide(arr, total, out=np.zeros_like(arr), where=total > 0)


def js_divergence(p: npt.ArrayLike, q: npt.ArrayLike, axis: int = -1) -> F64:
    """Jensen–Shannon divergence in bits, per row (0 = identical, 1 = disjoint)."""
    pn, qn = normalize(p, axis), normalize(q, axis)
    m = 0.5 * (pn + qn)

    def kl(a: F64) -> F64:
        ratio = np.divide(a, m, out=np.ones_like(a), where=(a > 0) & (m > 0))
        return np.sum(np.where(a > 0, a * np.log2(ratio), 0.0), axis=axis)

    return np.clip(0.5 * kl(pn) + 0.5 * kl(qn), 0.0, 1.0)


def bhattacharyya_distance(p: npt.ArrayLike, q: npt.ArrayLike, axis: int = -1) -> F64:
    """``-ln Σ sqrt(p q)`` per row; disjoint rows give ``-ln(BHATTACHARYYA_EPS)``."""
    coefficient = np.sum(np.sqrt(normalize(p, axis) * normalize(q, axis)), axis=axis)
    return -np.log(np.clip(coefficient, BHATTACHARYYA_EPS, 1.0))


def wasserstein_linear(p: npt.ArrayLike, q: npt.ArrayLike, bin_width: float = 1.0) -> F64:
    """Earth mover's distance between histograms on a line (last axis = bins)."""
    diff = np.cumsum(normalize(p) - normalize(q), axis=-1)
    return np.sum(np.abs(diff[..., :-1]), axis=-1) * bin_width


def wasserstein_circular(p: npt.ArrayLike, q: npt.ArrayLike, bin_width: float = 1.0) -> F64:
    """Earth mover's distance between histograms on a circle (last axis = bins).

    ``min_c Σ_k |D_k - c|`` with ``D`` the cumulative difference; the minimiser is a median of
    ``D``, so the distance is exact without searching over shifts.
    """
    diff = np.cumsum(normalize(p) - normalize(q), axis=-1)
    median = np.median(diff, axis=-1, keepdims=True)
    return np.sum(np.abs(diff - median), axis=-1) * bin_width


def wrap_angle(a: npt.ArrayLike) -> F64:
    """Angles wrapped into [-π, π)."""
    return (np.asarray(a, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi


def mean_angular_displacement_deg(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Mean absolute wrapped difference between paired angles, in degrees (NaN pairs skipped)."""
    diff = np.abs(wrap_angle(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)))
    valid = np.isfinite(diff)
    if not np.any(valid):
        return math.nan
    return float(np.degrees(diff[valid].mean()))


def circular_mean(a: npt.ArrayLike) -> float:
    arr = np.asarray(a, dtype=np.float64)
    return float(np.arctan2(np.sin(arr).sum(), np.cos(arr).sum()))


def circular_correlation(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Jammalamadaka–SenGupta circular correlation of paired angles (NaN pairs skipped)."""
    x = np.asarray(a, dtype=np.float64)
    y = np.asarray(b, dtype=np.float64)
    valid = np.isfinite(x) & np.isfinite(y)
    x, y = x[valid], y[valid]
    if len(x) < 2:
        return math.nan
    sx = np.sin(x - circular_mean(x))
    sy = np.sin(y - circular_mean(y))
    denominator = math.sqrt(float(np.sum(sx**2) * np.sum(sy**2)))
    if denominator == 0.0:
        return math.nan
    return float(np.sum(sx * sy) / denominator)


def heading_nll(probabilities: npt.ArrayLike, bins: npt.ArrayLike) -> F64:
    """Negative log density of each heading under its row's B-bin histogram.

    ``probabilities`` is (n, B) (rows need not be normalised), ``bins`` the (n,) observed bin of
    each detection. Density over [0, 2π): P(bin) · B / 2π.
    """
    probs = np.asarray(probabilities, dtype=np.float64)
    floored = np.maximum(normalize(probs), NLL_FLOOR)
    floored /= floored.sum(axis=-1, keepdims=True)
    b = np.asarray(bins, dtype=np.int64)
    n_bins = probs.shape[-1]
    chosen = floored[np.arange(len(b)), b]
    return -(np.log(chosen) + math.log(n_bins / (2 * math.pi)))


def chi_square_distance(x: npt.ArrayLike, y: npt.ArrayLike, axis: int = -1) -> F64:
    """``Σ (x-y)² / (x+y)`` over bins with ``x+y > 0`` (histograms as given, not normalised)."""
    xa = np.asarray(x, dtype=np.float64)
    ya = np.asarray(y, dtype=np.float64)
    total = xa + ya
    terms = np.divide((xa - ya) ** 2, total, out=np.zeros_like(total), where=total > 0)
    return np.sum(terms, axis=axis)


def activity_scores(
    truth: npt.ArrayLike, predicted: npt.ArrayLike, exposure: npt.ArrayLike | None = None
) -> dict[str, float]:
    """Spearman correlation, Poisson deviance and MAE of ``predicted`` counts against
    ``truth`` (see the module docstring), over the pairs whose forecast is finite.

    ``exposure`` (positive, per pair: how much of it was observed, e.g. place-windows) makes
    the Spearman one of rates, both series divided by it: an hour observed half as long holds
    half the detections in truth and forecast alike, and ranking the counts would credit a
    forecast of one rate at every hour (a static map) with ranking hours by how long they were
    observed. A forecast whose rate is the same everywhere has no rank correlation (NaN)."""
    from scipy.stats import spearmanr

    y_all, mu_all = np.asarray(truth, dtype=np.float64), np.asarray(predicted, dtype=np.float64)
    ok = np.isfinite(mu_all)
    y, mu = y_all[ok], np.maximum(mu_all[ok], 1e-9)
    with np.errstate(divide="ignore", invalid="ignore"):
        term = np.where(y > 0, y * np.log(y / mu), 0.0)
    rank_y, rank_mu = y, mu
    if exposure is not None:
        e = np.asarray(exposure, dtype=np.float64)[ok]
        seen = e > 0  # an hour with nothing in view has no rate
        rank_y, rank_mu = y[seen] / e[seen], mu[seen] / e[seen]
    # else no rank correlation; rates equal to rounding (sums of shares) are one rate
    varied = (
        len(rank_y) > 2 and np.ptp(rank_y) > 0
        and np.ptp(rank_mu) > 1e-9 * float(np.max(np.abs(rank_mu)))
    )
    rho = spearmanr(rank_y, rank_mu).statistic if varied else math.nan
    return {
        "spearman": float(rho),
        "poisson_deviance": float(2.0 * np.sum(term - (y - mu))),
        "mae": float(np.mean(np.abs(y - mu))) if len(y) else math.nan,
    }


HOUR_NS = 3_600 * 10**9


def hourly_activity(
    window_start_ns: npt.ArrayLike,
    truth: npt.ArrayLike,
    forecasts: Mapping[str, npt.ArrayLike],
    local_start_ns: npt.ArrayLike | None = None,
    exposure: npt.ArrayLike | None = None,
) -> tuple[npt.NDArray[np.int64], dict[str, list[float]], list[dict[str, float | str]]]:
    """Counts per window (``truth``) and each model's forecasts per window, summed per clock
    hour of the windows' starts: the hours (each as the UNIX ns of its start), the hourly
    series (``truth`` first) and each model's :func:`activity_scores` as ``{"model": name,
    ...}`` rows. ``local_start_ns`` (the starts on a local wall clock,
    ``Calendar.local_ns``) makes the hours that clock's (08:00-09:00 local in a zone half an
    hour off UTC; each of the two 02:00 hours of an autumn change apart); default: UTC's.
    ``exposure`` (per window, e.g. the place-windows observed in it), summed per hour, makes
    the Spearman one of rates (:func:`activity_scores`)."""
    starts = np.asarray(window_start_ns, dtype=np.int64)
    local = starts if local_start_ns is None else np.asarray(local_start_ns, dtype=np.int64)
    hour_of = starts - np.mod(local, HOUR_NS)  # the UNIX ns at which each local hour began
    hours, inverse = np.unique(hour_of, return_inverse=True)
    hourly_truth = np.bincount(inverse, np.asarray(truth, dtype=np.float64))
    series = {"truth": hourly_truth.tolist()}
    hourly_exposure = None if exposure is None else np.bincount(
        inverse, np.asarray(exposure, dtype=np.float64)
    )
    rows: list[dict[str, float | str]] = []
    for name, values in forecasts.items():
        hourly = np.bincount(inverse, np.asarray(values, dtype=np.float64))
        series[name] = hourly.tolist()
        rows.append({"model": name, **activity_scores(hourly_truth, hourly, hourly_exposure)})
    return hours.astype(np.int64), series, rows
