"""Mutation fuzzing of aion's readers, run in a subprocess by ``test_fuzz.py``.

``python -m tests.robustness.fuzz_worker TARGET SEED CASES TIMEOUT SEEDFILE...`` mutates the
valid seed files (or, for ``detections`` and ``dsg``, payloads it builds itself) ``CASES``
times, feeds each mutant to the target, and prints one JSON line: cases tried, how many were
accepted, how many raised a typed aion error, and the failures (any other exception, or a case
that ran longer than ``TIMEOUT`` seconds: a hang).

Mutations: truncation, 1-8 random bytes overwritten, one flipped bit, a span overwritten with
junk, a span deleted or duplicated. Maps are also mutated *inside* the zip (the manifest text,
or an array member with its checksum updated), so the checks behind the zip CRC are reached.

Structure-aware mutations (targets ``log_fields``, ``payload_fields``, ``map_values``) change
one *field* instead of random bytes, to values chosen to hurt: a length, count or size (0, one
off, doubled, 2^31 - 1, all ones, ...) or a time (0, the far future, 2^63 - 1, 2^64 - 1, a day
later, ...). Fields are found by walking the container: every MCAP record's length, the string
and map lengths, chunk sizes, message / chunk / statistics times, message-index entries, the
records *inside* a chunk (decompressed, mutated, recompressed with a valid CRC); ROS 1 bag
record header and data lengths, header field lengths, ``index_pos``, counts, chunk sizes and
the ``time`` / ``start_time`` / ``end_time`` fields (inside uncompressed chunks too); rosbag2
``metadata.yaml`` times and counts and sqlite message timestamps; the sequence counts, string
lengths and header stamps of CDR and ROS 1 payloads; single array values of a map (negative,
NaN, inf, huge, an index past the end) with valid checksums. ``log_fields`` mutants also go
through the command line (``aion build`` and ``aion info`` in-process: exit 0 or 2 only), and
a ``map_values`` mutant that loads must give finite, non-negative historical flows.

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
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

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


# -- structure-aware mutations: lengths, counts and times ------------------------------------


@dataclass(frozen=True)
class Field:
    """A field of a container: ``width`` little-endian bytes at ``offset``; ``kind`` is
    ``length`` (a length, count, size or offset), ``time`` (uint64 ns) or ``time32`` (ROS 1
    uint32 seconds)."""

    offset: int
    width: int
    kind: str


def interesting(old: int, width: int, kind: str, rng: random.Random) -> int:
    """A replacement for a field's value ``old`` that is likely to hurt."""
    top = (1 << (8 * width)) - 1
    day = 86_400 * (10**9 if kind == "time" else 1)
    if kind == "length":
        choices = [0, 1, old - 1, old + 1, 2 * old, old + rng.randrange(1, 1 << 12),
                   (1 << (8 * width - 1)) - 1, top, 1 << (8 * width - 2),
                   rng.getrandbits(8 * width)]
    else:
        choices = [0, 1, old - 1, old + day, old + 365 * day, old // 2, 2 * old,
                   (1 << (8 * width - 1)) - 1, 1 << (8 * width - 1), top, old - day]
    return min(max(rng.choice(choices), 0), top)


def set_field(data: bytes, field: Field, rng: random.Random) -> bytes:
    """``data`` with ``field`` set to an :func:`interesting` value."""
    a, b = field.offset, field.offset + field.width
    old = int.from_bytes(data[a:b], "little")
    new = interesting(old, field.width, field.kind, rng)
    return data[:a] + new.to_bytes(field.width, "little") + data[b:]


def _u(data: bytes, at: int, width: int) -> int:
    return int.from_bytes(data[at : at + width], "little")


class _Fields:
    """Collects fields while walking a record body (``at`` moves on)."""

    def __init__(self, data: bytes, at: int, end: int) -> None:
        self.data, self.at, self.end = data, at, end
        self.out: list[Field] = []

    def take(self, width: int, kind: str | None) -> int:
        value = _u(self.data, self.at, width) if self.at + width <= self.end else 0
        if kind is not None and self.at + width <= self.end:
            self.out.append(Field(self.at, width, kind))
        self.at += width
        return value

    def string(self) -> None:  # uint32 byte length + bytes (strings, byte arrays, maps)
        self.at += self.take(4, "length")


# MCAP record bodies: each entry is (width, kind) for a fixed field, or "str" for a uint32
# length-prefixed string / bytes / map. Message indexes and chunk records are walked apart.
_MCAP_LAYOUTS: dict[int, list[Any]] = {
    0x01: ["str", "str"],  # Header: profile, library
    0x02: [(8, "length"), (8, "length")],  # Footer: summary start, summary offset start
    0x03: [(2, None), "str", "str", "str"],  # Schema: id, name, encoding, data
    0x04: [(2, None), (2, None), "str", "str", "str"],  # Channel: ids, topic, encoding, meta
    0x05: [(2, None), (4, None), (8, "time"), (8, "time")],  # Message: log / publish time
    0x08: [(8, "time"), (8, "time"), (8, "length"), (8, "length"), "str", (8, "length"),
           "str", (8, "length"), (8, "length")],  # ChunkIndex
    0x0B: [(8, "length"), (2, "length"), (4, "length"), (4, "length"), (4, "length"),
           (4, "length"), (8, "time"), (8, "time"), "str"],  # Statistics
    0x0E: [(1, None), (8, "length"), (8, "length")],  # SummaryOffset
}


def _mcap_records(data: bytes, start: int, end: int) -> list[Field]:
    """The fields of the MCAP records in ``data[start:end]`` (records inside uncompressed
    chunks included)."""
    out: list[Field] = []
    p = start
    while p + 9 <= end:
        op, length = data[p], _u(data, p + 1, 8)
        body, stop = p + 9, p + 9 + length
        if stop > end:
            break
        out.append(Field(p + 1, 8, "length"))
        f = _Fields(data, body, stop)
        if op == 0x06:  # Chunk: times, sizes, compression, records
            f.take(8, "time"), f.take(8, "time"), f.take(8, "length"), f.take(4, None)
            compression_len = f.take(4, "length")
            compression = data[f.at : f.at + compression_len]
            f.at += compression_len
            f.take(8, "length")
            if compression == b"":
                out.extend(_mcap_records(data, f.at, stop))
        elif op == 0x07:  # MessageIndex: channel, then (log time, offset) pairs
            f.take(2, None)
            f.take(4, "length")
            while f.at + 16 <= stop:
                f.take(8, "time"), f.take(8, "length")
        else:
            for item in _MCAP_LAYOUTS.get(op, []):
                if item == "str":
                    f.string()
                else:
                    f.take(*item)
        out.extend(f.out)
        p = stop
    return out


def mcap_fields(data: bytes) -> list[Field]:
    """Every length and time field of an MCAP file (after its 8-byte magic)."""
    return _mcap_records(data, 8, len(data))


def mutate_mcap_chunk(data: bytes, rng: random.Random) -> bytes | None:
    """One field of the records *inside* a compressed chunk changed; the chunk recompressed
    with its sizes and CRC made right (so the reader trusts it). None: no such chunk."""
    import zlib

    chunks = []
    p = 8
    while p + 9 <= len(data):
        op, length = data[p], _u(data, p + 1, 8)
        if op == 0x06:
            chunks.append((p, length))
        p += 9 + length
    if not chunks:
        return None
    p, length = rng.choice(chunks)
    body = p + 9
    comp_len = _u(data, body + 28, 4)
    compression = data[body + 32 : body + 32 + comp_len].decode("ascii", "replace")
    records_at = body + 32 + comp_len + 8
    compressed = data[records_at : body + length]
    try:
        raw = _decompress(compression, compressed, _u(data, body + 16, 8))
    except Exception:
        return None
    fields = _mcap_records(raw, 0, len(raw))
    if not fields:
        return None
    raw = set_field(raw, rng.choice(fields), rng)
    packed = _compress(compression, raw)
    head = bytearray(data[body : records_at])
    head[16:24] = len(raw).to_bytes(8, "little")
    head[24:28] = (zlib.crc32(raw) & 0xFFFFFFFF).to_bytes(4, "little")
    head[-8:] = len(packed).to_bytes(8, "little")
    record = bytes([0x06]) + (len(head) + len(packed)).to_bytes(8, "little") + head + packed
    return data[:p] + record + data[body + length :]


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if compression == "zstd":
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == "lz4":
        import lz4.frame

        return bytes(lz4.frame.decompress(data))
    return data


def _compress(compression: str, data: bytes) -> bytes:
    if compression == "zstd":
        import zstandard

        return zstandard.ZstdCompressor().compress(data)
    if compression == "lz4":
        import lz4.frame

        return bytes(lz4.frame.compress(data))
    return data


_BAG_FIELDS = {
    b"index_pos": (8, "length"), b"conn_count": (4, "length"), b"chunk_count": (4, "length"),
    b"size": (4, "length"), b"count": (4, "length"), b"chunk_pos": (8, "length"),
    b"conn": (4, "length"), b"time": (4, "time32"), b"start_time": (4, "time32"),
    b"end_time": (4, "time32"),
}


def bag_fields(data: bytes, start: int | None = None, end: int | None = None) -> list[Field]:
    """Every record length, header-field length, count, size, position and time of a ROS 1
    bag (records inside uncompressed chunks included; index entries' times too)."""
    p = len(b"#ROSBAG V2.0\n") if start is None else start
    end = len(data) if end is None else end
    out: list[Field] = []
    while p + 8 <= end:
        header_len = _u(data, p, 4)
        out.append(Field(p, 4, "length"))
        h, h_end = p + 4, p + 4 + header_len
        if h_end + 4 > end:
            break
        op, compression = None, b""
        while h + 4 <= h_end:
            field_len = _u(data, h, 4)
            out.append(Field(h, 4, "length"))
            name, _, value = data[h + 4 : h + 4 + field_len].partition(b"=")
            at = h + 4 + len(name) + 1
            if name == b"op" and value:
                op = value[0]
            if name == b"compression":
                compression = value
            if name in _BAG_FIELDS and at + _BAG_FIELDS[name][0] <= h_end:
                out.append(Field(at, *_BAG_FIELDS[name]))
            h += 4 + field_len
        data_len = _u(data, h_end, 4)
        out.append(Field(h_end, 4, "length"))
        d, d_end = h_end + 4, h_end + 4 + data_len
        if d_end > end:
            break
        if op == 0x05 and compression == b"none":
            out.extend(bag_fields(data, d, d_end))
        elif op == 0x04:  # index data: (sec, nsec, offset) entries
            out.extend(Field(q, 4, "time32") for q in range(d, d_end - 11, 12))
        p = d_end
    return out


def payload_fields(data: bytes, cdr: bool) -> list[Field]:
    """Likely count and length fields of a serialized message (uint32 values below 4096 at
    4-aligned payload offsets for CDR, at any offset for ROS 1) and its header stamp."""
    base = 4 if cdr else 0
    step = 4 if cdr else 1
    out = [Field(4, 4, "time32")]  # the header stamp's seconds (after ROS 1's seq)
    for at in range(base, len(data) - 3, step):
        if _u(data, at, 4) < 4096:
            out.append(Field(at, 4, "length"))
    return out


def mutate_fields(data: bytes, fields: list[Field], rng: random.Random) -> bytes:
    """One random field set to an interesting value, or a byte mutation if there is none."""
    return set_field(data, rng.choice(fields), rng) if fields else mutate(data, rng)


def mutate_rosbag2(folder: Path, rng: random.Random) -> None:
    """A time or count of a rosbag2 folder changed: a number of ``metadata.yaml`` (starting
    time, duration, message counts), a message timestamp in the sqlite3 storage, or a field
    of an mcap storage file."""
    import re
    import sqlite3

    files = sorted(q for q in folder.iterdir() if q.is_file())
    victim = rng.choice(files)
    if victim.name == "metadata.yaml":
        text = victim.read_text()
        numbers = list(re.finditer(r"(?<=: )\d+", text))
        if numbers:
            m = rng.choice(numbers)
            value = interesting(int(m.group()), 8, rng.choice(["time", "length"]), rng)
            if rng.randrange(4) == 0:
                value = -value
            victim.write_text(text[: m.start()] + str(value) + text[m.end() :])
        return
    if victim.suffix == ".db3":
        with sqlite3.connect(victim) as db:
            rows = [r[0] for r in db.execute("SELECT id FROM messages")]
            if rows:
                value = interesting(10**18, 8, "time", rng) - (1 << 63) * rng.randrange(2)
                value = max(min(value, (1 << 63) - 1), -(1 << 63))
                db.execute("UPDATE messages SET timestamp=? WHERE id=?", (value, rng.choice(rows)))
        return
    data = victim.read_bytes()
    victim.write_bytes(mutate_fields(data, mcap_fields(data), rng) if data[:8] == _MCAP
                       else mutate(data, rng))


_MCAP = b"\x89MCAP0\r\n"


def mutate_log_fields(seed: Path, rng: random.Random, work: Path) -> Path:
    """A copy of the seed log with one length, count or time field changed (see above)."""
    target = work / seed.name
    if seed.is_dir():
        shutil.copytree(seed, target)
        mutate_rosbag2(target, rng)
        return target
    data = seed.read_bytes()
    if data[:8] == _MCAP:
        chunk = mutate_mcap_chunk(data, rng) if rng.randrange(2) else None
        data = chunk if chunk is not None else mutate_fields(data, mcap_fields(data), rng)
    else:
        data = mutate_fields(data, bag_fields(data), rng)
    target.write_bytes(data)
    return target


def interesting_value(dtype: np.dtype[Any], size: int, rng: random.Random) -> Any:
    """A value for one element of a map array (``size`` elements) that a valid map never
    holds there, or holds only at the edge."""
    if dtype.kind == "f":
        return rng.choice([-1.0, -1e300, np.nan, np.inf, -np.inf, 1e300, -0.0, 2.0**53])
    if dtype.kind == "c":
        return rng.choice([complex(np.nan, 0), complex(0, np.inf), complex(1e300, -1e300)])
    if dtype.kind == "b":
        return rng.choice([True, False])
    info = np.iinfo(dtype)
    return rng.choice([info.min, info.max, -1 if info.min < 0 else info.max, size, size + 1, 0])


def mutate_map_values(seed: Path, rng: random.Random, out: Path) -> None:
    """A map with one element of one array changed to an :func:`interesting_value`, or one
    state counter of its manifest, its checksums updated (only the load-time checks can
    catch it)."""
    import io

    with zipfile.ZipFile(seed) as zin:
        contents = {name: zin.read(name) for name in zin.namelist()}
    manifest = json.loads(contents["manifest.json"])
    members = [n for n in sorted(contents) if n.endswith(".npy")]
    arrays = {n: np.load(io.BytesIO(contents[n]), allow_pickle=False) for n in members}
    nonempty = [n for n in members if arrays[n].size]
    if rng.randrange(6) == 0 or not nonempty:
        state = manifest["state"]
        key = rng.choice(["accepted", "open_window", "log_time_ns"])
        state[key] = rng.choice([-1, 0, 2**62, 2**63 - 1, (state.get(key) or 0) + 1])
    else:
        name = rng.choice(nonempty)
        arr = np.array(arrays[name])
        index = tuple(rng.randrange(d) for d in arr.shape)
        arr[index] = interesting_value(arr.dtype, arr.shape[0], rng)
        buf = io.BytesIO()
        np.save(buf, arr, allow_pickle=False)
        data = buf.getvalue()
        contents[name] = data
        rec = manifest["members"][name[: -len(".npy")]]
        rec["sha256"] = hashlib.sha256(data).hexdigest()
        rec["size"] = len(data)
    contents["manifest.json"] = json.dumps(manifest).encode()
    _rezip(contents, out)


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
    from aion_cli.formats.logs import open_logs

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
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.writers import LogWriter

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


def _decode_detections(raw: Any, skip: bool = False) -> int:
    from aion_cli.formats.detections import adapter_for

    adapter = adapter_for(raw.msgtype)
    assert adapter is not None
    frames = adapter.decode([raw, raw], on_error="skip" if skip else "raise")
    return len(frames)


class CliExitError(Exception):
    """The command line exited with a code other than 0 and 2 (an internal error)."""


def _cli(*commands: list[Any]) -> int:
    """Run ``aion`` commands in-process; :class:`CliExitError` unless each exits 0 or 2 (the
    only codes bad input may give). Returns how many exited 0."""
    from click.testing import CliRunner

    from aion_cli.cli.main import cli

    ok = 0
    for args in commands:
        result = CliRunner().invoke(cli, [str(a) for a in args])
        if "CaseTimeoutError" in result.stderr:
            raise CaseTimeoutError
        if result.exit_code not in (0, 2):
            lines = result.stderr.strip().splitlines() or [repr(result.exception)]
            raise CliExitError(f"aion {args[0]} exited {result.exit_code}: {lines[0]}")
        ok += result.exit_code == 0
    return ok


def _query_map(path: Path) -> int:
    """``load_map`` and the historical table of a map: flows must be finite and >= 0."""
    from aion_cli.engine.query import historical_table
    from aion_cli.mapquery import load_map

    state = load_map(path).state
    table = historical_table(state)
    flow = np.asarray(table.flow, dtype=np.float64)
    if flow.size and not (np.isfinite(flow).all() and flow.min() >= 0):
        raise ValueError(f"a map that loads gave flows {flow.min()} .. {flow.max()}")
    return len(table)


def dsg_seed() -> bytes:
    from tests.cli.logdata import build_graph

    return bytes(build_graph().to_binary(False))


def _where(exc: BaseException) -> str:
    """The innermost frame of aion's own code an exception passed through (file:line func)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if "/formats/" in f.filename or "/aion_cli/" in f.filename]
    if not frames:
        return "no aion frame"
    f = frames[-1]
    return f"{Path(f.filename).parent.name}/{Path(f.filename).name}:{f.lineno} {f.name}"


def run_cases(
    target: str, seed: int, cases: int, timeout: float, files: list[Path]
) -> dict[str, Any]:
    """Run ``cases`` mutants through ``target``; the summary dict printed as JSON."""
    from aion_cli.errors import AionError

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
        from aion_cli.formats.dsg import decode_dsg, installed_version

        graph = dsg_seed()
        native = installed_version()

        def step(r: random.Random, work: Path) -> Any:
            # mostly the native version (one spark_dsg load per case); every 8th case the full
            # fallback over older versions (nine loads)
            version = None if r.randrange(8) == 0 else native
            return decode_dsg(mutate(graph, r), 0, version)

    elif target == "log_fields":

        def step(r: random.Random, work: Path) -> Any:
            log = mutate_log_fields(r.choice(files), r, work)
            _read_log(log)
            return _cli(["info", log], ["build", log, "-o", work / "out.aion", "-q"])

    elif target == "payload_fields":
        from dataclasses import replace

        payloads = detection_seeds()

        def step(r: random.Random, work: Path) -> Any:
            raw = r.choice(payloads)
            fields = payload_fields(raw.data, raw.encoding == "cdr")
            mutant = replace(raw, data=mutate_fields(raw.data, fields, r))
            _decode_detections(mutant)
            return _decode_detections(mutant, skip=True)

    elif target == "map_values":

        def step(r: random.Random, work: Path) -> Any:
            out = work / "mutant.aion"
            mutate_map_values(r.choice(files), r, out)
            return _query_map(out)

    elif target in ("read_map", "load_map"):
        from aion_cli.formats.mapfile import read_map
        from aion_cli.mapquery import load_map

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
                failures.append(
                    f"case {case}: {type(exc).__name__}: {exc} (raised through {_where(exc)}) | "
                    + "".join(tail)
                )
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
