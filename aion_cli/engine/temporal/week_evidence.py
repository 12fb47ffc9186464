"""Which calendar the map's data asks for: the hours of the week, or of weekdays and weekends.

The periodic profile's calendar (``ModelConfig.profile``, :mod:`.calendar`) is a config choice
and the entries' accumulators are kept in its bins (48 a day-and-weekend entry, 168 a week's:
3.5 times the bytes). Whether one weekday differs from the others (a Wednesday market) is a
question about the map as a whole, and the map as a whole can afford the week's bins: this
module keeps them, a few kilobytes a map, whatever the configured profile, and judges the two
calendars on them day ahead.

**The sums** (``TemporalState.week_sums``, float64[4, N], N = 7 × the profile's bins a day,
hour of the week, Monday 00:00 first). Each closed day adds, per hour of the week its slots
observed (units > 0, :func:`~aion_cli.engine.temporal.shape_prior.slot_units`): row 0, 1
(the days observed); row 1, Σ T, the detections of every entry; row 2, Σ m, the units
observed. Before the day is added it is scored (row 3): per slot the Poisson log-likelihood of
its total T under m × the map's rate per unit in its bin, once with the week's bins and once
with the day-and-weekend bins (the same sums, pooled over Monday–Friday and Saturday–Sunday),
each a Gamma-Poisson posterior mean (:func:`~aion_cli.engine.temporal.shape_prior.
shrunk_rate`) with c = α·φ pseudo-detections (:func:`~aion_cli.engine.temporal.shape_prior.
prior_strength`, φ the map's burstiness): the day-and-weekend rates shrunk toward the flat
rate, the week's toward the day-and-weekend rate of their hour (an hour of the week not yet
observed takes it: no gain, no loss). Row 3 adds the week's log-likelihood less the other's,
divided by φ (quasi-likelihood: bursty detections carry the information of fewer
independent ones), per hour of the week. All four rows are sums over days, so maps of
disjoint days add them (``build --map``, ``aion merge``), as ``window_chi2`` and
``day_level``: a continued build's are the same to the bit, a merged map's days were each
scored against its own part's earlier days.

**The choice** (:func:`calendar_choice`): ``week`` when every day of the week the map observed
was observed on two days or more and the week's day-ahead gain exceeds ``family_margin`` nats;
``day_weekend`` otherwise. A day never observed (the weekend of a fleet that runs on weekdays)
does not count: its hours take the weekday/weekend rate under both calendars, no gain and no
loss, so a map of weekdays whose Wednesdays differ may choose the week (before stop 70 the
fewest days of all seven were counted, 0 on such a map, which could never choose it). The
day-ahead score is what keeps a one-off busy day from passing for a weekday's rhythm: the
next same weekday forecast with half of that day's excess loses what the first gained. A
map written before the member reads as no evidence (``day_weekend``).

What the choice does (stop 68): it is reported (``aion info``, ``predict --format json``),
and the forecasts keep the configured profile. A map-wide week factor on every entry was
weighed and not taken: on the market scenario the map's Wednesday excess is one place's, and
multiplying the two flat places' forecasts by it would forecast them at 2.7 times their rate
on Wednesday mornings and 0.57 times it on the other weekdays' (docs/EVALUATION.md,
"Generated multi-week rhythms"). ``profile = "week"`` keeps each entry's own week, at 3.5
times its profile bytes; ``aion info`` names it when the data asks for the week. Since stop
69 a ``week`` map's forecasts follow the choice (:mod:`.calendar_view`): where the data does
not ask for the week, its entries' sums are read pooled into weekdays and weekends, as a
``day_weekend`` map of the same logs holds them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from aion_cli.engine.temporal.calendar import Calendar, weekday_of
from aion_cli.engine.temporal.day_level import add_sums as add_map_sums
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.shape_prior import (
    overdispersion,
    prior_strength,
    shrunk_rate,
    slot_units,
)
from aion_cli.engine.types import F64, I64
from aion_cli.engine.windows import EPOCH_NS
from aion_cli.errors import MapCorruptError

MEMBER = "week_sums"
"""The map-file member (after the temporal prefix): float64[4, 7 · bins a day]."""
MIN_DAYS = 2
"""Days each day of the week the map observed must have been observed on before ``week`` may
be chosen (a day never observed is no evidence either way: its hours of the week take the
weekday/weekend rate of their hour)."""
_LOG_FLOOR = 1e-12


def empty_sums(bins_per_day: int) -> F64:
    """The sums of a map without a closed day: zeros, float64[4, 7 · ``bins_per_day``]."""
    return np.zeros((4, 7 * bins_per_day))


def add_sums(a: F64, b: F64) -> F64:
    """The sums of two maps: added; a map's empty sums (read before the member existed:
    shape ``(4, 0)``) take the other's (the day-level sums' rule, one place)."""
    return add_map_sums(a, b, what="week")


def week_bins(calendar: Calendar, h: I64, utc_s: F64) -> I64:
    """The hour-of-the-week bin of slots in profile bin ``h`` (any profile: its bin within
    the day is ``h`` modulo the bins a day) centred at UTC model seconds ``utc_s``
    (``absorption.slot_utc_seconds``): their local weekday from the calendar."""
    centres = np.round(np.asarray(utc_s, np.float64) * 1e9).astype(np.int64) + np.int64(EPOCH_NS)
    weekday = weekday_of(calendar.day(centres))
    out: I64 = np.mod(h, calendar.bins_per_day) + calendar.bins_per_day * weekday
    return out


def rates(sums: F64, phi: float, bins_per_day: int) -> tuple[F64, F64]:
    """The map's rate per unit in each hour of the week under the week's bins and under the
    day-and-weekend bins (spread over the week's), float64[N] each (module docstring)."""
    t, m = sums[1], sums[2]
    weekend = np.arange(t.size) // bins_per_day >= 5
    kind = np.mod(np.arange(t.size), bins_per_day) + bins_per_day * weekend
    t_k: F64 = np.bincount(kind, t, minlength=2 * bins_per_day).astype(np.float64)
    m_k: F64 = np.bincount(kind, m, minlength=2 * bins_per_day).astype(np.float64)
    rho = float(t.sum() / m.sum()) if m.sum() > 0 else 0.0
    flat = np.full(t_k.size, rho)
    c = prior_strength(t_k, m_k, flat, phi)
    day_weekend = (shrunk_rate(t_k, m_k, flat, c) if np.isfinite(c) else flat)[kind]
    c = prior_strength(t, m, day_weekend, phi)
    week = shrunk_rate(t, m, day_weekend, c) if np.isfinite(c) else day_weekend
    return week, day_weekend


def add_day(
    sums: F64,
    day: DayWindows,
    week_bin: I64,
    window_chi2: F64,
    bins_per_day: int,
) -> F64:
    """``sums`` with the day scored against them and added (module docstring); ``week_bin``
    is each slot's hour of the week (:func:`week_bins`), ``window_chi2`` the map's burstiness
    sums before the day (a query's pending day and open window: one day,
    ``absorption.absorb_parts``). A new array (``sums`` may be a map's empty ``(4, 0)``)."""
    n_bins = 7 * bins_per_day
    out = sums.copy() if sums.size else empty_sums(bins_per_day)
    total, units = slot_units(day)
    seen = units > 0
    if not seen.any():
        return out
    t, m, w = total[seen], units[seen], week_bin[seen]
    if out[2].sum() > 0:
        phi = overdispersion(window_chi2)
        week, day_weekend = rates(out, phi, bins_per_day)
        gain = (_log_likelihood(t, m * week[w]) - _log_likelihood(t, m * day_weekend[w])) / phi
        out[3] += np.bincount(w, gain, minlength=n_bins)
    observed = np.bincount(w, minlength=n_bins) > 0
    out[0] += observed
    out[1] += np.bincount(w, t, minlength=n_bins)
    out[2] += np.bincount(w, m, minlength=n_bins)
    return out


def _log_likelihood(count: F64, mean: F64) -> F64:
    """Poisson log-likelihood of each count less its count's log-factorial (the same under
    both calendars)."""
    out: F64 = count * np.log(np.maximum(mean, _LOG_FLOOR)) - mean
    return out


def calendar_choice(sums: F64, margin: float) -> dict[str, Any]:
    """The calendar the data asks for (module docstring): ``calendar`` (``week`` or
    ``day_weekend``), ``gain`` (the week's day-ahead gain in nats, 0 before any score) and
    ``weekday_days`` (the fewest days any day of the week the map observed was observed on:
    a day it never observed, the weekend of a map of weekdays, forecasts with its kind's
    hours under either calendar and weighs neither way)."""
    if sums.size == 0:
        return {"calendar": "day_weekend", "gain": 0.0, "weekday_days": 0}
    per_day = sums.shape[1] // 7
    per_weekday = sums[0].reshape(7, per_day).max(axis=1)
    seen = per_weekday[per_weekday > 0]  # a day never observed takes its kind's hours
    days = int(seen.min()) if seen.size else 0
    gain = float(sums[3].sum())
    week = days >= MIN_DAYS and gain > margin
    return {"calendar": "week" if week else "day_weekend", "gain": gain, "weekday_days": days}


def stored_sums(arrays: Mapping[str, np.ndarray], prefix: str, n_profile: int) -> F64:
    """The stored sums (empty, shape ``(4, 0)``, for a map written before they were or
    without a closed day: no evidence); :class:`MapCorruptError` when they are not
    float64[4, 7 · bins a day] (bins a day: the profile's ``n_profile`` bins over 1, 2 or
    7 kinds of day) of finite numbers, the first three rows non-negative."""
    if prefix + MEMBER not in arrays:
        return np.zeros((4, 0))
    value = np.asarray(arrays[prefix + MEMBER])
    widths = {7 * n_profile // kinds for kinds in (1, 2, 7) if n_profile % kinds == 0}
    if value.ndim != 2 or value.shape[0] != 4 or value.shape[1] not in widths:
        raise MapCorruptError(
            f"{prefix}{MEMBER} must be of shape (4, 7 × the profile's bins a day), "
            f"got {value.shape}"
        )
    if value.dtype.kind != "f":
        raise MapCorruptError(f"{prefix}{MEMBER} must be real numbers, got {value.dtype}")
    if not np.all(np.isfinite(value)) or np.any(value[:3] < 0):
        raise MapCorruptError(f"{prefix}{MEMBER} holds non-finite or negative sums")
    out: F64 = value.astype(np.float64)
    return out


def check_width(sums: F64, bins_per_day: int, prefix: str) -> None:
    """:class:`MapCorruptError` when stored sums (:func:`stored_sums`, which knows the
    profile's bins but not its kinds of day) are not 7 × the config's ``bins_per_day`` wide:
    a day close or merge would add sums of other hours to them (numpy's broadcast error)."""
    if sums.size and sums.shape[1] != 7 * bins_per_day:
        raise MapCorruptError(
            f"{prefix}{MEMBER} must be of shape (4, {7 * bins_per_day}) for the map's "
            f"profile, got {sums.shape}"
        )
