"""MCAP records read byte by byte, with bounded memory and without trusting the summary.

:mod:`formats.mcap_source` reads MCAP files through this module rather than the ``mcap`` library's
stream and seeking readers, because those decompress a chunk whole (a 33 KB file can hold a
chunk that expands to a gigabyte), stop at the first chunk that fails its CRC, and read what the
summary indexes without checking it against the data. Here:

- :func:`walk` steps over the top-level records of the data section reading only their 9-byte
  heads; a record that overruns the file raises :class:`RecordError` with its offset.
- :func:`read_chunk_head` parses a chunk record's fields up to its data; :func:`read_chunk`
  reads and decompresses the data with the caps of :mod:`formats.limits` (the declared size is
  checked before anything is decompressed) and checks the CRC-32 of the records.
- :func:`chunk_messages` / :func:`chunk_records` split the records of a decompressed chunk;
  messages over the message cap are left out and reported.
- :func:`check_summary` compares the summary (chunk indexes and statistics) with the data
  section, walked record head by record head and with the message index records that follow
  each chunk (a few bytes per channel and chunk, no chunk is decompressed): chunks the summary
  does not index, channels a chunk index leaves out, counts and times that disagree.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import IO, Any

from aion_cli.formats import limits as caps

OP_HEADER = 0x01
OP_FOOTER = 0x02
OP_SCHEMA = 0x03
OP_CHANNEL = 0x04
OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_MESSAGE_INDEX = 0x07
OP_DATA_END = 0x0F

RECORD_HEAD = struct.Struct("<BQ")  # opcode, body length
_CHUNK_FIXED = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length
_U64 = struct.Struct("<Q")
_MESSAGE_HEAD = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time follows)
_INDEX_HEAD = struct.Struct("<HI")  # channel id, byte length of the (time, offset) entries
MESSAGE_PREFIX = 2 + 4 + 8 + 8  # the fixed fields of a Message body before its data
_INDEX_ENTRY = 16
_MAX_COMPRESSION_NAME = 255
#: prefix of the reason of a chunk that is damaged (not merely too large or in an unknown
#: compression), in :attr:`SummaryCheck.bad_chunks` and the reader's own records
CORRUPT = "corrupt: "


class RecordError(ValueError):
    """A top-level record that cannot be read (truncated file, damaged length)."""

    def __init__(self, message: str, offset: int) -> None:
        super().__init__(message)
        self.offset = offset


@dataclass(frozen=True)
class ChunkHead:
    """The fields of a chunk record before its data: where it is, its time range, sizes,
    CRC and compression. ``length`` counts the whole record (9-byte head included), as a
    chunk index's ``chunk_length`` does."""

    offset: int
    length: int
    start: int
    end: int
    uncompressed_size: int
    crc: int
    compression: str
    data_offset: int
    data_length: int


def walk(f: IO[bytes], start: int, stop: int) -> Iterator[tuple[int, int, int]]:
    """``(offset, opcode, body length)`` of the top-level records from byte ``start`` to
    ``stop`` (the file size), until a DataEnd or Footer record (not yielded) or ``stop``.
    Reads 9 bytes per record; the caller may read the body (``offset + 9``) in between.
    :class:`RecordError` for a record that overruns ``stop``."""
    pos = start
    while pos < stop:
        f.seek(pos)
        head = f.read(RECORD_HEAD.size)
        if len(head) < RECORD_HEAD.size:
            raise RecordError("the file ends inside its record head", pos)
        opcode, length = RECORD_HEAD.unpack(head)
        end = pos + RECORD_HEAD.size + length
        if end > stop:
            raise RecordError(f"its record claims {length:,} bytes, past the end of the file", pos)
        if opcode in (OP_DATA_END, OP_FOOTER):
            return
        yield pos, opcode, length
        pos = end


def read_chunk_head(
    f: IO[bytes], offset: int, stop: int, record_length: int | None = None
) -> ChunkHead:
    """The chunk record at byte ``offset`` up to its data (nothing of the data is read);
    ``record_length``: the whole record's length to use instead of the one the record states
    (a damaged length field, when a chunk index gives the length). :class:`ValueError` when
    there is no chunk record or its fields overrun it."""
    f.seek(offset)
    raw = f.read(RECORD_HEAD.size + _CHUNK_FIXED.size)
    if len(raw) < RECORD_HEAD.size + _CHUNK_FIXED.size:
        raise ValueError("the file ends inside the chunk record")
    opcode, length = RECORD_HEAD.unpack_from(raw)
    if record_length is not None:
        length = record_length - RECORD_HEAD.size
    if opcode != OP_CHUNK:
        raise ValueError(f"no chunk record there (opcode 0x{opcode:02x})")
    end = offset + RECORD_HEAD.size + length
    if end > stop:
        raise ValueError(f"the chunk record claims {length:,} bytes, past the end of the file")
    start_t, end_t, size, crc, name_len = _CHUNK_FIXED.unpack_from(raw, RECORD_HEAD.size)
    if name_len > _MAX_COMPRESSION_NAME:
        raise ValueError(f"a compression name of {name_len:,} bytes")
    name = f.read(name_len)
    data_len_raw = f.read(_U64.size)
    if len(name) < name_len or len(data_len_raw) < _U64.size:
        raise ValueError("the file ends inside the chunk record")
    (data_length,) = _U64.unpack(data_len_raw)
    data_offset = offset + RECORD_HEAD.size + _CHUNK_FIXED.size + name_len + _U64.size
    if data_offset + data_length > end:
        raise ValueError(f"its {data_length:,} data bytes overrun the chunk record")
    return ChunkHead(
        offset,
        RECORD_HEAD.size + length,
        start_t,
        end_t,
        size,
        crc,
        name.decode("utf-8", "replace"),
        data_offset,
        data_length,
    )


def read_chunk(
    f: IO[bytes],
    head: ChunkHead,
    limits: caps.ReadLimits,
    decompress: Callable[[bytes, str, int, int], bytes] = caps.decompress,
) -> bytes:
    """The decompressed records of the chunk ``head`` describes, CRC-checked (``decompress``:
    :func:`formats.limits.decompress` or a wrapper of it). Raises
    :class:`formats.limits.ChunkError` (over the cap, unknown compression, damaged data,
    CRC mismatch) before reading the data where the head already says so."""
    limit = limits.max_chunk_bytes
    if head.compression not in caps.KNOWN_COMPRESSIONS or head.compression in ("none", "bz2"):
        # MCAP knows zstd, lz4 and "" only; the others are ROS 1 bag names
        raise caps.UnknownCompressionError(f"unknown compression {head.compression[:40]!r}")
    if head.uncompressed_size > limit:
        raise caps.chunk_over_limit(head.uncompressed_size, limit)
    if not head.compression and head.data_length > limit:
        raise caps.chunk_over_limit(head.data_length, limit)
    f.seek(head.data_offset)
    data = f.read(head.data_length)
    if len(data) < head.data_length:
        raise caps.ChunkError("the file ends inside its data")
    buf = decompress(data, head.compression, head.uncompressed_size, limit)
    if head.crc and zlib.crc32(buf) != head.crc:
        # a flipped bit in compressed data often still decompresses: into garbage
        raise caps.ChunkError("its records fail their CRC-32 check")
    return buf


Oversized = tuple[int, int, int]
"""``(channel id, log time, payload bytes)`` of a message left out for its size."""


def chunk_messages(
    buf: bytes, wanted: set[int] | None, max_message: int
) -> tuple[list[tuple[int, int, bytes]], list[Oversized], int]:
    """``(log_time, channel_id, data)`` of the messages in a chunk's records on ``wanted``
    channels (all when None), sorted by log time; the messages of any channel left out because
    their data is over ``max_message`` bytes; how many messages within the cap the chunk holds
    on any channel. Parses the record heads with struct and slices only the wanted payloads.
    :class:`formats.limits.ChunkError` when records overrun the chunk."""
    out: list[tuple[int, int, bytes]] = []
    big: list[Oversized] = []
    seen = 0
    unpack_record = RECORD_HEAD.unpack_from
    unpack_message = _MESSAGE_HEAD.unpack_from
    pos, end = 0, len(buf)
    while pos < end:
        if pos + RECORD_HEAD.size > end:
            raise caps.ChunkError("its records overrun the chunk")
        opcode, length = unpack_record(buf, pos)
        body = pos + RECORD_HEAD.size
        pos = body + length
        if opcode == OP_MESSAGE:
            if length < MESSAGE_PREFIX or pos > end:
                raise caps.ChunkError("a message record overruns the chunk")
            channel_id, _, log_time = unpack_message(buf, body)
            if length - MESSAGE_PREFIX > max_message:
                big.append((channel_id, log_time, length - MESSAGE_PREFIX))
                continue
            seen += 1
            if wanted is None or channel_id in wanted:
                out.append((log_time, channel_id, buf[body + MESSAGE_PREFIX : pos]))
    if pos != end:
        raise caps.ChunkError("its records overrun the chunk")
    out.sort(key=_first)
    return out, big, seen


def _first(item: tuple[int, int, bytes]) -> int:
    return item[0]


def chunk_records(buf: bytes) -> Iterator[tuple[int, int, int]]:
    """``(opcode, body start, body end)`` of the records in a chunk's decompressed records;
    :class:`formats.limits.ChunkError` when one overruns the chunk (raised before any record
    is yielded, so a damaged chunk adds nothing)."""
    spans = []
    pos, end = 0, len(buf)
    while pos < end:
        if pos + RECORD_HEAD.size > end:
            raise caps.ChunkError("its records overrun the chunk")
        opcode, length = RECORD_HEAD.unpack_from(buf, pos)
        body = pos + RECORD_HEAD.size
        pos = body + length
        if pos > end or (opcode == OP_MESSAGE and length < MESSAGE_PREFIX):
            raise caps.ChunkError("its records overrun the chunk")
        spans.append((opcode, body, pos))
    return iter(spans)


def message_fields(buf: bytes | memoryview, body: int) -> tuple[int, int]:
    """``(channel id, log time)`` of the Message record whose body starts at ``body``."""
    channel_id, _, log_time = _MESSAGE_HEAD.unpack_from(buf, body)
    return channel_id, log_time


def read_index_heads(f: IO[bytes], start: int, stop: int) -> Iterator[tuple[int, int, int]]:
    """``(offset, channel id, message count)`` of the MessageIndex records from ``start`` up to
    the first other record or ``stop``; reads 15 bytes per record, not the entries."""
    pos = start
    while pos + RECORD_HEAD.size + _INDEX_HEAD.size <= stop:
        f.seek(pos)
        raw = f.read(RECORD_HEAD.size + _INDEX_HEAD.size)
        if len(raw) < RECORD_HEAD.size + _INDEX_HEAD.size:
            return
        opcode, length = RECORD_HEAD.unpack_from(raw)
        if opcode != OP_MESSAGE_INDEX or pos + RECORD_HEAD.size + length > stop:
            return
        channel_id, entries = _INDEX_HEAD.unpack_from(raw, RECORD_HEAD.size)
        if _INDEX_HEAD.size + entries > length:
            return
        yield pos, channel_id, entries // _INDEX_ENTRY
        pos += RECORD_HEAD.size + length


# -- the summary against the data ------------------------------------------------------------


@dataclass
class SummaryCheck:
    """What :func:`check_summary` found.

    ``problems``: ways in which the summary misses or misstates data (chunks or messages it
    does not index, channels a chunk index leaves out, statistics that disagree): reading
    through it would lose messages or report wrong figures, so the reader reads the data
    instead. ``bad_chunks``: chunk indexes whose chunk record cannot be read (offset -> why,
    prefixed :data:`CORRUPT`):
    those chunks alone are skipped. ``counts``: messages per channel of each chunk (by chunk
    offset) from its message index records. ``unsure``: the statistics count no message but
    some chunk without message indexes holds records (only reading it can tell).
    """

    problems: list[str] = field(default_factory=list)
    bad_chunks: dict[int, str] = field(default_factory=dict)
    counts: dict[int, dict[int, int]] = field(default_factory=dict)
    unsure: bool = False
    # chunks whose record states a wrong length but agrees with its index otherwise: read
    # with the index's length (offset -> chunk length); ``notes`` says so
    lengths: dict[int, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def iso(t_ns: int) -> str:
    """A log time as UTC ISO 8601 for messages (the raw value when out of range)."""
    try:
        return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    except (OverflowError, OSError, ValueError):
        return f"{t_ns} ns"


def check_summary(
    f: IO[bytes],
    size: int,
    chunk_indexes: list[Any],
    statistics: Any,
    topics: Mapping[int, str],
) -> SummaryCheck:
    """Compare an MCAP summary (``chunk_indexes``, ``statistics``: mcap library records) with
    the data section of the file ``f`` of ``size`` bytes; ``topics`` names channels in the
    messages. Walks the record heads from byte 8; where a damaged record stops the walk, it
    resumes at the next chunk an index points to (the unreadable chunk itself goes to
    ``bad_chunks``)."""
    check = SummaryCheck()
    by_offset = {c.chunk_start_offset: c for c in chunk_indexes}
    resume_points = sorted(by_offset)
    heads: dict[int, ChunkHead] = {}
    bare_messages = 0
    bare_times: list[int] = []
    pos = 8
    while True:
        try:
            for offset, opcode, length in walk(f, pos, size):
                if opcode == OP_CHUNK:
                    try:
                        heads[offset] = read_chunk_head(f, offset, size)
                    except ValueError as exc:
                        check.bad_chunks[offset] = f"{CORRUPT}unreadable chunk record: {exc}"
                        continue
                    counts = check.counts.setdefault(offset, {})
                    end = offset + RECORD_HEAD.size + length
                    for _, cid, n in read_index_heads(f, end, size):
                        counts[cid] = counts.get(cid, 0) + n
                elif opcode == OP_MESSAGE:
                    bare_messages += 1
                    if length >= MESSAGE_PREFIX:
                        f.seek(offset + RECORD_HEAD.size)
                        _, _, log_time = _MESSAGE_HEAD.unpack(f.read(_MESSAGE_HEAD.size))
                        bare_times.append(log_time)
            break
        except RecordError as exc:
            later = [p for p in resume_points if p > exc.offset]
            index = by_offset.get(exc.offset)
            if index is not None:
                head = _with_index_length(f, size, index)
                if head is None:
                    check.bad_chunks[exc.offset] = f"{CORRUPT}unreadable chunk record: {exc}"
                else:  # the length field alone is damaged: the index knows the length
                    heads[exc.offset] = head
                    check.lengths[exc.offset] = index.chunk_length
                    check.notes.append(
                        f"the record of the chunk at byte {exc.offset} states a wrong length "
                        f"({exc}); it is read with the length its chunk index gives"
                    )
            if not later:
                break
            pos = later[0]
    for offset, index in by_offset.items():
        if offset not in heads or offset in check.lengths:  # not walked: its message indexes
            first = offset + index.chunk_length
            last = min(size, first + index.message_index_length)
            counts = check.counts.setdefault(offset, {})
            for _, cid, n in read_index_heads(f, first, last):
                counts[cid] = counts.get(cid, 0) + n
    _compare(check, by_offset, heads, bare_messages, bare_times, statistics, topics)
    return check


def _with_index_length(f: IO[bytes], size: int, index: Any) -> ChunkHead | None:
    """The chunk record at ``index``'s offset read with the index's length, when every other
    field agrees with the index (only the record's length field is damaged); else None."""
    try:
        head = read_chunk_head(f, index.chunk_start_offset, size, index.chunk_length)
    except ValueError:
        return None
    same = (
        head.compression == index.compression
        and head.data_length == index.compressed_size
        and head.uncompressed_size == index.uncompressed_size
        and (head.start, head.end) == (index.message_start_time, index.message_end_time)
        and head.data_offset + head.data_length == index.chunk_start_offset + index.chunk_length
    )
    return head if same else None


def _compare(
    check: SummaryCheck,
    by_offset: dict[int, Any],
    heads: dict[int, ChunkHead],
    bare_messages: int,
    bare_times: list[int],
    statistics: Any,
    topics: Mapping[int, str],
) -> None:
    problems = check.problems
    unindexed = sorted(set(heads) - set(by_offset))
    if unindexed:
        problems.append(
            f"{len(unindexed)} chunk(s) are not in its chunk indexes (first at byte "
            f"{unindexed[0]})"
        )
    if bare_messages:
        problems.append(f"{bare_messages} message(s) outside chunks are not indexed")
    for offset, index in sorted(by_offset.items()):
        head = heads.get(offset)
        if head is None:
            check.bad_chunks.setdefault(
                offset, f"{CORRUPT}no chunk record at the offset its index gives"
            )
            continue
        fields = [
            name
            for name, ours, theirs in (
                ("length", head.length, index.chunk_length),
                ("compression", head.compression, index.compression),
                ("compressed size", head.data_length, index.compressed_size),
                ("uncompressed size", head.uncompressed_size, index.uncompressed_size),
                ("start time", head.start, index.message_start_time),
                ("end time", head.end, index.message_end_time),
            )
            if ours != theirs
        ]
        if fields:
            problems.append(
                f"the chunk index of the chunk at byte {offset} disagrees with the chunk "
                f"record ({', '.join(fields)})"
            )
        counts = check.counts.get(offset, {})
        listed = index.message_index_offsets or {}
        left_out = {cid: n for cid, n in counts.items() if n and listed and cid not in listed}
        for cid, n in sorted(left_out.items()):
            problems.append(
                f"the chunk index of the chunk at byte {offset} leaves out channel {cid} "
                f"({topics.get(cid, '?')}), which has {n:,} message(s) there"
            )
    if statistics is None:
        return
    _compare_statistics(check, by_offset, heads, bare_messages, bare_times, statistics)


def _compare_statistics(
    check: SummaryCheck,
    by_offset: dict[int, Any],
    heads: dict[int, ChunkHead],
    bare_messages: int,
    bare_times: list[int],
    statistics: Any,
) -> None:
    problems = check.problems
    stated = dict(statistics.channel_message_counts or {})
    if sum(stated.values()) != statistics.message_count:
        problems.append(
            f"its statistics count {statistics.message_count:,} messages in all but "
            f"{sum(stated.values()):,} over the channels"
        )
    indexed: dict[int, int] = {}
    every_chunk_indexed = True
    starts, ends = list(bare_times), list(bare_times)
    # (offset, start, end, uncompressed size) of every chunk: its record's where readable,
    # its index's where not (what cannot be checked is taken as the index says)
    spans = [(o, h.start, h.end, h.uncompressed_size) for o, h in heads.items()]
    spans += [
        (o, c.message_start_time, c.message_end_time, c.uncompressed_size)
        for o, c in by_offset.items()
        if o not in heads
    ]
    for offset, start, end, uncompressed in spans:
        counts = check.counts.get(offset, {})
        n = sum(counts.values())
        for cid, k in counts.items():
            indexed[cid] = indexed.get(cid, 0) + k
        has_index = bool(counts)
        if not has_index and uncompressed > 0:
            every_chunk_indexed = False
        if start <= end and (n > 0 or (not has_index and uncompressed > 0)):
            starts.append(start)
            ends.append(end)
    if spans and every_chunk_indexed and not bare_messages:
        if {c: k for c, k in indexed.items() if k} != {c: k for c, k in stated.items() if k}:
            problems.append(
                f"its statistics count {statistics.message_count:,} messages, its message "
                f"indexes {sum(indexed.values()):,}"
            )
    else:
        under = any(stated.get(cid, 0) < k for cid, k in indexed.items())
        if under:
            problems.append(
                f"its statistics count {statistics.message_count:,} messages, fewer than its "
                f"message indexes list ({sum(indexed.values()):,})"
            )
        elif statistics.message_count == 0 and not every_chunk_indexed:
            check.unsure = True
    if starts and statistics.message_count > 0:
        first, last = min(starts), max(ends)
        if statistics.message_start_time != first:
            problems.append(
                f"its statistics say the messages start at {iso(statistics.message_start_time)},"
                f" its chunks at {iso(first)}"
            )
        if statistics.message_end_time != last:
            problems.append(
                f"its statistics say the messages end at {iso(statistics.message_end_time)}, "
                f"its chunks at {iso(last)}"
            )
