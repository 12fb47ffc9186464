"""End-to-end ingest: ``aion build`` on a log of >= 5 M people detections, against reading it.

The log (cached in ``benchmarks/_work/``, generated once, ~15 s) is an MCAP (ROS 2 profile,
zstd chunks, as ``formats.writers.LogWriter`` writes them) of ``geometry_msgs/PoseArray``
messages at 10 Hz from a fixed people tracker over a campus of corridors (300 m x 300 m,
corridors 3 m wide every 50 m, ~25 people per message, heading as the pose yaw), positions in
the map frame. PoseArray keeps the file small (56 bytes per detection; spencer TrackedPersons
would be 712) and is serialized here with numpy straight into CDR (``LogWriter.write_raw``), so
generating 5 M detections takes seconds instead of building 5 M message dicts.

Timed in the same process on the same file, best of k:

* **raw iteration**: ``open_logs([log]).messages()`` yielding every RawMessage (reading chunks,
  zstd, framing): the floor any build has to pay;
* **rosbags decode**: the same plus ``LogSet.decode`` (rosbags' generic deserializer) of every
  message, i.e. what a straightforward reader does before touching a single field;
* **build**: ``aion_cli.pipeline.build_map`` (provenance hash, topic selection, streaming,
  numpy decoding, headings, Mapper, window closes with FreMEn updates, map write).

Ratios: build / raw iteration (target <= 2) and rosbags decode / build.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import WORK, best_of, corridor_points, timed

TOPIC = "/campus_tracker/people"
MSGTYPE = "geometry_msgs/msg/PoseArray"
RATE_HZ = 10.0
PER_MESSAGE = 25  # mean people per message (Poisson)
T0_NS = 1_700_000_000 * 10**9  # a Tuesday, 22:13 UTC
EXTENT, SPACING = 300.0, 50.0


def log_path(detections: int) -> Path:
    """Cache path of the generated log (name carries every generation parameter)."""
    return WORK / f"ingest_posearray_{detections}_{PER_MESSAGE}pm_{int(EXTENT)}m.mcap"


def _pose_array_cdr(sec: int, nsec: int, poses: bytes, n: int) -> bytes:
    """CDR of a PoseArray in frame "map": header (sec, nanosec, "map\\0"), count, padding to
    8, then ``n`` poses of 7 float64 (``poses``)."""
    head = struct.pack("<iII4sI", sec, nsec, 4, b"map\x00", n)  # 20 bytes after encapsulation
    return b"\x00\x01\x00\x00" + head + b"\x00" * 4 + poses  # poses start at offset 24 (8-aligned)


def generate(detections: int, path: Path | None = None, seed: int = 0) -> Path:
    """Write (once) a PoseArray log with at least ``detections`` detections; returns its path.

    Written to a temporary name and renamed, so an interrupted run never leaves a truncated
    cache behind."""
    from aion_cli.formats.writers import LogWriter

    path = path or log_path(detections)
    if path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    n_msgs = int(np.ceil(detections / PER_MESSAGE))
    counts = rng.poisson(PER_MESSAGE, n_msgs)
    counts[-1] += max(0, detections - int(counts.sum()))
    tmp = path.with_suffix(".tmp.mcap")
    tmp.unlink(missing_ok=True)
    step_ns = int(1e9 / RATE_HZ)
    block = 20_000  # messages generated per numpy block
    with LogWriter(tmp, "mcap") as writer:
        for a in range(0, n_msgs, block):
            c = counts[a : a + block]
            total = int(c.sum())
            xyz, heading = corridor_points(rng, total, EXTENT, SPACING)
            poses = np.zeros((total, 7))
            poses[:, :3] = xyz
            poses[:, 5], poses[:, 6] = np.sin(heading / 2), np.cos(heading / 2)
            raw = poses.tobytes()
            ends = np.cumsum(c) * 56
            starts = ends - c * 56
            for i, (s, e, k) in enumerate(zip(starts.tolist(), ends.tolist(), c.tolist(),
                                              strict=True)):
                t_ns = T0_NS + (a + i) * step_ns
                sec, nsec = divmod(t_ns, 10**9)
                writer.write_raw(TOPIC, MSGTYPE, _pose_array_cdr(sec, nsec, raw[s:e], k), t_ns)
    tmp.rename(path)
    return path


def _iterate(path: Path) -> int:
    from aion_cli.formats.logs import open_logs

    n = 0
    with open_logs([path]) as logs:
        for _ in logs.messages():
            n += 1
    return n


def _rosbags_decode(path: Path, limit: int | None) -> int:
    """Deserialize every message (or the first ``limit``) with rosbags; returns poses seen."""
    from aion_cli.formats.logs import open_logs

    poses = 0
    with open_logs([path]) as logs:
        for i, msg in enumerate(logs.messages()):
            if limit is not None and i >= limit:
                break
            poses += len(logs.decode(msg).poses)
    return poses


def _decode(path: Path, chunk: int = 2_000) -> int:
    """Read, decode and move into the map frame every detection, as ``aion build`` does (the
    production ``decoded_chunks``: chunks of raw messages decoded by ``DetectionFeeder`` one
    chunk ahead in a worker thread), without the Mapper; returns the detections decoded."""
    from aion_cli.detection_feed import DetectionCounts, DetectionFeeder, chunks, decoded_chunks
    from aion_cli.formats.logs import open_logs

    n = 0
    with open_logs([path]) as logs:
        feeder = DetectionFeeder(None, "map", DetectionCounts())
        for batch, _, _ in decoded_chunks(chunks(logs.messages(), set(), chunk), feeder):
            if batch is not None:
                n += len(batch.t_ns)
    return n


def _build(path: Path, out: Path) -> Any:
    from aion_cli.pipeline import BuildOptions, build_map

    out.unlink(missing_ok=True)
    return build_map(BuildOptions(logs=(path,), output=out))


def run(detections: int = 5_000_000, repeats: int = 2, rosbags_messages: int = 40_000
        ) -> list[dict[str, Any]]:
    """Generate (cached) and time raw iteration, rosbags decoding and the build.

    ``rosbags_messages``: rosbags' deserializer is timed on the first that many messages and
    extrapolated per detection (it is ~an order of magnitude slower than the build, and its
    per-message cost does not change along the file)."""
    t0 = time.perf_counter()
    existed = log_path(detections).exists()
    path = generate(detections)
    gen_s = time.perf_counter() - t0
    out = path.with_suffix(".aion")
    messages = _iterate(path)  # warm the page cache once
    raw_s = best_of(lambda: _iterate(path), repeats)
    decode_s = best_of(lambda: _decode(path), repeats)
    limit = min(rosbags_messages, messages)
    rb_s, rb_poses = timed(lambda: _rosbags_decode(path, limit))
    build_s = float("inf")
    report = None
    for _ in range(max(1, repeats)):
        s, report = timed(lambda: _build(path, out))
        build_s = min(build_s, s)
    assert report is not None
    n = int(report.detections_read)
    rb_per_det = rb_s / max(rb_poses, 1)
    return [{
        "name": "ingest",
        "log_bytes": path.stat().st_size,
        "messages": messages,
        "detections": n,
        "detections_used": int(report.detections_used),
        "entries_cells": int(report.cells),
        "windows": int(report.windows),
        "map_bytes": int(report.map_bytes),
        "generation_s": gen_s,
        "generated_now": not existed,
        "raw_iteration_s": raw_s,
        "rosbags_decode_s_extrapolated": rb_per_det * n,
        "rosbags_messages_timed": limit,
        "build_s": build_s,
        "build_detections_per_s": n / build_s,
        "raw_detections_per_s": n / raw_s,
        "rosbags_detections_per_s": 1 / rb_per_det,
        "build_vs_raw": build_s / raw_s,
        "decode_s": decode_s,
        "decode_vs_raw": decode_s / raw_s,
        "rosbags_vs_build": rb_per_det * n / build_s,
    }]


def profile_build(detections: int = 5_000_000, top: int = 25) -> str:
    """cProfile of one build (cumulative time), for finding hot spots."""
    import cProfile
    import io
    import pstats

    path = generate(detections)
    prof = cProfile.Profile()
    prof.enable()
    _build(path, path.with_suffix(".aion"))
    prof.disable()
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(top)
    return buf.getvalue()


if __name__ == "__main__":
    for row in run():
        print(row)
