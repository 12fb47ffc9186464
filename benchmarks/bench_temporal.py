"""Temporal model speed: learning and prediction throughput, 10^3..10^6 entries.

The temporal model (``aion_cli.engine.temporal``) models, per entry and value bin (V = B + 1:
the B direction bins and "no heading"), the expected detections per observed window. A day of
closed windows is *learned* by scoring it against the model of the earlier days (every enabled
flow and direction family) and then absorbing it into the accumulators
(``temporal.model.learn``, what a build does at each local midnight).

* **updates** = (entry·value-bin, window) elements learned per second: a fixed sensor observes
  every entry in every window, so a day of W = 144 ten-minute windows holds R·V·W of them,
  whether the entry had detections (a count to add) or not (an observed zero, which the
  scores and rates account for in closed form). Counts are drawn for a realistic fraction of
  the (entry, window) pairs (``COUNT_FRACTION`` = 20 % on weekdays, following each entry's
  daily rhythm, half as busy at weekends; Poisson counts spread over a dominant walking
  direction, its opposite, the other bins and "no heading"). Timed: ``learn`` of ``days``
  days (default 2) of ``DayWindows`` on a state with ``HISTORY_DAYS`` of history, and the
  absorption alone (``temporal.absorption.absorb``: observation and count accumulators, no
  scoring) on an empty state whose rows were written once before (``first_touch_s``, timed
  apart: on this VM the first write to a fresh page costs ~40 µs, and an entry's accumulators
  are ~8 KB, so an absorption into never-touched rows measures page faults, not the model).
* **vs loop**: ratio to a plain per-entry Python loop doing the same absorption (for each entry,
  for each of its count pairs: K complex exponentials e^{iω_k t}, then every nonzero value
  bin's ``cnt_fourier`` and ``cnt_profile``; the fixed sensor's windows once into the global
  block), run in the same process on ``LOOP_ENTRIES`` entries and extrapolated per entry, as
  the old FreMEn benchmark did. The loop's accumulators are checked against the vectorised
  absorption's (``loop_max_abs_error``). ``learn`` also scores the day, which the loop does
  not, so ``learn_vs_loop`` understates the ratio of equal work (``absorb_vs_loop``).
* **predictions** = entries × times per second of ``Predictor.at`` (each entry's chosen flow
  and direction families, reconciled totals), at ``TIMES`` hourly times of the next day; the
  preparation (``Predictor.of``: pooling, every family's parts, the family choice) is timed
  separately. ``predict_vs_loop``: ratio to a per-entry Python loop evaluating the chosen flow
  family only (static, shape, profile or FreMEn from the forecaster's precomputed parts; no
  directions, no reconciliation: the ratio understates equal work).

The history (``HISTORY_DAYS`` = 14 days, so every period of a week or shorter passes the span
gate and the families have day-ahead scores) is learned on ``TEMPLATES`` entries and tiled.
Large sizes are timed on the first ``POPULATION_CAP`` rows of an R-row state (the
population a call learns and pools; the other rows are reserved capacity, never written, so
they stay unbacked by memory — an evenly spaced subset would not: numpy backs large arrays
with 2 MB huge pages, so strided rows would fault in the whole state): a full 10^6-entry state
is ~8 KB per entry of accumulators (~8 GB, plus the forecast's working set of several GB),
more than fits next to other jobs on the shared machine, and ``learn`` of 10^6 entries would
take ~20 min; the per-update cost is per row, so R > cap repeats the cap's measurement in a
larger state (an upper bound on the rate a full map of R entries reaches). Prints a table;
no assertions (speed is measured here, never in timed tests).
Run: ``python -m benchmarks.bench_temporal [--sizes N ..] [--days D]``.
"""

from __future__ import annotations

import argparse
import cmath
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.absorption import absorb
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.model import Predictor, empty_state, learn
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.types import F64, I64
from aion_cli.engine.windows import to_model_seconds, window_centre_ns, window_ns

WINDOWS = 144  # ten-minute windows per day
DAY_S = 86_400
# Monday 2026-11-02 00:00 UTC: day 0 of the history (the timed days follow it)
START_NS = 1_793_577_600 * 10**9
COUNT_FRACTION = 0.2  # (entry, window) pairs with detections on a weekday, on average
TEMPLATES = 64
HISTORY_DAYS = 14
GROUP = 64  # entries per pooling group (a room)
POPULATION_CAP = 100_000
LOOP_ENTRIES = 24
TIMES = 24
ACCUMULATORS = ("cnt_fourier", "cnt_profile", "flow_score", "flow_chi2", "flow_scored",
                 "dir_score", "dir_scored")


@dataclass(frozen=True)
class Traffic:
    """Per template entry: busyness, phase of the daily rhythm, walking direction."""

    level: F64
    phase: F64
    direction: I64

    @classmethod
    def make(cls, bins: int, seed: int = 99) -> Traffic:
        rng = np.random.default_rng(seed)
        return cls(
            rng.uniform(0.5, 1.5, TEMPLATES),
            rng.uniform(0.0, 2 * np.pi, TEMPLATES),
            rng.integers(0, bins, TEMPLATES),
        )

    def value_rates(self, bins: int) -> F64:
        """Expected detections per value bin of a window with detections, per template."""
        v = bins + 1
        rates = np.full((TEMPLATES, v), 0.2 / (bins - 2))
        t = np.arange(TEMPLATES)
        rates[t, self.direction] = 1.5
        rates[t, (self.direction + bins // 2) % bins] = 0.8
        rates[:, bins] = 0.3  # detections without a heading
        return rates


def day_windows(params: TemporalParams, traffic: Traffic, rows: I64, first_day: int, days: int,
                seed: int, start_ns: int = START_NS) -> DayWindows:
    """``days`` days of fixed-sensor windows from day ``first_day`` after ``start_ns`` (a
    midnight) for entries ``rows`` (entry i behaves like template ``rows[i] % TEMPLATES``):
    counts in ~COUNT_FRACTION of the pairs, sorted by entry, then slot."""
    rng = np.random.default_rng(seed)
    delta = window_ns(params.config.window_s)
    first = start_ns // delta + first_day * WINDOWS
    windows = np.arange(first, first + days * WINDOWS, dtype=np.int64)
    centres = window_centre_ns(windows, delta)
    t_day = (centres // 10**9) % DAY_S
    weekend = params.calendar.profile_bin(centres) >= params.calendar.bins_per_day
    template = rows % TEMPLATES
    rhythm = 1.0 + 0.8 * np.cos(2 * np.pi * t_day[None, :] / DAY_S - traffic.phase[template, None])
    p = COUNT_FRACTION * traffic.level[template, None] * rhythm * np.where(weekend, 0.5, 1.0)
    hit = rng.random(p.shape) < np.minimum(p, 1.0)
    entry, slot = np.nonzero(hit)  # row-major: sorted by entry, then slot
    rates = traffic.value_rates(params.bins)[template[entry]]
    counts = rng.poisson(rates).astype(np.float64)
    counts[np.arange(entry.size), traffic.direction[template[entry]]] += 1.0  # >= 1 detection
    empty = np.zeros(0, np.int64)
    return DayWindows(windows, np.ones(windows.size, bool), empty, empty, rows[entry],
                      slot.astype(np.int64), counts)


def history_state(params: TemporalParams, traffic: Traffic, n_rows: int, population: I64,
                  start_ns: int = START_NS) -> TemporalState:
    """A state of ``n_rows`` rows whose ``population`` rows hold HISTORY_DAYS of history from
    ``start_ns`` (a midnight; learned on TEMPLATES entries and tiled)."""
    delta = window_ns(params.config.window_s)
    base = empty_state(params, TEMPLATES)
    t_rows = np.arange(TEMPLATES, dtype=np.int64)
    groups = t_rows // 16
    for day in range(HISTORY_DAYS):
        windows = day_windows(params, traffic, t_rows, day, 1, 1000 + day, start_ns)
        learn(params, base, windows, t_rows, groups, int(groups.max()) + 1, delta)
    state = empty_state(params, n_rows)
    src = population % TEMPLATES
    state.glob = base.glob.take([0])
    state.obs.put(population, base.obs.take(src))
    for name in ACCUMULATORS:
        getattr(state, name)[population] = getattr(base, name)[src]
    state.touch(population)
    return state


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall seconds, process CPU seconds summed over threads) of one call."""
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


# -- the per-entry Python loops (baselines) ------------------------------------------------------
LoopRows = dict[int, tuple[list[list[complex]], list[list[float]]]]


def loop_absorb(params: TemporalParams, windows: DayWindows, entries: list[int],
                delta: int) -> tuple[float, LoopRows, list[complex]]:
    """Absorb the count pairs of ``entries`` one entry at a time, in plain Python; returns
    (seconds, {entry: (cnt_fourier[V][K], cnt_profile[V][H])}, the global Fourier sums)."""
    omega = [float(w) for w in params.omega]
    v, n_prof = params.values, params.n_profile
    centres = window_centre_ns(windows.windows, delta)
    t_s = to_model_seconds(centres).tolist()
    h = params.calendar.profile_bin(centres).tolist()
    fixed = windows.fixed.tolist()
    cnt_entry = windows.cnt_entry
    lo = np.searchsorted(cnt_entry, entries)
    hi = np.searchsorted(cnt_entry, entries, side="right")
    pairs = {e: (windows.cnt_slot[a:b].tolist(), windows.cnt_values[a:b].tolist())
             for e, a, b in zip(entries, lo.tolist(), hi.tolist(), strict=True)}
    out: LoopRows = {}
    t0 = time.perf_counter()
    glob = [0j] * len(omega)
    for s, is_fixed in enumerate(fixed):  # the fixed sensor: once per window, for every entry
        if is_fixed:
            t = t_s[s]
            for k, w in enumerate(omega):
                glob[k] += cmath.exp(1j * w * t)
    for e in entries:
        fourier = [[0j] * len(omega) for _ in range(v)]
        profile = [[0.0] * n_prof for _ in range(v)]
        slots, values = pairs[e]
        for s, counts in zip(slots, values, strict=True):
            t, hb = t_s[s], h[s]
            z = [cmath.exp(1j * w * t) for w in omega]
            for b, n in enumerate(counts):
                if n:
                    row = fourier[b]
                    for k in range(len(omega)):
                        row[k] += n * z[k]
                    profile[b][hb] += n
        out[e] = (fourier, profile)
    return time.perf_counter() - t0, out, glob


def loop_flows(predictor: Predictor, entries: list[int], t_ns: int) -> tuple[float, list[float]]:
    """The chosen flow family of each entry at ``t_ns``, one entry at a time in Python (from
    the forecaster's precomputed parts, read into Python lists first)."""
    fc = predictor.forecaster
    params = predictor.params
    h = int(params.calendar.profile_bin(np.array([t_ns], np.int64))[0])
    t = float(to_model_seconds(np.array([t_ns], np.int64))[0])
    c = params.config.profile_prior
    omega = [float(w) for w in params.omega]
    names = [params.flow[int(f)] for f in predictor.flow_choice[entries]]
    mu = fc.rate_total[entries].tolist()
    e = np.asarray(entries, np.int64)
    at = np.full(e.size, h)
    shape = fc.shape_at(e, at).tolist()
    s_h = fc.profile_total_at(e, at).tolist()
    w_h = fc.profile_windows_at(e, at).tolist()
    coef = fc.coef_total[entries].tolist()
    idx = fc.period_idx[entries].tolist()
    out = []
    t0 = time.perf_counter()
    for i, name in enumerate(names):
        m = mu[i]
        if name == "static":
            lam = m
        elif name == "shape":
            lam = m * shape[i]
        elif name == "profile":
            parent = m * shape[i]
            den = parent * w_h[i] + c
            lam = parent * (s_h[i] + c) / den if den > 0 else 0.0
        else:
            order = int(name.removeprefix("fremen"))
            lam = m + 2.0 * sum((coef[i][j] * cmath.exp(-1j * omega[idx[i][j]] * t)).real
                                for j in range(order))
        out.append(max(lam, 0.0))
    return time.perf_counter() - t0, out


def _loop_error(state: TemporalState, loops: LoopRows, glob: list[complex]) -> float:
    worst = float(np.max(np.abs(state.glob.fourier[0] - np.asarray(glob))))
    for e, (fourier, profile) in loops.items():
        worst = max(worst, float(np.max(np.abs(state.cnt_fourier[e] - np.asarray(fourier)))),
                    float(np.max(np.abs(state.cnt_profile[e] - np.asarray(profile)))))
    return worst


def _absorb_and_loop(
    params: TemporalParams, size: int, population: I64, data: DayWindows
) -> tuple[float, float, float, float, float, list[int]]:
    """Seconds to write the population's rows of an empty R-row state once (first touch), the
    absorption alone into them (wall, CPU seconds), and the per-entry loop on LOOP_ENTRIES
    entries (seconds, max |difference| of their accumulators, the entries)."""
    delta = window_ns(params.config.window_s)
    fresh = empty_state(params, size)

    def touch() -> None:
        fresh.obs.zero(population)
        for name in ACCUMULATORS:
            getattr(fresh, name)[population] = 0.0

    touch_s, _ = _timed(touch)
    wall, cpu = _timed(lambda: absorb(params, fresh, data, delta))
    loop_rows = np.unique(data.cnt_entry)[:LOOP_ENTRIES].tolist()
    loop_s, loops, glob = loop_absorb(params, data, loop_rows, delta)
    return touch_s, wall, cpu, loop_s, _loop_error(fresh, loops, glob), loop_rows


# -- one size -----------------------------------------------------------------------------------
def measure(size: int, days: int = 2, config: ModelConfig | None = None) -> dict[str, Any]:
    """Learning, absorption, loop and prediction rates for one size (per wall second and per
    CPU second: the machine is shared, so wall rates understate an idle machine)."""
    params = TemporalParams.from_config(config or ModelConfig())
    delta = window_ns(params.config.window_s)
    traffic = Traffic.make(params.bins)
    n_pop = min(size, POPULATION_CAP)
    population = np.arange(n_pop, dtype=np.int64)
    groups = np.arange(n_pop, dtype=np.int64) // GROUP
    n_groups = int(groups.max()) + 1
    data = day_windows(params, traffic, population, HISTORY_DAYS, days, seed=7)
    updates = n_pop * params.values * data.windows.size

    touch_s, abs_wall, abs_cpu, loop_s, loop_error, loop_rows = _absorb_and_loop(
        params, size, population, data
    )
    loop_rate = len(loop_rows) * params.values * data.windows.size / loop_s

    state = history_state(params, traffic, size, population)
    learn_wall, learn_cpu = _timed(
        lambda: learn(params, state, data, population, groups, n_groups, delta)
    )

    prep_wall, predictor = _timed_value(
        lambda: Predictor.of(params, state, population, groups, n_groups)
    )
    next_day = START_NS + (HISTORY_DAYS + days) * DAY_S * 10**9
    times = [next_day + (k * 3600 + 1800) * 10**9 for k in range(TIMES)]

    def predict_all() -> None:
        for t in times:
            predictor.at(t)

    pred_wall, pred_cpu = _timed(predict_all)
    n_loop = min(n_pop, 2000)
    loop_entries = list(range(n_loop))
    probe = times[TIMES // 2]
    loop_pred_s, loop_vals = loop_flows(predictor, loop_entries, probe)
    fc = predictor.forecaster
    e = np.asarray(loop_entries, np.int64)
    h = params.calendar.profile_bin(np.full(e.size, probe, np.int64))
    t_s = to_model_seconds(np.full(e.size, probe, np.int64))
    vector = np.zeros(e.size)
    for f, name in enumerate(params.flow):
        pick = np.flatnonzero(predictor.flow_choice[e] == f)
        if pick.size:
            vector[pick] = np.maximum(fc.flow(name, e[pick], h[pick], t_s[pick]), 0.0)
    loop_pred_error = float(np.max(np.abs(vector - np.asarray(loop_vals))))
    loop_pred_rate = n_loop / loop_pred_s
    n_pred = n_pop * TIMES
    flow_names = np.asarray(params.flow)[predictor.flow_choice]
    dir_names = np.asarray(params.direction)[predictor.direction_choice]
    return {
        "entries": size,
        "timed_entries": int(n_pop),
        "days": days,
        "windows": int(data.windows.size),
        "values": params.values,
        "periods": params.n_periods,
        "count_pairs": int(data.cnt_entry.size),
        "count_fraction": data.cnt_entry.size / (n_pop * data.windows.size),
        "updates": int(updates),
        "learn_s": learn_wall,
        "updates_per_s": updates / learn_wall,
        "updates_per_cpu_s": updates / learn_cpu,
        "first_touch_s": touch_s,
        "absorb_s": abs_wall,
        "absorb_updates_per_s": updates / abs_wall,
        "absorb_updates_per_cpu_s": updates / abs_cpu,
        "loop_updates_per_s": loop_rate,
        "loop_entries": len(loop_rows),
        "loop_max_abs_error": loop_error,
        "learn_vs_loop": updates / learn_wall / loop_rate,
        "absorb_vs_loop": updates / abs_wall / loop_rate,
        "predictor_of_s": prep_wall,
        "predict_times": TIMES,
        "predict_s": pred_wall,
        "predictions_per_s": n_pred / pred_wall,
        "predictions_per_cpu_s": n_pred / pred_cpu,
        "loop_predictions_per_s": loop_pred_rate,
        "loop_predict_max_abs_error": loop_pred_error,
        "predict_vs_loop": n_pred / pred_wall / loop_pred_rate,
        "flow_families": _tally(flow_names),
        "direction_families": _tally(dir_names),
        "reconciled": bool(predictor.reconcile),
    }


def _timed_value(fn: Callable[[], Any]) -> tuple[float, Any]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _tally(names: np.ndarray) -> dict[str, int]:
    values, counts = np.unique(names, return_counts=True)
    return {str(v): int(c) for v, c in zip(values, counts, strict=True)}


def run(
    sizes: tuple[int, ...] = (10**3, 10**4, 10**5, 10**6), days: int = 2
) -> list[dict[str, Any]]:
    """Measure every size; one dict per size (see the module docstring for the units)."""
    return [measure(size, days) for size in sizes]


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10**3, 10**4, 10**5, 10**6])
    parser.add_argument("--days", type=int, default=2, help="days learned per timed call")
    args = parser.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    params = TemporalParams.from_config(ModelConfig())
    print(
        f"temporal model: V = {params.values} value bins, {params.n_periods} periods, "
        f"{len(params.flow)} flow / {len(params.direction)} direction families, H = "
        f"{params.n_profile}; {args.days} day(s) x {WINDOWS} windows per learn call, "
        f"{TIMES} prediction times; cpus={os.cpu_count()}, load average {load:.1f}"
    )
    print("rates per wall second (per CPU second in brackets); vs loop = rate / loop rate")
    rows = run(tuple(args.sizes), args.days)
    print(
        f"{'entries':>9} {'timed':>7} {'learn updates/s':>21} {'vs loop':>7} "
        f"{'absorb updates/s':>21} {'vs loop':>7} {'Predictor.of':>12} "
        f"{'predictions/s':>21} {'vs loop':>7}"
    )
    for r in rows:
        print(
            f"{r['entries']:>9,} {r['timed_entries']:>7,} "
            f"{r['updates_per_s']:>9.3g} ({r['updates_per_cpu_s']:>9.3g}) "
            f"{r['learn_vs_loop']:>6.0f}x "
            f"{r['absorb_updates_per_s']:>9.3g} ({r['absorb_updates_per_cpu_s']:>9.3g}) "
            f"{r['absorb_vs_loop']:>6.0f}x {r['predictor_of_s']:>10.3f} s "
            f"{r['predictions_per_s']:>9.3g} ({r['predictions_per_cpu_s']:>9.3g}) "
            f"{r['predict_vs_loop']:>6.0f}x"
        )
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    last = rows[-1]
    print(
        f"load average at the end {load:.1f}; per-entry Python loops: "
        f"{last['loop_updates_per_s']:.3g} absorption updates/s "
        f"(max |error| {last['loop_max_abs_error']:.2g}), "
        f"{last['loop_predictions_per_s']:.3g} flow predictions/s; counts in "
        f"{last['count_fraction']:.1%} of the (entry, window) pairs; chosen flow families "
        f"{last['flow_families']}, direction families {last['direction_families']}"
    )


if __name__ == "__main__":
    main()
