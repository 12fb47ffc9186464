"""How strongly the pooled periodic shapes are shrunk: the burstiness of the map's window
counts and an empirical-Bayes prior strength.

The parents' shapes (the map's and each group's detections per observed entry-window in each
profile bin, :class:`~aion_cli.engine.temporal.forecast.PoolStats`) are Gamma-Poisson posterior
means :func:`shrunk_rate` ``m (S + c) / (m W + c)`` toward a parent rate m: the map's flat rate
for the map's shape, a group's rate times the map's shape for the group's. How large c must be
depends on two things, both measured from the map rather than fixed by a constant:

* **Burstiness φ.** Detections are not independent: one walker is detected several times in
  a window and at several places, people come in groups, and a patrolling robot sees a place
  for part of a window. Under over-dispersed counts (variance φ times the mean) S detections
  carry the information of about S / φ independent ones. φ is measured per closed day, per
  profile bin and kind of slot (windows a fixed sensor saw, windows a robot saw): the day's
  slots s in that bin with T_s = the detections of every entry in s and m_s = the entries
  observed in it (1 for a fixed-sensor slot: its window total), ρ = Σ T / Σ m and the Pearson
  statistic χ² = Σ_s (T_s − ρ m_s)² / (ρ m_s) = (Σ_s T_s² / m_s) / ρ − Σ T on n − 1 degrees of
  freedom (cells without a detection say nothing and are left out). Given a cell's total,
  Poisson counts are multinomial and the expectation is exactly n − 1; over-dispersed ones
  give φ (n − 1). Cells are (day, bin), so a day busier than another as a whole (the level,
  not the shape) is not counted. χ² and the degrees of freedom are summed over days into
  ``TemporalState.window_chi2`` (two numbers that add, so maps of disjoint days add exactly),
  and φ = max(1, Σ χ² / Σ df) (:func:`overdispersion`).
* **How much the rates really vary, α.** The prior says a bin's true rate is Gamma with mean
  m and shape α (coefficient of variation 1/√α around its parent). With over-dispersion φ a
  bin's count has E[(S − W m)²] = φ W m + (W m)² / α, so the method of moments gives
  1/α = Σ [(S − W m)² − φ W m] / Σ (W m)² over the bins (:func:`prior_strength`): one day's
  hour-to-hour spikes that are only bursts leave little beyond φ W m (α large: the parent's
  shape), a rhythm seen day after day leaves much (α small: the bins' own rates).

The posterior mean is then ``m (S/φ + α) / (m W/φ + α)``: c = α·φ detections (bins that vary
no more than their noise, 1/α ≤ 0, take their parent's rate). α is estimated once for the
map's shape and once for all groups together. Groups use the map's φ (a group's window totals
are the map's seen through fewer entries, measured in the office as 1–22 where the map has
13–28, so groups lean on the map's shape). An entry's own ``profile`` keeps ``profile_prior``
pseudo-detections toward its shape: one entry's counts are far less bursty than a total over
many, and the day-ahead score judges that family against the shape anyway.

Why (figures in docs/EVALUATION.md): with c = ``profile_prior`` = 5 detections for every
shape, one day of the simulated office (window totals with φ ≈ 13–28) gave hour-of-day shapes
that forecast the next day worse than the static rate in three of four scenes (22 detections
in the 9 entry-windows of one hour became a forecast of several times the mean rate for an
hour that was empty the next day), so the map's day-ahead evidence chose ``static`` and its
sparse entries forecast their mean rate all night. On Lincoln (φ ≈ 229: linked tracks, crowds
on the hour) α ≈ 0.8 keeps the rhythm four days show clearly, where a fixed c·φ flattened it.
A fixed sensor over a steady Poisson stream has φ ≈ 1 and no excess variation: its shapes are
flat. The price: an empty hour is judged alone, and under bursty counts one empty night-hour
is weak evidence, so a short record of bursts forecasts nights at a few to a few tens of
percent of the day where the c = 5 shapes, over-confident, said nearly 0 (a hierarchy of time
blocks, tried, helps nights only where its blocks align with the rhythm).

The week's bins (``profile = "week"`` where the map's evidence asks for the week,
:mod:`.calendar_view`) add one level (:func:`_week_shapes`): each level's week is shrunk
toward its own weekday/weekend shape, not toward the map's week, so one place's market day
does not lift the other places' Wednesdays through the map's shape (docs/EVALUATION.md,
stop 69).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.types import F64, I64
from aion_cli.errors import MapCorruptError

MEMBER = "window_chi2"
"""The map-file member (after the temporal prefix): float64[2], Σ χ² and Σ degrees of freedom."""


def slot_units(day: DayWindows) -> tuple[F64, F64]:
    """Each slot of the day: its total T_s (the detections of every entry in it) and its
    units m_s (the entries observed in it, each for the part of the window it was observed
    in; a fixed-sensor slot: the share of its window recorded), as the module docstring
    defines them. A slot of units 0 was not observed."""
    slots = day.windows.size
    total = np.bincount(day.cnt_slot, weights=day.cnt_values.sum(axis=1), minlength=slots)
    # entries observed per slot, each for the part of the window it was observed in
    _, own_slot, own_weight = day.own_pairs()
    entries = np.bincount(own_slot, own_weight, minlength=slots)
    # a slot with detections was observed by the entries that had them (one, if none is held)
    shares = day.slot_shares()  # a fixed-sensor window: the share of it recorded
    units = np.where(day.fixed, shares, np.where((total > 0) & (entries <= 0), 1.0, entries))
    return total.astype(np.float64, copy=False), units.astype(np.float64, copy=False)


def day_chi2(day: DayWindows, h: I64, n_bins: int) -> F64:
    """[χ², degrees of freedom] of one day's window totals within its profile bins (module
    docstring); ``h`` is each slot's profile bin."""
    total, units = slot_units(day)
    seen = units > 0
    cell = (day.fixed.astype(np.int64) * n_bins + h)[seen]
    t, m = total[seen], units[seen]
    size = 2 * n_bins
    n = np.bincount(cell, minlength=size).astype(np.float64)
    a = np.bincount(cell, weights=t, minlength=size)
    b = np.bincount(cell, weights=m, minlength=size)
    q = np.bincount(cell, weights=t * t / m, minlength=size)
    use = (a > 0) & (n >= 2)
    chi2 = np.maximum(q[use] * b[use] / a[use] - a[use], 0.0)  # rounding can dip below 0
    return np.array([float(chi2.sum()), float((n[use] - 1.0).sum())])


def overdispersion(window_chi2: F64) -> float:
    """φ = max(1, Σ χ² / Σ df): 1 (Poisson) before any cell had two slots with detections."""
    chi2, df = float(window_chi2[0]), float(window_chi2[1])
    return max(1.0, chi2 / df) if df > 0 else 1.0


def prior_strength(counts: F64, windows: F64, prior: F64, phi: float) -> float:
    """c = α·φ pseudo-detections for shrinking bin rates ``counts / windows`` toward ``prior``
    (rates per window, same shape), α by the method of moments of the module docstring; inf
    where the bins vary no more than their noise (the shape is then the parent's)."""
    seen = windows > 0
    expected = windows[seen] * prior[seen]
    excess = float(((counts[seen] - expected) ** 2 - phi * expected).sum())
    scale = float((expected * expected).sum())
    if excess <= 0.0 or scale <= 0.0:
        return float("inf")
    return phi * scale / excess


def shrunk_rate(counts: F64, windows: F64, prior_rate: F64, prior_counts: float) -> F64:
    """Gamma-Poisson posterior mean rate: ``prior_counts`` pseudo-detections at
    ``prior_rate``, ``m (S + c) / (m W + c)`` — the own rate once the detections outweigh
    ``c``, the prior while they do not (so a sparse series leans on its parent); the prior
    rate where nothing was observed (or it is 0)."""
    m = np.asarray(prior_rate, dtype=np.float64)
    num = m * (counts + prior_counts)
    den = m * windows + prior_counts
    fallback = np.broadcast_to(m, np.broadcast(num, den).shape).astype(np.float64)
    out: F64 = np.divide(num, den, out=fallback, where=den > 0)
    return out


def group_shapes(
    s_g: F64, w_g: F64, phi: float, bins_per_day: int | None = None
) -> tuple[F64, F64]:
    """The groups' shapes r_g[G, H] (each shrunk toward the map's) and the map's r_map[H]
    (shrunk toward flat), with c = α·φ pseudo-detections at each level (module docstring);
    a group without detections has the map's shape. ``bins_per_day``: the profile's bins
    per day, when its H bins hold several kinds of day (weekday / weekend, or the days of
    the week): a map bin no window observed takes its hour of the day from the kinds that
    were (:func:`_unseen_kinds`), not the flat rate, and a group's such bin its own hour of
    the kinds seen (:func:`by_hour`), not the map's shape."""
    s_map, w_map = s_g.sum(axis=0), w_g.sum(axis=0)
    rho_map = s_map.sum() / w_map.sum() if w_map.sum() > 0 else 0.0
    if rho_map <= 0:
        return np.ones_like(s_g), np.ones(s_g.shape[1])
    if bins_per_day is not None and s_g.shape[1] == 7 * bins_per_day:
        return _week_shapes(s_g, w_g, phi, bins_per_day)
    flat = np.full(s_map.shape, rho_map)
    c = prior_strength(s_map, w_map, flat, phi)
    r_map = (shrunk_rate(s_map, w_map, flat, c) if np.isfinite(c) else flat) / rho_map
    if bins_per_day is not None:
        r_map = _unseen_kinds(r_map, s_map, w_map, rho_map, c, bins_per_day)
    rho_g = _levels(s_g, w_g)
    prior = rho_g[:, None] * r_map[None, :]
    busy = rho_g > 0
    c = prior_strength(s_g[busy], w_g[busy], prior[busy], phi)
    if bins_per_day is not None:  # a group's unseen bins: its own hours of the kinds seen
        unseen = unseen_bins(w_map, bins_per_day)
        s_g, w_g = by_hour(s_g, unseen, bins_per_day), by_hour(w_g, unseen, bins_per_day)
    return _group_shapes_of(s_g, w_g, prior, c, rho_g, r_map), r_map


def _levels(s_g: F64, w_g: F64) -> F64:
    """Each group's level ρ_g: its detections over its windows (0 where it has none)."""
    w_tot = w_g.sum(axis=1)
    out: F64 = np.divide(s_g.sum(axis=1), w_tot, out=np.zeros(len(w_tot)), where=w_tot > 0)
    return out


def _group_shapes_of(s_g: F64, w_g: F64, prior: F64, c: float, rho_g: F64, r_map: F64) -> F64:
    """The groups' shapes: each busy group's rates shrunk toward ``prior`` with strength
    ``c`` (the prior itself where c is infinite), over its level ρ_g; a group without
    detections takes the map's shape ``r_map``."""
    r_g = np.divide(
        shrunk_rate(s_g, w_g, prior, c) if np.isfinite(c) else prior,
        rho_g[:, None],
        out=np.zeros_like(s_g),
        where=rho_g[:, None] > 0,
    )
    out: F64 = np.where((rho_g > 0)[:, None], r_g, r_map[None, :])
    return out


def _week_shapes(s_g: F64, w_g: F64, phi: float, bins_per_day: int) -> tuple[F64, F64]:
    """:func:`group_shapes` of the week's bins (H = 7 × ``bins_per_day``): each level's
    week shrunk toward *its own* weekday/weekend shape (the same sums pooled into Monday–
    Friday and Saturday–Sunday, shaped as :func:`group_shapes` shapes them), with c = α·φ
    estimated at each level as there. A group's Wednesday is then a departure from its own
    weekdays, not from the map's Wednesday: a market at one place does not lift the quiet
    places' Wednesdays (nor lower their other weekdays) through the map's shape. A bin no
    window observed takes the weekday/weekend shape of its hour."""
    kind = pooled_week_bins(np.arange(s_g.shape[1]), bins_per_day)
    pooled_g, pooled_map = group_shapes(
        pool_week(s_g, bins_per_day), pool_week(w_g, bins_per_day), phi, bins_per_day
    )
    s_map, w_map = s_g.sum(axis=0), w_g.sum(axis=0)
    rho_map = s_map.sum() / w_map.sum()
    prior_map = rho_map * pooled_map[kind]
    c = prior_strength(s_map, w_map, prior_map, phi)
    r_map = (shrunk_rate(s_map, w_map, prior_map, c) if np.isfinite(c) else prior_map) / rho_map
    rho_g = _levels(s_g, w_g)
    prior = rho_g[:, None] * pooled_g[:, kind]
    busy = rho_g > 0
    c = prior_strength(s_g[busy], w_g[busy], prior[busy], phi)
    return _group_shapes_of(s_g, w_g, prior, c, rho_g, r_map), r_map


def pooled_week_bins(h: npt.ArrayLike, bins_per_day: int) -> I64:
    """The weekday/weekend bin (0 .. 2 · ``bins_per_day`` − 1) of the week's bins ``h``
    (Monday 00:00 first)."""
    week_h = np.asarray(h, dtype=np.int64)
    out: I64 = np.mod(week_h, bins_per_day) + bins_per_day * (week_h // bins_per_day >= 5)
    return out


def pool_week(values: npt.NDArray[Any], bins_per_day: int) -> npt.NDArray[Any]:
    """``values[..., 7 · bins_per_day]`` (sums per hour of the week) summed into the hours
    of weekdays and of weekends, ``[..., 2 · bins_per_day]`` (integer sums stay integers)."""
    days = np.asarray(values).reshape(*np.shape(values)[:-1], 7, bins_per_day)
    return np.concatenate(
        [days[..., :5, :].sum(axis=-2), days[..., 5:, :].sum(axis=-2)], axis=-1
    )


def _unseen_kinds(
    r_map: F64, s_map: F64, w_map: F64, rho_map: float, c: float, bins_per_day: int
) -> F64:
    """r_map with every bin no window observed (a weekend when the data held weekdays only,
    a Thursday under the weekly profile when it held none) set to the map's shape at the
    same hour of the day pooled over the kinds of day observed then: the detections and
    windows of that hour summed over them, shrunk toward the flat rate as the bins are (the
    same c). People's routines follow the clock, so an unseen kind of day is forecast with
    the rhythm of the days seen, not as flat as a day without hours (its level stays the
    map's: nothing tells a quieter weekend). A bin whose hour no kind observed stays flat;
    observed bins are unchanged, so the shape is today's wherever every kind was seen. The
    groups' shapes and each entry's ``profile`` pool their own sums the same way
    (:func:`by_hour`)."""
    unseen = unseen_bins(w_map, bins_per_day)
    if unseen is None:
        return r_map
    kinds = r_map.size // bins_per_day
    s_hour = s_map.reshape(kinds, bins_per_day).sum(axis=0)
    w_hour = w_map.reshape(kinds, bins_per_day).sum(axis=0)
    flat = np.full(bins_per_day, rho_map)
    hourly = shrunk_rate(s_hour, w_hour, flat, c) if np.isfinite(c) else flat
    out = r_map.copy()
    hour = np.flatnonzero(unseen) % bins_per_day
    out[unseen] = hourly[hour] / rho_map  # an hour nobody saw: shrunk_rate's flat rate
    return out


def unseen_bins(w_map: F64, bins_per_day: int) -> npt.NDArray[np.bool_] | None:
    """The profile bins of a kind of day no window observed (``w_map``: the map's windows
    per bin), bool[H]; None when there are none, or the profile has one kind of day."""
    kinds = w_map.size // bins_per_day
    unseen = w_map <= 0
    if kinds < 2 or w_map.size != kinds * bins_per_day or not unseen.any():
        return None
    return unseen


def by_hour(values: F64, unseen: npt.NDArray[np.bool_] | None, bins_per_day: int) -> F64:
    """``values[..., H]`` (sums per profile bin: detections, windows) with each ``unseen``
    bin replaced by the sum over the kinds of day at the same hour: a kind of day no window
    observed takes the hours of the kinds that were (:func:`_unseen_kinds`, at every level).
    The other bins are returned as they are (the same array when there is nothing to do)."""
    if unseen is None:
        return values
    kinds = values.shape[-1] // bins_per_day
    lead = values.shape[:-1]
    hours = np.asarray(values, np.float64).reshape(*lead, kinds, bins_per_day).sum(axis=-2)
    out: F64 = np.array(values, dtype=np.float64)
    out[..., unseen] = hours[..., np.flatnonzero(unseen) % bins_per_day]
    return out


def stored_window_chi2(arrays: Mapping[str, np.ndarray], prefix: str) -> F64:
    """The stored sums (zeros for a map written before they were: φ = 1);
    :class:`MapCorruptError` when they are not two finite non-negative numbers."""
    if prefix + MEMBER not in arrays:
        return np.zeros(2)
    value = np.asarray(arrays[prefix + MEMBER])
    if value.shape != (2,) or value.dtype.kind != "f":
        raise MapCorruptError(f"{prefix}{MEMBER} must be two real numbers")
    if not np.all(np.isfinite(value)) or np.any(value < 0):
        raise MapCorruptError(f"{prefix}{MEMBER} holds non-finite or negative values")
    out: F64 = value.astype(np.float64)
    return out
