"""Mutation fuzzing of the log readers, the detection decoders, the scene-graph decoder and the
map loader: truncated and bit-flipped valid inputs must give a result or a typed aion error
(an ``AionError`` subclass), never another exception and never a hang. Three targets mutate
*fields* instead of bytes -- lengths, counts and times of MCAP / bag / rosbag2 records, of CDR
and ROS 1 payloads, and single values of map arrays -- and run ``aion build`` / ``aion info``
on the log mutants (exit 0 or 2, never 1).

The cases run in ``tests/robustness/fuzz_worker.py`` subprocesses (an address-space limit turns
a runaway allocation into a MemoryError; a per-case timer catches hangs). The default run tries
a few hundred inputs in all; ``AION_FUZZ_LONG=1`` adds the long run (thousands). Each test
prints the number of inputs tried (``pytest -s`` shows them).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import (
    T0,
    S,
    build_json,
    graph_payload,
    robot_tf,
    scene_graph,
    walk,
    write_log,
)

LONG = os.environ.get("AION_FUZZ_LONG", "") not in ("", "0")
# no result after this long is a hang (a damaged scene graph can legitimately take ~11 s: spark_dsg
# allocates gigabytes for a corrupt length, see docs/ROBUSTNESS.md)
CASE_TIMEOUT_S = 30.0
LOG_CONTAINERS = {
    "a.mcap": "mcap",
    "b.mcap": "mcap-ros1",
    "c.bag": "bag",
    "d_r2": "rosbag2-sqlite3",
    "e_r2": "rosbag2-mcap",
}

# target -> (cases in the default run, cases in the long run). The *_fields / map_values
# targets mutate lengths, counts and times (structure-aware, see fuzz_worker.py).
BUDGET = {
    "logs": (40, 3000),
    "detections": (80, 5000),
    "dsg": (30, 1000),
    "read_map": (40, 3000),
    "load_map": (40, 3000),
    "log_fields": (30, 3000),
    "payload_fields": (80, 5000),
    "map_values": (30, 3000),
}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Path]]:
    """Small valid inputs: one log per container (people, TF, a scene graph), a map of it, and
    a map of two days (a closed day: the week sums of format 2.2; a pending one: provisional
    scores), so that the map targets mutate every member a map can hold."""
    from tests.cli.logdata import write_office_log

    folder = tmp_path_factory.mktemp("fuzz_seeds")
    msgs = sorted(
        [
            *walk(40),
            *[robot_tf(T0 + 5 * k * S) for k in range(8)],
            scene_graph(T0 + 1, graph_payload()),
        ],
        key=lambda m: m[3],
    )
    logs = [write_log(folder / name, msgs, c) for name, c in LOG_CONTAINERS.items()]
    build_json(logs[0], "-o", folder / "m.aion")
    days = [folder / "day0.mcap", folder / "day1.mcap"]
    for k, day in enumerate(days):
        write_office_log(day, shift_s=k * 86_400, duration_s=2 * 3600)
    build_json(*days, "-o", folder / "days.aion")
    return {"logs": logs, "maps": [folder / "m.aion", folder / "days.aion"]}


def fuzz(target: str, seed: int, cases: int, files: list[Path]) -> dict[str, Any]:
    """Run the worker; fail on any untyped exception or hang; return its summary."""
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "tests.robustness.fuzz_worker",
            target,
            str(seed),
            str(cases),
            str(CASE_TIMEOUT_S),
            *map(str, files),
        ],
        capture_output=True,
        text=True,
        timeout=60 + cases * CASE_TIMEOUT_S,
        check=False,
        cwd=Path(__file__).resolve().parents[2],
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    print(
        f"fuzz {target}: {summary['cases']} inputs tried, {summary['accepted']} read, "
        f"{summary['typed_errors']} typed errors, {len(summary['failures'])} failures"
    )
    assert summary["failures"] == [], "\n".join(summary["failures"][:10])
    assert summary["accepted"] + summary["typed_errors"] == cases
    return summary


def _files(target: str, seeds: dict[str, list[Path]]) -> list[Path]:
    if target in ("logs", "log_fields"):
        return seeds["logs"]
    if target in ("read_map", "load_map", "map_values"):
        return seeds["maps"]
    return []


@pytest.mark.parametrize("target", sorted(BUDGET))
def test_fuzz_short(target: str, seeds: dict[str, list[Path]]) -> None:
    summary = fuzz(target, 20261122, BUDGET[target][0], _files(target, seeds))
    # the mutants reach both outcomes: the fuzzer is not only feeding hopeless garbage
    assert summary["typed_errors"] > 0
    if target != "read_map":
        assert summary["accepted"] > 0


@pytest.mark.fuzz_long
@pytest.mark.skipif(not LONG, reason="the long fuzz run: set AION_FUZZ_LONG=1")
@pytest.mark.parametrize("target", sorted(BUDGET))
def test_fuzz_long(target: str, seeds: dict[str, list[Path]]) -> None:
    fuzz(target, 7, BUDGET[target][1], _files(target, seeds))


def test_the_worker_reports_untyped_exceptions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The harness can fail: a reader that raises a plain exception is reported as a failure."""
    import signal

    from tests.robustness import fuzz_worker

    bad = tmp_path / "x.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n")

    def broken(path: Path) -> int:
        raise RuntimeError("untyped")

    monkeypatch.setattr(fuzz_worker, "_read_log", broken)
    handler = signal.getsignal(signal.SIGALRM)
    try:
        summary = fuzz_worker.run_cases("logs", 1, 3, 5.0, [bad])
    finally:
        signal.signal(signal.SIGALRM, handler)
    assert len(summary["failures"]) == 3
    assert "RuntimeError: untyped" in summary["failures"][0]


def test_the_field_walkers_find_the_real_fields(seeds: dict[str, list[Path]]) -> None:
    """The structure-aware mutations hit the fields they claim to: the message times inside
    an MCAP chunk (rewritten with a valid CRC, the reader sees the new time), a bag's message
    record times, a CDR payload's sequence count."""
    import io
    import random

    from tests.robustness import fuzz_worker as fw

    mcap_log, bag_log = seeds["logs"][0], seeds["logs"][2]
    data = mcap_log.read_bytes()
    kinds = {f.kind for f in fw.mcap_fields(data)}
    assert kinds == {"length", "time"}

    class Far(random.Random):  # every choice: the largest int64 time
        def choice(self, seq: Any) -> Any:
            times = [x for x in seq if isinstance(x, fw.Field) and x.kind == "time"]
            return times[0] if times else (2**63 - 1 if isinstance(seq[0], int) else seq[0])

    mutant = fw.mutate_mcap_chunk(data, Far(1))
    assert mutant is not None

    def log_times(raw: bytes) -> list[int]:  # a linear read: the chunk's offsets moved
        from mcap.records import Message
        from mcap.stream_reader import StreamReader

        records = StreamReader(io.BytesIO(raw), validate_crcs=True).records
        return sorted(r.log_time for r in records if isinstance(r, Message))

    before, after = log_times(data), log_times(mutant)
    assert len(after) == len(before)
    assert after[-1] == 2**63 - 1
    assert after[:-1] == before[1:]  # the first message's log time, now 2^63 - 1
    bag = bag_log.read_bytes()
    seconds = {fw._u(bag, f.offset, 4) for f in fw.bag_fields(bag) if f.kind == "time32"}
    assert T0 // S in seconds  # the first person's message time
    payload = fw.detection_seeds()[0]  # TrackedPersons in CDR with 3 tracks
    fields = fw.payload_fields(payload.data, True)
    assert [f for f in fields if fw._u(payload.data, f.offset, 4) == 3]  # the count
