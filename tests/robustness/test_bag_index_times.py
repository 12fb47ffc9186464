"""A ROS 1 bag whose index gives one message a time far outside its chunk (one flipped byte
of an IndexData record, in a copy of the real leg_tracker bag positive_2): ``aion info`` said
the bag ran from 1981 to 2015 (34 years, "a simulation's clock?") and ``aion build`` dropped
the message as a stray clock; rosbags stops its read there. The message record in the chunk
keeps the true time: it is used, with a warning that names the damaged entry, and the bag
reads as the undamaged original does."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from tests.cli.conftest import map_cells, run_json
from tests.shared_data import real

INDEX_DATA = 0x04  # ROS 1 bag record op of a chunk's per-connection index


def _fields(header: bytes) -> dict[bytes, bytes]:
    out, i = {}, 0
    while i < len(header):
        (n,) = struct.unpack_from("<I", header, i)
        key, value = header[i + 4 : i + 4 + n].split(b"=", 1)
        out[key] = value
        i += 4 + n
    return out


def _damage_entry(data: bytearray, entry: int) -> int:
    """Flip bit 30 of the seconds of index entry ``entry`` of the first IndexData record
    (entries: uint32 sec, uint32 nsec, uint32 offset); the entry's new time (ns)."""
    pos = 13  # after "#ROSBAG V2.0\n"
    while pos < len(data):
        (head,) = struct.unpack_from("<I", data, pos)
        fields = _fields(bytes(data[pos + 4 : pos + 4 + head]))
        (size,) = struct.unpack_from("<I", data, pos + 4 + head)
        start = pos + 8 + head
        if fields[b"op"][0] == INDEX_DATA:
            at = start + 12 * entry
            data[at + 3] ^= 0x40
            sec, nsec = struct.unpack_from("<II", data, at)
            return sec * 1_000_000_000 + nsec
        pos = start + size
    raise AssertionError("no IndexData record")


def test_an_index_entry_outside_its_chunk_takes_the_message_s_own_time(tmp_path: Path) -> None:
    original = real("logs", "leg_tracker", "positive_2_extracted.bag")
    data = bytearray(original.read_bytes())
    damaged_ns = _damage_entry(data, 10)
    damaged = tmp_path / "damaged.bag"
    damaged.write_bytes(bytes(data))

    want = run_json("info", original, "--format", "json")
    got = run_json("info", damaged, "--format", "json")
    assert damaged_ns < want["start_ns"] - 10 * 365 * 86400 * 10**9  # years before the bag
    for key in ("start_ns", "end_ns", "messages"):
        assert got[key] == want[key], key
    (said,) = [w for w in got["warnings"] if "damaged index entry" in w]
    assert said.startswith("damaged.bag: its index gives 1 message of the chunk at byte ")
    assert "the message's own time is used" in said

    args = ("--map-frame", "right_laser", "--workers", "1", "--format", "json")
    ok = run_json("build", original, "-o", tmp_path / "ok.aion", *args)
    repaired = run_json("build", damaged, "-o", tmp_path / "repaired.aion", *args)
    assert repaired["detections"] == ok["detections"]
    assert repaired["headings"] == ok["headings"]
    assert repaired["time_span"] == ok["time_span"]
    for a, b in zip(map_cells(tmp_path / "repaired.aion"), map_cells(tmp_path / "ok.aion"),
                    strict=True):  # fmt: skip
        np.testing.assert_array_equal(a, b)
