"""Mutation fuzzing of aion's readers, run in a subprocess by ``test_fuzz.py``.

``python -m tests.robustness.fuzz_worker TARGET SEED CASES TIMEOUT SEEDFILE...`` mutates the
valid seed files (or, for ``detections`` and ``dsg``, payloads it builds itself) ``CASES``
times, feeds each mutant to the target, and prints one JSON line: cases tried, how many were
accepted, how many raised a typed aion error, and the failures (any other exception, or a case
that ran longer than ``TIMEOUT`` seconds: a hang).

Mutations: truncation, 1-8 random bytes overwritten, one flipped bit, a span overwritten with
junk, a span deleted or duplicated. Maps are also mutated *inside* the zip (the manifest text,
or an array member with its checksum updated), so the checks behind the zip CRC are reached.

A subprocess, because a mutant may make a C++ reader (spark_dsg) allocate without bound: the
worker runs under an address-space limit, so that becomes a MemoryError (which aion must turn
into a typed error) instead of a machine out of memory.
"""

from __future__ import annotations

import hashlib
import json
import random
import resource
import shutil
import signal
import sys
import tempfile
import traceback
import zipfile
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

MEMORY_LIMIT = 3 * 1024**3


class CaseTimeoutError(Exception):
    """A case ran past its time limit."""


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeoutError


# -- mutations -------------------------------------------------------------------------------


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One random structural mutation of ``data``."""
    if not data:
        return bytes([rng.randrange(256)])
    d = bytearray(data)
    kind = rng.randrange(6)
    n = len(d)
    if kind == 0:
        return bytes(d[: rng.randrange(n)])
    if kind == 1:
        for _ in range(rng.randrange(1, 9)):
            d[rng.randrange(n)] = rng.randrange(256)
    elif kind == 2:
        d[rng.randrange(n)] ^= 1 << rng.randrange(8)
    elif kind == 3:
        at = rng.randrange(n)
        span = min(rng.randrange(1, 65), n - at)
        d[at : at + span] = bytes(rng.randrange(256) for _ in range(span))
    elif kind == 4:
        at = rng.randrange(n)
        del d[at : at + rng.randrange(1, 65)]
    else:
        at = rng.randrange(n)
        d[at:at] = d[at : at + rng.randrange(1, 65)]
    return bytes(d)


def _rezip(contents: dict[str, bytes], path: Path) -> None:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)


def mutate_map(seed: Path, rng: random.Random, out: Path) -> None:
    """A mutant map: raw bytes, the manifest text, or an array member whose checksum and size
    in the manifest are updated to match (so the deeper checks run)."""
    kind = rng.randrange(3)
    if kind == 0:
        out.write_bytes(mutate(seed.read_bytes(), rng))
        return
    with zipfile.ZipFile(seed) as zin:
        contents = {name: zin.read(name) for name in zin.namelist()}
    if kind == 1:
        contents["manifest.json"] = mutate(contents["manifest.json"], rng)
    else:
        name = rng.choice(sorted(n for n in contents if n.endswith(".npy")))
        data = mutate(contents[name], rng)
        contents[name] = data
        manifest = json.loads(contents["manifest.json"])
        rec = manifest["members"][name[: -len(".npy")]]
        rec["sha256"] = hashlib.sha256(data).hexdigest()
        rec["size"] = len(data)
        contents["manifest.json"] = json.dumps(manifest).encode()
    _rezip(contents, out)


# -- targets ---------------------------------------------------------------------------------


def _read_log(path: Path) -> int:
    """open_logs + every message + decoding the first 20: what ``aion build`` reads."""
    from formats.logs import open_logs

    n = 0
    with open_logs([path]) as logset:
        _ = logset.topics, logset.start_ns, logset.end_ns
        for msg in logset.messages():
            if n < 20:
                logset.decode(msg)
            n += 1
    return n


def _mutant_log(seed: Path, rng: random.Random, work: Path) -> Path:
    """A copy of the seed log (file or rosbag2 folder) with one file mutated."""
    if seed.is_dir():
        target = work / seed.name
        shutil.copytree(seed, target)
        files = sorted(p for p in target.iterdir() if p.is_file())
        victim = rng.choice(files)
        victim.write_bytes(mutate(victim.read_bytes(), rng))
        return target
    target = work / seed.name
    target.write_bytes(mutate(seed.read_bytes(), rng))
    return target


def detection_seeds() -> list[Any]:
    """One RawMessage per fast-decoded type and encoding, with several people each."""
    from formats.raw import RawMessage
    from formats.writers import LogWriter

    person = {
        "track_id": 3,
        "pose": {"pose": {"position": {"x": 1.0, "y": 2.0, "z": 0.0}, "orientation": {"w": 1.0}}},
        "twist": {"twist": {"linear": {"x": 1.0}}},
    }
    header = {"stamp": {"sec": 1_795_420_800, "nanosec": 5}, "frame_id": "map"}
    pose = {"position": {"x": 1.0, "y": 2.0, "z": 0.0}, "orientation": {"w": 1.0}}
    messages = {
        "spencer_tracking_msgs/msg/TrackedPersons": {"header": header, "tracks": [person] * 3},
        "geometry_msgs/msg/PoseArray": {"header": header, "poses": [pose] * 3},
        "people_msgs/msg/People": {
            "header": header,
            "people": [{"name": "a", "position": {"x": 1.0}, "velocity": {"x": 1.0}}] * 3,
        },
        "vision_msgs/msg/Detection3DArray": {
            "header": header,
            "detections": [{"header": header, "bbox": {"center": pose}}] * 2,
        },
    }
    seeds = []
    with tempfile.TemporaryDirectory() as tmp:
        for container, encoding in (("mcap", "cdr"), ("mcap-ros1", "ros1")):
            with LogWriter(Path(tmp) / f"{container}.mcap", container) as writer:
                for msgtype, msg in messages.items():
                    data = writer.serialize(msgtype, msg)
                    seeds.append(RawMessage("/d", msgtype, 1_795_420_800 * 10**9, data, encoding))
    return seeds


def _decode_detections(raw: Any) -> int:
    from formats.detections import adapter_for

    adapter = adapter_for(raw.msgtype)
    assert adapter is not None
    frames = adapter.decode([raw, raw])
    return len(frames)


def dsg_seed() -> bytes:
    from tests.cli.logdata import build_graph

    return bytes(build_graph().to_binary(False))


def run_cases(
    target: str, seed: int, cases: int, timeout: float, files: list[Path]
) -> dict[str, Any]:
    """Run ``cases`` mutants through ``target``; the summary dict printed as JSON."""
    from aion_cli.engine.errors import AionError

    rng = random.Random(seed)
    step: Callable[[random.Random, Path], Any]
    if target == "logs":

        def step(r: random.Random, work: Path) -> Any:
            return _read_log(_mutant_log(r.choice(files), r, work))

    elif target == "detections":
        from dataclasses import replace

        payloads = detection_seeds()

        def step(r: random.Random, work: Path) -> Any:
            raw = r.choice(payloads)
            return _decode_detections(replace(raw, data=mutate(raw.data, r)))

    elif target == "dsg":
        from formats.dsg import decode_dsg, installed_version

        graph = dsg_seed()
        native = installed_version()

        def step(r: random.Random, work: Path) -> Any:
            # mostly the native version (one spark_dsg load per case); every 8th case the full
            # fallback over older versions (nine loads)
            version = None if r.randrange(8) == 0 else native
            return decode_dsg(mutate(graph, r), 0, version)

    elif target in ("read_map", "load_map"):
        from aion_cli.pipeline import load_map
        from formats.mapfile import read_map

        def step(r: random.Random, work: Path) -> Any:
            out = work / "mutant.aion"
            mutate_map(r.choice(files), r, out)
            return read_map(out) if target == "read_map" else load_map(out)

    else:
        raise SystemExit(f"unknown target {target}")

    accepted = typed = 0
    failures: list[str] = []
    signal.signal(signal.SIGALRM, _alarm)
    for case in range(cases):
        with tempfile.TemporaryDirectory() as tmp:
            case_rng = random.Random(rng.getrandbits(64))
            signal.setitimer(signal.ITIMER_REAL, timeout)
            try:
                step(case_rng, Path(tmp))
                accepted += 1
            except AionError:
                typed += 1
            except CaseTimeoutError:
                failures.append(f"case {case}: no result after {timeout} s (hang)")
            except Exception as exc:
                tail = traceback.format_exception(exc)[-3:]
                failures.append(f"case {case}: {type(exc).__name__}: {exc} | {''.join(tail)}")
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
    return {
        "target": target,
        "cases": cases,
        "accepted": accepted,
        "typed_errors": typed,
        "failures": failures,
    }


def main(argv: list[str]) -> None:
    target, seed, cases, timeout, *files = argv
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    summary = run_cases(target, int(seed), int(cases), float(timeout), [Path(f) for f in files])
    sys.stdout.write(json.dumps(summary) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
