"""FreMEn speed: state-updates/s and state-predictions/s with 31 periods, 10^3..10^6 states.

* **updates** = (row, window) observations absorbed per second by ``FremenModel.update`` with
  the prequential order selection (orders 0..4, every k-th observation of a row scored by the
  row's model frozen at the start of the day, k = ``score_stride``: the config default unless
  ``--stride``), one call per day of 10-minute windows
  (W = 144, every row observed in every window: the dense worst case), as the mapper calls it.
  Large sizes are timed on an evenly spaced subset of the rows of the full-size state (at most
  ``UPDATE_CAP`` observations per call); the per-observation cost does not depend on the rows
  left out. The column "accumulators only" is the same call for a mean-only model (max_order
  0): the two matrix products without the top-M selection and the order errors.
* **predictions** = rows × times per second of ``FremenModel.predict`` (chosen orders, 144
  times), in row blocks of 10^5 so the output fits in memory.
* **vs loop**: ratio to a straightforward per-state Python loop (complex sums per observation,
  sort of the amplitudes once per day, the same stride rule) run in the same process on a few
  rows and extrapolated per state.

States start from two weeks of 10-minute history (every period admitted by the span gate),
built from 64 synthetic activity rows and tiled. Prints a table; no assertions (speed is measured
here, never in timed tests). Run: ``python -m benchmarks.bench_fremen [--stride K] [--sizes N ..]``.
"""

from __future__ import annotations

import argparse
import cmath
import math
import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from aion_cli.engine.config import DAY_S, ModelConfig, default_periods
from aion_cli.engine.fremen import FremenModel, FremenState

WINDOW_S = 600.0
WINDOWS = 144  # one day of 10-minute windows per update call
TIMES = 144  # prediction times per row
UPDATE_CAP = 1_500_000  # observations per timed update call (large sizes: a row subset)
PREDICT_BLOCK = 100_000
TEMPLATES = 64
HISTORY_DAYS = 14


def _activity(rng: np.random.Generator, t: np.ndarray, n_rows: int) -> np.ndarray:
    """Activity-like rows in [0, 1): daily rhythm, row-specific level and phase (the same on
    every call: row i keeps its rhythm from day to day), Poisson noise from ``rng``."""
    rows = np.random.default_rng(99)
    level = rows.uniform(0.2, 3.0, (n_rows, 1))
    phase = rows.uniform(0, 2 * np.pi, (n_rows, 1))
    rate = level * (1 + 0.8 * np.cos(2 * np.pi * t[None, :] / DAY_S - phase))
    return 1.0 - np.exp(-rng.poisson(rate) / 5.0)


def history_state(model: FremenModel, n_rows: int, seed: int = 0) -> tuple[FremenState, float]:
    """A state of ``n_rows`` rows with HISTORY_DAYS of history (tiled from TEMPLATES rows) and
    the time at which the next day starts."""
    rng = np.random.default_rng(seed)
    base = model.empty(TEMPLATES)
    rows = np.arange(TEMPLATES)
    for day in range(HISTORY_DAYS):
        t = day * DAY_S + (np.arange(WINDOWS) + 0.5) * WINDOW_S
        model.update(
            base, rows, t, _activity(rng, t, TEMPLATES), np.ones((TEMPLATES, t.size), bool)
        )
    return base.take(np.arange(n_rows) % TEMPLATES), HISTORY_DAYS * DAY_S


class LoopFremen:
    """The straightforward per-state loop: Python complex numbers, one observation at a time."""

    def __init__(self, model: FremenModel, state: FremenState, row: int) -> None:
        self.periods = model.periods
        self.omega = [2 * math.pi / p for p in model.periods]
        self.span_factor = model.span_factor
        self.max_order = model.max_order
        self.stride = model.score_stride
        self.n = float(state.n[row])
        self.sum_s = float(state.sum_s[row])
        self.se = [complex(x) for x in state.sum_se[row]]
        self.e = [complex(x) for x in state.sum_e[row]]
        self.first = float(state.t_first[row])
        self.last = float(state.t_last[row])
        self.err = [float(x) for x in state.order_err[row]]
        self.err_n = float(state.order_n[row])
        self.rank_period = model.rank_period
        self.frozen_epoch: int | None = None
        self.frozen: tuple[float, list[tuple[float, float, float]]] | None = None

    def _terms(self) -> tuple[float, list[tuple[float, float, float]]]:
        mu = self.sum_s / self.n
        span = self.last - self.first
        terms = []
        for k, w in enumerate(self.omega):
            if span >= self.span_factor * self.periods[k]:
                g = (self.se[k] - mu * self.e[k]) / self.n
                terms.append((abs(g), w, cmath.phase(g)))
        terms.sort(key=lambda x: -x[0])
        return mu, terms

    def predict(self, t: float, order: int) -> float:
        mu, terms = self._terms()
        p = mu + sum(2 * a * math.cos(w * t - ph) for a, w, ph in terms[:order])
        return min(1.0, max(0.0, p))

    def add(self, t: float, s: float) -> None:
        epoch = math.floor(t / self.rank_period)
        if epoch != self.frozen_epoch:  # freeze the model that forecasts this epoch
            self.frozen_epoch = epoch
            self.frozen = self._terms() if self.n > 0 else None
        if self.frozen is not None and self.n % self.stride == 0:  # a scored observation
            mu, terms = self.frozen
            p = mu
            self.err[0] += abs(s - min(1.0, max(0.0, p)))
            for m in range(1, self.max_order + 1):
                if m <= len(terms):
                    a, w, ph = terms[m - 1]
                    p += 2 * a * math.cos(w * t - ph)
                self.err[m] += abs(s - min(1.0, max(0.0, p)))
            self.err_n += 1
        self.n += 1
        self.sum_s += s
        for k, w in enumerate(self.omega):
            z = cmath.exp(1j * w * t)
            self.se[k] += s * z
            self.e[k] += z
        self.first = min(self.first, t)
        self.last = max(self.last, t)


def loop_rates(model: FremenModel, state: FremenState, t_next: float) -> tuple[float, float]:
    """Per-state loop: (updates/s, predictions/s) measured on a few rows."""
    rng = np.random.default_rng(1)
    rows = 6
    t = t_next + (np.arange(WINDOWS) + 0.5) * WINDOW_S
    values = _activity(rng, t, rows)
    loops = [LoopFremen(model, state, r) for r in range(rows)]

    def feed() -> None:
        for i, lp in enumerate(loops):
            for w in range(WINDOWS):
                lp.add(float(t[w]), float(values[i, w]))

    t0 = time.perf_counter()
    feed()
    upd = rows * WINDOWS / (time.perf_counter() - t0)
    orders = model.chosen_order(state)[:rows]

    def ask() -> None:
        for i, lp in enumerate(loops):
            mu, terms = lp._terms()  # once per state, as a loop implementation would
            for tq in t:
                p = mu + sum(2 * a * math.cos(w * tq - ph) for a, w, ph in terms[: orders[i]])
                min(1.0, max(0.0, p))

    t0 = time.perf_counter()
    ask()
    pred = rows * TIMES / (time.perf_counter() - t0)
    return upd, pred


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall seconds, process CPU seconds summed over threads) of one call."""
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


def _accumulator_times(
    mean_only: FremenModel, size: int, t: np.ndarray, rng: np.random.Generator
) -> tuple[float, float]:
    """Times of one mean-only update of every row (accumulator matrix products only)."""
    state = mean_only.empty(size)
    values = _activity(rng, t, size)
    observed = np.ones(values.shape, bool)
    rows = np.arange(size)
    return _timed(lambda: mean_only.update(state, rows, t, values, observed))


def measure(model: FremenModel, size: int) -> dict[str, Any]:
    """Update, accumulator-only update and prediction rates for one size (per wall second and
    per CPU second: the machine is shared, so wall rates understate an idle machine)."""
    mean_only = FremenModel(model.periods, max_order=0)  # the accumulators: stride-independent
    state, t_next = history_state(model, size)
    rng = np.random.default_rng(2)
    t = t_next + (np.arange(WINDOWS) + 0.5) * WINDOW_S
    n_timed = min(size, max(1, UPDATE_CAP // WINDOWS))
    rows = np.linspace(0, size - 1, n_timed).astype(np.int64)
    values = _activity(rng, t, n_timed)
    observed = np.ones(values.shape, bool)
    upd_wall, upd_cpu = _timed(lambda: model.update(state, rows, t, values, observed))

    acc_wall, acc_cpu = _accumulator_times(mean_only, size, t, rng)

    tq = t + DAY_S

    def predict_all() -> None:
        for a in range(0, size, PREDICT_BLOCK):
            model.predict(state, tq, rows=np.arange(a, min(a + PREDICT_BLOCK, size)))

    pred_wall, pred_cpu = _timed(predict_all)
    n_upd, n_pred = n_timed * WINDOWS, size * TIMES
    return {
        "states": size,
        "stride": model.score_stride,
        "timed_rows": n_timed,
        "windows": WINDOWS,
        "updates_per_s": n_upd / upd_wall,
        "updates_per_cpu_s": n_upd / upd_cpu,
        "accumulator_updates_per_s": size * WINDOWS / acc_wall,
        "accumulator_updates_per_cpu_s": size * WINDOWS / acc_cpu,
        "predictions_per_s": n_pred / pred_wall,
        "predictions_per_cpu_s": n_pred / pred_cpu,
        "chosen_orders": np.bincount(model.chosen_order(state), minlength=5).tolist(),
    }


def run(
    sizes: tuple[int, ...] = (10**3, 10**4, 10**5, 10**6), stride: int | None = None
) -> list[dict[str, Any]]:
    """Measure every size; one dict per size (rates in observations or predictions per s,
    ratios to the per-state loop measured once in the same process). ``stride``: the scoring
    stride (default: the config's)."""
    k = ModelConfig().score_stride if stride is None else stride
    model = FremenModel(default_periods(), max_order=4, score_stride=k)
    small, t_next = history_state(model, TEMPLATES)
    loop_upd, loop_pred = loop_rates(model, small, t_next)
    results = []
    for size in sizes:
        r = measure(model, size)
        r["update_vs_loop"] = r["updates_per_s"] / loop_upd
        r["predict_vs_loop"] = r["predictions_per_s"] / loop_pred
        r["loop_updates_per_s"] = loop_upd
        r["loop_predictions_per_s"] = loop_pred
        results.append(r)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stride", type=int, default=None, help="score_stride (config default)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10**3, 10**4, 10**5, 10**6])
    args = parser.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"FreMEn, {len(default_periods())} periods, orders 0..4, {WINDOWS} windows per update "
        f"call, {TIMES} prediction times; cpus={os.cpu_count()}, load average {load:.1f}"
    )
    print("rates per wall second (per CPU second in brackets); vs loop = wall rate / loop rate")
    rows = run(tuple(args.sizes), args.stride)
    print(
        f"{'states':>9} {'timed':>7} {'k':>4} {'updates/s':>21} {'vs loop':>7} "
        f"{'accum-only updates/s':>21} {'predictions/s':>21} {'vs loop':>7}"
    )
    for r in rows:
        print(
            f"{r['states']:>9,} {r['timed_rows']:>7,} {r['stride']:>4} "
            f"{r['updates_per_s']:>9.3g} ({r['updates_per_cpu_s']:>9.3g}) "
            f"{r['update_vs_loop']:>6.0f}x "
            f"{r['accumulator_updates_per_s']:>9.3g} ({r['accumulator_updates_per_cpu_s']:>9.3g}) "
            f"{r['predictions_per_s']:>9.3g} ({r['predictions_per_cpu_s']:>9.3g}) "
            f"{r['predict_vs_loop']:>6.0f}x"
        )
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"load average at the end {load:.1f}; "
        f"per-state Python loop (k = {rows[0]['stride']}): "
        f"{rows[0]['loop_updates_per_s']:.3g} updates/s, "
        f"{rows[0]['loop_predictions_per_s']:.3g} predictions/s; chosen orders 0..4 of the "
        f"timed states: {rows[-1]['chosen_orders']}"
    )


if __name__ == "__main__":
    main()
