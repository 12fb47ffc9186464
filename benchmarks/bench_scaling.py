"""Scaling: ingest time and peak memory against detections and against entries.

Each point runs in a fresh subprocess (``common.peak_rss``), which reports the ingest wall time
and its own peak resident memory above the post-import baseline, so points do not see each
other's high-water marks.

* **detections** (10^5 .. 10^7): the 300 m campus of ``bench_engine`` (~2.5·10^4 entries and
  ~2·10^3 nodes with bound cells after warm-up), detections fed in batches of 10^5 within one
  window: time should be linear (slope ~1) and memory flat (entries do not grow; batches are
  streamed).
* **entries** (10^3 .. 3·10^5): 10^6 detections uniform over a square sized for that many 0.5 m
  cells, over two windows, so one window close is included, and the pending day it joins is
  closed too (``MapState.close_day``: the temporal model absorbs it; there is no earlier day to
  score it against): memory should be linear in entries (~8 KB each of temporal accumulators:
  V = B + 1 value bins x 31 complex Fourier sums and x 48 profile bins), time ~flat until the
  per-entry work dominates. 10^6 entries would need ~8 GB for the accumulators alone (and ~80 s
  of first-touch page faults on this VM), which does not fit next to the other engineers' jobs
  on this 23 GB machine: the slope is fitted on the measured points.

The log-log slope of each series is fitted with ``np.polyfit``; a PNG with both panels is
written (matplotlib, Agg backend).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import ROOT, peak_rss

PNG = ROOT / "benchmarks" / "scaling.png"
BATCH = 100_000


def detections_child(n: int) -> dict[str, Any]:
    """(Child.) Ingest ``n`` detections into a warm campus mapper within one window."""
    from aion_cli.engine.config import ModelConfig
    from benchmarks.bench_engine import T0_NS, WINDOW_NS, detections, warm_mapper

    mapper = warm_mapper(ModelConfig())
    rng = np.random.default_rng(1)
    span = WINDOW_NS - 10**9
    seconds = 0.0
    for a in range(0, n, BATCH):
        k = min(BATCH, n - a)
        batch = detections(rng, k, T0_NS + span * a // n, max(span * k // n, 1))
        t0 = time.perf_counter()
        mapper.add_detections(batch)
        seconds += time.perf_counter() - t0
    return {"detections": n, "seconds": seconds,
            "entries": len(mapper.state.entries.live_rows())}


def entries_child(entries: int, n: int) -> dict[str, Any]:
    """(Child.) ``n`` detections uniform over ~``entries`` cells, two windows (one close)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from benchmarks.bench_engine import T0_NS, WINDOW_NS

    config = ModelConfig()
    # enough detections per cell that ~every cell is hit: side chosen for `entries` cells
    side = float(np.sqrt(entries)) * config.cell_size
    rng = np.random.default_rng(2)
    mapper = Mapper(config)
    mapper.set_fixed_sensor(T0_NS, T0_NS + 3 * WINDOW_NS)
    t_all = np.sort(rng.integers(0, 2 * WINDOW_NS, n)) + T0_NS
    seconds = 0.0
    for a in range(0, n, BATCH):
        t = t_all[a : a + BATCH]
        xyz = np.c_[rng.uniform(0, side, (len(t), 2)), np.full(len(t), 0.9)]
        batch = DetectionBatch(t, xyz, rng.uniform(-np.pi, np.pi, len(t)), np.full(len(t), 1.2),
                               np.full(len(t), -1, np.int64))
        t0 = time.perf_counter()
        mapper.add_detections(batch)
        seconds += time.perf_counter() - t0
    t0 = time.perf_counter()
    mapper.advance(T0_NS + 2 * WINDOW_NS)
    mapper.state.close_day()  # the pending day holding the closed windows is learned too
    seconds += time.perf_counter() - t0
    return {"entries": len(mapper.state.entries.live_rows()), "detections": n,
            "seconds": seconds}


def slope(x: list[float], y: list[float]) -> float:
    """Least-squares slope of log y against log x (1 = linear)."""
    if len(x) < 2:
        return float("nan")
    return float(np.polyfit(np.log(x), np.log(np.maximum(y, 1e-12)), 1)[0])


def plot(det: list[dict[str, Any]], ent: list[dict[str, Any]], path: Path = PNG) -> Path:
    """Two log-log panels (time and peak memory against detections / entries)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, rows, key, title in ((axes[0], det, "detections", "against detections"),
                                 (axes[1], ent, "entries", "against entries")):
        x = [r[key] for r in rows]
        ax.loglog(x, [r["seconds"] for r in rows], "o-", color="tab:blue", label="ingest time")
        ax.set_xlabel(key)
        ax.set_ylabel("seconds", color="tab:blue")
        ax.grid(True, which="both", alpha=0.3)
        ax2 = ax.twinx()
        mem = [r["peak_above_base_bytes"] / 1e6 for r in rows]
        ax2.loglog(x, mem, "s--", color="tab:red", label="peak memory")
        ax2.set_ylim(min(mem) / 2, max(mem) * 2)  # a flat series must look flat, not noisy
        ax2.set_ylabel("peak RSS above baseline (MB)", color="tab:red")
        ax.set_title(f"{title}: time slope {slope(x, [r['seconds'] for r in rows]):.2f}, "
                     f"memory slope {slope(x, [r['peak_above_base_bytes'] for r in rows]):.2f}",
                     fontsize=9)
    fig.suptitle("aion Mapper ingest scaling (log-log)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run(det_sizes: tuple[int, ...] = (10**5, 10**6, 10**7),
        entry_sizes: tuple[int, ...] = (10**3, 10**4, 10**5, 3 * 10**5),
        entry_detections: int = 10**6, png: Path | None = PNG) -> list[dict[str, Any]]:
    """Both series (one dict per point) plus one summary dict per series with the slopes."""
    det = [peak_rss("benchmarks.bench_scaling:detections_child", n=n) for n in det_sizes]
    ent = [peak_rss("benchmarks.bench_scaling:entries_child", entries=e, n=entry_detections)
           for e in entry_sizes]
    if png is not None:
        plot(det, ent, png)
    out: list[dict[str, Any]] = []
    for series, rows, key in (("detections", det, "detections"), ("entries", ent, "entries")):
        for r in rows:
            out.append({"name": f"scaling {series}", "series": series, **r})
        x = [float(r[key]) for r in rows]
        t_slope = slope(x, [r["seconds"] for r in rows])
        m_slope = slope(x, [float(r["peak_above_base_bytes"]) for r in rows])
        summary: dict[str, Any] = {"name": f"scaling {series} slopes", "series": series,
                                   "time_slope": t_slope, "memory_slope": m_slope,
                                   "points": len(rows)}
        if series == "entries" and len(rows) >= 2:
            # memory at 10^6 entries from the fitted power law
            coef = np.polyfit(np.log(x), np.log([float(r["peak_above_base_bytes"])
                                                 for r in rows]), 1)
            summary["extrapolated_peak_bytes_at_1e6"] = float(np.exp(np.polyval(coef,
                                                                                np.log(1e6))))
        out.append(summary)
    return out


if __name__ == "__main__":
    for row in run():
        print(row)
