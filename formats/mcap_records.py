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
  messages over the message cap are left out and reported; a payload that fills most of its
  chunk may come as a view of it, on the channels the caller asks.
- :func:`formats.mcap_summary.check_summary` compares the summary with the data section,
  with :func:`walk` and :func:`read_index_heads` (no chunk is decompressed).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Generator, Iterator
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from operator import itemgetter
from typing import IO, TYPE_CHECKING

from aion_cli.formats import limits as caps
from aion_cli.formats.crc import crc32

if TYPE_CHECKING:
    from aion_cli.formats.raw import Payload

MAGIC = b"\x89MCAP0\r\n"
"""The bytes an MCAP file starts and ends with."""
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
MESSAGE_HEAD = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time follows)
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


def walk(f: IO[bytes], start: int, stop: int) -> Generator[tuple[int, int, int], None, int | None]:
    """``(offset, opcode, body length)`` of the top-level records from byte ``start`` to
    ``stop`` (the file size), until a DataEnd or Footer record (not yielded; its offset is
    the generator's return value) or ``stop`` (None). Reads 9 bytes per record; the caller
    may read the body (``offset + 9``) in between. :class:`RecordError` for a record that
    overruns ``stop``."""
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
            return pos
        yield pos, opcode, length
        pos = end
    return None


#: the records from a log's DataEnd on: DataEnd, then the summary section (Schema, Channel,
#: ChunkIndex, AttachmentIndex, Statistics, MetadataIndex, SummaryOffset) and the Footer
_AFTER_DATA = frozenset(
    {OP_DATA_END, OP_SCHEMA, OP_CHANNEL, 0x08, 0x0A, 0x0B, 0x0D, 0x0E, OP_FOOTER}
)
#: opcodes from here on are an application's own records (the MCAP specification's 0x80-0xFF)
_OWN_OPCODES = 0x80


def end_of_log(f: IO[bytes], start: int, stop: int) -> int | None:
    """Where the MCAP whose top-level records run on from byte ``start`` (its DataEnd or
    summary section) ends: after its Footer record and the closing magic; None when no
    Footer and magic follow (a file cut short, a damaged record length); where another
    MCAP starts instead of a record (a log without its summary and footer, another appended
    to it), or bytes that are no record a log ends with (garbage appended to a log without
    its summary and footer). Short of ``stop`` (the file size) when something was appended
    after the log."""
    pos = start
    while pos + RECORD_HEAD.size <= stop:
        f.seek(pos)
        head = f.read(len(MAGIC))
        if head == MAGIC:
            return pos
        opcode, length = RECORD_HEAD.unpack(head + f.read(RECORD_HEAD.size - len(head)))
        if opcode not in _AFTER_DATA and opcode < _OWN_OPCODES:
            return pos  # no record the end of a log holds: bytes appended after it
        end = pos + RECORD_HEAD.size + length
        if end > stop:
            return None
        if opcode == OP_FOOTER:
            f.seek(end)
            return end + len(MAGIC) if f.read(len(MAGIC)) == MAGIC else None
        pos = end
    return None


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
    if head.crc and crc32(buf) != head.crc:
        # a flipped bit in compressed data often still decompresses: into garbage
        raise caps.ChunkError("its records fail their CRC-32 check")
    return buf


Record = tuple[int, int, "Payload"]
"""``(log time, channel id, data)`` of a message read out of a chunk."""

Oversized = tuple[int, int, int]
"""``(channel id, log time, payload bytes)`` of a message left out for its size."""


def chunk_messages(
    buf: bytes, wanted: set[int] | None, max_message: int, views: AbstractSet[int] = frozenset()
) -> tuple[list[Record], list[Oversized], int]:
    """``(log_time, channel_id, data)`` of the messages in a chunk's records on ``wanted``
    channels (all when None), sorted by log time; the messages of any channel left out because
    their data is over ``max_message`` bytes; how many messages within the cap the chunk holds
    on any channel. Parses the record heads with struct and slices only the wanted payloads.
    :class:`formats.limits.ChunkError` when records overrun the chunk.

    On ``views`` channels, a payload of at least half of ``buf`` is a read-only memoryview
    of ``buf`` instead of a copy (a scene graph of megabytes that fills its chunk: the copy
    cost as much as a third of decompressing it); ``buf`` must be a fresh ``bytes`` the caller
    never reuses (a decompressed chunk), and a view keeps at most twice its bytes alive."""
    out: list[Record] = []
    big: list[Oversized] = []
    seen = 0
    unpack_record = RECORD_HEAD.unpack_from
    unpack_message = MESSAGE_HEAD.unpack_from
    pos, end = 0, len(buf)
    view = memoryview(buf).toreadonly() if views else None
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
                first = body + MESSAGE_PREFIX
                if view is not None and 2 * (pos - first) >= end and channel_id in views:
                    out.append((log_time, channel_id, view[first:pos]))
                else:
                    out.append((log_time, channel_id, buf[first:pos]))
    if pos != end:
        raise caps.ChunkError("its records overrun the chunk")
    out.sort(key=_first)  # stable: ties keep record order
    return out, big, seen


_first = itemgetter(0)
"""A message's log time (the sort key of :func:`chunk_messages`; a C getter, not a Python
function call per message)."""


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
    channel_id, _, log_time = MESSAGE_HEAD.unpack_from(buf, body)
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
