"""Are the forecast's spreads calibrated? Coverage of the 10th–90th percentile band.

``aion predict`` gives each place's window count a spread, ``flow_p10`` .. ``flow_p90``: the
quantiles of a negative binomial with the predicted mean and variance φ·mean
(``choice.count_quantiles``). A calibrated spread holds 80 % of held-out counts. Counts are
whole numbers, so the printed band ``p10 ≤ n ≤ p90`` holds *more* than 80 % of them even when
the distribution is exactly right (a mean of 0.05 gives p10 = p90 = 0, which holds 95 % of
counts): the band's share is reported as the user reads it (``inside``, with ``below`` and
``above`` its tails, each at most 10 % when calibrated), and calibration itself is judged by the
randomised PIT (Czado, Gneiting & Held 2009, *Predictive model assessment for count data*):
u = F(n − 1) + V·P(n), V uniform on [0, 1], is uniform on [0, 1] exactly when the forecast
distribution F is the counts' own, so the share of u in [0.1, 0.9] is 0.8. ``pit`` is that
share's expectation over V (no random draw: each count contributes the part of
[F(n − 1), F(n)] inside [0.1, 0.9] over its length), so the figure is the same on every run.

:func:`spread_coverage` reads any counts against any means and variances; :func:`entry_positions`
finds the map place a held-out detection counts toward (as ``aion build`` routes it), so that
``evaluate holdout`` and ``evaluate lincoln`` judge (place, window) counts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.evaluation.metrics import HOUR_NS

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]

LOW, HIGH = 0.1, 0.9
"""The band ``aion predict`` prints: flow_p10 .. flow_p90."""


def spread_coverage(
    counts: npt.ArrayLike, mean: npt.ArrayLike, variance: npt.ArrayLike
) -> dict[str, Any]:
    """How held-out ``counts`` fall in the forecast band of their ``mean`` and ``variance``
    (pairs whose mean is not finite are left out): ``counts`` (how many were judged),
    ``inside`` (the share with p10 ≤ n ≤ p90), ``below`` (n < p10), ``above`` (n > p90) and
    ``pit`` (the share of the randomised PIT in [0.1, 0.9]: 0.8 when calibrated, below when
    the spread is too narrow, above when too wide; see the module docstring). The shares are
    None when no pair is judged."""
    from aion_cli.engine.temporal.choice import count_cdf, count_quantiles

    y = np.asarray(counts, dtype=np.float64)
    mu = np.asarray(mean, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    known = np.isfinite(mu) & np.isfinite(var) & np.isfinite(y)
    y, mu, var = y[known], mu[known], var[known]
    if y.size == 0:
        return {"counts": 0, "inside": None, "below": None, "above": None, "pit": None}
    lo, hi = count_quantiles(mu, var, LOW), count_quantiles(mu, var, HIGH)
    at, before = count_cdf(y, mu, var), count_cdf(y - 1.0, mu, var)
    mass = at - before
    part = np.clip(np.minimum(at, HIGH) - np.maximum(before, LOW), 0.0, None)
    # a count of probability 0 under the forecast (beyond the far tail): its PIT is F(n) = 1
    # or 0, outside the band
    pit = np.divide(part, mass, out=np.zeros_like(part), where=mass > 0)
    return {
        "counts": int(y.size),
        "inside": float(np.mean((y >= lo) & (y <= hi))),
        "below": float(np.mean(y < lo)),
        "above": float(np.mean(y > hi)),
        "pit": float(np.mean(pit)),
    }


def entry_positions(state: MapState, rows: I64, xyz: F64) -> I64:
    """For each detection at ``xyz`` (map frame), the position in ``rows`` (the predictor's
    entries, canonical order) of the map entry ``aion build`` would count it toward: the
    entry its spatial-hash cell routes to. -1 where the map has no such entry (a cell the
    map never saw, a position that cannot be hashed): such detections belong to no
    place's forecast."""
    from aion_cli.engine.spatial_hash import hashable_indices, pack_keys_unchecked

    out = np.full(len(xyz), -1, np.int64)
    if len(xyz) == 0 or rows.size == 0:
        return out
    ijk, _finite, hashable = hashable_indices(np.asarray(xyz, dtype=np.float64),
                                              state.config.cell_size)
    if not hashable.any():
        return out
    found_rows, found = state.routes.lookup(pack_keys_unchecked(ijk[hashable]))
    position = np.full(len(state.entries.kind), -1, np.int64)
    position[rows] = np.arange(rows.size)
    out[np.flatnonzero(hashable)] = np.where(found, position[np.maximum(found_rows, 0)], -1)
    return out


def pair_counts(
    place: I64, window: I64, n_windows: int, detection_place: I64, detection_window: I64
) -> F64:
    """The held-out detections of each (place, window position) pair: detections at
    ``detection_place`` (-1: none) in ``detection_window`` (-1: a window not judged), counted
    toward the pairs ``place``/``window`` list (pairs need not be sorted)."""
    keep = (detection_place >= 0) & (detection_window >= 0)
    key = detection_place[keep] * n_windows + detection_window[keep]
    pair_key = place * n_windows + window
    distinct, tally = np.unique(key, return_counts=True)
    if distinct.size == 0:
        return np.zeros(pair_key.size)
    at = np.minimum(np.searchsorted(distinct, pair_key), distinct.size - 1)
    out: F64 = np.where(distinct[at] == pair_key, tally[at], 0).astype(np.float64)
    return out


def spread_of(
    state: MapState,
    rows: I64,
    xyz: F64,
    detection_window: I64,
    pairs: tuple[I64, I64, int],
    forecast: tuple[F64, F64],
    starts: tuple[I64, I64],
) -> dict[str, dict[str, Any]]:
    """The coverage of the held-out counts by the forecast's band (:func:`spread_coverage`),
    per (place, window) pair and per hour. ``xyz`` and ``detection_window`` (position among
    the windows judged, -1 for none): the held-out detections; ``pairs``: (place position,
    window position, number of windows) of every pair observed; ``forecast``: each pair's
    expected count and its variance (NaN for a place without a forecast: left out);
    ``starts``: the windows' starts, UNIX and on the map's wall clock, whose local hours
    group them as ``metrics.hourly_activity`` does.

    An hour's band is that of the sum of its pairs' counts, mean the sum of their means and
    variance that of a sum of places in each window, as for a room
    (``query.aggregate_table``): the places' variances plus their covariance from how bursty
    the map's window totals are (:func:`~aion_cli.engine.temporal.totals.sum_variance`, the
    window's reference total the sum of its pairs' means: what the test observed then),
    summed over the hour's windows, and the hour's sum widened by how much whole days differ
    in level (``Predictor.level_variance`` times the hour's mean squared: its windows share
    the day's level). Detections at no map place count toward no pair, nor toward an hour."""
    from aion_cli.engine.temporal.totals import sum_variance

    place, window, n_windows = pairs
    expected, variance = forecast
    counts = pair_counts(place, window, n_windows, entry_positions(state, rows, xyz),
                         detection_window)
    judged = np.isfinite(expected) & np.isfinite(variance)
    unix, local = starts
    hour_of = unix - np.mod(local, HOUR_NS)
    _hours, hour = np.unique(hour_of, return_inverse=True)
    hour = hour.reshape(-1)
    n_hours = int(hour.max()) + 1 if hour.size else 0
    w = window[judged]
    per_window: F64 = np.bincount(w, expected[judged], minlength=n_windows).astype(np.float64)
    predictor = state.predictor()[1]
    window_var = sum_variance(expected[judged], variance[judged], w, n_windows, per_window,
                              predictor.phi_total)

    def per_hour(values: F64) -> F64:
        out: F64 = np.bincount(hour, values, minlength=n_hours).astype(np.float64)
        return out

    watched = np.bincount(hour[w], minlength=n_hours) > 0
    hour_mean = per_hour(per_window)
    window_counts: F64 = np.bincount(w, counts[judged], minlength=n_windows).astype(np.float64)
    return {
        "place_windows": spread_coverage(counts, expected, variance),
        "hours": spread_coverage(
            per_hour(window_counts)[watched], hour_mean[watched],
            (per_hour(window_var) + predictor.level_variance * hour_mean * hour_mean)[watched],
        ),
    }


def spread_note(spread: dict[str, dict[str, Any]]) -> str | None:
    """One line saying how the band held the test counts (``evaluate lincoln`` and
    ``holdout`` print it beside their tables); None without a judged pair."""
    pairs, hours = spread.get("place_windows") or {}, spread.get("hours") or {}
    if not pairs.get("counts"):
        return None
    line = (
        f"aion's flow_p10..flow_p90 band held {pairs['inside']:.1%} of the "
        f"{pairs['counts']:,} (place, window) test counts, PIT {pairs['pit']:.3f} in band "
        "(0.8 when calibrated)"
    )
    if hours.get("counts"):
        line += (
            f"; of the {hours['counts']:,} hours' totals, places summed as the map's "
            "window totals vary, "
            f"{hours['inside']:.1%} (PIT {hours['pit']:.3f})"
        )
    return line
