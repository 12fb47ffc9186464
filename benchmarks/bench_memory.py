"""Memory: aion (Mapper + MapState after ingesting) against a dense STeF-style grid.

Environments (people walk only along corridors, ``benchmarks.common.corridor_points``):

* **campus**: 1 km x 1 km, corridors 3 m wide every 100 m along x and y (22 corridors, ~6 % of
  the area), one floor;
* **building**: 5 floors 4 m apart, 100 m x 100 m each, corridors 3 m wide every 20 m.

aion is measured in a fresh subprocess (``common.peak_rss``): a Mapper at the default config
(δ = 0.5 m, B = 8, 31 periods, orders 0..4) ingests the detections in batches of 10^5 over three
10-minute windows (window closes with FreMEn updates included), with a places graph along the
corridor centre lines (a node every 2 m, re-published every 5 minutes so cells bind to stable
nodes) and, for comparison, without a graph (cells only; for the campus only with
``run(campus_cells_only=True)``: it is the slowest and largest run). Reported: the child's
peak RSS above its post-import baseline, the retained state (bytes of
``MapState.to_arrays()``), and the map file (``formats.mapfile.write_map``).

The dense grid (``aion_cli.evaluation.grid.GridMoD``) at the same 0.5 m resolution holds one
FreMEn state per cell and bin for every cell of the bounding box. For the campus that is
~4·10^6 cells x 8 bins x ~1 KB ≈ 34 GB, more than this machine's RAM, so it is computed
analytically: cells of ``GridSpec.covering`` x ``GridMoD.stored_bytes()`` per cell (taken from a
small instance). The analytic figure is checked against a real dense grid of one building floor
fitted on one window in a subprocess (its peak RSS). The building's dense grid is one 2-D grid
per floor (the cheapest dense layout; a 3-D voxel grid over the height would be ~8x larger).
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from benchmarks.common import WORK, corridor_nodes, corridor_points, peak_rss

ENVIRONMENTS: dict[str, dict[str, Any]] = {
    "campus": {"extent": 1000.0, "spacing": 100.0, "floors": 1},
    "building": {"extent": 100.0, "spacing": 20.0, "floors": 5},
}
T0_NS = 1_700_000_400 * 10**9
WINDOW_NS = 600 * 10**9
WINDOWS = 3
BATCH = 100_000


def aion_child(env: str, detections: int, graph: bool, write: bool = True) -> dict[str, Any]:
    """(Runs in the child.) Ingest ``detections`` on ``env`` and report sizes."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Layer

    p = ENVIRONMENTS[env]
    config = ModelConfig()
    mapper = Mapper(config)
    span = WINDOWS * WINDOW_NS
    mapper.set_fixed_sensor(T0_NS, T0_NS + span)
    snapshot = None
    if graph:
        xyz, edges = corridor_nodes(p["extent"], p["spacing"], 2.0, p["floors"])
        ids = (np.uint64(ord("p")) << np.uint64(56)) + np.arange(len(xyz), dtype=np.uint64)
        snapshot = GraphSnapshot(T0_NS, Layer(ids, xyz, np.zeros(len(xyz), np.uint64)), edges)
    rng = np.random.default_rng(11)
    t_all = np.sort(rng.integers(0, span, detections)) + T0_NS
    next_graph = T0_NS
    t0 = time.perf_counter()
    for a in range(0, detections, BATCH):
        t = t_all[a : a + BATCH]
        while snapshot is not None and next_graph <= int(t[0]):
            mapper.add_graph(GraphSnapshot(next_graph, snapshot.places, snapshot.edges))
            next_graph += 300 * 10**9
        xyz, heading = corridor_points(rng, len(t), p["extent"], p["spacing"], 3.0, p["floors"])
        mapper.add_detections(DetectionBatch(t, xyz, heading, np.full(len(t), 1.2),
                                             np.full(len(t), -1, np.int64)))
    mapper.advance(T0_NS + span)
    ingest_s = time.perf_counter() - t0
    del t_all
    st = mapper.state
    arrays, meta = st.to_arrays(lazy=True)
    out: dict[str, Any] = {
        "env": env,
        "graph": graph,
        "detections": detections,
        "entries_cells": len(st.entries.cell_rows()),
        "entries_nodes": len(st.entries.node_rows()),
        "bound_cells": len(st.redirects),
        "state_bytes": int(sum(a.nbytes for a in arrays.values())),
        "ingest_s": ingest_s,
    }
    if write:
        from aion_cli.formats.mapfile import write_map

        path = WORK / f"memory_{env}_{'graph' if graph else 'cells'}_{os.getpid()}.aion"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_map(path, arrays, {"state": meta})
        out["map_file_bytes"] = path.stat().st_size
        path.unlink()
    return out


def dense_child(extent: float, spacing: float, detections: int) -> dict[str, Any]:
    """(Runs in the child.) A real dense GridMoD over one ``extent`` square floor, fitted on
    one window of corridor detections (every state row written, so every page is resident)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.evaluation.grid import GridMoD, GridSpec

    config = ModelConfig()
    rng = np.random.default_rng(5)
    xyz, heading = corridor_points(rng, detections, extent, spacing)
    spec = GridSpec.covering(xyz[:, :2], config.cell_size)
    grid = GridMoD(spec, config)
    t = np.sort(rng.integers(0, WINDOW_NS - 1, detections)) + T0_NS
    grid.fit(DetectionBatch(t, xyz, heading, np.full(detections, 1.2),
                            np.full(detections, -1, np.int64)), T0_NS, T0_NS + WINDOW_NS)
    return {"cells": spec.n_cells, "stored_bytes": grid.stored_bytes()}


def dense_bytes_per_cell() -> float:
    """``GridMoD.stored_bytes()`` per cell (FreMEn state of B rows + counts), from a small grid."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.evaluation.grid import GridMoD, GridSpec

    grid = GridMoD(GridSpec((0.0, 0.0), 0.5, 10, 10), ModelConfig())
    return grid.stored_bytes() / grid.spec.n_cells


def dense_cells(env: str) -> int:
    """Cells of the dense grid(s) covering ``env`` at 0.5 m (one 2-D grid per floor)."""
    from aion_cli.evaluation.grid import GridSpec

    p = ENVIRONMENTS[env]
    corners = np.array([[-1.5, -1.5], [p["extent"] + 1.5, p["extent"] + 1.5]])
    return GridSpec.covering(corners, 0.5).n_cells * int(p["floors"])


def _dense_check(scale: float, per_cell: float) -> dict[str, Any]:
    """A real dense grid over one building floor in a subprocess: measured bytes per cell
    against the analytic ``per_cell``."""
    check = peak_rss("benchmarks.bench_memory:dense_child", extent=100.0 * min(1.0, scale * 4),
                     spacing=20.0, detections=max(1000, int(200_000 * scale)))
    return {
        "name": "dense grid check (one real floor)",
        "cells": check["cells"],
        "stored_bytes": check["stored_bytes"],
        "peak_above_base_bytes": check["peak_above_base_bytes"],
        "analytic_bytes_per_cell": per_cell,
        "measured_peak_bytes_per_cell": check["peak_above_base_bytes"] / check["cells"],
    }


def run(scale: float = 1.0, envs: tuple[str, ...] = ("campus", "building"),
        graphs: tuple[bool, ...] = (True, False), check_dense: bool = True,
        campus_cells_only: bool = False) -> list[dict[str, Any]]:
    """aion vs dense grid per environment (``scale`` multiplies the detection counts: 10^6 on
    the campus, 5·10^5 in the building; the smoke test narrows ``envs``/``graphs`` and skips
    the real dense-grid check). The campus without a graph (~2.5·10^5 cell entries, ~6 GB
    peak, ~90 s here) runs only with ``campus_cells_only``, to keep ``make bench`` within 15
    minutes."""
    per_cell = dense_bytes_per_cell()
    rows: list[dict[str, Any]] = []
    if check_dense:
        rows.append(_dense_check(scale, per_cell))
    sizes = {"campus": int(1_000_000 * scale), "building": int(500_000 * scale)}
    for env in envs:
        cells = dense_cells(env)
        dense = cells * per_cell
        for graph in graphs:
            if env == "campus" and not graph and not campus_cells_only:
                continue
            a = peak_rss("benchmarks.bench_memory:aion_child", env=env,
                         detections=max(sizes[env], 1000), graph=graph)
            a.update(
                name=f"memory {env} ({'graph' if graph else 'cells only'})",
                dense_cells=cells,
                dense_bytes_analytic=dense,
                dense_fits_in_ram=bool(dense < _ram_bytes()),
                aion_peak_bytes=a["peak_above_base_bytes"],
                ratio_dense_over_aion_peak=dense / max(a["peak_above_base_bytes"], 1),
                ratio_dense_over_aion_state=dense / max(a["state_bytes"], 1),
            )
            rows.append(a)
    return rows


def _ram_bytes() -> int:
    import psutil  # type: ignore[import-untyped]

    return int(psutil.virtual_memory().total)


if __name__ == "__main__":
    for row in run():
        print(row)
