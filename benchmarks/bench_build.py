"""Issue 15: ``aion build`` at the speed of reading.

Two of the issue's targets, measured in one process (ratios to a baseline timed in the same
run on the same data) on the logs of ``build_logs`` (cached in ``benchmarks/_work/``):

* **Build vs reading** (:func:`run_ratio`). The 20-day-like logs (``build_logs.ratio_log``:
  spencer ``TrackedPersons`` at 10 Hz from a fixed tracker, 62,501 messages over 20 days in
  bursts, 1, 5 and 25 people per message, a ``DsgUpdate`` of the floor's ~150-place graph
  every 10 minutes). Timed: ``open_logs([log]).messages()`` yielding every message (the raw
  iteration: reading, zstd, framing; the floor of any build) and
  ``aion_cli.pipeline.build_map`` (hashing, topics, decoding, the Mapper, window closes,
  graphs, map write). Reported per size: detections/s end to end (target >= 1 M/s at 5 per
  message) and build / raw iteration (target <= 2x).
* **Scene-graph cost** (:func:`run_graphs`). One hour of a live Hydra
  (``build_logs.graph_logs``: a ``DsgUpdate`` of 5,000 places every second, every payload
  different, plus people at 10 Hz, 5 per message). The same detections are also
  written without the graph topic; the graphs' share of the build is
  ``(build with - build without) / build with`` (target <= 25 %), and their cost per graph
  message ``(with - without) / graph messages``; also the share the graphs would keep if only
  reading their bytes cost anything (``graph_share_floor_reading``: raw iteration with minus
  without graphs, over the build without graphs plus that; a floor for a reader of every
  graph, which the build is not: the graphs it leaves out, each the tail of its chunk here,
  are not decompressed, :mod:`formats.mcap_partial`). For the reading: per payload,
  spark_dsg's ``DynamicSceneGraph.from_binary`` alone, ``formats.dsg.decode_dsg`` (spark_dsg
  plus the navigational-layer arrays) and ``Mapper.add_graph`` (ownership) on decoded
  snapshots inside one window (so no window closes).

The issue's other targets (map size, ``aion predict`` / ``info`` process times, streaming
memory) are ``bench_build_scale``'s. :func:`run` runs all four parts (the runner's ``build``
section; also ``python -m benchmarks.bench_build``); ``--profile ratio|graphs`` and
``--sample`` show where one build spends its time (:mod:`benchmarks.build_profile`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.build_logs import (
    GRAPH_TOPIC,
    SITE,
    T0_NS,
    WINDOW_NS,
    graph_logs,
    ratio_log,
    ratio_log_path,
)
from benchmarks.common import best_of, corridor_points, timed


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


def _stream_reading(path: Path, samples: int, repeats: int) -> dict[str, float]:
    """Per payload the build uses from a 1 Hz stream with the default ``--graph-period`` (every
    fifth): ``read_graph`` of the whole payload against the stream's
    ``formats.dsg_delta.GraphReader`` (only the node records changed since the payload before
    re-read), and ``decode_dsg`` to a snapshot without and with that reader (its layer labels
    kept too). Interleaved, best of ``repeats``."""
    from aion_cli.formats.dsg import decode_dsg
    from aion_cli.formats.dsg_binary import read_graph
    from aion_cli.formats.dsg_delta import GraphReader

    used = _payloads(path, 5 * samples + 1)[::5]
    if len(used) < 2:
        return {}
    first, rest = used[0], used[1:]

    def by_changes(decode: bool) -> float:
        reader = GraphReader()
        if decode:
            decode_dsg(first[1], first[0], reader=reader)
        else:
            reader.read(first[1])
        t0 = time.perf_counter()
        for t, p in rest:
            if decode:
                decode_dsg(p, t, reader=reader)
            else:
                reader.read(p)
        return time.perf_counter() - t0

    whole_s = changes_s = decode_s = stream_s = float("inf")
    for _ in range(max(1, repeats)):
        whole_s = min(whole_s, best_of(lambda: [read_graph(p) for _, p in rest], 1))
        changes_s = min(changes_s, by_changes(False))
        decode_s = min(decode_s, best_of(lambda: [decode_dsg(p, t) for t, p in rest], 1))
        stream_s = min(stream_s, by_changes(True))
    k = len(rest)
    return {"read_whole_s_per_graph": whole_s / k,
            "read_by_changes_s_per_graph": changes_s / k,
            "read_by_changes_speedup": whole_s / changes_s,
            "decode_dsg_alone_s_per_graph": decode_s / k,
            "decode_dsg_stream_s_per_graph": stream_s / k}


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
            **_stream_reading(path, samples, repeats),
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
        # the share the graphs would keep if reading every graph's bytes (zstd, framing) were
        # all they cost: a reader of every message (the raw iteration); aion's build leaves
        # the graphs --graph-period drops compressed where they end their chunk, as here
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


# -- everything -----------------------------------------------------------------------------------
def run(quick: bool = False) -> list[dict[str, Any]]:
    """The whole section: full sizes (a few minutes plus log generation once), or seconds."""
    from benchmarks.bench_build_scale import run_map, run_memory

    if quick:
        return (run_ratio(messages=3_001, days=2, repeats=1)
                + run_graphs(places=300, seconds=60.0)
                + run_map(sizes=(1000, 3000), repeats=1)
                + run_memory(sizes_gb=(0.01, 0.03)))
    return (run_ratio() + run_graphs() + run_map() + run_memory())


if __name__ == "__main__":
    import argparse

    from benchmarks.build_profile import profile_build, sample_build

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--profile", choices=("ratio", "graphs"), default=None,
                        help="print a cProfile of the 5-per-message or the graph-stream build")
    parser.add_argument("--places", type=int, default=5000, help="graph stream: places")
    parser.add_argument("--seconds", type=float, default=3600.0, help="graph stream: length")
    parser.add_argument("--dump", type=Path, default=None, help="also write raw .prof files")
    parser.add_argument("--sample", choices=("ratio", "graphs"), default=None,
                        help="print wall-clock stack samples of the 5-per-message or the "
                        "graph-stream build (no cost per call, unlike --profile)")
    parser.add_argument("--only", choices=("ratio", "graphs", "map", "memory"), default=None,
                        help="one part (graphs: the stream of --places / --seconds)")
    args = parser.parse_args()
    if args.sample is not None:
        if args.sample == "graphs":
            print(sample_build(graph_logs(args.places, args.seconds)[0]))
        else:
            print(sample_build(ratio_log(5, 3_001, 2) if args.quick else ratio_log(5, 62_501, 20)))
    elif args.profile == "ratio":
        log = ratio_log(5, 3_001, 2) if args.quick else ratio_log(5, 62_501, 20)
        print(profile_build(log, dump=args.dump))
    elif args.profile == "graphs":
        print(profile_build(graph_logs(args.places, args.seconds)[0], dump=args.dump))
    elif args.only == "graphs":
        for row in run_graphs(args.places, args.seconds):
            print(row)
    elif args.only is not None:
        from benchmarks.bench_build_scale import run_map, run_memory

        parts: dict[str, Callable[[], list[dict[str, Any]]]] = {
            "ratio": run_ratio, "map": run_map, "memory": run_memory}
        for row in parts[args.only]():
            print(row)
    else:
        for row in run(args.quick):
            print(row)
