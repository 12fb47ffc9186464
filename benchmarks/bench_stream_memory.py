"""Streaming memory: peak RSS of ``aion build`` on a multi-GB log against the log's size.

On demand only (not part of the test run)::

    .venv/bin/python -m benchmarks.bench_stream_memory            # a 2 GB log
    .venv/bin/python -m benchmarks.bench_stream_memory --gb 4

Writes an *uncompressed* MCAP (as rosbag2's mcap storage does by default) of spencer
``TrackedPersons`` messages, 40 people each (about 36 KB per message), to a temporary folder
that is deleted afterwards. The messages are written raw: a few serialized templates with
zero header stamps, so aion uses each message's log time (one message per 0.1 s) and
generating gigabytes takes seconds. Then ``aion build LOG -o MAP -q`` runs in a subprocess and
its peak resident set size is read from ``os.wait4`` (the child's own rusage). A log 1/8 the
size is built the same way, so the output shows whether memory follows the log's length.

A streaming build holds one chunk of messages (``--batch-size``) and the model state, not the
log: peak RSS should be flat in the log size and far below it.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.common import child_usage

PEOPLE = 40
TEMPLATES = 16
PERIOD_NS = 100_000_000
T0_NS = 1_795_420_800 * 10**9
TYPE = "spencer_tracking_msgs/msg/TrackedPersons"


def templates() -> list[bytes]:
    """Serialized TrackedPersons messages (CDR), zero stamps, people on a 20 x 20 m floor."""
    from aion_cli.formats.writers import LogWriter

    out = []
    with tempfile.TemporaryDirectory() as tmp, LogWriter(Path(tmp) / "t.mcap") as writer:
        for k in range(TEMPLATES):
            tracks = [
                {
                    "track_id": j,
                    "is_matched": True,
                    "pose": {
                        "pose": {
                            "position": {"x": (j * 0.5 + k * 0.13) % 20, "y": (j * 0.37) % 20},
                            "orientation": {"w": 1.0},
                        }
                    },
                    "twist": {"twist": {"linear": {"x": 1.0, "y": 0.2}}},
                }
                for j in range(PEOPLE)
            ]
            msg = {
                "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "map"},
                "tracks": tracks,
            }
            out.append(writer.serialize(TYPE, msg))
    return out


def write_log(path: Path, target_bytes: int) -> dict[str, int]:
    """An uncompressed ROS 2 MCAP of about ``target_bytes``; returns its counts."""
    from mcap.writer import CompressionType, Writer

    from aion_cli.formats import msgdefs

    payloads = templates()
    n = 0
    written = 0
    with path.open("wb") as fh:
        writer = Writer(fh, compression=CompressionType.NONE)
        writer.start(profile="ros2", library="aion bench_stream_memory")
        schema = writer.register_schema(TYPE, "ros2msg", msgdefs.definition(TYPE, 2).encode())
        channel = writer.register_channel("/tracks", "cdr", schema)
        while written < target_bytes:
            data = payloads[n % TEMPLATES]
            t = T0_NS + n * PERIOD_NS
            writer.add_message(channel, t, data, t, n)
            written += len(data) + 31  # message record overhead
            n += 1
        writer.finish()
    return {"bytes": path.stat().st_size, "messages": n, "detections": n * PEOPLE}


def build_peak_rss(log: Path, out: Path) -> dict[str, Any]:
    """Run ``aion build`` on ``log``; the child's peak RSS (bytes) and wall time."""
    aion = Path(sys.executable).with_name("aion")
    start = time.perf_counter()
    code, err, usage = child_usage([str(aion), "build", str(log), "-o", str(out), "-q"])
    if code != 0:
        raise SystemExit(f"aion build failed ({code}): {err}")
    return {"peak_rss": usage.ru_maxrss * 1024, "seconds": time.perf_counter() - start}


def measure(gb: float, folder: Path) -> list[dict[str, Any]]:
    rows = []
    for label, size in (("1/8", gb / 8), ("full", gb)):
        log = folder / f"stream_{label.replace('/', '_')}.mcap"
        t = time.perf_counter()
        counts = write_log(log, int(size * 1024**3))
        written_s = time.perf_counter() - t
        result = build_peak_rss(log, folder / "out.aion")
        rows.append({"log": label, **counts, "write_s": written_s, **result})
        log.unlink()
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--gb", type=float, default=2.0, help="size of the big log in GiB")
    parser.add_argument("--dir", type=Path, default=None, help="folder for the temporary log")
    args = parser.parse_args(argv)
    folder = Path(tempfile.mkdtemp(prefix="aion-stream-", dir=args.dir))
    try:
        rows = measure(args.gb, folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(
        f"{'log':>5} {'size':>10} {'messages':>10} {'detections':>11} {'peak RSS':>10} "
        f"{'RSS/log':>8} {'build s':>8}"
    )
    for r in rows:
        print(
            f"{r['log']:>5} {r['bytes'] / 1024**2:>8.0f}MB {r['messages']:>10,} "
            f"{r['detections']:>11,} {r['peak_rss'] / 1024**2:>8.0f}MB "
            f"{r['peak_rss'] / r['bytes']:>8.3f} {r['seconds']:>8.1f}"
        )
    small, big = rows
    print(
        f"peak RSS full / (1/8): {big['peak_rss'] / small['peak_rss']:.2f}x "
        f"for {big['bytes'] / small['bytes']:.0f}x the log"
    )


if __name__ == "__main__":
    main()
