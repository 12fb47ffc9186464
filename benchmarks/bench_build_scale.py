"""Issue 15 at scale: queries on big maps at once, and a build's memory on big logs.

Two of the issue's targets (the other two, build vs reading and the scene-graph cost, are
``bench_build``'s; its :func:`~benchmarks.bench_build.run` runs all four as the runner's
``build`` section):

* **Map size and queries** (:func:`run_map`). Maps of 10^4 and 10^5 cell entries with two weeks
  of fixed-sensor history (``bench_engine.build_state``), written with
  ``formats.mapfile.write_map``: bytes per entry, by member kind (``entry``, ``temporal_cnt``,
  ...), against :data:`BASELINE_BYTES_PER_ENTRY` (measured before issue 15; target >= 4x
  smaller); and the largest map's query-only copy (``aion compact``: without the Fourier sums
  only learning needs), with ``predict --top 10`` on it (the same last line as on the map).
  ``aion predict MAP --top 10`` and ``aion info MAP`` on the largest map as whole processes
  (subprocess wall time, best of k; target <= 1 s for predict), against the interpreter's
  own start (``python -c pass``) and ``aion --help``; for predict also its CPU time (a
  table, ``-q``) and ``aion --help``'s, which a loaded machine inflates less than wall.
* **Streaming memory** (:func:`run_memory`). Peak RSS of ``build_map`` in a fresh interpreter
  (``benchmarks.common.peak_rss`` running :func:`build_for_rss`) on uncompressed
  TrackedPersons MCAPs of growing size (``bench_stream_memory.write_log``: 40 people per
  message), fitted linearly against the log size: the slope in MB per GB of log and the peak
  extrapolated to 10 GB (target <= 500 MB) when the largest log measured is smaller.

Maps are rebuilt every run (their format is what is being changed); the memory logs are
deleted after use.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.bench_build import build
from benchmarks.build_logs import T0_NS
from benchmarks.common import WORK, peak_rss

#: bytes per entry of the 10^5-entry query map before issue 15 (run_map at commit 57fb219:
#: 952,767,408 bytes for 100,405 entries, 83 % of it temporal_cnt)
BASELINE_BYTES_PER_ENTRY = 9_489.0


# -- map size and query processes -------------------------------------------------------------
def _kind(name: str) -> str:
    parts = name.split("_")
    return "_".join(parts[:2]) if parts[0] == "temporal" and len(parts) > 2 else parts[0]


def write_query_map(n_entries: int, path: Path) -> dict[str, Any]:
    """A map of ~``n_entries`` cell entries with two weeks of history (``bench_engine``'s
    query map) written with ``write_map`` and the manifest fields the CLI shows; returns its
    size, entry count and bytes per member kind."""
    from aion_cli.derived_seal import seal
    from aion_cli.formats.mapfile import read_manifest, write_map
    from benchmarks.bench_engine import build_state

    state = build_state(n_entries)
    entries = len(state.entries.live_rows())
    arrays, meta = state.to_arrays()
    path.unlink(missing_ok=True)
    day = 86_400 * 10**9
    write_map(path, arrays, {
        "state": meta, "config": state.config.to_dict(), "inputs": [],
        "time_span": {"start_ns": T0_NS - 14 * day, "end_ns": T0_NS},
        "timezone": state.config.timezone, "graph_source": "none", "observation": "fixed",
    }, seal=seal)  # sealed as every map aion writes
    del state, arrays
    members = read_manifest(path)["members"]
    kinds: dict[str, int] = {}
    for name, rec in members.items():
        kinds[_kind(name)] = kinds.get(_kind(name), 0) + int(rec["size"])
    size = path.stat().st_size
    return {"entries": entries, "map_bytes": size, "bytes_per_entry": size / entries,
            "members": len(members),
            "bytes_per_entry_by_kind": {k: v / entries for k, v in
                                        sorted(kinds.items(), key=lambda kv: -kv[1])}}


def write_places_map(extent: float, spacing: float, path: Path) -> dict[str, Any]:
    """A map of a corridor graph's places (``bench_engine.campus_graph`` over ``extent`` m,
    corridors every ``spacing`` m, a place every 2 m: 88,727 places at 1,150 m / 14 m) after
    three 10-minute windows of 400,000 detections on the corridors, for the PLY / PCD export
    and the entries files at scale (docs/BENCHMARKS.md); its place and entry counts."""
    from aion_cli.derived_seal import seal
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.formats.mapfile import write_map
    from benchmarks.bench_engine import T0_NS as T0
    from benchmarks.bench_engine import WINDOW_NS, campus_graph, detections

    rng = np.random.default_rng(7)
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(T0 - WINDOW_NS, T0 + 10 * WINDOW_NS)
    graph = campus_graph(T0 - WINDOW_NS, extent, spacing)
    mapper.add_graph(graph)
    for w in range(3):
        start = T0 - WINDOW_NS + w * WINDOW_NS
        mapper.add_detections(detections(rng, 400_000, start, WINDOW_NS - 10**9, extent, spacing))
        mapper.add_graph(campus_graph(start + 60 * 10**9, extent, spacing))
    mapper.advance(T0 + 3 * WINDOW_NS)
    state = mapper.state
    arrays, meta = state.to_arrays()
    path.unlink(missing_ok=True)
    write_map(path, arrays, {
        "state": meta, "config": state.config.to_dict(), "inputs": [],
        "time_span": {"start_ns": T0 - WINDOW_NS, "end_ns": T0 + 3 * WINDOW_NS},
        "timezone": state.config.timezone, "graph_source": "log", "observation": "fixed",
    }, seal=seal)  # sealed as every map aion writes
    return {"places": len(graph.places.ids), "entries": len(state.entries.live_rows())}


def process_s(args: list[str], repeats: int) -> tuple[float, str]:
    """Best wall time of a subprocess (must exit 0) and its last stdout line, after one
    untimed run. The processes run as an installed aion does: with Python's bytecode cache
    (``PYTHONDONTWRITEBYTECODE`` is dropped from their environment; a development shell that
    sets it would otherwise make every run compile aion's modules again, ~0.1 s)."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    subprocess.run(args, capture_output=True, check=False, env=env)
    best, out = float("inf"), ""
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        proc = subprocess.run(args, capture_output=True, text=True, check=False, env=env)
        best = min(best, time.perf_counter() - t0)
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}): {proc.stderr}")
        out = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else ""
    return best, out


def process_cpu_s(args: list[str], repeats: int) -> float:
    """Least CPU time (user + system, from the children's rusage) of a subprocess over
    ``repeats`` runs: on a machine shared with other work, wall time measures the load
    (2-3x at load 8-13 on 2 cores, 2026-12-06) and CPU time the process."""
    import os
    import resource

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    best = float("inf")
    for _ in range(max(1, repeats)):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(args, capture_output=True, check=True, env=env)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        best = min(best, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return best


def run_map(sizes: tuple[int, ...] = (10**4, 10**5), repeats: int = 3) -> list[dict[str, Any]]:
    """Bytes per entry for each size; predict / info process times on the largest map."""
    WORK.mkdir(parents=True, exist_ok=True)
    rows = []
    path = WORK / "build_query.aion"
    for n in sizes:
        t0 = time.perf_counter()
        info = write_query_map(n, path)
        info["write_s"] = time.perf_counter() - t0
        rows.append({"name": f"map size {n:.0e} entries",
                     "vs_baseline": BASELINE_BYTES_PER_ENTRY / info["bytes_per_entry"], **info})
    top = rows[-1]  # the largest map, which the processes below query
    rows.append(_query_only_row(path, top))
    aion = str(Path(sys.executable).with_name("aion"))
    when = "2023-11-16 12:00"  # the day after the map's window (UTC)
    python_s, _ = process_s([sys.executable, "-c", "pass"], repeats)
    help_s, _ = process_s([aion, "--help"], repeats)
    predict_s, line = process_s(
        [aion, "predict", str(path), "--top", "10", "--time", when, "--format", "csv"], repeats)
    info_s, _ = process_s([aion, "info", str(path), "--format", "json"], repeats)
    common = {"entries": top["entries"], "map_bytes": top["map_bytes"],
              "python_start_s": python_s, "aion_help_s": help_s}
    predict_args = [aion, "predict", str(path), "--top", "10", "--time", when, "-q"]
    rows.append({"name": "aion predict MAP --top 10", "seconds": predict_s,
                 "vs_aion_help": predict_s / help_s, "last_line": line[:200],
                 "cpu_s": process_cpu_s(predict_args, repeats),
                 "help_cpu_s": process_cpu_s([aion, "--help"], repeats), **common})
    rows.append({"name": "aion info MAP", "seconds": info_s, "vs_aion_help": info_s / help_s,
                 **common})
    small = path.with_name("build_query_robot.aion")
    small_s, small_line = process_s(
        [aion, "predict", str(small), "--top", "10", "--time", when, "--format", "csv"], repeats)
    rows.append({"name": "aion predict MAP --top 10, query-only map", "seconds": small_s,
                 "vs_aion_help": small_s / help_s, "same_answer": small_line == line, **common,
                 "map_bytes": small.stat().st_size})
    path.unlink(missing_ok=True)
    small.unlink(missing_ok=True)
    return rows


def _query_only_row(path: Path, full: dict[str, Any]) -> dict[str, Any]:
    """``aion compact`` of the map at ``path`` (kept beside it for the predict timing): its
    bytes per entry against the baseline (the same predictions, the map cannot learn more)."""
    from aion_cli.query_only import compact_map

    t0 = time.perf_counter()
    report = compact_map(path, path.with_name("build_query_robot.aion"))
    seconds = time.perf_counter() - t0
    per_entry = report.map_bytes / full["entries"]
    return {"name": f"map size {full['entries']:.0e} entries, query-only (aion compact)",
            "entries": full["entries"], "map_bytes": report.map_bytes,
            "bytes_per_entry": per_entry, "vs_baseline": BASELINE_BYTES_PER_ENTRY / per_entry,
            "vs_full_map": full["bytes_per_entry"] / per_entry, "compact_s": seconds,
            "bytes_per_entry_by_kind": {}}


# -- streaming memory -----------------------------------------------------------------------------
def build_for_rss(log: str, out: str) -> dict[str, Any]:
    """Child side of :func:`run_memory`: one build; its wall time and counts."""
    t0 = time.perf_counter()
    report = build(Path(log), Path(out))
    s = time.perf_counter() - t0
    Path(out).unlink(missing_ok=True)
    return {"build_s": s, "detections": int(report.detections_read),
            "windows": int(report.windows), "map_bytes": int(report.map_bytes)}


def run_memory(sizes_gb: tuple[float, ...] = (0.5, 2.0, 10.0), folder: Path | None = None
               ) -> list[dict[str, Any]]:
    """Peak RSS of a build per log size (a fresh interpreter each), the linear fit (MB per GB
    of log) and the peak at 10 GB (measured, or extrapolated from the fit)."""
    from benchmarks.bench_stream_memory import write_log as write_stream_log

    folder = folder or WORK / "stream_memory"
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    try:
        for gb in sizes_gb:
            log = folder / f"stream_{gb:g}gb.mcap"
            t0 = time.perf_counter()
            counts = write_stream_log(log, int(gb * 1e9))
            write_s = time.perf_counter() - t0
            r = peak_rss("benchmarks.bench_build_scale:build_for_rss", timeout=7200.0, log=str(log),
                         out=str(folder / "out.aion"))
            log.unlink()
            rows.append({"name": f"stream memory {gb:g} GB", "log_bytes": counts["bytes"],
                         "messages": counts["messages"], "write_s": write_s, **r})
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    log_gb = np.array([r["log_bytes"] / 1e9 for r in rows])
    mb = np.array([r["peak_rss_bytes"] / 1e6 for r in rows])
    slope, intercept = np.polyfit(log_gb, mb, 1) if len(rows) > 1 else (float("nan"), mb[0])
    big = int(log_gb.argmax())
    largest = float(log_gb[big])
    at10 = float(mb[big]) if largest >= 10.0 else float(intercept + slope * 10.0)
    rows.append({"name": "stream memory fit", "mb_per_gb": float(slope),
                 "intercept_mb": float(intercept), "largest_gb": largest,
                 "largest_peak_mb": float(mb[big]), "peak_mb_at_10gb": at10,
                 "extrapolated": largest < 10.0})
    return rows
