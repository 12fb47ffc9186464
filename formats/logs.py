"""Open robot logs of any supported container as one time-ordered stream of raw messages.

``open_logs(paths)`` accepts MCAP files (ROS 2 and ROS 1 profiles, also bare rosbag2 ``.mcap``
files), ROS 1 ``.bag`` files and rosbag2 folders (sqlite3 or mcap storage), guessing each file's
format from its path and first bytes. The :class:`LogSet` it returns lists topics with counts from
the files' indexes (no message is read for that), yields :class:`~formats.raw.RawMessage` records
merged over all files in log-time order, and decodes a message on request with the definitions the
log itself embeds.

MCAP files are read with the ``mcap`` library directly (rosbags refuses ROS 1-profile MCAP, and the
raw bytes are what the numpy adapters want): chunks that hold no requested topic are skipped
without decompressing them. A truncated or partly corrupt MCAP is read linearly up to the break,
and :attr:`LogSet.warnings` says where reading stopped. The storage files of rosbag2 folders with
(uncompressed) mcap storage go the same way; ROS 1 bags and sqlite3 or compressed rosbag2 folders
are read with the rosbags readers.

:meth:`LogSet.recorded_windows` says which time windows the logs recorded anything in, from the
same indexes (:mod:`formats.recorded`), without reading message payloads where a container
indexes its messages.
"""

from __future__ import annotations

import heapq
import io
import re
import struct
import zlib
from array import array
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from operator import attrgetter
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.errors import LogFormatError, MessageDecodeError, TopicNotFoundError
from formats import recorded
from formats.raw import Encoding, RawMessage, TopicInfo, normalize_msgtype

if TYPE_CHECKING:
    import numpy.typing as npt
    from rosbags.typesys.store import Typestore

    from formats.recorded import Windows

FORMATS: tuple[str, ...] = ("mcap", "bag", "rosbag2")
"""Values of ``fmt`` / ``--format``."""

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_BAG_MAGIC = b"#ROSBAG V2.0"
_SQLITE_MAGIC = b"SQLite format 3\x00"
_SEPARATOR = re.compile(r"^={3,}[ \t]*$", re.MULTILINE)
_MESSAGE_ENCODINGS: dict[str, Encoding] = {"cdr": "cdr", "ros1": "ros1"}
_MCAP_READ_ERRORS = (
    EOFError,
    ValueError,
    KeyError,
    struct.error,
    OSError,
    MemoryError,
    OverflowError,  # a damaged record length too large to read
)


@dataclass(frozen=True)
class LogFile:
    """One opened file: container format (``mcap-ros2``, ``mcap-ros1``, ``bag``,
    ``rosbag2-sqlite3``, ``rosbag2-mcap``), size on disk, time range and message count."""

    path: Path
    format: str
    size_bytes: int
    start_ns: int
    end_ns: int
    message_count: int


@dataclass
class _Topic:
    """What a source knows about one of its topics."""

    topic: str
    msgtype: str
    encoding: Encoding
    definition: str
    idl: bool = False  # definition is ROS 2 IDL rather than .msg text
    count: int = 0
    keys: list[Any] = field(default_factory=list)  # channel ids or rosbags connections


class _Source:
    """One log file or rosbag2 folder behind :class:`LogSet`."""

    file: LogFile
    topics: dict[tuple[str, str], _Topic]  # by (topic, msgtype)
    warnings: list[str]

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        """This source's messages on ``topics`` (all when None), in log-time order."""
        raise NotImplementedError

    def recorded_windows(self, window_ns: int) -> Windows:
        """Sorted unique windows ``floor(t / window_ns)`` (``window_ns`` already checked) that
        hold at least one message of this source, any topic, from its indexes where it has
        them."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the file handles."""


def _schema_encoding_ok(encoding: str) -> bool:
    return encoding in ("ros1msg", "ros2msg", "ros2idl", "")


class _McapSource(_Source):
    """An MCAP file read with the mcap library (both ROS profiles).

    With a summary, chunks are visited in time order through the chunk indexes, skipping chunks
    without requested channels; without one (or when it is unreadable) the file is read
    linearly, up to the first unreadable record.
    """

    def __init__(self, path: Path, fmt_name: str | None = None) -> None:
        from mcap.exceptions import McapError
        from zstandard import ZstdError

        self.path = path
        self.warnings = []
        self._stream: IO[bytes] = path.open("rb")
        # RuntimeError: what lz4 raises on a damaged frame
        self._errors: tuple[type[BaseException], ...] = (
            McapError,
            ZstdError,
            RuntimeError,
            *_MCAP_READ_ERRORS,
        )
        self._chunk_indexes: list[Any] | None = None
        self._stop_offset: int | None = None
        # log times of every message, kept by the linear scan of a file without a usable
        # summary: recorded_windows then needs no second read (8 bytes per message)
        self._scanned_times: npt.NDArray[np.int64] | None = None
        self._profile = ""
        channels, schemas, counts, start, end = self._read_summary()
        if channels is None:
            channels, schemas, counts, start, end = self._scan()
        self._channels: dict[int, tuple[str, str, Encoding]] = {}
        self.topics = {}
        for cid, channel in sorted(channels.items()):
            schema = schemas.get(channel.schema_id)
            encoding = _MESSAGE_ENCODINGS.get(channel.message_encoding)
            if schema is None or encoding is None or not _schema_encoding_ok(schema.encoding):
                enc = schema.encoding if schema is not None else "none"
                self.warnings.append(
                    f"{path.name}: topic {channel.topic} skipped: message encoding "
                    f"{channel.message_encoding!r} with schema encoding {enc!r} is not ROS"
                )
                continue
            msgtype = normalize_msgtype(schema.name)
            info = self.topics.get((channel.topic, msgtype))
            if info is None:
                definition = schema.data.decode("utf-8", "replace")
                info = self.topics[channel.topic, msgtype] = _Topic(
                    channel.topic, msgtype, encoding, definition, schema.encoding == "ros2idl"
                )
            info.count += counts.get(cid, 0)
            info.keys.append(cid)
            self._channels[cid] = (channel.topic, msgtype, encoding)
        if fmt_name is not None:
            fmt = fmt_name
        elif self._profile == "ros1" or (not self._profile and _all_ros1(self.topics)):
            fmt = "mcap-ros1"
        else:
            fmt = "mcap-ros2"
        total = sum(counts.values())
        self.file = LogFile(path, fmt, path.stat().st_size, start, end, total)

    # -- opening ---------------------------------------------------------------------------

    def _read_summary(self) -> tuple[Any, Any, dict[int, int], int, int]:
        """Channels, schemas, counts and time range from the summary section, or ``None``
        channels when there is no usable summary (no footer, no statistics, no chunk index)."""
        from mcap.reader import SeekingReader

        try:
            reader = SeekingReader(self._stream)
            self._profile = reader.get_header().profile
            summary = reader.get_summary()
        except self._errors:
            return None, None, {}, 0, 0
        if summary is None or summary.statistics is None or not summary.chunk_indexes:
            return None, None, {}, 0, 0
        stats = summary.statistics
        self._chunk_indexes = sorted(
            summary.chunk_indexes, key=lambda c: (c.message_start_time, c.chunk_start_offset)
        )
        return (
            summary.channels,
            summary.schemas,
            dict(stats.channel_message_counts),
            stats.message_start_time,
            stats.message_end_time,
        )

    def _scan(self) -> tuple[Any, Any, dict[int, int], int, int]:
        """Read the whole file linearly to count messages and keep their log times (for
        :meth:`recorded_windows`); note where an unreadable record stops the read (truncated
        or corrupt file)."""
        from mcap.records import Channel, Header, Message, Schema

        channels: dict[int, Any] = {}
        schemas: dict[int, Any] = {}
        counts: dict[int, int] = {}
        times = array("Q")
        start, end, n = 2**63 - 1, 0, 0
        for record in self._linear_records(scanning=True):
            if isinstance(record, Message):
                counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                times.append(record.log_time)
                start = min(start, record.log_time)
                end = max(end, record.log_time)
                n += 1
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Header):
                self._profile = record.profile
        self._scanned_times = np.frombuffer(times, dtype=np.uint64).astype(np.int64)
        if self._stop_offset is not None:
            self.warnings.append(
                f"{self.path.name}: truncated or corrupt MCAP: read stopped at byte "
                f"{self._stop_offset} of {self.path.stat().st_size} after {n} messages; "
                "the rest of the file is ignored"
            )
        return channels, schemas, counts, (start if n else 0), end

    def _linear_records(self, *, scanning: bool = False) -> Iterator[Any]:
        """Every record of the file in file order, chunks broken up with their messages sorted
        by log time; stops quietly at the first unreadable record (remembered when scanning)."""
        from mcap.stream_reader import StreamReader

        with self.path.open("rb") as stream:  # own handle: iterations may interleave
            reader = StreamReader(stream, skip_magic=False, emit_chunks=True)
            yield from self._split_records(reader.records, stream, scanning)

    def _split_records(
        self, records: Iterator[Any], stream: IO[bytes], scanning: bool
    ) -> Iterator[Any]:
        """Records of ``records`` with chunks broken up; ``stream`` gives the byte offset of the
        last good record when reading fails."""
        from mcap.records import Chunk, Message
        from mcap.stream_reader import breakup_chunk

        good = 0
        while True:
            try:
                record = next(records)
                if isinstance(record, Chunk):
                    parts = breakup_chunk(record, validate_crc=True)
                    parts.sort(key=_record_sort_key)
                else:
                    parts = [record]
            except StopIteration:
                return
            except self._errors:
                if scanning:
                    self._stop_offset = good
                return
            good = stream.tell()
            for part in parts:
                if scanning or isinstance(part, Message):
                    yield part

    # -- reading ---------------------------------------------------------------------------

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        wanted = {
            cid
            for cid, (topic, _, _) in self._channels.items()
            if topics is None or topic in topics
        }
        if not wanted:
            return iter(())
        if self._chunk_indexes is None:
            return self._messages_linear(wanted)
        if _chunks_overlap(self._chunk_indexes):
            return self._messages_library(wanted)
        return self._messages_chunks(wanted)

    def _messages_chunks(self, wanted: set[int]) -> Iterator[RawMessage]:
        """Time order by chunk: chunk indexes sorted by start time do not overlap, so each
        chunk's messages sorted by log time continue the stream."""
        from mcap.data_stream import ReadDataStream
        from mcap.records import Chunk

        channels = self._channels
        stream = self._stream
        assert self._chunk_indexes is not None
        for index in self._chunk_indexes:
            if index.message_index_offsets and wanted.isdisjoint(index.message_index_offsets):
                continue
            try:
                stream.seek(index.chunk_start_offset + 1 + 8, io.SEEK_SET)
                selected = _chunk_messages(Chunk.read(ReadDataStream(stream)), wanted)
            except self._errors as exc:
                self.warnings.append(
                    f"{self.path.name}: corrupt chunk at byte {index.chunk_start_offset} "
                    f"({exc}); the rest of the file is ignored"
                )
                return
            for log_time, channel_id, data in selected:
                topic, msgtype, encoding = channels[channel_id]
                yield RawMessage(topic, msgtype, log_time, data, encoding)

    def _messages_library(self, wanted: set[int]) -> Iterator[RawMessage]:
        """Overlapping chunks: let the mcap reader interleave them in log-time order."""
        from mcap.reader import SeekingReader

        topics = {self._channels[cid][0] for cid in wanted}
        channels = self._channels
        reader = SeekingReader(self._stream, validate_crcs=True)
        try:
            for _, channel, r in reader.iter_messages(topics=topics, log_time_order=True):
                if channel.id in wanted:
                    topic, msgtype, encoding = channels[channel.id]
                    yield RawMessage(topic, msgtype, r.log_time, r.data, encoding)
        except self._errors as exc:
            self.warnings.append(
                f"{self.path.name}: corrupt chunk ({exc}); the rest of the file is ignored"
            )

    def _messages_linear(self, wanted: set[int]) -> Iterator[RawMessage]:
        channels = self._channels
        for r in self._linear_records():
            if r.channel_id in wanted:
                topic, msgtype, encoding = channels[r.channel_id]
                yield RawMessage(topic, msgtype, r.log_time, r.data, encoding)

    # -- recorded windows ------------------------------------------------------------------

    def recorded_windows(self, window_ns: int) -> Windows:
        """From the chunk indexes when the file has a summary: a chunk within one window or
        two adjacent ones records the windows of its first and last message; only wider chunks
        need their message times, from their MessageIndex records (a few bytes each; the chunk
        is decompressed only when it has none or they are damaged). Without a summary, the log
        times the opening scan kept (read up to the first unreadable record)."""
        if self._chunk_indexes is None:
            times = self._scanned_times
            return recorded.windows_of(times if times is not None else [], window_ns)
        indexes = self._chunk_indexes
        n = len(indexes)
        # uint64 in the file: as int64, like every time in aion
        starts = np.fromiter((c.message_start_time for c in indexes), np.uint64, n).astype(np.int64)
        ends = np.fromiter((c.message_end_time for c in indexes), np.uint64, n).astype(np.int64)
        indexed = np.fromiter((bool(c.message_index_offsets) for c in indexes), np.bool_, n)
        empty = starts > ends  # some writers mark a chunk without messages so
        # 0..0 without message indexes: a chunk without messages, or one message at t = 0
        unsure = ~indexed & (starts == 0) & (ends == 0)
        read = (recorded.wide_spans(starts, ends, window_ns) | unsure) & ~empty
        parts = []
        stop = n
        with self.path.open("rb") as stream:  # own handle: message iterations may be running
            for k in np.flatnonzero(read):
                times = self._chunk_times(stream, indexes[k])
                if times is None:  # unreadable chunk: like messages(), stop here
                    stop = int(k)
                    break
                parts.append(recorded.windows_of(times, window_ns))
        ends_only = ~read & ~empty
        ends_only[stop:] = False
        parts.append(recorded.end_windows(starts[ends_only], ends[ends_only], window_ns))
        return recorded.union(parts)

    def _chunk_times(self, stream: IO[bytes], index: Any) -> npt.NDArray[np.int64] | None:
        """Log times of one chunk's messages: from its MessageIndex records, else from the
        decompressed chunk; ``None`` (and a warning) when the chunk itself is unreadable."""
        from mcap.data_stream import ReadDataStream
        from mcap.records import Chunk

        if index.message_index_offsets and index.message_index_length > 0:
            base = index.chunk_start_offset + index.chunk_length
            try:
                stream.seek(base, io.SEEK_SET)
                block = stream.read(index.message_index_length)
                offsets = [off - base for off in index.message_index_offsets.values()]
                return recorded.message_index_times(block, offsets)
            except self._errors:
                pass  # a damaged index does not mean a damaged chunk: read the chunk
        try:
            stream.seek(index.chunk_start_offset + 1 + 8, io.SEEK_SET)
            chunk = Chunk.read(ReadDataStream(stream))
            buf = _decompress(chunk)
            if chunk.uncompressed_crc and zlib.crc32(buf) != chunk.uncompressed_crc:
                raise ValueError("chunk records fail their CRC-32 check")
            return recorded.record_log_times(buf)
        except self._errors as exc:
            warning = (
                f"{self.path.name}: corrupt chunk at byte {index.chunk_start_offset} ({exc}); "
                "no recorded window is taken from it or from later chunks"
            )
            if warning not in self.warnings:  # once, however often windows are asked for
                self.warnings.append(warning)
            return None

    def close(self) -> None:
        self._stream.close()


_MESSAGE_OPCODE = 0x05
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time follows)
_MESSAGE_PREFIX = 2 + 4 + 8 + 8


def _decompress(chunk: Any) -> bytes:
    """The records section of an MCAP chunk (zstd, lz4 or uncompressed)."""
    if chunk.compression in ("zstd", "lz4"):
        try:
            if chunk.compression == "zstd":
                import zstandard

                return bytes(zstandard.decompress(chunk.data, chunk.uncompressed_size))
            import lz4.frame  # type: ignore[import-untyped]

            return bytes(lz4.frame.decompress(chunk.data))
        except Exception as exc:  # zstandard.ZstdError, lz4's RuntimeError: a damaged chunk
            raise ValueError(f"cannot decompress the {chunk.compression} chunk: {exc}") from exc
    if chunk.compression:
        raise ValueError(f"unsupported MCAP chunk compression {chunk.compression!r}")
    return bytes(chunk.data)


def _chunk_messages(chunk: Any, wanted: set[int]) -> list[tuple[int, int, bytes]]:
    """``(log_time, channel_id, data)`` of the chunk's messages on ``wanted`` channels, sorted
    by log time. Parses the record headers with struct and slices only the wanted payloads:
    several times faster than building an mcap ``Message`` object per record."""
    buf = _decompress(chunk)
    if chunk.uncompressed_crc and zlib.crc32(buf) != chunk.uncompressed_crc:
        # a flipped bit in compressed data often still decompresses: into garbage
        raise ValueError("chunk records fail their CRC-32 check")
    out: list[tuple[int, int, bytes]] = []
    unpack_record = _RECORD_HEAD.unpack_from
    unpack_message = _MESSAGE_HEAD.unpack_from
    pos, end = 0, len(buf)
    while pos < end:
        opcode, length = unpack_record(buf, pos)
        body = pos + 9
        pos = body + length
        if opcode == _MESSAGE_OPCODE:
            channel_id, _, log_time = unpack_message(buf, body)
            if channel_id in wanted:
                out.append((log_time, channel_id, buf[body + _MESSAGE_PREFIX : pos]))
    if pos != end:
        raise ValueError("chunk records overrun the chunk")
    out.sort(key=_first)
    return out


def _first(item: tuple[int, int, bytes]) -> int:
    return item[0]


def _record_sort_key(record: Any) -> tuple[int, int]:
    """Non-message records (schemas, channels) first, then messages by log time."""
    log_time = getattr(record, "log_time", None)
    return (0, 0) if log_time is None else (1, int(log_time))


def _chunks_overlap(indexes: list[Any]) -> bool:
    end = -1
    for index in indexes:
        if index.message_start_time < end:
            return True
        end = max(end, index.message_end_time)
    return False


def _all_ros1(topics: dict[tuple[str, str], _Topic]) -> bool:
    return bool(topics) and all(t.encoding == "ros1" for t in topics.values())


class _RosbagsSource(_Source):
    """A ROS 1 bag or a rosbag2 folder, read with the rosbags readers."""

    def __init__(self, path: Path, kind: str) -> None:
        self.path = path
        self.warnings = []
        self._reader = _open_rosbags(path, kind)
        reader = self._reader
        self.topics = {}
        for conn in reader.connections:
            encoding: Encoding
            if kind == "bag":
                encoding = "ros1"
            else:
                fmt = getattr(conn.ext, "serialization_format", "cdr")
                if fmt not in _MESSAGE_ENCODINGS:
                    self.warnings.append(
                        f"{path.name}: topic {conn.topic} skipped: serialization {fmt!r} is not CDR"
                    )
                    continue
                encoding = _MESSAGE_ENCODINGS[fmt]
            msgtype = normalize_msgtype(conn.msgtype)
            info = self.topics.get((conn.topic, msgtype))
            if info is None:
                definition = conn.msgdef.data if conn.msgdef is not None else ""
                idl = conn.msgdef is not None and conn.msgdef.format.name == "IDL"
                info = self.topics[conn.topic, msgtype] = _Topic(
                    conn.topic, msgtype, encoding, definition or "", idl
                )
            info.count += conn.msgcount
            info.keys.append(conn)
        total = sum(t.count for t in self.topics.values())
        if kind == "bag":
            fmt_name = "bag"
            size = path.stat().st_size
        else:
            storages = getattr(reader.storage, "storages", [])
            mcap = any("mcap" in type(x).__name__.lower() for x in storages)
            fmt_name = "rosbag2-mcap" if mcap else "rosbag2-sqlite3"
            size = sum(p.stat().st_size for p in path.iterdir() if p.is_file())
        start = reader.start_time if total else 0
        end = max(reader.end_time - 1, start) if total else 0  # rosbags' end is exclusive
        self.file = LogFile(path, fmt_name, size, start, end, total)

    def plain_mcap_files(self) -> list[Path]:
        """The storage files of an uncompressed rosbag2 folder with mcap storage, else []."""
        if self.file.format != "rosbag2-mcap" or self._reader.compression_format:
            return []
        storages = getattr(self._reader.storage, "storages", [])
        paths = [getattr(x, "path", None) for x in storages]
        if not paths or not all(isinstance(p, Path) and p.suffix == ".mcap" for p in paths):
            return []
        return [p for p in paths if isinstance(p, Path)]

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        conns = [
            conn
            for info in self.topics.values()
            if topics is None or info.topic in topics
            for conn in info.keys
        ]
        if not conns:
            return iter(())
        return self._messages(conns)

    def _messages(self, conns: list[Any]) -> Iterator[RawMessage]:
        meta = {
            conn.id: (info.topic, info.msgtype, info.encoding)
            for info in self.topics.values()
            for conn in info.keys
            if conn in conns
        }
        try:
            for conn, t_ns, data in self._reader.messages(connections=conns):
                topic, msgtype, encoding = meta[conn.id]
                if type(data) is not bytes:
                    data = bytes(data)
                yield RawMessage(topic, msgtype, t_ns, data, encoding)
        except Exception as exc:  # rosbags raises its own errors, sqlite3 and struct errors
            raise LogFormatError(
                f"{self.path}: cannot read messages ({exc})",
                hint="the log may be corrupt; for ROS 1 bags try `rosbag reindex`",
            ) from exc

    def recorded_windows(self, window_ns: int) -> Windows:
        """ROS 1 bags: the message times of the index rosbags loaded at open (no chunk is
        read). rosbag2 folders: per storage file, SQLite computes the windows over the indexed
        ``timestamp`` column; mcap storage files read here (compressed bags) give their times
        through the rosbags storage reader, which never decompresses message payloads."""
        try:
            if self.file.format == "bag":
                return self._bag_windows(window_ns)
            return self._rosbag2_windows(window_ns)
        except LogFormatError:
            raise
        except Exception as exc:  # rosbags, apsw / sqlite3 and struct errors
            raise LogFormatError(
                f"{self.path}: cannot read message times ({exc})",
                hint="the log may be corrupt; for ROS 1 bags try `rosbag reindex`",
            ) from exc

    def _bag_windows(self, window_ns: int) -> Windows:
        indexes = getattr(self._reader, "indexes", None)
        if isinstance(indexes, dict):
            return recorded.windows_of(recorded.rosbag1_index_times(indexes), window_ns)
        # a rosbags version without the loaded index: read the messages for their times
        return recorded.windows_of(recorded.times_of(self._reader.messages()), window_ns)

    def _rosbag2_windows(self, window_ns: int) -> Windows:
        storages = getattr(self._reader.storage, "storages", None)
        if not isinstance(storages, list):
            return recorded.windows_of(
                recorded.times_of(self._reader.messages(self._reader.connections)), window_ns
            )
        parts = []
        for storage in storages:
            # rosbags decompressed file-compressed storage at open, and message compression
            # leaves the timestamps alone: the sqlite3 query holds for every bag
            db = getattr(storage, "dbconn", None)
            if db is not None:
                parts.append(recorded.sqlite_windows(db, window_ns))
            else:
                times = recorded.times_of(storage.messages(storage.connections))
                parts.append(recorded.windows_of(times, window_ns))
        return recorded.union(parts)

    def close(self) -> None:
        self._reader.close()


def _open_rosbags(path: Path, kind: str) -> Any:
    """An open rosbags Reader for ``path``, with rosbags errors turned into LogFormatError."""
    if kind == "bag":
        from rosbags.rosbag1 import Reader as Reader1

        reader: Any = Reader1(path)
        what = "ROS 1 bag"
        hint = "the bag may be truncated or corrupt; try `rosbag reindex` on a copy"
    else:
        from rosbags.rosbag2 import Reader as Reader2

        reader = Reader2(path)
        what = "rosbag2 folder"
        hint = "check metadata.yaml and the storage files (.db3 / .mcap) next to it"
    try:
        reader.open()
    except Exception as exc:  # rosbags ReaderError and the errors of its storage plugins
        raise LogFormatError(f"{path}: not a readable {what} ({exc})", hint=hint) from exc
    return reader


# --- format guessing ------------------------------------------------------------------------


def guess_format(path: Path) -> tuple[str, Path]:
    """``(format, path to open)`` for ``path``: ``.mcap`` / ``.bag`` files, rosbag2 folders
    (or their ``metadata.yaml`` / ``.db3``), otherwise the file's first bytes decide."""
    if not path.exists():
        raise LogFormatError(f"no such file or folder: {path}", hint="check the log path")
    if path.is_dir():
        if (path / "metadata.yaml").is_file():
            return "rosbag2", path
        found = sorted(p.name for p in path.iterdir())[:5]
        raise LogFormatError(
            f"{path} is a folder but not a rosbag2 bag (no metadata.yaml)",
            hint="pass a .mcap or .bag file, or a rosbag2 folder; the folder holds: "
            + (", ".join(found) if found else "nothing"),
        )
    if path.stat().st_size == 0:
        raise LogFormatError(f"{path} is empty (0 bytes)", hint="the recording was not written")
    if path.name == "metadata.yaml" or (
        path.suffix == ".db3" and (path.parent / "metadata.yaml").is_file()
    ):
        return "rosbag2", path.parent
    suffix = path.suffix.lower()
    if suffix == ".mcap":
        return "mcap", path
    if suffix == ".bag":
        return "bag", path
    with path.open("rb") as f:
        head = f.read(16)
    if head.startswith(_MCAP_MAGIC):
        return "mcap", path
    if head.startswith(_BAG_MAGIC):
        return "bag", path
    if head.startswith(_SQLITE_MAGIC):
        raise LogFormatError(
            f"{path} is an SQLite file without a rosbag2 metadata.yaml next to it",
            hint="pass the rosbag2 folder that holds metadata.yaml",
        )
    raise LogFormatError(
        f"cannot tell the log format of {path}",
        hint="aion reads .mcap, ROS 1 .bag and rosbag2 folders; use --log-format mcap|bag|rosbag2",
    )


def _open_sources(path: Path, fmt: str | None) -> list[_Source]:
    """The sources of one path: one file, or the storage files of a rosbag2 folder."""
    if fmt is not None and fmt not in FORMATS:
        raise LogFormatError(
            f"unknown log format {fmt!r}", hint=f"use one of: {', '.join(FORMATS)}"
        )
    guessed, target = guess_format(path)
    kind = fmt or guessed
    if kind == "mcap":
        if target.is_dir():
            files = sorted(target.glob("*.mcap"))
            if len(files) != 1:
                raise LogFormatError(
                    f"{target} holds {len(files)} .mcap files", hint="pass one .mcap file"
                )
            target = files[0]
        return [_open_mcap(target)]
    if kind == "bag":
        return [_RosbagsSource(target, "bag")]
    folder = target.parent if target.is_file() else target
    try:
        source = _RosbagsSource(folder, "rosbag2")
    except LogFormatError:
        # A recording killed before it finished leaves mcap storage files without a summary,
        # which rosbags refuses; the mcap reader recovers what was written.
        storage = sorted(folder.glob("*.mcap"))
        if not storage:
            raise
        return [_open_mcap(f, fmt_name="rosbag2-mcap") for f in storage]
    files = source.plain_mcap_files()
    if files:
        # rosbag2 with mcap storage: the mcap reader is faster than rosbags' mcap plugin.
        source.close()
        return [_open_mcap(f, fmt_name="rosbag2-mcap") for f in files]
    return [source]


def _open_mcap(path: Path, fmt_name: str | None = None) -> _McapSource:
    size = path.stat().st_size
    if size == 0:
        raise LogFormatError(f"{path} is empty (0 bytes)", hint="the recording was not written")
    with path.open("rb") as f:
        head = f.read(len(_MCAP_MAGIC))
    if head != _MCAP_MAGIC:
        raise LogFormatError(
            f"{path} is not an MCAP file (it does not start with the MCAP magic bytes)",
            hint="check the file, or pass --format bag|rosbag2 if it is another log type",
        )
    return _McapSource(path, fmt_name)


# --- the merged set -------------------------------------------------------------------------


class LogSet:
    """Several opened logs seen as one: topics, time range, merged message stream, decoding.

    Use as a context manager (or call :meth:`close`). Counts and the time range come from the
    files' indexes; :meth:`messages` reads only the requested topics and never decodes.
    """

    def __init__(self, sources: list[_Source]) -> None:
        self._sources = sources
        self.files: list[LogFile] = [s.file for s in sources]
        merged: dict[tuple[str, str], TopicInfo] = {}
        self._definitions: dict[tuple[str, str, str], tuple[str, bool]] = {}
        for source in sources:
            for t in source.topics.values():
                key = (t.topic, t.msgtype)
                defkey = (t.topic, t.msgtype, t.encoding)
                if t.definition.strip() and defkey not in self._definitions:
                    self._definitions[defkey] = (t.definition, t.idl)
                prev = merged.get(key)
                src = str(source.file.path)
                if prev is None:
                    merged[key] = TopicInfo(
                        t.topic, t.msgtype, t.count, t.encoding, t.definition, src
                    )
                else:
                    merged[key] = TopicInfo(
                        t.topic,
                        t.msgtype,
                        prev.count + t.count,
                        prev.encoding,
                        prev.definition or t.definition,
                        f"{prev.source}, {src}",
                    )
        self.topics: list[TopicInfo] = sorted(merged.values(), key=attrgetter("topic"))
        with_messages = [f for f in self.files if f.message_count > 0]
        self.start_ns: int = min((f.start_ns for f in with_messages), default=0)
        self.end_ns: int = max((f.end_ns for f in with_messages), default=0)
        self._decoders: dict[tuple[str, str, str], Callable[[bytes], Any]] = {}
        self._stores: dict[str, Typestore] = {}
        self._closed = False

    @property
    def warnings(self) -> list[str]:
        """Problems met so far (skipped topics, truncated files), one line each."""
        return [w for s in self._sources for w in s.warnings]

    @property
    def duration_ns(self) -> int:
        return max(self.end_ns - self.start_ns, 0)

    def topic(self, name: str) -> TopicInfo:
        """The topic called ``name``; :class:`TopicNotFoundError` lists the log's topics."""
        for info in self.topics:
            if info.topic == name:
                return info
        candidates = [f"{t.topic} ({t.msgtype})" for t in self.topics]
        raise TopicNotFoundError(
            f"topic {name!r} is not in the log", candidates=candidates, hint="see `aion info LOG`"
        )

    def total(self, topics: Iterable[str] | None = None) -> int:
        """Number of messages on ``topics`` (all when None), from the indexes."""
        selected = None if topics is None else set(topics)
        return sum(t.count for t in self.topics if selected is None or t.topic in selected)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Messages on ``topics`` (all when None; names not in the log are ignored) of every
        file, merged in log-time order (ties keep file order)."""
        if self._closed:
            raise ValueError("messages() on a closed LogSet")
        selected = None if topics is None else set(topics)
        streams = [s.messages(selected) for s in self._sources]
        if len(streams) == 1:
            return streams[0]
        return heapq.merge(*streams, key=attrgetter("log_time_ns"))

    def recorded_windows(self, window_ns: int) -> Windows:
        """Sorted unique window indices ``floor(t / window_ns)`` holding at least one message
        (any topic, any file of the set, log time).

        What a fixed sensor observed: the windows in which it recorded something, never the
        time between two recordings within a file or between files. Read from the containers'
        indexes without message payloads where they have them (MCAP summaries, ROS 1 bag
        indexes, rosbag2 sqlite3); :class:`ConfigError` for a window that is not a positive
        number of nanoseconds.
        """
        return recorded.union(w for _, w in self.recorded_windows_by_file(window_ns))

    def recorded_windows_by_file(self, window_ns: int) -> list[tuple[LogFile, Windows]]:
        """:meth:`recorded_windows` of each entry of :attr:`files`, in the same order (a rosbag2
        folder is one entry; its mcap storage files are one entry each)."""
        if self._closed:
            raise ValueError("recorded_windows() on a closed LogSet")
        size = recorded.window_size(window_ns)
        return [(s.file, s.recorded_windows(size)) for s in self._sources]

    def decode(self, msg: RawMessage) -> Any:
        """``msg`` as a rosbags message object, decoded with the definition the log embeds for
        its topic (shipped definitions from :mod:`formats.msgdefs` when the log has none)."""
        key = (msg.topic, msg.msgtype, msg.encoding)
        decoder = self._decoders.get(key)
        if decoder is None:
            decoder = self._decoders[key] = self._make_decoder(msg)
        try:
            return decoder(msg.data)
        except Exception as exc:  # rosbags raises struct, index and value errors on bad bytes
            raise MessageDecodeError(
                f"cannot decode a {msg.msgtype} message on {msg.topic} at {msg.log_time_ns} ns "
                f"({type(exc).__name__}: {exc})",
                hint="the payload does not match its definition; the log may be corrupt",
            ) from exc

    def _make_decoder(self, msg: RawMessage) -> Callable[[bytes], Any]:
        definition, idl = self._definitions.get((msg.topic, msg.msgtype, msg.encoding), ("", False))
        store = _store_with_definition(self._stores, msg.encoding, msg.msgtype, definition, idl)
        if msg.encoding == "ros1":
            des1 = store.deserialize_ros1
            return lambda data: des1(data, msg.msgtype)
        des2 = store.deserialize_cdr
        return lambda data: des2(data, msg.msgtype)

    def close(self) -> None:
        """Close every file."""
        self._closed = True
        for source in self._sources:
            source.close()

    def __enter__(self) -> LogSet:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _store_with_definition(
    stores: dict[str, Typestore], encoding: str, msgtype: str, definition: str, idl: bool
) -> Typestore:
    """A typestore that knows ``msgtype`` as ``definition`` defines it: the set's shared store
    for ``encoding``, or a private one when the log's definition conflicts with it."""
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.base import TypesysError

    from formats import msgdefs

    ros_version = 1 if encoding == "ros1" else 2
    if not definition.strip():
        shipped = msgdefs.typestore(ros_version)
        if msgtype in shipped.fielddefs:
            return shipped
        raise MessageDecodeError(
            f"the log has no definition for {msgtype} and aion ships none",
            hint="give a log recorded with message definitions (ROS 2 Iron or later, MCAP)",
        )
    types = _parse_definition(definition, msgtype, idl)
    store = stores.get(encoding)
    if store is None:
        store = stores[encoding] = get_typestore(
            Stores.ROS1_NOETIC if ros_version == 1 else Stores.ROS2_HUMBLE
        )
    try:
        store.register(types)
        return store
    except TypesysError:
        # The log's own version of a type differs from the standard one: decode this topic with
        # a store holding only the log's definitions (plus the builtin time types they use).
        from rosbags.typesys.store import Typestore

        private = Typestore()
        builtins = {k: v for k, v in store.fielddefs.items() if k.startswith("builtin_interfaces/")}
        private.register({**builtins, **types})
        return private


def _parse_definition(definition: str, msgtype: str, idl: bool) -> dict[str, Any]:
    from rosbags.typesys import get_types_from_idl, get_types_from_msg

    if not idl:
        # rosbags wants the 80-character separator; ROS tools accept any run of "=".
        definition = _SEPARATOR.sub("=" * 80, definition)
    try:
        if idl:
            return dict(get_types_from_idl(definition))
        return dict(get_types_from_msg(definition, msgtype))
    except Exception as exc:  # rosbags parser errors
        raise MessageDecodeError(
            f"cannot parse the log's definition of {msgtype} ({exc})",
            hint="the log's embedded message definition is malformed",
        ) from exc


def open_logs(paths: Iterable[Path | str], fmt: str | None = None) -> LogSet:
    """Open ``paths`` (files or rosbag2 folders) as one :class:`LogSet`; ``fmt`` (``"mcap"``,
    ``"bag"``, ``"rosbag2"``) overrides the format guessed from each path.

    Raises :class:`LogFormatError` for missing, empty, unreadable or message-less logs.
    """
    sources: list[_Source] = []
    try:
        for p in paths:
            sources.extend(_open_sources(Path(p), fmt))
        if not sources:
            raise LogFormatError("no log given", hint="pass at least one log file or folder")
        logset = LogSet(sources)
        if all(f.message_count == 0 for f in logset.files):
            names = ", ".join(str(f.path) for f in logset.files)
            detail = "; ".join(logset.warnings)
            raise LogFormatError(
                f"{names}: no messages" + (f" ({detail})" if detail else ""),
                hint="the recording holds no readable messages",
            )
        for f in logset.files:
            if f.message_count == 0:
                sources[logset.files.index(f)].warnings.append(f"{f.path}: no messages")
        return logset
    except BaseException:
        for source in sources:
            source.close()
        raise
