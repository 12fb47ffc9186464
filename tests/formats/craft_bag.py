"""Hand-made ROS 1 bags, record by record, for tests of damaged and hostile containers
(:mod:`tests.formats.craft` does MCAP files): one connection whose messages come from a bag
written by :class:`formats.writers.LogWriter` (:func:`bag_topic`), in chunks crafted here
(:func:`craft_bag`) with a given compression, lying sizes, a bomb or a shuffled index.
"""

from __future__ import annotations

import bz2
import struct
from dataclasses import dataclass
from pathlib import Path

from tests.formats.craft import iter_pieces

# -- ROS 1 bags --------------------------------------------------------------------------------

BAG_MAGIC = b"#ROSBAG V2.0\n"


def _field(name: str, value: bytes) -> bytes:
    item = name.encode() + b"=" + value
    return struct.pack("<I", len(item)) + item


def bag_record(fields: dict[str, bytes], data: bytes) -> bytes:
    """One ROS 1 bag record: header length, ``name=value`` fields, data length, data."""
    header = b"".join(_field(k, v) for k, v in fields.items())
    return struct.pack("<I", len(header)) + header + struct.pack("<I", len(data)) + data


def _u32(v: int) -> bytes:
    return struct.pack("<I", v)


def _u64(v: int) -> bytes:
    return struct.pack("<Q", v)


def _time(t_ns: int) -> bytes:
    sec, nsec = divmod(t_ns, 10**9)
    return struct.pack("<II", sec, nsec)


@dataclass(frozen=True)
class BagTopic:
    """A connection of a crafted bag: topic, type, md5sum and message definition."""

    topic: str
    msgtype: str
    md5sum: str
    definition: str


def bag_topic(path: Path, topic: str) -> tuple[BagTopic, list[tuple[int, bytes]]]:
    """A connection of a bag written by LogWriter and its ``(log time, payload)`` messages."""
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        (conn,) = [c for c in reader.connections if c.topic == topic]
        assert conn.msgdef is not None
        msgs = [(t, bytes(d)) for _, t, d in reader.messages(connections=[conn])]
        msgtype = conn.msgtype.replace("/msg/", "/")
        return BagTopic(conn.topic, msgtype, conn.digest, conn.msgdef.data), msgs


def _connection(conn_id: int, topic: BagTopic) -> bytes:
    inner = b"".join(
        _field(k, v.encode())
        for k, v in (
            ("topic", topic.topic),
            ("type", topic.msgtype),
            ("md5sum", topic.md5sum),
            ("message_definition", topic.definition),
        )
    )
    return bag_record(
        {"op": b"\x07", "conn": _u32(conn_id), "topic": topic.topic.encode()}, inner
    )


def _msgdata(t_ns: int, payload: bytes) -> bytes:
    return bag_record({"op": b"\x02", "conn": _u32(0), "time": _time(t_ns)}, payload)


def craft_bag(
    topic: BagTopic,
    chunks: list[list[tuple[int, bytes]]],
    compression: str | list[str] = "none",
    *,
    declared_sizes: list[int | None] | None = None,
    bomb: tuple[int, int] | None = None,
    info_order: list[int] | None = None,
) -> bytes:
    """A ROS 1 bag of one connection whose messages are in ``chunks`` (lists of ``(log time,
    payload)``), compressed with ``compression`` (``none``, ``bz2`` or ``lz4``, or a list of
    those, one per chunk; any other name stores the records as they are under that name).
    ``declared_sizes``: per chunk, a ``size`` field other than the truth (None: the truth).
    ``bomb = (chunk, zeros)``: that chunk also holds one more message of ``zeros`` zero bytes,
    compressed piece by piece. ``info_order``: the chunks' order in the index (default: file
    order). An empty chunk has no index records, and a chunk info of no connection at the
    time the chunk before it ends."""
    out = bytearray(BAG_MAGIC) + bytes(4096)  # the bag header record, written last
    infos = []
    for k, msgs in enumerate(chunks):
        packing = compression if isinstance(compression, str) else compression[k]
        parts = [_connection(0, topic)]
        pos = len(parts[0])
        offsets = []
        for t, payload in msgs:
            rec = _msgdata(t, payload)
            offsets.append((t, pos))
            parts.append(rec)
            pos += len(rec)
        extra = bomb[1] if bomb is not None and bomb[0] == k else 0
        tail = b""
        if extra:
            t_bomb = msgs[-1][0] + 1 if msgs else 1
            tail = _msgdata(t_bomb, b"")[:-4] + _u32(extra)
            offsets.append((t_bomb, pos))
            pos += len(tail) + extra
        if packing == "lz4":
            import lz4.frame

            assert not extra, "bombs are bz2"
            data = bytearray(lz4.frame.compress(b"".join(parts)))
        elif packing == "bz2":
            comp = bz2.BZ2Compressor(9)
            data = bytearray()
            for part in parts:
                data += comp.compress(part)
            if extra:
                data += comp.compress(tail)
                for piece in iter_pieces(extra):
                    data += comp.compress(piece)
            data += comp.flush()
        else:
            assert not extra, "a bomb needs compression"
            data = bytearray(b"".join(parts))
        size = pos
        if declared_sizes is not None and declared_sizes[k] is not None:
            size = int(declared_sizes[k])  # type: ignore[arg-type]
        chunk_pos = len(out)
        out += bag_record(
            {"op": b"\x05", "compression": packing.encode(), "size": _u32(size)}, bytes(data)
        )
        if offsets:
            index = b"".join(_time(t) + _u32(off) for t, off in offsets)
            out += bag_record(
                {"op": b"\x04", "ver": _u32(1), "conn": _u32(0), "count": _u32(len(offsets))},
                index,
            )
        times = [t for t, _ in offsets] or [infos[-1][2] if infos else 0]
        infos.append((chunk_pos, min(times), max(times), len(offsets)))
    index_pos = len(out)
    out += _connection(0, topic)
    for k in info_order if info_order is not None else range(len(infos)):
        chunk_pos, start, end, count = infos[k]
        out += bag_record(
            {
                "op": b"\x06",
                "ver": _u32(1),
                "chunk_pos": _u64(chunk_pos),
                "start_time": _time(start),
                "end_time": _time(end),
                "count": _u32(1 if count else 0),
            },
            _u32(0) + _u32(count) if count else b"",
        )
    fields = {
        "op": b"\x03",
        "index_pos": _u64(index_pos),
        "conn_count": _u32(1),
        "chunk_count": _u32(len(chunks)),
    }
    pad = 4096 - len(bag_record(fields, b""))
    out[len(BAG_MAGIC) : len(BAG_MAGIC) + 4096] = bag_record(fields, b" " * pad)
    return bytes(out)
