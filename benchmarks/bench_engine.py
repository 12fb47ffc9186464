"""Engine ingest: ``Mapper.add_detections`` throughput (hash, bin, route, accumulate).

No decoding: detections are generated as :class:`DetectionBatch` es beforehand. The map is a
300 m x 300 m campus of corridors (3 m wide every 50 m; ~5·10^4 cell entries at δ = 0.5 m) with
a places graph along the corridor centre lines (a node every 2 m, ~2·10^3 nodes). Before the
timed part, one window of detections creates the cells and a second graph snapshot 60 s later
binds the cells within ``bind_radius`` of a stable node, so routing goes through real
redirects (bound cells -> nodes) as well as live cells, as in a steady-state build.

Two regimes, in batches of 10^5 detections (what the build hands over):

* **one window** (10^6 and 10^7 detections): all timed detections fall into the open window:
  the pure hot path;
* **24 windows** (10^6 detections): the detections span 4 h, so a window closes every ~4·10^4
  detections (bind check, the window's observation and counts recorded into the pending day;
  the 4 h cross midnight UTC, so a day is closed: scored against the model before it and
  absorbed by the temporal model): the real build loop, whose time is dominated by the window
  closes. The pending day left at the end is closed inside the timing too
  (``MapState.close_day``), so no recorded window escapes it.

Baselines in the same process: ``np.bincount`` over the precomputed flat ``row·B + bin``
indices (the accumulation alone, the floor) and a per-detection Python dict loop (floor, bin,
dict lookup of the cell, counter increment) timed on 10^5 detections and extrapolated.

Queries (:func:`run_queries`), on a built map.

The map has ~10^5 entries: one window of detections spread uniformly over a 165 m x 165 m
square (~1.1·10^5 cells of 0.5 m, ~99 % hit) gives the entries; their temporal accumulators
are then given two weeks of 10-minute fixed-sensor history before that window
(``bench_temporal.history_state``: 64 template entries learned day by day, with counts in
~20 % of the windows, tiled), so every period of a week or shorter is admitted and the
families have day-ahead scores, as in a mature map. The map is written with
``formats.mapfile.write_map`` to ``benchmarks/_work``.

Timed (best of k, same process):

* **map load**: ``mapquery.load_map`` (read_map with checksums + ``MapState.from_arrays``),
  ratio to a plain ``np.load`` of the same arrays from an uncompressed ``.npz``;
* **predict, one time**: the first ``engine.query.predict_table`` after loading (it prepares
  the forecasts: the pending day absorbed, ``Predictor.of``), then ``predict_table`` with the
  forecasts prepared (best of k), ratio to the bare model evaluation it contains
  (``Predictor.at``);
* **predict, 100 times**: ``predict_table`` (one time per call: 3 calls timed, extrapolated to
  100), and the batched predictions of every entry at 100 times (``Predictor.pairs``, all
  entries x 10 times per call);
* **plan** on a 10^5-node grid: ``bench_queries_plan.bench_plan`` (ratio to scipy Dijkstra);
* **export** of 10^4 nodes (+ edges) with ``formats.export.export_scene`` (PLY).
"""

from __future__ import annotations

import math
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Layer
from benchmarks.common import WORK, best_of, corridor_nodes, corridor_points

EXTENT, SPACING = 300.0, 50.0
T0_NS = 1_700_000_400 * 10**9  # start of a 10-minute window (UNIX time multiple of 600 s)
BATCH = 100_000
WINDOW_NS = 600 * 10**9


def campus_graph(t_ns: int, extent: float = EXTENT, spacing: float = SPACING) -> GraphSnapshot:
    """The places layer along the corridors (ids ``p0..``) with edges, at log time ``t_ns``."""
    xyz, edges = corridor_nodes(extent, spacing, node_step=2.0)
    ids = (np.uint64(ord("p")) << np.uint64(56)) + np.arange(len(xyz), dtype=np.uint64)
    places = Layer(ids, xyz, np.zeros(len(xyz), np.uint64))
    return GraphSnapshot(int(t_ns), places, edges)


def detections(rng: np.random.Generator, n: int, t0_ns: int, span_ns: int,
               extent: float = EXTENT, spacing: float = SPACING) -> DetectionBatch:
    """``n`` detections on the corridors, times sorted over ``[t0, t0 + span)``."""
    xyz, heading = corridor_points(rng, n, extent, spacing)
    t = np.sort(rng.integers(0, max(span_ns, 1), n)) + t0_ns
    speed = rng.normal(1.2, 0.2, n)
    return DetectionBatch(t.astype(np.int64), xyz, heading, speed, np.full(n, -1, np.int64))


def warm_mapper(config: ModelConfig, extent: float = EXTENT, spacing: float = SPACING,
                warm: int = 300_000, graph: bool = True) -> Mapper:
    """A mapper after one window of detections and (with ``graph``) a bind of the cells near
    stable nodes; the open window is the next one."""
    rng = np.random.default_rng(7)
    mapper = Mapper(config)
    mapper.set_fixed_sensor(T0_NS - WINDOW_NS, T0_NS + 400 * WINDOW_NS)
    if graph:
        mapper.add_graph(campus_graph(T0_NS - WINDOW_NS, extent, spacing))
    mapper.add_detections(detections(rng, warm, T0_NS - WINDOW_NS, WINDOW_NS - 10**9, extent,
                                     spacing))
    if graph:
        mapper.add_graph(campus_graph(T0_NS - WINDOW_NS + 60 * 10**9, extent, spacing))
    mapper.advance(T0_NS)
    mapper.state.close_day()  # the warm-up window's day is learned outside the timing
    return mapper


def batches(n: int, windows: int, seed: int = 1) -> list[DetectionBatch]:
    """``n`` detections from T0 over ``windows`` windows, split into time-ordered batches."""
    rng = np.random.default_rng(seed)
    span = windows * WINDOW_NS - 10**9
    out = []
    for a in range(0, n, BATCH):
        k = min(BATCH, n - a)
        t0 = T0_NS + span * a // n
        out.append(detections(rng, k, t0, max(span * k // n, 1)))
    return out


def dict_loop_rate(batch: DetectionBatch, cell: float, bins: int) -> float:
    """Detections/s of a per-detection Python loop doing the same job (dict of cells)."""
    table: dict[tuple[int, int, int], list[int]] = {}
    xyz, heading = batch.xyz.tolist(), batch.heading.tolist()
    width = 2 * math.pi / bins
    t0 = time.perf_counter()
    for (x, y, z), h in zip(xyz, heading, strict=True):
        key = (math.floor(x / cell), math.floor(y / cell), math.floor(z / cell))
        counts = table.get(key)
        if counts is None:
            counts = table[key] = [0] * bins
        counts[int((h + math.pi) // width) % bins] += 1
    return len(xyz) / (time.perf_counter() - t0)


def measure(n: int, windows: int, repeats: int) -> dict[str, Any]:
    """Best-of-``repeats`` throughput of feeding ``n`` detections to a warm mapper."""
    config = ModelConfig()
    data = batches(n, windows)
    best = float("inf")
    mapper = None
    for _ in range(max(1, repeats)):
        mapper = warm_mapper(config)
        t0 = time.perf_counter()
        for b in data:
            mapper.add_detections(b)
        mapper.state.close_day()  # the closed windows of the pending day are learned too
        best = min(best, time.perf_counter() - t0)
    assert mapper is not None
    st = mapper.state
    # the floor: one bincount over the same flat indices
    rows = np.concatenate([st.routes.lookup(
        np.asarray(__import__("aion_cli.engine.spatial_hash", fromlist=["x"]).keys_for_points(
            b.xyz, config.cell_size)))[0] for b in data])
    from aion_cli.engine.entries import direction_bins

    bins = np.concatenate([direction_bins(b.heading, config.bins) for b in data])
    flat = np.maximum(rows, 0) * config.bins + bins
    size = int(flat.max()) + 1
    bincount_s = best_of(lambda: np.bincount(flat, minlength=size), repeats)
    loop_rate = dict_loop_rate(data[0].select(np.arange(min(len(data[0]), BATCH))),
                               config.cell_size, config.bins)
    sketch_s = best_of(lambda: sample_all(data), repeats)
    entries = st.entries
    return {
        "detections": n,
        "windows": windows,
        "seconds": best,
        "detections_per_s": n / best,
        "entries_cells": len(entries.cell_rows()),
        "entries_nodes": len(entries.node_rows()),
        "bound_cells": len(st.redirects),
        "bincount_per_s": n / bincount_s,
        "vs_bincount": best / bincount_s,
        "dict_loop_per_s": loop_rate,
        "vs_dict_loop": (n / best) / loop_rate,
        "sketch_seconds": sketch_s,
        "sketch_vs_ingest": sketch_s / best,
    }


def sample_all(data: list[DetectionBatch]) -> Any:
    """What a build adds per batch beside the Mapper: the sample of its detections that tells
    one recording in two log files (``engine.detection_sketch``, the manifest's
    ``recordings``), timed against ``add_detections`` of the same batches."""
    from aion_cli.engine.detection_sketch import DetectionSketch

    sketch = DetectionSketch()
    for b in data:
        sketch.add(b.t_ns, b.xyz)
    return sketch


def run(sizes: tuple[int, ...] = (10**6, 10**7), repeats: int = 2,
        windowed_max: int = 10**6) -> list[dict[str, Any]]:
    """One dict per (size, regime); the 24-window regime only up to ``windowed_max``
    detections (its time is the window closes', not the detections')."""
    out = []
    for n in sizes:
        for windows in (1, 24) if n <= windowed_max else (1,):
            r = measure(n, windows, repeats if n < 10**7 and windows == 1 else 1)
            r["name"] = f"engine ingest {n:.0e} det, {windows} window(s)"
            out.append(r)
    return out


# -- queries on a built map ----------------------------------------------------------------------

def build_state(n_entries: int) -> Any:
    """A MapState with ~``n_entries`` cell entries, two weeks of temporal history before its
    one window (which stays in the pending day, as at the end of a build)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from benchmarks.bench_temporal import HISTORY_DAYS, Traffic, history_state

    config = ModelConfig()
    side = float(np.sqrt(n_entries / 0.99)) * config.cell_size
    n = 5 * n_entries
    rng = np.random.default_rng(3)
    xyz = np.c_[rng.uniform(0, side, (n, 2)), np.full(n, 0.9)]
    t = np.sort(rng.integers(0, 599 * 10**9, n)) + T0_NS
    mapper = Mapper(config)
    mapper.set_fixed_sensor(T0_NS, T0_NS + 600 * 10**9)
    mapper.add_detections(DetectionBatch(t, xyz, rng.uniform(-np.pi, np.pi, n),
                                         np.full(n, 1.2), np.full(n, -1, np.int64)))
    mapper.advance(T0_NS + 600 * 10**9)
    state = mapper.state
    day_ns = 86_400 * 10**9
    start = T0_NS // day_ns * day_ns - HISTORY_DAYS * day_ns  # the 14 days before T0's day
    live = state.entries.live_rows()
    state.temporal = history_state(state.params, Traffic.make(config.bins),
                                   state.temporal.n_rows, live, start)
    return state


def map_loader() -> Any:
    """``load_map`` (moving from ``aion_cli.pipeline`` to ``aion_cli.mapquery``)."""
    import importlib

    for module in ("aion_cli.mapquery", "aion_cli.pipeline"):
        try:
            return importlib.import_module(module).load_map
        except (ImportError, AttributeError):
            continue
    raise ImportError("no load_map in aion_cli.mapquery or aion_cli.pipeline")


def _write(state: Any, path: Path) -> None:
    from aion_cli.formats.mapfile import write_map

    arrays, meta = state.to_arrays()
    path.unlink(missing_ok=True)
    write_map(path, arrays, {"state": meta})


def bench_load_predict(n_entries: int, repeats: int, n_times: int = 100,
                       table_calls: int = 3) -> list[dict[str, Any]]:
    """Map load and whole-map predictions (at one and at ``n_times`` times) on a
    ~``n_entries`` map. ``predict_table`` takes one time per call: it is called
    ``table_calls`` times and the cost of ``n_times`` calls extrapolated (each call does the
    same work), which keeps ``make bench`` within its time budget."""
    from aion_cli.engine.query import predict_table
    from aion_cli.formats.mapfile import read_map

    WORK.mkdir(parents=True, exist_ok=True)
    path = WORK / f"queries_{n_entries}.aion"
    state = build_state(n_entries)
    _write(state, path)
    del state
    arrays, _ = read_map(path)
    npz = path.with_suffix(".npz")
    named: dict[str, Any] = {k.replace("/", "__"): v for k, v in arrays.items()}
    np.savez(npz, **named)
    del arrays
    load_map = map_loader()
    load_s = best_of(lambda: load_map(path), min(repeats, 2))
    npz_s = best_of(lambda: dict(np.load(npz)), 1)
    loaded = load_map(path)
    st = loaded.state
    entries = len(st.entries.live_rows())
    t_ns = T0_NS + 15 * 86400 * 10**9
    t0 = time.perf_counter()
    predict_table(st, t_ns)  # prepares the forecasts (pending day, Predictor.of), cached
    first_s = time.perf_counter() - t0
    table_s = best_of(lambda: predict_table(st, t_ns), repeats)
    rows, predictor = st.predictor()
    bare_s = best_of(lambda: predictor.at(t_ns), repeats)
    times = t_ns + np.arange(n_times, dtype=np.int64) * 600 * 10**9
    calls = min(n_times, table_calls)
    t0 = time.perf_counter()
    for tq in times[:calls].tolist():
        predict_table(st, tq)
    loop100_s = (time.perf_counter() - t0) * n_times / calls  # extrapolated to n_times calls
    n = len(rows)
    everyone = np.arange(n, dtype=np.int64)
    per_call = 10

    def batched() -> None:
        for a in range(0, n_times, per_call):
            chunk = times[a : a + per_call]
            predictor.pairs(np.tile(everyone, chunk.size), np.repeat(chunk, n))

    batch_s = best_of(batched, 1)
    size = path.stat().st_size
    path.unlink()
    npz.unlink()
    return [
        {"name": "map load", "seconds": load_s, "entries": entries, "map_file_bytes": size,
         "vs_npz_load": load_s / npz_s},
        {"name": "first predict_table (prepares forecasts)", "seconds": first_s,
         "entries": entries, "vs_prepared_table": first_s / table_s},
        {"name": "predict_table, 1 time", "seconds": table_s, "entries": entries,
         "vs_bare_predictor": table_s / bare_s, "bare_predictor_s": bare_s},
        {"name": f"predict_table x {n_times} times", "seconds": loop100_s, "entries": entries,
         "per_time_s": loop100_s / n_times, "calls_timed": calls, "extrapolated": calls < n_times},
        {"name": f"batched Predictor.pairs, {n_times} times", "seconds": batch_s,
         "entries": entries, "predictions_per_s": n * n_times / batch_s,
         "vs_table_loop": loop100_s / batch_s},
    ]


def bench_export(n_nodes: int, repeats: int) -> dict[str, Any]:
    """``export_scene`` of ``n_nodes`` nodes with grid edges (PLY) into benchmarks/_work."""
    from aion_cli.formats.export import export_scene

    rng = np.random.default_rng(4)
    side = int(np.ceil(np.sqrt(n_nodes)))
    ii, jj = np.divmod(np.arange(n_nodes), side)
    xyz = np.c_[ii * 1.5, jj * 1.5, np.zeros(n_nodes)]
    nxt = np.flatnonzero(jj[:-1] + 1 == jj[1:])
    edges = np.stack([xyz[nxt], xyz[nxt + 1]], axis=1)
    out = WORK / "export"

    def go() -> None:
        shutil.rmtree(out, ignore_errors=True)
        export_scene(out, xyz, rng.gamma(2.0, 2.0, n_nodes), rng.random(n_nodes),
                     rng.uniform(-np.pi, np.pi, n_nodes), edges_xyz_pairs=edges)

    go()  # open3d import and first-call costs out of the timing
    s = best_of(go, repeats)
    files = sum(p.stat().st_size for p in out.iterdir())
    shutil.rmtree(out, ignore_errors=True)
    return {"name": f"export {n_nodes} nodes (ply)", "seconds": s, "nodes": n_nodes,
            "edges": len(edges), "bytes_written": files}


def run_queries(n_entries: int = 100_000, export_nodes: int = 10_000, plan: bool = True,
                repeats: int = 3, times: int = 100) -> list[dict[str, Any]]:
    """Every query measurement as ``{"name", "seconds", ...}``."""
    rows = bench_load_predict(n_entries, repeats, times)
    if plan:
        from benchmarks.bench_queries_plan import bench_plan

        rows += bench_plan()
    rows.append(bench_export(export_nodes, repeats))
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
