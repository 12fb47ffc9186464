"""ROS 1 bags whose index cannot be read, indexed in memory from their chunks, as
``rosbag reindex`` would.

A ROS 1 bag keeps its index (connection and chunk info records) at its end, and its header
says where. A recording that did not finish (a robot that lost power: the ``.bag.active``
file, ``index_pos`` 0), a copy cut short, or a damaged index leaves the chunks readable but
the bag unreadable to rosbags. :func:`reindex` walks the records from the bag header on,
reads every chunk (decompressed within the chunk cap), and fills the reader's connections,
per-connection index entries, chunk infos and chunks as rosbags' ``open`` would from the
index; it stops at a chunk the file cuts short, and skips a chunk whose data cannot be read.
"""

from __future__ import annotations

import io
import struct
from collections import defaultdict
from contextlib import suppress
from typing import Any

from rosbags.rosbag1.reader import (
    Chunk,
    ChunkInfo,
    Header,
    IndexData,
    ReaderError,
    RecordType,
    read_uint32,
)

from aion_cli.formats import limits as caps
from aion_cli.formats.bag_reader import BagReader, _no_decompressor
from aion_cli.number_text import counted

_MAGIC_LENGTH = len(b"#ROSBAG V2.0\n")
#: what a record that does not parse raises in rosbags' readers
_RECORD_ERRORS = (ReaderError, struct.error, KeyError, ValueError, UnicodeDecodeError)


def reindex(reader: BagReader, why: str) -> str:
    """Index ``reader``'s bag (open: ``reader.bio``) from its chunks; returns the warning
    that says so (``why``: why its own index could not be used, how many messages were
    found, where the read stopped). Raises ReaderError when no message can be read."""
    bio = reader.bio
    assert bio is not None
    size = bio.seek(0, io.SEEK_END)
    bio.seek(_MAGIC_LENGTH)
    Header.read(bio, RecordType.BAGHEADER)
    pos = bio.seek(read_uint32(bio), io.SEEK_CUR)
    connections: dict[int, Any] = {}
    indexes: dict[int, list[IndexData]] = defaultdict(list)
    found = (connections, indexes)
    stop: int | None = None
    skipped: list[tuple[int, str]] = []  # (position, why) of the chunks that cannot be read
    lost: dict[int, int] = defaultdict(int)  # per connection: messages their index records list
    cut_chunk = False  # the chunk at ``stop`` is cut short and its whole records were read
    after_chunk = -1  # the last record that is not an index data record
    while pos < size:
        bio.seek(pos)
        try:
            header = Header.read(bio)
            op = header.get_uint8("op")
            length = read_uint32(bio)
        except _RECORD_ERRORS:
            stop = pos
            break
        data_at = bio.tell()
        if data_at + length > size:  # a record the file cuts short
            stop = pos
            if op == RecordType.CHUNK and header.get_string("compression") == "none":
                with suppress(*_RECORD_ERRORS):  # what a recorder wrote of its last chunk
                    _read_chunk(reader, found, pos, header, data_at, size - data_at, part=True)
                    cut_chunk = True
            break
        if op == RecordType.IDXDATA:  # after a chunk: its messages per connection
            if skipped and skipped[-1][0] == after_chunk:
                with suppress(*_RECORD_ERRORS):
                    lost[header.get_uint32("conn")] += header.get_uint32("count")
        else:
            after_chunk = pos
        if op == RecordType.CHUNK:
            try:  # an uncompressed chunk gives the records it holds whole, as a cut one does
                plain = header.get_string("compression") == "none"
                _read_chunk(reader, found, pos, header, data_at, length, part=plain)
            except (*_RECORD_ERRORS, caps.ChunkError) as exc:
                skipped.append((pos, str(exc) or type(exc).__name__))
        elif op == RecordType.CONNECTION:  # the index's copies of the chunks' connections
            bio.seek(pos)
            with suppress(*_RECORD_ERRORS):
                conn = reader.read_connection()
                connections.setdefault(conn.id, conn)
        pos = data_at + length
    # (messages of a connection whose record was never met cannot be decoded: left out)
    reader.indexes = {cid: sorted(indexes[cid]) for cid in connections}
    messages = sum(len(entries) for entries in reader.indexes.values())
    if not messages:
        raise ReaderError(f"{why}; no message of its chunks could be read either")
    reader.connections = [
        conn._replace(msgcount=len(reader.indexes[cid]))
        for cid, conn in sorted(connections.items())
    ]
    chunks = len(reader.chunk_infos)
    text = (
        f"{reader.name}: {why}; indexed in memory from its {chunks:,} chunk"
        f"{'' if chunks == 1 else 's'}, as `rosbag reindex` would: {counted(messages, 'message')}"
    )
    if skipped:
        text += _skipped_text(skipped, lost, connections)
    if cut_chunk:
        text += f"; the file ends inside the chunk at byte {stop:,}: its whole messages are read"
    elif stop is not None:
        text += (
            f"; the record at byte {stop:,} is cut short or damaged: the {size - stop:,} bytes "
            "from there on are not read"
        )
    return text


def _skipped_text(
    skipped: list[tuple[int, str]], lost: dict[int, int], connections: dict[int, Any]
) -> str:
    """What the reindex warning says of the chunks that cannot be read: how many, where the
    first is and why, and the messages lost per topic as the index data records after them
    list them (a recorder writes one per connection after each chunk), as the warning of a
    skipped chunk of an indexed bag counts them."""
    n = len(skipped)
    pos, why = skipped[0]
    where = f"at byte {pos}" if n == 1 else f"the first at byte {pos}"
    text = f"; {n:,} chunk{'' if n == 1 else 's'} could not be read ({where}: {why})"
    counts = sorted(
        (connections[cid].topic if cid in connections else f"connection {cid}", k)
        for cid, k in lost.items()
        if k
    )
    if not counts:
        return text + ": the messages they hold are not counted (no index record follows them)"
    total = sum(k for _, k in counts)
    per = ", ".join(f"{name} {k:,}" for name, k in counts)
    return text + f": {total:,} message{'s' if total != 1 else ''} lost ({per})"


def _read_chunk(
    reader: BagReader,
    found: tuple[dict[int, Any], dict[int, list[IndexData]]],
    pos: int,
    header: Header,
    data_at: int,
    length: int,
    *,
    part: bool = False,
) -> None:
    """Index the chunk record at ``pos`` (``length`` data bytes from ``data_at``): its
    connections and messages (time, offset) go to ``found`` (connections by id, index
    entries per connection); ``part``: the file ends inside it, its whole records count."""
    connections, indexes = found
    compression = header.get_string("compression")
    declared = header.get_uint32("size") if "size" in header else 0
    bio = reader.bio
    assert bio is not None
    bio.seek(data_at)
    records = caps.decompress(
        bio.read(length), compression, declared, reader.limits.max_chunk_bytes
    )
    buf = io.BytesIO(records)
    counts: dict[int, int] = defaultdict(int)
    entries: list[tuple[int, IndexData]] = []
    saved, reader.bio = reader.bio, buf  # rosbags reads a connection record from reader.bio
    try:
        while buf.tell() < len(records):
            at = buf.tell()
            try:
                inner = Header.read(buf)
                op = inner.get_uint8("op")
                if op == RecordType.CONNECTION:
                    buf.seek(at)
                    conn = reader.read_connection()
                    connections.setdefault(conn.id, conn)
                    continue
                size = read_uint32(buf)
                if buf.tell() + size > len(records):
                    raise ReaderError("a record overruns its chunk")
                if op == RecordType.MSGDATA:
                    entry = IndexData(inner.get_time("time"), pos, at)
                    entries.append((inner.get_uint32("conn"), entry))
                buf.seek(size, io.SEEK_CUR)
            except _RECORD_ERRORS:
                if not part:
                    raise
                break  # the record the file cuts short
    finally:
        reader.bio = saved
    for cid, entry in entries:  # only a chunk read whole (or in part, ``part``) is indexed
        indexes[cid].append(entry)
        counts[cid] += 1
    times = [entry.time for _, entry in entries]
    reader.chunk_infos.append(
        ChunkInfo(pos, min(times, default=2**63 - 1), max(times, default=-1) + 1, dict(counts))
    )
    reader.chunks[pos] = Chunk(length, data_at, _no_decompressor)
    reader.chunk_meta[pos] = (compression, declared)
