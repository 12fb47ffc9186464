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
CHUNK_INFO = 0x06  # ... and of a chunk's info (its start and end time) in the bag's index


def _fields(header: bytes) -> dict[bytes, bytes]:
    out, i = {}, 0
    while i < len(header):
        (n,) = struct.unpack_from("<I", header, i)
        key, value = header[i + 4 : i + 4 + n].split(b"=", 1)
        out[key] = value
        i += 4 + n
    return out


def _records(data: bytearray) -> list[tuple[int, int, int, dict[bytes, bytes]]]:
    """(op, header start, data start, header fields) of every record after the magic."""
    out, pos = [], 13  # after "#ROSBAG V2.0\n"
    while pos < len(data):
        (head,) = struct.unpack_from("<I", data, pos)
        fields = _fields(bytes(data[pos + 4 : pos + 4 + head]))
        (size,) = struct.unpack_from("<I", data, pos + 4 + head)
        out.append((fields[b"op"][0], pos + 4, pos + 8 + head, fields))
        pos += 8 + head + size
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


def test_a_chunk_info_that_starts_late_leaves_the_index_as_it_is(tmp_path: Path) -> None:
    """The other damage: the chunk info's start time moved 20 ms later, so the chunk's first
    few index entries (a minority) lie before it. Their message records keep the index's
    times: nothing is repaired and nothing is said of damaged entries."""
    original = real("logs", "leg_tracker", "positive_2_extracted.bag")
    data = bytearray(original.read_bytes())
    ((_, head, _, fields),) = [r for r in _records(data) if r[0] == CHUNK_INFO]
    sec, nsec = struct.unpack("<II", fields[b"start_time"])
    nsec += 20_000_000
    sec, nsec = sec + nsec // 1_000_000_000, nsec % 1_000_000_000
    at = bytes(data).index(b"start_time=", head) + len(b"start_time=")
    data[at : at + 8] = struct.pack("<II", sec, nsec)
    late = tmp_path / "late.bag"
    late.write_bytes(bytes(data))
    want = run_json("info", original, "--format", "json")
    got = run_json("info", late, "--format", "json")
    for key in ("start_ns", "end_ns", "messages"):
        assert got[key] == want[key], key
    assert not [w for w in got["warnings"] if "damaged index entry" in w]


def test_a_connection_id_of_2_30_in_the_index_is_read_without_a_table_that_long(
    tmp_path: Path,
) -> None:
    """The connection record of the bag's index for the scene-graph topic names connection
    2^30 (one damaged byte, found by the long fuzz run of stop 66, target log_fields): the
    index times were looked up in a table as long as the largest id, 4 GiB (``aion info``:
    ``internal error: MemoryError``). Now the bag reads as rosbags reads it: that
    connection's one message, which its index no longer finds, is lost with a warning that
    says so; every other message is read, byte for byte the written ones."""
    from aion_cli.formats.logs import open_logs
    from tests.robustness.conftest import (
        DSG_TOPIC,
        T0,
        S,
        graph_payload,
        robot_tf,
        run,
        scene_graph,
        walk,
        write_log,
    )

    msgs = [*walk(20), *[robot_tf(T0 + 5 * k * S) for k in range(4)],
            scene_graph(T0 + 1, graph_payload())]
    bag = write_log(tmp_path / "b.bag", sorted(msgs, key=lambda m: m[3]), "bag")
    with open_logs([bag]) as logs:
        whole = sorted((m.topic, m.log_time_ns, m.data) for m in logs.messages())
    data = bytearray(bag.read_bytes())
    (conn,) = [r for r in _records(data) if r[0] == 0x07 and r[3][b"topic"] == DSG_TOPIC.encode()]
    at = bytes(data[conn[1] : conn[2]]).index(b"conn=") + conn[1] + len(b"conn=")
    struct.pack_into("<I", data, at, 2**30)
    bag.write_bytes(bytes(data))
    with open_logs([bag]) as logs:
        got = sorted((m.topic, m.log_time_ns, m.data) for m in logs.messages())
        warnings = logs.warnings
    assert got == [m for m in whole if m[0] != DSG_TOPIC]
    assert any("1 message cannot be found" in w for w in warnings)
    for command in (["info", bag], ["build", bag, "-o", tmp_path / "m.aion", "-q"]):
        result = run(*command)
        assert result.exit_code == 0, result.stderr
