"""Planning and map-file speed: plan() on a 10^5-node grid, map write/read throughput, and
the first query of a map of 10^5 entries whose counts are all pending.

Prints a table; no assertions (DESIGN.md §8: speed is measured here, never by timed tests).
Ratios are against baselines run in the same process: scipy's C Dijkstra on the same static
costs (the planner's pure-Python A* loop is expected to be slower by a constant factor) and a
raw ``np.save``/``np.load`` of the same arrays into memory (the map file's overhead: zip,
sha256, checks). Run: ``python -m benchmarks.bench_queries_plan``.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.nav_graph import NavGraph
from aion_cli.engine.planning import NodeCosts, arc_costs, plan
from aion_cli.formats.mapfile import read_map, write_map

GRID_SIDE = 317  # 317^2 = 100 489 nodes


def _best_of(fn: Callable[[], Any], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` runs (seconds)."""
    return min(_timed(fn) for _ in range(repeat))


def _timed(fn: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _cpu_of(fn: Callable[[], Any]) -> float:
    """Process CPU time of one run: less sensitive than wall time to other loads."""
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def grid_graph(side: int = GRID_SIDE, spacing: float = 1.0) -> NavGraph:
    """A 4-connected ``side`` x ``side`` grid of places, ``spacing`` metres apart."""
    ii, jj = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    xyz = np.c_[ii.ravel() * spacing, jj.ravel() * spacing, np.zeros(side * side)]
    idx = np.arange(side * side).reshape(side, side)
    edges = np.r_[
        np.c_[idx[:-1].ravel(), idx[1:].ravel()], np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]
    ]
    ids = (np.uint64(ord("p")) << np.uint64(56)) + np.arange(side * side, dtype=np.uint64)
    return NavGraph.build(ids, xyz, edges)


def random_costs(m: int) -> Callable[[float], NodeCosts]:
    """Deterministic per-time random dynamics (a stand-in for FreMEn predictions)."""

    def cost(t_s: float) -> NodeCosts:
        rng = np.random.default_rng(int(t_s) % 2**31)
        return NodeCosts(
            rng.random(m), rng.random(m) * 20, rng.uniform(-np.pi, np.pi, m), rng.random(m)
        )

    return cost


def bench_plan() -> list[dict[str, Any]]:
    config = ModelConfig()
    t0 = time.perf_counter()
    graph = grid_graph()
    _ = graph.arcs
    build_s = time.perf_counter() - t0
    m = len(graph)
    start, goal = int(graph.ids[0]), int(graph.ids[-1])
    fn = random_costs(m)
    temporal = _best_of(lambda: plan(graph, start, goal, 0.0, 1.0, fn, config))
    distance = _best_of(lambda: plan(graph, start, goal, 0.0, 1.0, None, config))
    static = fn(0.0)
    weights = arc_costs(graph, static, config)
    matrix = csr_matrix((weights, (graph.arcs.src, graph.arcs.dst)), shape=(m, m))
    scipy_s = _best_of(lambda: dijkstra(matrix, directed=True, indices=0))
    result = plan(graph, start, goal, 0.0, 1.0, fn, config)
    rng = np.random.default_rng(1)
    pairs = rng.integers(0, m, size=(10, 2))
    t0 = time.perf_counter()
    expanded = 0
    for a, b in pairs:
        expanded += plan(graph, int(graph.ids[a]), int(graph.ids[b]), 0.0, 1.0, fn, config).expanded
    random_s = (time.perf_counter() - t0) / len(pairs)
    return [
        {"name": "navgraph build (10^5 nodes)", "seconds": build_s, "nodes": m},
        {
            "name": "plan temporal corner-corner",
            "seconds": temporal,
            "cpu_s": _cpu_of(lambda: plan(graph, start, goal, 0.0, 1.0, fn, config)),
            "expanded": result.expanded,
            "vs_scipy_dijkstra": temporal / scipy_s,
        },
        {
            "name": "plan temporal random pairs (mean)",
            "seconds": random_s,
            "mean_expanded": expanded / len(pairs),
        },
        {
            "name": "plan distance-only corner-corner",
            "seconds": distance,
            "cpu_s": _cpu_of(lambda: plan(graph, start, goal, 0.0, 1.0, None, config)),
        },
        {"name": "scipy dijkstra baseline (static)", "seconds": scipy_s},
    ]


def bench_mapfile(n_rows: int = 200_000, bins: int = 8) -> list[dict[str, Any]]:
    rng = np.random.default_rng(0)
    arrays = {
        "entries/xyz": rng.normal(size=(n_rows, 3)),
        "entries/counts": rng.poisson(2.0, size=(n_rows, bins)).astype(np.float64),
        "fremen/sum_se": rng.normal(size=(n_rows, 31)) + 1j * rng.normal(size=(n_rows, 31)),
        "entries/key": rng.integers(0, 2**40, size=n_rows, dtype=np.int64),
    }
    total = sum(a.nbytes for a in arrays.values())

    def raw_roundtrip() -> None:
        import io

        for arr in arrays.values():
            buf = io.BytesIO()
            np.save(buf, arr, allow_pickle=False)
            buf.seek(0)
            np.load(buf, allow_pickle=False)

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.aion"
        write_s = _best_of(lambda: write_map(path, arrays, {"bench": True}))
        read_s = _best_of(lambda: read_map(path))
        read_cpu = _cpu_of(lambda: read_map(path))
        raw_s = _best_of(raw_roundtrip)
        size = path.stat().st_size
    return [
        {
            "name": "map write",
            "seconds": write_s,
            "mb": total / 1e6,
            "mb_per_s": total / 1e6 / write_s,
        },
        {
            "name": "map read",
            "seconds": read_s,
            "cpu_s": read_cpu,
            "mb": total / 1e6,
            "mb_per_s": total / 1e6 / read_s,
        },
        {
            "name": "raw np.save+np.load baseline",
            "seconds": raw_s,
            "map_rw_vs_raw": (write_s + read_s) / raw_s,
            "file_mb": size / 1e6,
        },
    ]


def bench_first_query(detections: int = 120_000, side: float = 400.0) -> list[dict[str, Any]]:
    """The first query of a big sparse map whose counts are all pending: one hour of a fixed
    sensor's detections spread over ``side`` x ``side`` m (~one entry each), the day left
    open, saved, read back and asked one prediction. The query absorbs the pending day into
    the state read from the file, every accumulator row written for the first time: most of
    its wall time is the kernel backing those pages (wall well above CPU on this VM). 120k
    detections: 8.9 s wall (3.4 s CPU) when each write backed a 2 MB huge page, 3.1 s
    (1.1 s CPU) with 4 KB pages written unread (``aion_cli.engine.zeros``)."""
    import aion_cli as aion
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    t0 = 1_767_607_200 * 10**9  # 2026-01-05 10:00 UTC
    rng = np.random.default_rng(0)
    t = t0 + np.sort(rng.integers(0, 3600 * 10**9, detections))
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(int(t[0]), int(t[-1]))
    xyz = np.c_[rng.uniform(0, side, detections), rng.uniform(0, side, detections)]
    xyz = np.c_[xyz, np.zeros(detections)]
    heading = rng.uniform(-3, 3, detections)
    mapper.add_detections(DetectionBatch.from_arrays(t, xyz, heading, np.ones(detections)))
    with tempfile.TemporaryDirectory() as tmp:
        path = aion.Map.from_state(mapper.state, timezone="UTC").save(Path(tmp) / "sparse.aion")
        loaded = aion.Map.load(path)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        loaded.predict("2026-01-05 10:30", tz="UTC", top=10)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        entries = len(loaded.state.entries.live_rows())
    return [
        {
            "name": "first query of a sparse map",
            "seconds": wall,
            "cpu_s": cpu,
            "entries": entries,
            "us_per_entry": wall / entries * 1e6,
        }
    ]


def run() -> list[dict[str, Any]]:
    """Every measurement as a list of dicts (``name``, ``seconds`` and extras)."""
    return bench_plan() + bench_mapfile() + bench_first_query()


def main() -> None:
    for row in run():
        extras = ", ".join(
            f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
            for k, v in row.items()
            if k not in ("name", "seconds")
        )
        print(f"{row['name']:<36} {row['seconds'] * 1e3:9.1f} ms  {extras}")


if __name__ == "__main__":
    main()
