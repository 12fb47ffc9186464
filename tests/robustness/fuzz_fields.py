"""Structure-aware mutations for the fuzz worker (``fuzz_worker.py``; its targets
``log_fields``, ``payload_fields`` and ``map_values``): one *field* is changed instead of
random bytes, to values chosen to hurt: a length, count or size (0, one off, doubled,
2^31 - 1, all ones, ...) or a time (0, the far future, 2^63 - 1, 2^64 - 1, a day later, ...).

Fields are found by walking the container: every MCAP record's length, the string and map
lengths, chunk sizes, message / chunk / statistics times, message-index entries, the records
*inside* a chunk (decompressed, mutated, recompressed with a valid CRC); ROS 1 bag record
header and data lengths, header field lengths, ``index_pos``, counts, chunk sizes and the
``time`` / ``start_time`` / ``end_time`` fields (inside uncompressed chunks too); rosbag2
``metadata.yaml`` times and counts and sqlite message timestamps; the sequence counts, string
lengths and header stamps of CDR and ROS 1 payloads; single array values of a map (negative,
NaN, inf, huge, an index past the end) with valid checksums.
"""

from __future__ import annotations

import json
import random
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tests.formats.map_damage import declare_member
from tests.robustness.fuzz_mutate import _rezip, mutate


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
        declare_member(rec, data)
    contents["manifest.json"] = json.dumps(manifest).encode()
    _rezip(contents, out)
