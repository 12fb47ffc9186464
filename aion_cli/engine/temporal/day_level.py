"""How much whole days differ in level: the between-day variance of a sum of places.

The map's φ_T (:mod:`.shape_prior`, :mod:`.totals`) measures how its window totals vary
*within* a day and profile bin, so a day that is busier or quieter as a whole than the
forecast is outside the band of an hour's, a room's or a building's total
(docs/EVALUATION.md, "Are the spreads calibrated?"). This module measures the days' levels.

**The sums** (``TemporalState.day_level``, float64[4, 2H], one column per cell of
:func:`~aion_cli.engine.temporal.shape_prior.day_chi2`: kind of slot × profile bin). For each
closed day and cell it observed (units b > 0: the slots' units, detections per unit
ρ = a / b, a the slots' detections), the map adds 1, ρ, ρ² and ρ / b to the cell's column:
sums over days, so maps of disjoint days (``build --map``, ``aion merge``) add exactly, as
``window_chi2`` does. A query's pending day and open window are one day of these sums, as
closing them will add it (``absorption.absorb_parts``: the open window had been a day of its
own, a cell's days observed one too many). A map written before the member reads as zeros: no
level variance.

**The level.** A day's rate in a cell is L_d λ_h: a day-level factor L_d (mean 1, variance
c, shared by every cell of the day) times the cell's rate. Within a day the cell's rate is
measured with variance φ_T λ_h / b (window totals of dispersion φ_T), so over the days of a
cell E[s²] = c λ_h² + φ_T λ_h E[1/b], and the method of moments over the cells (each weighed
by its degrees of freedom, n_h − 1) gives

    ĉ = Σ_h (n_h − 1) (s²_h − φ_T · mean_h(ρ / b)) / Σ_h (n_h − 1) ρ̄_h²,

clipped at 0 (days that vary no more than their windows' noise add nothing). A forecast
built from D days misses a new day's level by L_new − L̄: variance c (1 + 1/D). And ĉ rests on
about D − 1 degrees of freedom (the cells of one day share its level), so few days give a
rough ĉ: the predictive level of a new day is then Student-t rather than normal, and the
band's variance is widened by (t_{0.9, D−1} / z_{0.9})², the square of how much wider the
80 % interval of that t is than the normal one (×5.8 for 2 days, ×2.2 for 3, ×1.2 for 10,
→ 1). :func:`level_variance` returns c (1 + 1/D) times that: the variance of a day's level
around the forecast's, which a sum of places with mean S adds as c · S² to its variance
(:func:`~aion_cli.engine.temporal.totals.sum_variance`). A map of one day (or none) has no
estimate and adds 0: its bands are as before.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.types import F64, I64
from aion_cli.errors import MapCorruptError

MEMBER = "day_level"
"""The map-file member (after the temporal prefix): float64[4, 2H], per (kind of slot,
profile bin) the days observed, Σ ρ, Σ ρ² and Σ ρ / b."""

LEVEL_QUANTILE = 0.9
"""The band's upper quantile (``flow_p90``), whose t / normal ratio widens a level measured
on few days."""
Z_HIGH = 1.2815515655446004
"""The standard normal's :data:`LEVEL_QUANTILE` quantile."""


def empty_sums(n_bins: int) -> F64:
    """The sums of a map without a closed day: zeros, float64[4, 2 · ``n_bins``]."""
    return np.zeros((4, 2 * n_bins))


def day_sums(day: DayWindows, h: I64, n_bins: int) -> F64:
    """One day's contribution to the sums (module docstring): per cell it observed, 1, ρ,
    ρ² and ρ / b; ``h`` is each slot's profile bin."""
    from aion_cli.engine.temporal.shape_prior import slot_units

    total, units = slot_units(day)
    seen = units > 0
    cell = (day.fixed.astype(np.int64) * n_bins + h)[seen]
    size = 2 * n_bins
    a = np.bincount(cell, weights=total[seen], minlength=size)
    b = np.bincount(cell, weights=units[seen], minlength=size)
    observed = b > 0
    rho = np.divide(a, b, out=np.zeros(size), where=observed)
    per_unit = np.divide(rho, b, out=np.zeros(size), where=observed)
    return np.stack([observed.astype(np.float64), rho, rho * rho, per_unit])


def add_sums(a: F64, b: F64, what: str = "day-level") -> F64:
    """The sums of two maps (or a map and a day): added, a map's empty sums (a map read
    before the member existed: shape ``(4, 0)``) taking the other's. ``what`` names the sums
    in the error for shapes that differ (the week sums share this rule)."""
    if a.size == 0:
        return b.copy()
    if b.size == 0:
        return a
    if a.shape != b.shape:
        raise ValueError(f"{what} sums of shapes {a.shape} and {b.shape} cannot be added")
    out: F64 = a + b
    return out


def level_variance(sums: F64, phi_total: float) -> float:
    """c (1 + 1/D) widened for few days (module docstring): the variance of a new day's level
    factor around the forecast's, from the map's ``sums`` and the dispersion ``phi_total`` of
    its window totals; 0 without two days in any cell."""
    if sums.size == 0:
        return 0.0
    n, s1, s2, per_unit = sums
    use = n >= 2
    if not use.any():
        return 0.0
    n, s1, s2, per_unit = n[use], s1[use], s2[use], per_unit[use]
    mean = s1 / n
    spread = np.maximum(s2 - s1 * mean, 0.0)  # Σ (ρ − ρ̄)²; rounding can dip below 0
    noise = max(phi_total, 1.0) * per_unit / n  # the within-day variance of each ρ
    excess = float((spread - (n - 1.0) * noise).sum())
    scale = float(((n - 1.0) * mean * mean).sum())
    if excess <= 0.0 or scale <= 0.0:
        return 0.0
    days = float(n.max())
    return excess / scale * (1.0 + 1.0 / days) * few_days_widening(days)


def few_days_widening(days: float) -> float:
    """(t_{0.9, D − 1} / z_{0.9})²: how much a level variance estimated from ``days`` days
    widens the band's variance (module docstring); 1 in the limit of many days. The t
    quantile in closed form for 1 and 2 degrees of freedom, else by its Cornish-Fisher
    series in 1/ν to the fourth term (within 3·10⁻⁴ of the exact quantile from ν = 3 on;
    numpy only: no ``scipy.stats`` import on a query's path)."""
    nu = max(days - 1.0, 1.0)
    z = Z_HIGH
    if nu < 2.0:
        q = math.tan(math.pi * (LEVEL_QUANTILE - 0.5))
    elif nu < 3.0:
        p = LEVEL_QUANTILE
        q = (2.0 * p - 1.0) / math.sqrt(2.0 * p * (1.0 - p))
    else:
        q = (
            z
            + (z**3 + z) / (4.0 * nu)
            + (5.0 * z**5 + 16.0 * z**3 + 3.0 * z) / (96.0 * nu**2)
            + (3.0 * z**7 + 19.0 * z**5 + 17.0 * z**3 - 15.0 * z) / (384.0 * nu**3)
            + (79.0 * z**9 + 776.0 * z**7 + 1482.0 * z**5 - 1920.0 * z**3 - 945.0 * z)
            / (92160.0 * nu**4)
        )
    return float((q / z) ** 2)


def stored_sums(arrays: Mapping[str, np.ndarray], prefix: str, n_bins: int) -> F64:
    """The stored sums (empty, shape ``(4, 0)``, for a map written before they were: no
    level variance); :class:`MapCorruptError` when they are not float64[4, 2H] of finite
    non-negative numbers."""
    if prefix + MEMBER not in arrays:
        return np.zeros((4, 0))
    value = np.asarray(arrays[prefix + MEMBER])
    if value.shape != (4, 2 * n_bins) or value.dtype.kind != "f":
        raise MapCorruptError(
            f"{prefix}{MEMBER} must be real numbers of shape (4, {2 * n_bins}), "
            f"got {value.dtype} {value.shape}"
        )
    if not np.all(np.isfinite(value)) or np.any(value < 0):
        raise MapCorruptError(f"{prefix}{MEMBER} holds non-finite or negative values")
    out: F64 = value.astype(np.float64)
    return out
