"""Hand-made MCAP files, record by record, for tests of damaged and hostile containers (ROS 1
bags: :mod:`tests.formats.craft_bag`): chunks with a wrong CRC, an unknown compression, a lying
size; summaries whose chunk indexes or statistics disagree with the data; decompression bombs.

The records themselves (schemas, channels, serialized messages) come from a file written with
:class:`formats.writers.LogWriter` (:func:`mcap_parts`), so every message is a real, decodable
ROS message; only the container around them is crafted here, with the ``mcap`` library's own
record classes. Bombs are compressed piece by piece (:func:`zeros_chunk`), so crafting a chunk
that expands to a gigabyte takes a few MB.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.data_stream import RecordBuilder
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Schema,
    Statistics,
)

MAGIC = b"\x89MCAP0\r\n"
PIECE = 16 << 20


@dataclass
class McapParts:
    """What a LogWriter MCAP holds: its header, schemas, channels and messages (file order)."""

    header: Header
    schemas: list[Schema]
    channels: list[Channel]
    messages: list[Message]

    def on(self, topic: str) -> list[Message]:
        ids = {c.id for c in self.channels if c.topic == topic}
        return [m for m in self.messages if m.channel_id in ids]


def mcap_parts(path: Path) -> McapParts:
    """The records of an MCAP file (read with the mcap library's stream reader)."""
    from mcap.stream_reader import StreamReader

    header, schemas, channels, messages = None, {}, {}, []
    with path.open("rb") as fh:
        for record in StreamReader(fh).records:
            if isinstance(record, Header):
                header = record
            elif isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                messages.append(record)
    assert header is not None
    return McapParts(header, list(schemas.values()), list(channels.values()), messages)


def _record(record: Any) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())


@dataclass
class CraftedChunk:
    """A chunk as it will be written: the record's fields, and the messages it holds (for the
    message indexes, the statistics and the chunk index)."""

    compression: str
    data: bytes
    uncompressed_size: int
    uncompressed_crc: int
    start: int
    end: int
    # (channel id, log time, offset in the uncompressed records) of each message
    entries: list[tuple[int, int, int]] = field(default_factory=list)


def records_chunk(
    records: Iterable[Any],
    compression: str = "zstd",
    *,
    declared_size: int | None = None,
    crc: int | None = None,
) -> CraftedChunk:
    """A chunk holding ``records`` (schemas, channels, messages), compressed with
    ``compression`` (``"zstd"``, ``"lz4"``, ``""``, or any other name: then the records are
    stored as they are, labelled with that name). ``declared_size`` / ``crc`` override the
    honest uncompressed size and CRC-32."""
    import lz4.frame  # type: ignore[import-untyped]
    import zstandard

    raw = bytearray()
    entries = []
    for record in records:
        if isinstance(record, Message):
            entries.append((record.channel_id, record.log_time, len(raw)))
        raw += _record(record)
    if compression == "zstd":
        data = zstandard.ZstdCompressor().compress(bytes(raw))
    elif compression == "lz4":
        data = lz4.frame.compress(bytes(raw))
    else:
        data = bytes(raw)
    times = [t for _, t, _ in entries]
    return CraftedChunk(
        compression,
        data,
        len(raw) if declared_size is None else declared_size,
        zlib.crc32(raw) if crc is None else crc,
        min(times, default=0),
        max(times, default=0),
        entries,
    )


def _message_head(channel_id: int, log_time: int, payload: int) -> bytes:
    """Opcode, length and the fixed fields of a Message record with ``payload`` data bytes."""
    return struct.pack("<BQHIQQ", 0x05, 2 + 4 + 8 + 8 + payload, channel_id, 0, log_time, log_time)


def zeros_chunk(
    channel_id: int,
    log_time: int,
    payload: int,
    compression: str = "zstd",
    *,
    declared_size: int | None = None,
    frame_size: bool = True,
) -> CraftedChunk:
    """A decompression bomb: one chunk holding one message of ``payload`` zero bytes,
    compressed piece by piece (never ``payload`` bytes in memory). ``declared_size``: the
    uncompressed size the chunk claims (default: the truth); ``frame_size``: whether the zstd
    frame header states its content size."""
    import lz4.frame
    import zstandard

    head = _message_head(channel_id, log_time, payload)
    zero = bytes(min(PIECE, payload))
    if compression == "zstd":
        size = len(head) + payload if frame_size else -1
        cobj: Any = zstandard.ZstdCompressor(write_content_size=frame_size).compressobj(size)
        out = [cobj.compress(head)]
        crc = zlib.crc32(head)
        left = payload
        while left:
            piece = zero[: min(left, PIECE)]
            out.append(cobj.compress(piece))
            crc = zlib.crc32(piece, crc)
            left -= len(piece)
        out.append(cobj.flush())
    elif compression == "lz4":
        comp = lz4.frame.LZ4FrameCompressor()
        out = [comp.begin(), comp.compress(head)]
        crc = zlib.crc32(head)
        left = payload
        while left:
            piece = zero[: min(left, PIECE)]
            out.append(comp.compress(piece))
            crc = zlib.crc32(piece, crc)
            left -= len(piece)
        out.append(comp.flush())
    else:
        raise ValueError(compression)
    true_size = len(head) + payload
    return CraftedChunk(
        compression,
        b"".join(out),
        true_size if declared_size is None else declared_size,
        crc,
        log_time,
        log_time,
        [(channel_id, log_time, 0)],
    )


@dataclass
class Summary:
    """The summary a crafted file will carry (edit it before :meth:`McapFile.bytes`)."""

    schemas: list[Schema]
    channels: list[Channel]
    statistics: Statistics
    chunk_indexes: list[ChunkIndex]


class McapFile:
    """An MCAP file assembled record by record: the header, then data-section items in the
    order added (chunks with their message indexes, bare records), a summary built from what
    was written (edit it through ``edit``), the footer."""

    def __init__(self, parts: McapParts) -> None:
        self.parts = parts
        self._data = bytearray(MAGIC + _record(parts.header))
        self._indexes: list[ChunkIndex] = []
        self._counts: dict[int, int] = {}
        self._times: list[int] = []
        self.chunk_offsets: list[int] = []

    def chunk(self, chunk: CraftedChunk, *, message_indexes: bool = True) -> McapFile:
        """Add ``chunk`` and (unless told not to) its message index records."""
        start = len(self._data)
        self.chunk_offsets.append(start)
        self._data += _record(
            Chunk(
                compression=chunk.compression,
                data=chunk.data,
                message_end_time=chunk.end,
                message_start_time=chunk.start,
                uncompressed_crc=chunk.uncompressed_crc,
                uncompressed_size=chunk.uncompressed_size,
            )
        )
        length = len(self._data) - start
        offsets: dict[int, int] = {}
        if message_indexes:
            by_channel: dict[int, list[tuple[int, int]]] = {}
            for cid, t, off in chunk.entries:
                by_channel.setdefault(cid, []).append((t, off))
            for cid, records in sorted(by_channel.items()):
                offsets[cid] = len(self._data)
                self._data += _record(MessageIndex(channel_id=cid, records=records))
        for cid, t, _ in chunk.entries:
            self._counts[cid] = self._counts.get(cid, 0) + 1
            self._times.append(t)
        self._indexes.append(
            ChunkIndex(
                chunk_length=length,
                chunk_start_offset=start,
                compression=chunk.compression,
                compressed_size=len(chunk.data),
                message_end_time=chunk.end,
                message_index_length=len(self._data) - start - length,
                message_index_offsets=offsets,
                message_start_time=chunk.start,
                uncompressed_size=chunk.uncompressed_size,
            )
        )
        return self

    def chunks(self, messages: list[Message], per_chunk: int, **kw: Any) -> McapFile:
        """``messages`` in chunks of ``per_chunk``, the schemas and channels in the first."""
        for k in range(0, len(messages), per_chunk):
            head: list[Any] = [*self.parts.schemas, *self.parts.channels] if k == 0 else []
            self.chunk(records_chunk([*head, *messages[k : k + per_chunk]], **kw))
        return self

    def record(self, record: Any) -> McapFile:
        """A bare record in the data section (a schema, a channel, an unchunked message)."""
        if isinstance(record, Message):
            self._counts[record.channel_id] = self._counts.get(record.channel_id, 0) + 1
            self._times.append(record.log_time)
        self._data += _record(record)
        return self

    def summary(self) -> Summary:
        """The honest summary of what was written so far."""
        return Summary(
            list(self.parts.schemas),
            list(self.parts.channels),
            Statistics(
                attachment_count=0,
                channel_count=len(self.parts.channels),
                channel_message_counts=dict(self._counts),
                chunk_count=len(self._indexes),
                message_count=sum(self._counts.values()),
                message_end_time=max(self._times, default=0),
                message_start_time=min(self._times, default=0),
                metadata_count=0,
                schema_count=len(self.parts.schemas),
            ),
            [ChunkIndex(**vars(c)) for c in self._indexes],
        )

    def bytes(
        self, edit: Callable[[Summary], None] | None = None, *, with_summary: bool = True
    ) -> bytes:
        """The whole file. ``edit`` changes the summary before it is written;
        ``with_summary=False`` ends the file after the data section (a footer without one)."""
        out = bytearray(self._data)
        out += _record(DataEnd(data_section_crc=0))
        summary_start = 0
        if with_summary:
            summary = self.summary()
            if edit is not None:
                edit(summary)
            summary_start = len(out)
            for record in [*summary.schemas, *summary.channels]:
                out += _record(record)
            for index in summary.chunk_indexes:
                out += _record(index)
            out += _record(summary.statistics)
        out += _record(Footer(summary_start=summary_start, summary_offset_start=0, summary_crc=0))
        out += MAGIC
        return bytes(out)

    def write(self, path: Path, edit: Callable[[Summary], None] | None = None, **kw: Any) -> Path:
        path.write_bytes(self.bytes(edit, **kw))
        return path


def iter_pieces(total: int) -> Iterator[bytes]:
    """``total`` zero bytes in pieces of at most 16 MiB."""
    zero = bytes(min(PIECE, total))
    while total:
        piece = zero[: min(total, PIECE)]
        total -= len(piece)
        yield piece
