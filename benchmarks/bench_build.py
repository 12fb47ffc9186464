"""Issue 15: ``aion build`` at the speed of reading, and queries on big maps at once.

Every figure of the issue's targets, measured in one process (ratios to a baseline timed in the
same run on the same data):

* **Build vs reading** (:func:`run_ratio`). Logs like the issue's 20-day log: spencer
  ``TrackedPersons`` at 10 Hz from a fixed tracker over a floor of corridors (60 m x 60 m,
  corridors 3 m wide every 20 m), 62,501 messages over 20 days in bursts (the tracker publishes
  while people pass: each 10-minute window gets a burst of consecutive 10 Hz messages, more by
  day than at night and on weekdays than at weekends), with 1, 5 and 25 people per message
  (``1 + Poisson(k - 1)``: the mean is k and no message is empty), and a
  ``hydra_msgs/DsgUpdate`` every 10 minutes carrying the floor's places graph (spark_dsg
  binary, ~150 places along the corridors, no mesh). The graph payload is the same in every
  update, as a fixed sensor's static map is (the simulator's stream reuses the bytes when
  nothing changed). Timed: ``open_logs([log]).messages()`` yielding every message (the raw
  iteration: reading, zstd, framing; the floor of any build) and
  ``aion_cli.pipeline.build_map`` (hashing, topics, decoding, the Mapper, window closes,
  graphs, map write). Reported per size: detections/s end to end (target >= 1 M/s at 5 per
  message) and build / raw iteration (target <= 2x).
* **Scene-graph cost** (:func:`run_graphs`). One hour of a live Hydra: a ``DsgUpdate`` of
  5,000 places (corridor network, edges between neighbours) every second, every payload
  different (each update moves 50 places by a centimetre and stamps them, as the backend's
  optimisation does), plus people at 10 Hz, 5 per message. The same detections are also
  written without the graph topic; the graphs' share of the build is
  ``(build with - build without) / build with`` (target <= 25 %), and their cost per graph
  message ``(with - without) / graph messages``; also the share the graphs would keep if only
  reading their bytes cost anything (``graph_share_floor_reading``: raw iteration with minus
  without graphs, over the build without graphs plus that). For the reading: per payload,
  spark_dsg's ``DynamicSceneGraph.from_binary`` alone, ``formats.dsg.decode_dsg`` (spark_dsg
  plus the navigational-layer arrays) and ``Mapper.add_graph`` (ownership) on decoded
  snapshots inside one window (so no window closes).
* **Map size and queries** (:func:`run_map`). Maps of 10^4 and 10^5 cell entries with two weeks
  of fixed-sensor history (``bench_engine.build_state``), written with
  ``formats.mapfile.write_map``: bytes per entry, by member kind (``entry``, ``temporal_cnt``,
  ...), against :data:`BASELINE_BYTES_PER_ENTRY` (measured before issue 15; target >= 4x
  smaller). ``aion predict MAP --top 10`` and ``aion info MAP`` on the largest map as whole
  processes (subprocess wall time, best of k; target <= 1 s for predict), against the
  interpreter's own start (``python -c pass``) and ``aion --help``.
* **Streaming memory** (:func:`run_memory`). Peak RSS of ``build_map`` in a fresh interpreter
  (``benchmarks.common.peak_rss``) on uncompressed TrackedPersons MCAPs of growing size
  (``bench_stream_memory.write_log``: 40 people per message), fitted linearly against the log
  size: the slope in MB per GB of log and the peak extrapolated to 10 GB (target <= 500 MB)
  when the largest log measured is smaller.

Logs of the first two parts are cached in ``benchmarks/_work/`` (their names carry every
generation parameter); maps are rebuilt every run (their format is what is being changed), the
memory logs are deleted after use. :func:`profile_build` gives a cProfile of one build.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import WORK, best_of, corridor_nodes, corridor_points, peak_rss, timed

TOPIC = "/spencer/perception/tracked_persons"
GRAPH_TOPIC = "/hydra/backend/dsg"
TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"
T0_NS = 1_700_006_400 * 10**9  # 2023-11-15 00:00 UTC, a Wednesday (window- and day-aligned)
WINDOW_NS = 600 * 10**9
RATE_HZ = 10.0
PLACE_ID0 = ord("p") << 56  # spark_dsg NodeSymbol('p', 0)

#: the ratio logs' floor: corridors 3 m wide every 20 m over 60 m x 60 m, a place every 3 m
FLOOR = (60.0, 20.0, 3.0)
#: the graph stream's site: corridors every 10 m over 160 m x 160 m, a place every metre
#: (5,185 places; the first 5,000 in (x, y) order are the graph)
SITE = (160.0, 10.0, 1.0)

#: bytes per entry of the 10^5-entry query map before issue 15 (run_map at commit 57fb219:
#: 952,767,408 bytes for 100,405 entries, 83 % of it temporal_cnt)
BASELINE_BYTES_PER_ENTRY = 9_489.0


# -- scene graphs ---------------------------------------------------------------------------------
def places_graph(extent: float, spacing: float, step: float, limit: int | None = None
                 ) -> tuple[Any, Any]:
    """Places along the corridor centre lines (``corridor_nodes``), the first ``limit`` of them
    in (x, y) order, and the edges among those kept: (xyz float64[n,3], edges int64[k,2])."""
    xyz, edges = corridor_nodes(extent, spacing, node_step=step)
    if limit is not None and limit < len(xyz):
        xyz = xyz[:limit]
        edges = edges[(edges < limit).all(axis=1)]
    return xyz, edges


def spark_graph(xyz: Any, edges: Any, t_ns: int) -> Any:
    """A spark_dsg graph of PLACES nodes ``p0..`` at ``xyz`` with ``edges`` (weighted by a fixed
    1 m clearance), every node last updated at ``t_ns``."""
    import spark_dsg as dsg

    g = dsg.DynamicSceneGraph()
    for i, p in enumerate(np.asarray(xyz, float)):
        a = dsg.PlaceNodeAttributes()
        a.position = p
        a.distance = 1.0
        a.real_place = True
        a.last_update_time_ns = int(t_ns)
        g.add_node(dsg.DsgLayers.PLACES, PLACE_ID0 + i, a)
    for i, j in np.asarray(edges, np.int64).tolist():
        info = dsg.EdgeAttributes()
        info.weight = 1.0
        info.weighted = True
        g.insert_edge(PLACE_ID0 + i, PLACE_ID0 + j, info)
    return g


class StaticPayload:
    """The same spark_dsg binary in every update (a fixed sensor's static map)."""

    def __init__(self, xyz: Any, edges: Any) -> None:
        self.data = bytes(spark_graph(xyz, edges, T0_NS).to_binary(False))

    def __call__(self, t_ns: int) -> bytes:
        return self.data


class MovingPayload:
    """A new binary per update: ``moved`` random places shift by up to 1 cm and are stamped
    with the update's time (what Hydra's backend optimisation does to a live graph)."""

    def __init__(self, xyz: Any, edges: Any, moved: int = 50, seed: int = 5) -> None:
        self.xyz = np.asarray(xyz, float).copy()
        self.graph = spark_graph(self.xyz, edges, T0_NS)
        self.moved = min(moved, len(self.xyz))
        self.rng = np.random.default_rng(seed)

    def __call__(self, t_ns: int) -> bytes:
        which = self.rng.choice(len(self.xyz), self.moved, replace=False)
        self.xyz[which, :2] += self.rng.uniform(-0.01, 0.01, (self.moved, 2))
        for i in which.tolist():
            attrs = self.graph.get_node(PLACE_ID0 + i).attributes
            attrs.position = self.xyz[i]
            attrs.last_update_time_ns = int(t_ns)
        return bytes(self.graph.to_binary(False))


# -- logs -----------------------------------------------------------------------------------------
def burst_times(messages: int, days: int, seed: int = 0) -> Any:
    """Stamps (int64 ns, sorted) of ``messages`` tracker messages over ``days`` days from
    :data:`T0_NS`: spread over the 10-minute windows by a daily profile (morning and evening
    peaks, a lunch bump, quiet nights, weekends at 30 %), each window's share published as one
    burst of consecutive 10 Hz messages starting at a random instant of the window."""
    rng = np.random.default_rng(seed)
    windows = days * 144
    start = T0_NS + np.arange(windows, dtype=np.int64) * WINDOW_NS
    hour = (start // 10**9 % 86_400) / 3600.0
    weekday = (start // 10**9 // 86_400 + 3) % 7  # Monday = 0 (1970-01-01 was a Thursday)
    w = (0.15 + np.exp(-(((hour - 9) / 1.5) ** 2)) + np.exp(-(((hour - 17) / 1.5) ** 2))
         + 0.5 * np.exp(-(((hour - 12.5) / 1.0) ** 2)))
    w = w * np.where(weekday >= 5, 0.3, 1.0)
    counts = rng.multinomial(messages, w / w.sum())
    step = int(1e9 / RATE_HZ)
    room = np.maximum(WINDOW_NS - counts * step - 10**9, 1)
    first = start + (rng.random(windows) * room).astype(np.int64)
    window_of = np.repeat(np.arange(windows), counts)
    within = np.arange(messages) - np.repeat(np.cumsum(counts) - counts, counts)
    return first[window_of] + within * step


def steady_times(seconds: float) -> Any:
    """Stamps of a tracker publishing at 10 Hz for ``seconds`` from :data:`T0_NS`."""
    step = int(1e9 / RATE_HZ)
    return T0_NS + np.arange(int(seconds * RATE_HZ), dtype=np.int64) * step + step // 2


def write_log(path: Path, times: Any, per_message: int, area: tuple[float, float],
              graph: Callable[[int], bytes] | None = None, graph_period_s: float = 600.0,
              seed: int = 1) -> dict[str, int]:
    """Write (once; cached by ``path``) a TrackedPersons log, messages at ``times``, each with
    ``1 + Poisson(per_message - 1)`` people on the corridors of ``area`` (extent, spacing) in
    the map frame, velocity from heading and speed, and (with ``graph``) a DsgUpdate of
    ``graph(t)`` every ``graph_period_s`` from the first message on, merged in time order.

    Messages are serialized with numpy through the project's own CDR helpers
    (``formats.tracks_log._tracked_person_records`` / ``_tracked_persons_bytes``) 20,000 at a time
    and written with ``formats.writers.LogWriter`` (MCAP, zstd chunks), which writes to a
    staging name and renames on success, so an interrupted run leaves no truncated cache."""
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.formats.tracks_log import _tracked_person_records, _tracked_persons_bytes
    from aion_cli.formats.writers import LogWriter, stamp

    if path.exists():
        return {}
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    times = np.asarray(times, np.int64)
    counts = 1 + rng.poisson(max(per_message - 1, 0), len(times))
    graph_times: list[int] = []
    if graph is not None:
        period = round(graph_period_s * 1e9)
        graph_times = list(range(int(times[0]), int(times[-1]) + 1, period))
    burst = np.cumsum(np.r_[0, np.diff(times) > int(2e9 / RATE_HZ)])  # one id per burst
    block, g, detections = 20_000, 0, 0
    with LogWriter(path, "mcap") as writer:
        for a in range(0, len(times), block):
            c = counts[a : a + block]
            total = int(c.sum())
            xyz, heading = corridor_points(rng, total, *area)
            msg = np.repeat(np.arange(a, a + len(c)), c)
            within = np.arange(total) - np.repeat(np.cumsum(c) - c, c)
            batch = DetectionBatch(times[msg], xyz, heading, rng.normal(1.2, 0.2, total),
                                   burst[msg] * 1000 + within)
            records = _tracked_person_records(batch, True)
            ends = np.cumsum(c)
            for i, (t, s, e) in enumerate(zip(times[a : a + block].tolist(),
                                              (ends - c).tolist(), ends.tolist(), strict=True)):
                while g < len(graph_times) and graph_times[g] <= t:
                    assert graph is not None
                    writer.write(GRAPH_TOPIC, DSG_UPDATE, {
                        "header": {"stamp": stamp(graph_times[g]), "frame_id": "map"},
                        "layer_contents": graph(graph_times[g]),
                        "full_update": True,
                        "sequence_number": g,
                    }, graph_times[g])
                    g += 1
                raw = _tracked_persons_bytes(records[s:e], t, "map", True, a + i)
                writer.write_raw(TOPIC, TRACKED, raw, t)
            detections += total
    return {"messages": len(times), "detections": detections, "graph_messages": g}


def ratio_log_path(per_message: int, messages: int, days: int) -> Path:
    """Cache path of the 20-day-like log (the name carries the generation parameters)."""
    extent, _, step = FLOOR
    return WORK / (f"build_tp_{messages}m_{days}d_{per_message}pm_{int(extent)}m"
                   f"_g{int(step)}s600.mcap")


def ratio_log(per_message: int, messages: int, days: int) -> Path:
    """The cached 20-day-like log with ``per_message`` people per message (written once)."""
    extent, spacing, step = FLOOR
    path = ratio_log_path(per_message, messages, days)
    if not path.exists():
        xyz, edges = places_graph(extent, spacing, step)
        write_log(path, burst_times(messages, days), per_message, (extent, spacing),
                  StaticPayload(xyz, edges), 600.0)
    return path


def graph_logs(places: int, seconds: float, per_message: int = 5) -> tuple[Path, Path]:
    """The cached live-Hydra log (``places``-place graphs at 1 Hz for ``seconds``) and the same
    detections without the graph topic."""
    extent, spacing, step = SITE
    stem = f"build_graphs_{places}p_{int(seconds)}s_{per_message}pm"
    with_g, without = WORK / f"{stem}.mcap", WORK / f"{stem}_nographs.mcap"
    times = steady_times(seconds)
    area = (extent, spacing)
    if not with_g.exists():
        xyz, edges = places_graph(extent, spacing, step, places)
        write_log(with_g, times, per_message, area, MovingPayload(xyz, edges), 1.0)
    if not without.exists():
        write_log(without, times, per_message, area)
    return with_g, without


# -- timing ---------------------------------------------------------------------------------------
def iterate(path: Path) -> int:
    """Raw iteration: every message of the log yielded by ``open_logs`` (nothing decoded)."""
    from aion_cli.formats.logs import open_logs

    n = 0
    with open_logs([path]) as logs:
        for _ in logs.messages():
            n += 1
    return n


def build(path: Path, out: Path) -> Any:
    """``aion build LOG -o OUT`` in this process (``pipeline.build_map``); its BuildReport."""
    from aion_cli.pipeline import BuildOptions, build_map

    out.unlink(missing_ok=True)
    return build_map(BuildOptions(logs=(path,), output=out))


def best_build(path: Path, repeats: int) -> tuple[float, Any]:
    """Smallest wall time of ``repeats`` builds of ``path`` and the last report."""
    best, report = float("inf"), None
    out = path.with_suffix(".aion")
    for _ in range(max(1, repeats)):
        s, report = timed(lambda: build(path, out))
        best = min(best, s)
    out.unlink(missing_ok=True)
    return best, report


def graph_period_default() -> Any:
    """``BuildOptions``' graph thinning period default, if the build has one (issue 15)."""
    from aion_cli.pipeline import BuildOptions

    for f in dataclasses.fields(BuildOptions):
        if "graph" in f.name and ("period" in f.name or "interval" in f.name):
            return {f.name: f.default}
    return None


def run_ratio(per_messages: tuple[int, ...] = (1, 5, 25), messages: int = 62_501,
              days: int = 20, repeats: int = 2) -> list[dict[str, Any]]:
    """Build vs raw iteration on the 20-day-like logs, one row per people-per-message size."""
    rows = []
    for k in per_messages:
        t0 = time.perf_counter()
        existed = ratio_log_path(k, messages, days).exists()
        path = ratio_log(k, messages, days)
        gen_s = time.perf_counter() - t0
        n_msgs = iterate(path)  # warms the page cache
        raw_s = best_of(functools.partial(iterate, path), max(repeats, 3))
        build_s, report = best_build(path, repeats)
        n = int(report.detections_read)
        rows.append({
            "name": f"build {k} per message",
            "per_message": k, "days": days, "log_bytes": path.stat().st_size,
            "messages": n_msgs, "graph_messages": int(report.graph_messages),
            "graph_skipped": int(report.graph_skipped), "detections": n,
            "detections_used": int(report.detections_used), "cells": int(report.cells),
            "nodes": int(report.nodes), "windows": int(report.windows),
            "map_bytes": int(report.map_bytes),
            "generation_s": gen_s, "generated_now": not existed,
            "raw_iteration_s": raw_s, "build_s": build_s,
            "build_detections_per_s": n / build_s, "raw_detections_per_s": n / raw_s,
            "build_vs_raw": build_s / raw_s,
        })
    return rows


def _payloads(path: Path, limit: int) -> list[tuple[int, Any]]:
    """The first ``limit`` DsgUpdate payloads of ``path`` as (stamp ns, uint8 array)."""
    from aion_cli.formats.logs import open_logs

    out = []
    with open_logs([path]) as logs:
        for msg in logs.messages({GRAPH_TOPIC}):
            d = logs.decode(msg)
            t = int(d.header.stamp.sec) * 10**9 + int(d.header.stamp.nanosec)
            out.append((t, np.asarray(d.layer_contents, np.uint8)))
            if len(out) >= limit:
                break
    return out


def _message_reading(path: Path, limit: int, repeats: int) -> dict[str, float]:
    """Per DsgUpdate message: rosbags' decode of the whole message (what ``GraphFeed`` did to
    get the payload and stamp) and ``formats.dsg_update_fast.read_dsg_update`` (the header
    stamp and a view of the payload, straight from the bytes)."""
    from aion_cli.formats.dsg_update_fast import read_dsg_update
    from aion_cli.formats.logs import open_logs

    with open_logs([path]) as logs:
        msgs = []
        for msg in logs.messages({GRAPH_TOPIC}):
            msgs.append(msg)
            if len(msgs) >= limit:
                break
        k = max(len(msgs), 1)
        rosbags_s = best_of(lambda: [logs.decode(m) for m in msgs], repeats)
        fast_s = best_of(lambda: [read_dsg_update(m.data, m.encoding) for m in msgs], repeats)
    return {"payload_rosbags_s_per_graph": rosbags_s / k,
            "payload_fast_s_per_graph": fast_s / k}


def graph_parts(path: Path, samples: int = 10, repeats: int = 3) -> dict[str, Any]:
    """Per payload: spark_dsg ``from_binary``, ``formats.dsg.decode_dsg`` through spark_dsg
    (``fast=False``: ``from_binary`` and the per-node scan, the path before the numpy reader)
    and through the numpy reader (the default), the message reading before and after
    (:func:`_message_reading`) and ``Mapper.add_graph`` on the decoded snapshots (a mapper
    holding one minute of detections, all snapshots inside one window: ownership only, no
    window close). The decode paths are timed interleaved, best of ``repeats``."""
    import spark_dsg as dsg

    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.formats.dsg import decode_dsg

    payloads = _payloads(path, samples)
    if not payloads:
        return {}
    raw = [bytes(p) for _, p in payloads]
    spark_s = slow_s = fast_s = float("inf")
    for _ in range(max(1, repeats)):
        spark_s = min(spark_s, best_of(
            lambda: [dsg.DynamicSceneGraph.from_binary(b) for b in raw], 1))
        slow_s = min(slow_s, best_of(
            lambda: [decode_dsg(p, t, fast=False) for t, p in payloads], 1))
        fast_s = min(fast_s, best_of(lambda: [decode_dsg(p, t) for t, p in payloads], 1))
    base = T0_NS // WINDOW_NS * WINDOW_NS
    snaps = [dataclasses.replace(decode_dsg(p, t).snapshot, t_ns=base + 10**9 * (i + 1))
             for i, (t, p) in enumerate(payloads)]
    rng = np.random.default_rng(9)
    n = 30_000
    xyz, heading = corridor_points(rng, n, SITE[0], SITE[1])
    batch = DetectionBatch(np.sort(rng.integers(0, 10**9, n)) + base, xyz, heading,
                           np.full(n, 1.2), np.full(n, -1, np.int64))

    def own() -> float:
        mapper = Mapper(ModelConfig())
        mapper.set_fixed_sensor(base, base + WINDOW_NS)
        mapper.add_graph(snaps[0])
        mapper.add_detections(batch)
        t0 = time.perf_counter()
        for s in snaps[1:]:
            mapper.add_graph(s)
        return time.perf_counter() - t0

    own_s = min(own() for _ in range(repeats))
    k = len(payloads)
    return {"payload_bytes": len(raw[0]), "places": len(snaps[0].places),
            "spark_from_binary_s_per_graph": spark_s / k,
            "decode_dsg_spark_s_per_graph": slow_s / k,
            "decode_dsg_s_per_graph": fast_s / k,
            "decode_speedup": slow_s / fast_s,
            **_message_reading(path, samples, repeats),
            "add_graph_s_per_graph": own_s / max(k - 1, 1)}


@contextlib.contextmanager
def without_fast_graph_readers() -> Iterator[None]:
    """Builds inside read scene graphs as before the numpy readers: every DsgUpdate decoded
    by rosbags for its payload and stamp, every payload by spark_dsg and the per-node scan
    (``formats.dsg_update_fast.read_dsg_update`` declines, ``decode_dsg`` takes its
    ``fast=False`` path). For the before/after ratio in one process."""
    from unittest import mock

    with mock.patch("aion_cli.formats.dsg_update_fast.read_dsg_update", return_value=None), \
            mock.patch("aion_cli.formats.dsg_payload._fast_applies", return_value=False):
        yield


def run_graphs(places: int = 5000, seconds: float = 3600.0, repeats: int = 1,
               compare_spark: bool = True) -> list[dict[str, Any]]:
    """The graphs' share of a build of a live-Hydra log, and their cost per message; with
    ``compare_spark`` also the build reading the graphs as before the numpy readers
    (:func:`without_fast_graph_readers`) and its share, in the same process."""
    t0 = time.perf_counter()
    with_g, without = graph_logs(places, seconds)
    gen_s = time.perf_counter() - t0
    msgs = iterate(with_g)
    raw_s = best_of(lambda: iterate(with_g), repeats)
    raw_without_s = best_of(lambda: iterate(without), repeats)
    with_s, report = best_build(with_g, repeats)
    without_s, report0 = best_build(without, repeats)
    graphs = msgs - iterate(without)  # graph messages in the log
    extra = with_s - without_s
    row = {
        "name": f"graph stream {places} places 1 Hz {seconds / 3600:.3g} h",
        "places": places, "seconds": seconds, "log_bytes": with_g.stat().st_size,
        "messages": msgs, "graph_messages_in_log": graphs,
        "graph_messages_used": int(report.graph_messages),
        "graph_skipped": int(report.graph_skipped),
        "detections": int(report.detections_read), "nodes": int(report.nodes),
        "cells": int(report.cells), "generation_s": gen_s,
        "raw_iteration_s": raw_s, "raw_iteration_without_graphs_s": raw_without_s,
        "build_s": with_s, "build_without_graphs_s": without_s,
        "cells_without_graphs": int(report0.cells),
        "graph_share": extra / with_s, "graph_s_per_message": extra / max(graphs, 1),
        # reading the graph bytes (zstd, framing) cannot be skipped in a log whose chunks mix
        # topics: the share the graphs would keep if everything after reading them were free
        "graph_reading_s": raw_s - raw_without_s,
        "graph_share_floor_reading": (raw_s - raw_without_s)
        / max(without_s + raw_s - raw_without_s, 1e-12),
        "build_vs_raw": with_s / raw_s, "graph_period_option": graph_period_default(),
    }
    if compare_spark:
        with without_fast_graph_readers():
            spark_s, _ = best_build(with_g, repeats)
        row.update({"build_spark_dsg_s": spark_s,
                    "graph_share_spark_dsg": (spark_s - without_s) / spark_s,
                    "graph_s_per_message_spark_dsg": (spark_s - without_s) / max(graphs, 1)})
    row.update(graph_parts(with_g))
    return [row]


# -- map size and query processes -------------------------------------------------------------
def _kind(name: str) -> str:
    parts = name.split("_")
    return "_".join(parts[:2]) if parts[0] == "temporal" and len(parts) > 2 else parts[0]


def write_query_map(n_entries: int, path: Path) -> dict[str, Any]:
    """A map of ~``n_entries`` cell entries with two weeks of history (``bench_engine``'s
    query map) written with ``write_map`` and the manifest fields the CLI shows; returns its
    size, entry count and bytes per member kind."""
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
    })
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
    aion = str(Path(sys.executable).with_name("aion"))
    when = "2023-11-16 12:00"  # the day after the map's window (UTC)
    python_s, _ = process_s([sys.executable, "-c", "pass"], repeats)
    help_s, _ = process_s([aion, "--help"], repeats)
    predict_s, line = process_s(
        [aion, "predict", str(path), "--top", "10", "--time", when, "--format", "csv"], repeats)
    info_s, _ = process_s([aion, "info", str(path), "--format", "json"], repeats)
    top = rows[-1]
    common = {"entries": top["entries"], "map_bytes": top["map_bytes"],
              "python_start_s": python_s, "aion_help_s": help_s}
    rows.append({"name": "aion predict MAP --top 10", "seconds": predict_s,
                 "vs_aion_help": predict_s / help_s, "last_line": line[:200], **common})
    rows.append({"name": "aion info MAP", "seconds": info_s, "vs_aion_help": info_s / help_s,
                 **common})
    path.unlink(missing_ok=True)
    return rows


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
            r = peak_rss("benchmarks.bench_build:build_for_rss", timeout=7200.0, log=str(log),
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


# -- everything -----------------------------------------------------------------------------------
def run(quick: bool = False) -> list[dict[str, Any]]:
    """The whole section: full sizes (a few minutes plus log generation once), or seconds."""
    if quick:
        return (run_ratio(messages=3_001, days=2, repeats=1)
                + run_graphs(places=300, seconds=60.0)
                + run_map(sizes=(1000, 3000), repeats=1)
                + run_memory(sizes_gb=(0.01, 0.03)))
    return (run_ratio() + run_graphs() + run_map() + run_memory())


def profile_build(path: Path, top: int = 25, dump: Path | None = None) -> str:
    """cProfile of one build of ``path``: the ``top`` functions by cumulative and by own time,
    for the main thread and, separately, for the detection decode worker thread
    (``DetectionFeeder.decode_rows``, which every decode of a chunk or of a job of chunks goes
    through, runs there; the main thread's profile sees it only as waiting; it is wrapped for
    the run, here only, to profile it as well). ``dump``: also write the raw stats to
    ``dump``-main.prof and ``dump``-worker.prof (for pstats / snakeviz)."""
    import cProfile
    import io
    import pstats

    from aion_cli.detection_feed import DetectionFeeder

    out = path.with_suffix(".profile.aion")
    main, worker = cProfile.Profile(), cProfile.Profile()
    decode = DetectionFeeder.decode_rows
    calls = [0]

    def profiled(self: Any, *args: Any) -> Any:
        calls[0] += 1
        worker.enable()
        try:
            return decode(self, *args)
        finally:
            worker.disable()

    DetectionFeeder.decode_rows = profiled  # type: ignore[method-assign,assignment]
    try:
        t0 = time.perf_counter()
        main.enable()
        report = build(path, out)
        main.disable()
        wall = time.perf_counter() - t0
    finally:
        DetectionFeeder.decode_rows = decode  # type: ignore[method-assign]
    out.unlink(missing_ok=True)
    if dump is not None:
        main.dump_stats(f"{dump}-main.prof")
        worker.dump_stats(f"{dump}-worker.prof")
    buf = io.StringIO()
    buf.write(f"build of {path.name}: {wall:.2f} s under cProfile, "
              f"{report.detections_read:,} detections, {report.graph_messages:,} graphs, "
              f"{report.windows:,} windows, {calls[0]:,} decodes (per topic: chunks or jobs of "
              "chunks)\n\n")
    for label, prof in (("main thread", main), ("decode worker thread", worker)):
        for order in ("cumulative", "tottime"):
            buf.write(f"## {label}, top {top} by {order}\n")
            pstats.Stats(prof, stream=buf).sort_stats(order).print_stats(top)
    return buf.getvalue()


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--profile", choices=("ratio", "graphs"), default=None,
                        help="print a cProfile of the 5-per-message or the graph-stream build")
    parser.add_argument("--places", type=int, default=5000, help="graph stream: places")
    parser.add_argument("--seconds", type=float, default=3600.0, help="graph stream: length")
    parser.add_argument("--dump", type=Path, default=None, help="also write raw .prof files")
    parser.add_argument("--only", choices=("ratio", "graphs", "map", "memory"), default=None,
                        help="one part (graphs: the stream of --places / --seconds)")
    args = parser.parse_args()
    if args.profile == "ratio":
        log = ratio_log(5, 3_001, 2) if args.quick else ratio_log(5, 62_501, 20)
        print(profile_build(log, dump=args.dump))
    elif args.profile == "graphs":
        print(profile_build(graph_logs(args.places, args.seconds)[0], dump=args.dump))
    elif args.only == "graphs":
        for row in run_graphs(args.places, args.seconds):
            print(row)
    elif args.only is not None:
        parts: dict[str, Callable[[], list[dict[str, Any]]]] = {
            "ratio": run_ratio, "map": run_map, "memory": run_memory}
        for row in parts[args.only]():
            print(row)
    else:
        for row in run(args.quick):
            print(row)
