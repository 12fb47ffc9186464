"""Which time windows a log recorded anything in, from the containers' indexes.

A log without a robot trajectory is a fixed sensor that observed exactly the windows in which it
recorded at least one message (design, section 4): never the time between two recordings. Window
``w`` is ``floor(t_ns / window_ns)`` of a message's log time, aligned to the UNIX epoch.

The readers of :mod:`formats.mcap_source`, :mod:`formats.rosbags_source` and
:mod:`formats.rosbag2_reindex` answer that from what each container indexes (MCAP chunk and
message indexes, the ROS 1 bag index, the rosbag2 sqlite3 ``timestamp`` column) and fall back to
message log times only where nothing is indexed. This module holds the byte-level and numpy parts
of that: window arithmetic, MessageIndex and chunk-record parsing, the SQL query. No file is
opened here (readers pass the streams they opened) and nothing per message survives as a Python
object.
"""

from __future__ import annotations

import operator
import struct
from array import array
from collections.abc import Iterable, Mapping, Sequence
from itertools import chain
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from aion_cli.errors import ConfigError

Windows = npt.NDArray[np.int64]
"""Sorted unique window indices ``floor(t_ns / window_ns)``."""

_RECORD_HEAD = struct.Struct("<BQ")  # opcode, record length
_MESSAGE_INDEX_OPCODE = 0x07
_MESSAGE_OPCODE = 0x05
_MESSAGE_INDEX_HEAD = struct.Struct("<HI")  # channel id, byte length of the (time, offset) pairs
_LOG_TIME = struct.Struct("<Q")
_LOG_TIME_AT = 2 + 4  # a Message body: channel id (u16), sequence (u32), then log time (u64)
_INDEX_ENTRY = np.dtype([("log_time", "<u8"), ("offset", "<u8")])


def window_size(window_ns: int) -> int:
    """``window_ns`` as a positive int below 2**63; :class:`ConfigError` otherwise (a zero or
    negative window has no meaning, and numpy divides int64 times only by int64 values)."""
    try:
        size = operator.index(window_ns)
    except TypeError:
        raise ConfigError(
            f"time window {window_ns!r} is not a whole number of nanoseconds",
            hint="give the window as an integer number of nanoseconds, e.g. 600_000_000_000",
        ) from None
    if not 0 < size < 2**63:
        raise ConfigError(
            f"time window {size} ns is not a positive int64", hint="the default window is 600 s"
        )
    return size


def no_windows() -> Windows:
    """An empty window array (a log, or part of one, with no messages)."""
    return np.zeros(0, dtype=np.int64)


def windows_of(times: npt.ArrayLike, window_ns: int) -> Windows:
    """Sorted unique ``floor(t / window_ns)`` of log times ``times`` (ns; unsigned container
    times above 2**63 wrap like every other int64 time in aion)."""
    t = np.asarray(times)
    if t.size == 0:
        return no_windows()
    if t.dtype != np.int64:
        t = t.astype(np.int64)
    return np.unique(t // window_ns)  # numpy floors integer division, as the epoch grid wants


def union(parts: Iterable[Windows]) -> Windows:
    """Sorted unique windows of several window arrays."""
    arrays = [p for p in parts if p.size]
    if not arrays:
        return no_windows()
    return np.unique(np.concatenate(arrays))


def wide_spans(
    starts: npt.NDArray[np.int64], ends: npt.NDArray[np.int64], window_ns: int
) -> npt.NDArray[np.bool_]:
    """Mask of time spans ``[start, end]`` (MCAP chunks) that reach over more than two windows:
    they may hold unrecorded windows inside, so their message times are needed."""
    return ends // window_ns - starts // window_ns > 1


def end_windows(
    starts: npt.NDArray[np.int64], ends: npt.NDArray[np.int64], window_ns: int
) -> Windows:
    """Windows of time spans that hold a message at both ends and lie within one window or two
    adjacent ones: exactly the windows of their ends, no message time needed."""
    return np.unique(np.concatenate([starts // window_ns, ends // window_ns]))


def read_message_index(
    stream: IO[bytes], size: int, index: Any, channels: Iterable[int]
) -> list[npt.NDArray[Any]] | None:
    """The entries (``log_time``, ``offset``) of the MessageIndex records after the chunk of
    ``index`` (an MCAP ChunkIndex) for each of ``channels``, in their order, read from
    ``stream`` (a file of ``size`` bytes; one read of the records' block); None when the
    block lies past the end of the file or its records are damaged. ``OSError`` from the
    stream is the caller's."""
    base = index.chunk_start_offset + index.chunk_length
    listed = index.message_index_offsets
    if base >= size:
        return None
    stream.seek(base)
    block = stream.read(min(index.message_index_length, size - base))
    try:
        return message_index(block, [listed[c] - base for c in channels])
    except (KeyError, ValueError):
        return None


def message_index(block: bytes | memoryview, offsets: Iterable[int]) -> list[npt.NDArray[Any]]:
    """The entries (``log_time``, ``offset``: uint64 fields) of each MCAP MessageIndex record
    that starts at ``offsets`` (relative to ``block``, the bytes after a chunk), in the order
    of ``offsets``; views into ``block``. :class:`ValueError` when a record is not a
    MessageIndex or overruns the block."""
    size = len(block)
    out = []
    for rel in offsets:
        if rel < 0 or rel + _RECORD_HEAD.size + _MESSAGE_INDEX_HEAD.size > size:
            raise ValueError(f"message index at +{rel} lies outside the index block")
        opcode, length = _RECORD_HEAD.unpack_from(block, rel)
        body = rel + _RECORD_HEAD.size
        _, entries_len = _MESSAGE_INDEX_HEAD.unpack_from(block, body)
        first = body + _MESSAGE_INDEX_HEAD.size
        if (
            opcode != _MESSAGE_INDEX_OPCODE
            or entries_len % _INDEX_ENTRY.itemsize
            or _MESSAGE_INDEX_HEAD.size + entries_len > length
            or body + length > size
        ):
            raise ValueError(f"no valid message index record at +{rel}")
        out.append(
            np.frombuffer(
                block, _INDEX_ENTRY, count=entries_len // _INDEX_ENTRY.itemsize, offset=first
            )
        )
    return out


def record_log_times(buf: bytes | memoryview) -> npt.NDArray[np.int64]:
    """Log times of the Message records in ``buf`` (the decompressed records of an MCAP chunk);
    other records are skipped. Reads the 8 time bytes of each record, nothing of the payloads.
    :class:`ValueError` when the records overrun ``buf``."""
    times = array("Q")
    unpack_record = _RECORD_HEAD.unpack_from
    unpack_time = _LOG_TIME.unpack_from
    pos, end = 0, len(buf)
    while pos < end:
        opcode, length = unpack_record(buf, pos)
        body = pos + _RECORD_HEAD.size
        pos = body + length
        if opcode == _MESSAGE_OPCODE:
            if length < _LOG_TIME_AT + _LOG_TIME.size or pos > end:
                raise ValueError("a message record overruns the chunk")
            times.append(unpack_time(buf, body + _LOG_TIME_AT)[0])
    if pos != end:
        raise ValueError("chunk records overrun the chunk")
    return np.frombuffer(times, dtype=np.uint64).astype(np.int64)


def rosbag1_index_times(indexes: Mapping[int, Sequence[tuple[int, ...]]]) -> npt.NDArray[np.int64]:
    """Message times of a ROS 1 bag index as rosbags loads it at open: per connection, a list of
    ``(time, chunk_pos, offset)`` entries. About 35 ns per message, no chunk is read."""
    total = sum(len(entries) for entries in indexes.values())
    first = operator.itemgetter(0)
    return np.fromiter(
        map(first, chain.from_iterable(indexes.values())), dtype=np.int64, count=total
    )


def sqlite_windows(connection: Any, window_ns: int) -> Windows:
    """Recorded windows of a rosbag2 sqlite3 storage file, computed by SQLite over the
    ``messages.timestamp`` column (``connection``: an open sqlite3 or apsw connection).

    rosbag2 indexes that column (``timestamp_idx``), so SQLite scans the index instead of the
    rows with their payloads, and only one row per window reaches Python. Integer division in
    SQL truncates toward zero; the CASE floors negative times as numpy does.
    """
    query = (
        "SELECT DISTINCT CASE WHEN timestamp >= 0 THEN timestamp / ?1 "
        "ELSE (timestamp + 1) / ?1 - 1 END FROM messages"
    )
    rows = connection.execute(query, (window_ns,))
    return np.unique(np.fromiter((row[0] for row in rows), dtype=np.int64))


def times_of(records: Iterable[tuple[Any, int, Any]]) -> npt.NDArray[np.int64]:
    """Times of ``(connection, t_ns, data)`` tuples as the rosbags readers yield them: the
    fallback where a container indexes nothing usable (the payloads are read by rosbags)."""
    return np.fromiter((t for _, t, _ in records), dtype=np.int64)
