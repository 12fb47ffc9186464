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
and :attr:`LogSet.warnings` says where reading stopped; messages a file holds out of log-time
order come out in order. The storage files of rosbag2 folders with (uncompressed) mcap storage go
the same way; ROS 1 bags and sqlite3 or compressed rosbag2 folders are read with the rosbags
readers, a rosbag2 folder's storage files matched to its topics by topic and type (not by QoS).

rosbag2 storage files without ``metadata.yaml`` (a folder of them, one ``.db3`` given alone, or a
folder whose metadata.yaml is unusable) are indexed in memory from the files themselves, as
``ros2 bag reindex`` would (:func:`reindex` returns that metadata). Files compressed whole with
zstd (``*.db3.zstd``, ``*.mcap.zstd``: ``compression_mode: file``) given without their folder are
read through a decompressed temporary copy (:mod:`formats.rosbag2_storage`), removed on close.

:meth:`LogSet.recorded_windows` says which time windows the logs recorded anything in, from the
same indexes (:mod:`formats.recorded`), without reading message payloads where a container
indexes its messages.
"""

from __future__ import annotations

import heapq
import io
import re
import struct
from array import array
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from operator import attrgetter
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.errors import LogFormatError, MessageDecodeError, TopicNotFoundError
from formats import recorded
from formats.limits import ReadLimits
from formats.raw import Encoding, RawMessage, TopicInfo, check_regular_input, normalize_msgtype

if TYPE_CHECKING:
    import numpy.typing as npt
    from rosbags.typesys.store import Typestore

    from formats.recorded import Windows

FORMATS: tuple[str, ...] = ("mcap", "bag", "rosbag2")
"""Values of ``fmt`` / ``--format``."""

_LOG_HINT = "pass a log file (.mcap, .bag) or a rosbag2 folder"

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_BAG_MAGIC = b"#ROSBAG V2.0"
_SQLITE_MAGIC = b"SQLite format 3\x00"
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
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
    qos: str = ""  # rosbag2's offered_qos_profiles (YAML text) where the storage keeps it


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
    """An MCAP file read with aion's own record reader (:mod:`formats.mcap_records`; both ROS
    profiles), holding no file open between reads.

    The summary is used only after :func:`formats.mcap_records.check_summary` found it in
    agreement with the data section: then chunks are visited in time order through the chunk
    indexes, skipping chunks without requested channels, and a chunk that cannot be read
    (CRC mismatch, unknown compression, over the size cap, damaged) is skipped alone with a
    warning naming it and the messages lost. Without a summary, or when it disagrees with the
    data (chunks or channels it leaves out, statistics that do not match), the file is read
    linearly, chunk by chunk, up to the first record whose framing is broken.
    """

    def __init__(
        self,
        path: Path,
        fmt_name: str | None = None,
        limits: ReadLimits | None = None,
        *,
        unzstd: bool = False,
    ) -> None:
        """``unzstd``: message payloads are zstd-compressed (a rosbag2 bag recorded with
        ``compression_mode: message``), each decompressed within the message cap."""
        from mcap.exceptions import McapError

        from formats import mcap_records

        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self._unzstd = unzstd
        self._size = path.stat().st_size
        # the mcap library reads the summary section (its errors: McapError)
        self._errors: tuple[type[BaseException], ...] = (McapError, *_MCAP_READ_ERRORS)
        self._chunk_indexes: list[Any] | None = None
        # chunks that cannot be read (offset -> why) and their message counts per channel
        # (from the message index records after each chunk)
        self._bad_chunks: dict[int, str] = {}
        self._chunk_counts: dict[int, dict[int, int]] = {}
        # chunks whose record states a wrong length: read with their index's (offset -> length)
        self._lengths: dict[int, int] = {}
        self._stop_offset: int | None = None
        # log times of every message, kept by the linear scan of a file without a usable
        # summary: recorded_windows then needs no second read (8 bytes per message)
        self._scanned_times: npt.NDArray[np.int64] | None = None
        # with messages out of order in a file read linearly: the earliest log time of each
        # group of records holding messages and of all after it (see _records_linear)
        self._later_min: npt.NDArray[np.int64] | None = None
        self._profile = ""
        self.channel_topics: dict[int, str] = {}
        # messages over the cap met while opening, said once the channels' topics are known
        self._pending_big: list[tuple[int, int, int]] | None = []
        with path.open("rb") as f:
            summary = self._read_summary(f)
            check = None
            if summary is not None:
                names = {cid: c.topic for cid, c in summary.channels.items()}
                check = mcap_records.check_summary(
                    f, self._size, summary.chunk_indexes, summary.statistics, names
                )
        distrust = check is not None and (bool(check.problems) or check.unsure)
        if summary is None or check is None or distrust:
            channels, schemas, counts, start, end = self._scan()
            if summary is not None and check is not None:
                channels = {**summary.channels, **channels}
                schemas = {**summary.schemas, **schemas}
                self._distrusted(check, summary.statistics, counts)
        else:
            stats = summary.statistics
            channels, schemas = summary.channels, summary.schemas
            counts = dict(stats.channel_message_counts)
            start, end = stats.message_start_time, stats.message_end_time
            self._chunk_indexes = sorted(
                summary.chunk_indexes, key=lambda c: (c.message_start_time, c.chunk_start_offset)
            )
            self._bad_chunks.update(check.bad_chunks)
            for index in self._chunk_indexes:  # what the index says is refused already
                why = _refused(index, self._limits)
                if why is not None:
                    self._bad_chunks.setdefault(index.chunk_start_offset, why)
            self._chunk_counts = check.counts
            self._lengths = check.lengths
            for note in check.notes:
                self._warn(f"{path.name}: {note}")
            for offset in self._bad_chunks:  # what cannot be read is not counted
                for cid, n in check.counts.get(offset, {}).items():
                    counts[cid] = max(counts.get(cid, 0) - n, 0)
            if _summary_lacks_records(channels, schemas, stats.channel_count):
                # the summary may leave out the channel and schema records (the MCAP spec
                # makes repeating them optional): take them from the data section; messages
                # still go through the chunk indexes
                found_channels, found_schemas, *_ = self._scan()
                channels = {**found_channels, **channels}
                schemas = {**found_schemas, **schemas}
        self._channels: dict[int, tuple[str, str, Encoding]] = {}
        # every channel, ROS or not: what records() reads (the conformance tests use it)
        self.channel_topics = {cid: channel.topic for cid, channel in sorted(channels.items())}
        for offset in sorted(self._bad_chunks):
            self._chunk_lost(offset)
        pending, self._pending_big = self._pending_big, None
        self._oversized(pending or [])
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
                info.qos = (channel.metadata or {}).get("offered_qos_profiles", "")
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
        self.file = LogFile(path, fmt, self._size, start if total else 0, end, total)

    # -- opening ---------------------------------------------------------------------------

    def _read_summary(self, f: IO[bytes]) -> Any:
        """The summary section (mcap's ``Summary``: channels, schemas, statistics, chunk
        indexes), or None when there is no usable one (no footer, no statistics, no chunk
        index)."""
        from mcap.reader import SeekingReader

        try:
            reader = SeekingReader(f, record_size_limit=None)
            self._profile = reader.get_header().profile
            summary = reader.get_summary()
        except self._errors:
            return None
        if summary is None or summary.statistics is None or not summary.chunk_indexes:
            return None
        return summary

    def _distrusted(self, check: Any, stats: Any, counts: dict[int, int]) -> None:
        """Say that the summary was not used and what the data held instead."""
        total = sum(counts.values())
        if check.problems:
            more = len(check.problems) - 1
            first = check.problems[0] + (f" (and {more} more)" if more > 0 else "")
            self._warn(
                f"{self.path.name}: its summary disagrees with the data: {first}; aion read the "
                f"chunks themselves instead (linear scan): {total:,} messages"
            )
        elif total != stats.message_count:
            self._warn(
                f"{self.path.name}: its statistics count {stats.message_count:,} messages but "
                f"its chunks hold {total:,}; aion read the chunks themselves (linear scan)"
            )

    def _scan(self) -> tuple[Any, Any, dict[int, int], int, int]:
        """Read the whole file linearly to count messages and keep their log times (for
        :meth:`recorded_windows`); note where an unreadable record stops the read (truncated
        or corrupt file)."""
        from mcap.records import Channel, Header, Schema

        channels: dict[int, Any] = {}
        schemas: dict[int, Any] = {}
        counts: dict[int, int] = {}
        times = array("Q")
        group_starts = array("Q")  # earliest log time of each record group holding messages
        start, end, n = 2**63 - 1, 0, 0
        for group in self._linear_groups(None, scanning=True):
            first = 2**64 - 1
            for record in group:
                if type(record) is tuple:
                    log_time, cid = record[0], record[1]
                    counts[cid] = counts.get(cid, 0) + 1
                    times.append(log_time)
                    first = min(first, log_time)
                    end = max(end, log_time)
                    n += 1
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Header):
                    self._profile = record.profile
            if first != 2**64 - 1:
                group_starts.append(first)
                start = min(start, first)
        self._scanned_times = np.frombuffer(times, dtype=np.uint64).astype(np.int64)
        if np.any(np.diff(self._scanned_times) < 0):
            # messages out of log-time order in the file: what a linear read may still hold
            # back is bounded by the earliest message of every later group
            starts = np.frombuffer(group_starts, dtype=np.uint64).astype(np.int64)
            self._later_min = np.minimum.accumulate(starts[::-1])[::-1]
        if self._stop_offset is not None:
            self._warn(
                f"{self.path.name}: truncated or corrupt MCAP: read stopped at byte "
                f"{self._stop_offset} of {self._size} after {n} messages; "
                "the rest of the file is ignored"
            )
        return channels, schemas, counts, (start if n else 0), end

    def _linear_records(self, wanted: set[int] | None) -> Iterator[tuple[int, int, bytes]]:
        """Every message on ``wanted`` channels in file order, chunks broken up with their
        messages sorted by log time; unreadable chunks skipped, the read stopped quietly at the
        first record whose framing is broken."""
        for group in self._linear_groups(wanted):
            yield from group

    def _linear_groups(
        self, wanted: set[int] | None, *, scanning: bool = False
    ) -> Iterator[list[Any]]:
        """The file's top-level records in file order, as lists: a chunk broken up with its
        records sorted by log time (messages as ``(log_time, channel_id, data)``), a message
        alone. Only the messages on ``wanted`` (all when None) unless ``scanning``, which
        also yields headers, schemas and channels, leaves the payloads out (``b""``) and
        remembers where a broken record stopped the read. A group is yielded for every record
        holding a readable message, empty when none is wanted, so that group ``k`` is the same
        record in every pass (what ``_later_min`` counts)."""
        from formats import mcap_records as mr

        counts: dict[int, int] | None = None  # message index counts of the last chunk
        with self.path.open("rb") as f:  # own handle, held while this pass runs
            records = mr.walk(f, len(_MCAP_MAGIC), self._size)
            while True:
                try:
                    offset, opcode, length = next(records)
                except StopIteration:
                    break
                except mr.RecordError as exc:
                    if scanning:
                        self._stop_offset = exc.offset
                    break
                if opcode == mr.OP_MESSAGE_INDEX:
                    if scanning and counts is not None:
                        for _, cid, k in mr.read_index_heads(f, offset, offset + 9 + length):
                            counts[cid] = counts.get(cid, 0) + k
                    continue
                counts = None
                group: list[Any] | None = None
                if opcode == mr.OP_CHUNK:
                    if scanning:
                        counts = self._chunk_counts.setdefault(offset, {})
                    group = self._linear_chunk(f, offset, wanted, scanning)
                elif opcode == mr.OP_MESSAGE:
                    group = self._bare_message(f, offset, length, wanted, scanning)
                elif scanning and opcode in (mr.OP_HEADER, mr.OP_SCHEMA, mr.OP_CHANNEL):
                    group = self._bare_definition(f, offset, opcode, length)
                if group is not None:
                    yield group

    def _linear_chunk(
        self, f: IO[bytes], offset: int, wanted: set[int] | None, scanning: bool
    ) -> list[Any] | None:
        """The records of the chunk at ``offset`` for :meth:`_linear_groups`, or None when it
        holds no readable message (or cannot be read: remembered, and said when not
        scanning; the scan says it once the chunk's message counts are known)."""
        from formats import mcap_records as mr

        if offset in self._bad_chunks:
            return None
        try:
            head = mr.read_chunk_head(f, offset, self._size)
            buf = mr.read_chunk(f, head, self._limits, _decompress)
            if scanning:
                return self._chunk_definitions(buf)
            selected, big, seen = mr.chunk_messages(buf, wanted, self._limits.max_message_bytes)
        except ValueError as exc:  # ChunkError and the head's ValueError
            self._bad_chunks[offset] = _why(exc)
            if not scanning:
                self._chunk_lost(offset)
            return None
        self._oversized(big)
        return selected if seen else None

    def _chunk_definitions(self, buf: bytes) -> list[Any] | None:
        """Schemas and channels (mcap records) and messages (``(log_time, channel_id, b"")``)
        of a decompressed chunk, definitions first, messages by log time; None when it holds
        neither. :class:`formats.limits.ChunkError` for records that do not parse."""
        from mcap.records import Channel, Schema

        from formats import mcap_records as mr

        cap = self._limits.max_message_bytes
        items: list[Any] = []
        messages: list[tuple[int, int, bytes]] = []
        big: list[tuple[int, int, int]] = []
        for opcode, b0, b1 in mr.chunk_records(buf):
            if opcode == mr.OP_MESSAGE:
                cid, log_time = mr.message_fields(buf, b0)
                if b1 - b0 - mr.MESSAGE_PREFIX > cap:
                    big.append((cid, log_time, b1 - b0 - mr.MESSAGE_PREFIX))
                else:
                    messages.append((log_time, cid, b""))
            elif opcode in (mr.OP_SCHEMA, mr.OP_CHANNEL):
                kind = Schema if opcode == mr.OP_SCHEMA else Channel
                items.append(_parse_record(kind, buf[b0:b1]))
        self._oversized(big)
        messages.sort(key=_first)
        items.extend(messages)
        return items or None

    def _bare_message(
        self, f: IO[bytes], offset: int, length: int, wanted: set[int] | None, scanning: bool
    ) -> list[Any] | None:
        """A Message record outside chunks as a group, None when it is malformed or over the
        message cap (that one said in a warning, its payload never read)."""
        from formats import mcap_records as mr

        if length < mr.MESSAGE_PREFIX:
            return None
        f.seek(offset + 9)
        cid, log_time = mr.message_fields(f.read(mr.MESSAGE_PREFIX), 0)
        size = length - mr.MESSAGE_PREFIX
        if size > self._limits.max_message_bytes:
            self._oversized([(cid, log_time, size)])
            return None
        if scanning:
            return [(log_time, cid, b"")]
        if wanted is not None and cid not in wanted:
            return []
        data = f.read(size)
        if len(data) < size:
            return None
        return [(log_time, cid, data)]

    def _bare_definition(
        self, f: IO[bytes], offset: int, opcode: int, length: int
    ) -> list[Any] | None:
        """A Header, Schema or Channel record outside chunks (for the scan), None (and a
        warning) when it does not parse."""
        from mcap.records import Channel, Header, Schema

        from formats import mcap_records as mr

        kinds = {mr.OP_HEADER: Header, mr.OP_SCHEMA: Schema, mr.OP_CHANNEL: Channel}
        f.seek(offset + 9)
        try:
            return [_parse_record(kinds[opcode], f.read(length))]
        except ValueError as exc:
            self._warn(f"{self.path.name}: record at byte {offset} skipped: {exc}")
            return None

    # -- warnings --------------------------------------------------------------------------

    def _warn(self, text: str) -> None:
        """Add a warning once, however often the file is read."""
        if text not in self.warnings:
            self.warnings.append(text)

    def _chunk_lost(self, offset: int) -> None:
        """Warn that the chunk at ``offset`` is skipped: why, and the messages lost per topic
        (from its message index records; all topics, not only those being read, so the line
        is the same whichever pass meets the chunk)."""
        what, why = _noun_and_reason(self._bad_chunks[offset])
        counts = {cid: n for cid, n in self._chunk_counts.get(offset, {}).items() if n}
        if counts:
            names = sorted(
                (self.channel_topics.get(cid, f"channel {cid}"), n) for cid, n in counts.items()
            )
            per = ", ".join(f"{name} {n:,}" for name, n in names)
            total = sum(counts.values())
            lost = f"{total:,} message{'s' if total != 1 else ''} lost ({per})"
        else:
            lost = "its messages are lost (no message index counts them)"
        self._warn(f"{self.path.name}: {what} at byte {offset} skipped: {why}; {lost}")

    def _oversized(self, big: list[tuple[int, int, int]]) -> None:
        """Warn about messages left out for their size."""
        from formats import limits as caps
        from formats.mcap_records import iso

        if self._pending_big is not None:
            self._pending_big.extend(big)
            return
        for cid, log_time, size in big:
            topic = self.channel_topics.get(cid, f"channel {cid}")
            self._warn(
                f"{self.path.name}: a message on {topic} at {iso(log_time)} skipped: "
                + str(caps.message_over_limit(size, self._limits.max_message_bytes))
            )

    # -- reading ---------------------------------------------------------------------------

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        wanted = {
            cid
            for cid, (topic, _, _) in self._channels.items()
            if topics is None or topic in topics
        }
        if not wanted:
            return iter(())
        return self._raw_messages(wanted)

    def _raw_messages(self, wanted: set[int]) -> Iterator[RawMessage]:
        channels = self._channels
        if self._unzstd:
            yield from self._unzstd_messages(wanted)
            return
        if self._chunk_indexes is not None and not _chunks_overlap(self._chunk_indexes):
            # the hot path: a chunk's messages at a time, no generator step per message
            for selected in self._chunk_batches(wanted):
                for log_time, channel_id, data in selected:
                    topic, msgtype, encoding = channels[channel_id]
                    yield RawMessage(topic, msgtype, log_time, data, encoding)
            return
        for log_time, channel_id, data in self._records(wanted):
            topic, msgtype, encoding = channels[channel_id]
            yield RawMessage(topic, msgtype, log_time, data, encoding)

    def _unzstd_messages(self, wanted: set[int]) -> Iterator[RawMessage]:
        """Messages whose payloads are zstd-compressed, decompressed one by one within the
        message cap (one over it is skipped with a warning)."""
        from formats.limits import OverLimitError
        from formats.mcap_records import iso

        cap = self._limits.max_message_bytes
        for log_time, channel_id, data in self._records(wanted):
            topic, msgtype, encoding = self._channels[channel_id]
            if data[:4] == _ZSTD_MAGIC:
                try:
                    data = _unzstd(data, cap)
                except OverLimitError as exc:
                    self._warn(f"{self.path.name}: a message on {topic} at {iso(log_time)} "
                               f"skipped: {exc}")
                    continue
            yield RawMessage(topic, msgtype, log_time, data, encoding)

    def records(self, channel_ids: Iterable[int] | None = None) -> Iterator[tuple[int, int, bytes]]:
        """``(log_time, channel_id, data)`` of every message on ``channel_ids`` (all channels
        of the file when None, ROS or not: see :attr:`channel_topics`), in log-time order, read
        exactly as :meth:`messages` reads ROS topics. For tests of the MCAP reading itself on
        files whose channels are not ROS (the MCAP conformance suite)."""
        wanted = set(self.channel_topics if channel_ids is None else channel_ids)
        if not wanted:
            return iter(())
        return self._records(wanted)

    def _records(self, wanted: set[int]) -> Iterator[tuple[int, int, bytes]]:
        """The messages of the ``wanted`` channels by the fastest path the file allows."""
        if self._chunk_indexes is None:
            return self._records_linear(wanted)
        if _chunks_overlap(self._chunk_indexes):
            return self._records_merged(wanted)
        return (record for batch in self._chunk_batches(wanted) for record in batch)

    def _selected(self, index: Any, wanted: set[int]) -> bool:
        """Whether the chunk of ``index`` may hold a wanted message (its index lists the
        channels it holds, checked against the data at open) and can be read."""
        if index.chunk_start_offset in self._bad_chunks:
            return False
        return not (index.message_index_offsets and wanted.isdisjoint(index.message_index_offsets))

    def _chunk_batches(self, wanted: set[int]) -> Iterator[list[tuple[int, int, bytes]]]:
        """Time order by chunk: chunk indexes sorted by start time do not overlap, so each
        chunk's messages sorted by log time (one list per chunk) continue the stream."""
        assert self._chunk_indexes is not None
        for index in self._chunk_indexes:
            if self._selected(index, wanted):
                selected = self._read_indexed(index.chunk_start_offset, wanted)
                if selected:
                    yield selected

    def _read_indexed(self, offset: int, wanted: set[int]) -> list[tuple[int, int, bytes]]:
        """The wanted messages of the indexed chunk at ``offset``, sorted by log time; [] (and
        a warning) when it cannot be read. Opens the file for this chunk only."""
        from formats import mcap_records as mr

        try:
            with self.path.open("rb") as f:
                head = mr.read_chunk_head(f, offset, self._size, self._lengths.get(offset))
                buf = mr.read_chunk(f, head, self._limits, _decompress)
            selected, big, _ = mr.chunk_messages(buf, wanted, self._limits.max_message_bytes)
        except ValueError as exc:  # ChunkError and the head's ValueError
            self._bad_chunks[offset] = _why(exc)
            self._chunk_lost(offset)
            return []
        self._oversized(big)
        return selected

    def _records_merged(self, wanted: set[int]) -> Iterator[tuple[int, int, bytes]]:
        """Overlapping chunks, merged in log-time order: a chunk is read when the stream
        reaches its start time, so only the chunks overlapping one moment are held; ties keep
        chunk order."""
        assert self._chunk_indexes is not None
        chunks = [c for c in self._chunk_indexes if self._selected(c, wanted)]
        heap: list[tuple[int, int, int, bytes]] = []
        seq = 0
        k = 0
        while k < len(chunks) or heap:
            if k < len(chunks) and (not heap or chunks[k].message_start_time <= heap[0][0]):
                for log_time, channel_id, data in self._read_indexed(
                    chunks[k].chunk_start_offset, wanted
                ):
                    heapq.heappush(heap, (log_time, seq, channel_id, data))
                    seq += 1
                k += 1
                continue
            log_time, _, channel_id, data = heapq.heappop(heap)
            yield log_time, channel_id, data

    def _records_linear(self, wanted: set[int]) -> Iterator[tuple[int, int, bytes]]:
        """A file without a usable summary, read in file order. When the opening scan found
        messages out of log-time order (unchunked writers that log as messages arrive, or
        overlapping chunks), they are put in order with a heap that holds a message back only
        while a later group of records can still hold an earlier one (what ``_later_min``
        says); ties keep file order."""
        later_min = self._later_min
        if later_min is None:
            yield from self._linear_records(wanted)
            return
        heap: list[tuple[int, int, int, bytes]] = []
        seq = 0
        groups = len(later_min)
        for k, group in enumerate(self._linear_groups(wanted)):
            for log_time, channel_id, data in group:
                heapq.heappush(heap, (log_time, seq, channel_id, data))
                seq += 1
            bound = int(later_min[k + 1]) if k + 1 < groups else None
            while heap and (bound is None or heap[0][0] <= bound):
                log_time, _, channel_id, data = heapq.heappop(heap)
                yield log_time, channel_id, data
        while heap:
            log_time, _, channel_id, data = heapq.heappop(heap)
            yield log_time, channel_id, data

    # -- recorded windows ------------------------------------------------------------------

    def recorded_windows(self, window_ns: int) -> Windows:
        """From the chunk indexes when the file has a summary: a chunk within one window or
        two adjacent ones records the windows of its first and last message; only wider chunks
        need their message times, from their MessageIndex records (a few bytes each; the chunk
        is decompressed only when it has none or they are damaged). Chunks that cannot be read
        record nothing. Without a summary, the log times the opening scan kept."""
        if self._chunk_indexes is None:
            times = self._scanned_times
            return recorded.windows_of(times if times is not None else [], window_ns)
        indexes = self._chunk_indexes
        n = len(indexes)
        # uint64 in the file: as int64, like every time in aion
        starts = np.fromiter((c.message_start_time for c in indexes), np.uint64, n).astype(np.int64)
        ends = np.fromiter((c.message_end_time for c in indexes), np.uint64, n).astype(np.int64)
        indexed = np.fromiter((bool(c.message_index_offsets) for c in indexes), np.bool_, n)
        bad = np.fromiter((c.chunk_start_offset in self._bad_chunks for c in indexes), np.bool_, n)
        empty = (starts > ends) | bad  # some writers mark a chunk without messages so
        # 0..0 without message indexes: a chunk without messages, or one message at t = 0
        unsure = ~indexed & (starts == 0) & (ends == 0)
        read = (recorded.wide_spans(starts, ends, window_ns) | unsure) & ~empty
        parts = []
        with self.path.open("rb") as stream:  # own handle, for this call only
            for k in np.flatnonzero(read):
                times = self._chunk_times(stream, indexes[k])
                if times is not None:  # None: an unreadable chunk, skipped with a warning
                    parts.append(recorded.windows_of(times, window_ns))
        ends_only = ~read & ~empty
        parts.append(recorded.end_windows(starts[ends_only], ends[ends_only], window_ns))
        return recorded.union(parts)

    def _chunk_times(self, stream: IO[bytes], index: Any) -> npt.NDArray[np.int64] | None:
        """Log times of one chunk's messages: from its MessageIndex records, else from the
        decompressed chunk; ``None`` (and a warning) when the chunk itself is unreadable."""
        from formats import mcap_records as mr

        if index.message_index_offsets and index.message_index_length > 0:
            base = index.chunk_start_offset + index.chunk_length
            try:
                stream.seek(base, io.SEEK_SET)
                block = stream.read(min(index.message_index_length, self._size - base))
                offsets = [off - base for off in index.message_index_offsets.values()]
                return recorded.message_index_times(block, offsets)
            except self._errors:
                pass  # a damaged index does not mean a damaged chunk: read the chunk
        offset = index.chunk_start_offset
        try:
            head = mr.read_chunk_head(stream, offset, self._size, self._lengths.get(offset))
            buf = mr.read_chunk(stream, head, self._limits, _decompress)
            return recorded.record_log_times(buf)
        except ValueError as exc:  # ChunkError, the head's and record_log_times' ValueError
            self._bad_chunks[offset] = _why(exc)
            self._chunk_lost(offset)
            return None

    def close(self) -> None:
        """Nothing to release: the file is open only while a read runs."""


def _refused(index: Any, limits: ReadLimits) -> str | None:
    """Why the chunk a (checked) chunk index describes will not be read, from the index
    alone: an unknown compression, or more than the chunk cap; None when it may be read."""
    from formats import limits as caps

    if index.compression not in ("", "zstd", "lz4"):
        return str(caps.UnknownCompressionError(f"unknown compression {index.compression[:40]!r}"))
    size = index.uncompressed_size if index.compression else index.compressed_size
    if size > limits.max_chunk_bytes:
        return str(caps.chunk_over_limit(size, limits.max_chunk_bytes))
    return None


def _why(exc: Exception) -> str:
    """Why a chunk cannot be read, for :meth:`_McapSource._chunk_lost`: damage is marked as
    such; a chunk over the cap or in an unknown compression is not corrupt."""
    from formats.limits import OverLimitError, UnknownCompressionError
    from formats.mcap_records import CORRUPT

    if isinstance(exc, OverLimitError | UnknownCompressionError):
        return str(exc)
    return CORRUPT + str(exc)


def _noun_and_reason(why: str) -> tuple[str, str]:
    from formats.mcap_records import CORRUPT

    if why.startswith(CORRUPT):
        return "corrupt chunk", why.removeprefix(CORRUPT)
    return "chunk", why


def _decompress(data: bytes | memoryview, compression: str, declared: int, limit: int) -> bytes:
    """Every MCAP chunk's records go through here (:func:`formats.limits.decompress`: the
    declared size checked against ``limit`` first, the output bounded)."""
    from formats import limits as caps

    return caps.decompress(data, compression, declared, limit)


def _parse_record(kind: Any, body: bytes) -> Any:
    """An mcap library record (Header, Schema, Channel) from its body bytes;
    :class:`formats.limits.ChunkError` when it does not parse."""
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError

    from formats.limits import ChunkError

    try:
        return kind.read(ReadDataStream(io.BytesIO(body)))
    except (McapError, *_MCAP_READ_ERRORS, UnicodeDecodeError) as exc:  # EndOfFile: too short
        raise ChunkError(f"a {kind.__name__} record does not parse ({exc})") from exc


def _first(item: tuple[int, int, bytes]) -> int:
    return item[0]


def _chunks_overlap(indexes: list[Any]) -> bool:
    end = -1
    for index in indexes:
        if index.message_start_time < end:
            return True
        end = max(end, index.message_end_time)
    return False


def _summary_lacks_records(channels: dict[int, Any], schemas: dict[int, Any], count: int) -> bool:
    """Whether a summary section leaves out channels its statistics count, or schemas its
    channels use (schema id 0: a channel without schema)."""
    if len(channels) < count:
        return True
    return any(c.schema_id != 0 and c.schema_id not in schemas for c in channels.values())


def _all_ros1(topics: dict[tuple[str, str], _Topic]) -> bool:
    return bool(topics) and all(t.encoding == "ros1" for t in topics.values())


class _RosbagsSource(_Source):
    """A ROS 1 bag or a rosbag2 folder, read with the rosbags readers."""

    def __init__(self, path: Path, kind: str, limits: ReadLimits | None = None) -> None:
        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self._reader = _open_rosbags(path, kind, self._limits)
        reader = self._reader
        self._index_times: npt.NDArray[np.int64] | None = None
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
        start, end = 0, 0
        if kind == "bag":
            fmt_name = "bag"
            size = path.stat().st_size
            self._index_times = recorded.rosbag1_index_times(reader.indexes)
            if self._index_times.size:  # the index's message times, not the chunk infos'
                start, end = int(self._index_times.min()), int(self._index_times.max()) + 1
            names = {conn.id: conn.topic for conn in reader.connections}
            for pos, (why, counts) in sorted(reader.refused.items()):
                self.warnings.append(self._chunk_skipped(pos, why, counts, names))
            reader.suspend()  # no file handle held between reads
        else:
            storages = getattr(reader.storage, "storages", [])
            mcap = any("mcap" in type(x).__name__.lower() for x in storages)
            fmt_name = "rosbag2-mcap" if mcap else "rosbag2-sqlite3"
            size = sum(p.stat().st_size for p in path.iterdir() if p.is_file())
            start, end = self._count_storages(storages, reader)
            if storages:
                counts = {key: t.count for key, t in self.topics.items()}
                warning = _metadata_warning(path, start, end - 1, sum(counts.values()), counts)
                if warning:
                    self.warnings.append(warning)
        total = sum(t.count for t in self.topics.values())
        start = start if total else 0
        end = max(end - 1, start) if total else 0  # rosbags' end is exclusive
        self.file = LogFile(path, fmt_name, size, start, end, total)

    def _count_storages(self, storages: list[Any], reader: Any) -> tuple[int, int]:
        """Message counts per topic and the time range (end exclusive) of a rosbag2 folder
        from its storage files (SQL counts and MIN / MAX over the indexed timestamps, or the
        MCAP statistics, which rosbags read at open) rather than from metadata.yaml: real
        metadata can be wrong (rosbag2's own wbag test bags state another recording's time
        range). Without storage readers, metadata.yaml's figures stay."""
        if not storages:
            return reader.start_time, reader.end_time
        counted: Counter[tuple[str, str]] = Counter()
        for storage in storages:
            for conn in storage.connections:
                counted[conn.topic, normalize_msgtype(conn.msgtype)] += conn.msgcount
        for key, info in self.topics.items():
            info.count = counted.get(key, 0)
        metas = [s.metadata for s in storages if s.metadata.message_count > 0]
        if not metas:
            return 0, 0
        return min(m.start_time for m in metas), max(m.end_time for m in metas)

    def mcap_storage(self) -> tuple[list[tuple[Path, Path | None]], bool] | None:
        """For a rosbag2 folder with mcap storage, what aion's MCAP reader reads instead of
        rosbags' mcap plugin (faster, and with the size caps): the storage files, each with
        the compressed file rosbags decompressed it from (``compression_mode: file``; the
        decompressed copy lives while this source is open) or None, and whether message
        payloads are zstd-compressed (``compression_mode: message``). None for other
        folders."""
        if self.file.format != "rosbag2-mcap":
            return None
        storages = getattr(self._reader.storage, "storages", [])
        paths = [getattr(x, "path", None) for x in storages]
        if not paths or not all(isinstance(p, Path) and p.suffix == ".mcap" for p in paths):
            return None
        mode = self._reader.compression_mode if self._reader.compression_format else None
        if mode not in (None, "file", "message"):
            return None
        files: list[tuple[Path, Path | None]] = []
        for p in paths:
            assert isinstance(p, Path)
            original = None
            if mode == "file":
                original = next(
                    (q for q in sorted(self.path.iterdir()) if q.is_file() and q.stem == p.name),
                    self.path / f"{p.name}.zstd",
                )
            files.append((p, original))
        return files, mode == "message"

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        if self.file.format != "bag":
            storages = getattr(self._reader.storage, "storages", None)
            if isinstance(storages, list):
                wanted = _wanted_types(self.topics, topics)
                if not wanted:
                    return iter(())
                unzstd = self._reader.compression_mode == "message"
                return _storage_messages(self, storages, wanted, unzstd)
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
        """Through :class:`formats.bag_reader.BagReader` (ROS 1 bags): the file open while
        the iteration runs, chunks that cannot be read skipped with a warning."""
        meta = {
            conn.id: (info.topic, info.msgtype, info.encoding)
            for info in self.topics.values()
            for conn in info.keys
            if conn in conns
        }
        names = {conn.id: conn.topic for conn in conns}
        reader = self._reader

        def bad_chunk(pos: int, why: str, lost: dict[int, int]) -> None:
            warning = self._chunk_skipped(pos, why, lost, names)
            if warning not in self.warnings:
                self.warnings.append(warning)

        def oversized(conn: Any, t_ns: int, size: int) -> None:
            from formats import limits as caps
            from formats.mcap_records import iso

            warning = (
                f"{self.path.name}: a message on {conn.topic} at {iso(t_ns)} skipped: "
                + str(caps.message_over_limit(size, self._limits.max_message_bytes))
            )
            if warning not in self.warnings:
                self.warnings.append(warning)

        try:
            reader.resume()
            for conn, t_ns, data in reader.iter_messages(conns, bad_chunk, oversized):
                topic, msgtype, encoding = meta[conn.id]
                yield RawMessage(topic, msgtype, t_ns, data, encoding)
        except LogFormatError:
            raise
        except Exception as exc:  # rosbags raises its own errors, OSError, struct errors
            raise LogFormatError(
                f"{self.path}: cannot read messages ({exc})",
                hint="the log may be corrupt; for ROS 1 bags try `rosbag reindex`",
            ) from exc
        finally:
            reader.suspend()

    def _chunk_skipped(
        self, pos: int, why: str, lost: dict[int, int], names: dict[int, str]
    ) -> str:
        """The warning for a bag chunk that is skipped: where, why, the messages lost."""
        counts = sorted((names.get(cid, f"connection {cid}"), n) for cid, n in lost.items() if n)
        total = sum(n for _, n in counts)
        per = ", ".join(f"{name} {n:,}" for name, n in counts)
        return (
            f"{self.path.name}: chunk at byte {pos} skipped: {why}; "
            f"{total:,} message{'s' if total != 1 else ''} lost ({per})"
        )

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
        times = self._index_times
        return recorded.windows_of(times if times is not None else [], window_ns)

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


class _ReindexedSqliteSource(_Source):
    """rosbag2 sqlite3 storage files without metadata.yaml, indexed in memory from the files
    themselves, as ``ros2 bag reindex`` would: topics, types, serialization, offered QoS and
    message counts from each file's ``topics`` table and SQL counts over ``messages`` (no
    payload is read), the time range from the indexed ``timestamp`` column, the message
    definitions from ``message_definitions`` where the file has them. The files' messages are
    merged in log-time order; zstd-compressed payloads (a bag recorded with message
    compression) are recognised by their magic bytes.
    """

    def __init__(
        self,
        path: Path,
        files: list[Path],
        originals: list[Path],
        limits: ReadLimits | None = None,
    ) -> None:
        from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self.file_count = len(files)
        self._storages: list[Any] = []
        for plain, original in zip(files, originals, strict=True):
            storage = Sqlite3Reader(plain)
            try:
                storage.open()
            except Exception as exc:  # rosbags ReaderError, apsw errors
                self.close()
                raise LogFormatError(
                    f"{original}: not a readable rosbag2 sqlite3 storage file ({exc})",
                    hint="the storage file may be truncated or corrupt",
                ) from exc
            self._storages.append(storage)
        self.topics = {}
        # per file: name, first and last message time, message count (what reindex writes)
        self.per_file: list[tuple[str, int, int, int]] = []
        for storage, original in zip(self._storages, originals, strict=True):
            qos = _sqlite_qos(storage)
            count = 0
            for conn in storage.connections:
                fmt = getattr(conn.ext, "serialization_format", "cdr")
                if fmt not in _MESSAGE_ENCODINGS:
                    self.warnings.append(
                        f"{original.name}: topic {conn.topic} skipped: serialization {fmt!r} "
                        "is not CDR"
                    )
                    continue
                msgtype = normalize_msgtype(conn.msgtype)
                info = self.topics.get((conn.topic, msgtype))
                if info is None:
                    msgdef = conn.msgdef
                    known = msgdef is not None and msgdef.format.name != "NONE"
                    info = self.topics[conn.topic, msgtype] = _Topic(
                        conn.topic,
                        msgtype,
                        _MESSAGE_ENCODINGS[fmt],
                        (msgdef.data or "") if known else "",
                        known and msgdef.format.name == "IDL",
                    )
                info.count += conn.msgcount
                info.keys.append(conn)
                info.qos = info.qos or qos.get(conn.id, "")
                count += conn.msgcount
            meta = storage.metadata  # rosbags: end_time is exclusive
            first, last = (meta.start_time, meta.end_time - 1) if count else (0, 0)
            self.per_file.append((original.name, first, last, count))
        total = sum(t.count for t in self.topics.values())
        with_messages = [f for f in self.per_file if f[3] > 0]
        start = min((f[1] for f in with_messages), default=0)
        end = max((f[2] for f in with_messages), default=0)
        size = sum(o.stat().st_size for o in originals)
        self.file = LogFile(path, "rosbag2-sqlite3", size, start, end, total)

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        wanted = _wanted_types(self.topics, topics)
        if not wanted:
            return iter(())
        return _storage_messages(self, self._storages, wanted, None)

    def recorded_windows(self, window_ns: int) -> Windows:
        """Per storage file, SQLite computes the windows over the indexed ``timestamp``
        column (no payload is read)."""
        try:
            return recorded.union(
                recorded.sqlite_windows(storage.dbconn, window_ns) for storage in self._storages
            )
        except Exception as exc:  # apsw errors on a damaged file
            raise LogFormatError(
                f"{self.path}: cannot read message times ({exc})",
                hint="the storage files may be corrupt or truncated",
            ) from exc

    def close(self) -> None:
        storages, self._storages = self._storages, []
        for storage in storages:
            if storage.dbconn is not None:
                storage.close()


def _sqlite_qos(storage: Any) -> dict[int, str]:
    """``topic id -> offered_qos_profiles`` text of a rosbag2 sqlite3 file (schema 2 and later
    keep it in the topics table), {} where it has none."""
    if storage.schema < 2:
        return {}
    rows = storage.dbconn.execute("SELECT id, offered_qos_profiles FROM topics")
    return {int(cid): str(text or "") for cid, text in rows}


class _Unpacked(_Source):
    """A source read from decompressed temporary copies of zstd-compressed files: shown as the
    compressed file (``path``, its size on disk; the rosbag2 storage format for an mcap
    storage file), and removing the copies when closed."""

    def __init__(self, inner: _Source, temps: list[Any], path: Path | None = None) -> None:
        self.inner = inner
        self.topics = inner.topics
        self.warnings = inner.warnings
        self.file_count = getattr(inner, "file_count", 1)
        self._temps = temps
        f = inner.file
        if path is not None:
            fmt = f.format
            if fmt.startswith("mcap") and ".mcap" in path.name:
                fmt = "rosbag2-mcap"  # *.mcap.zstd: rosbag2's whole-file compression
            f = replace(f, path=path, format=fmt, size_bytes=path.stat().st_size)
        self.file = f

    def owns(self, source: _Source) -> None:
        """Close ``source`` too when this one is closed (what keeps the copies alive)."""
        self._temps.append(_Closing(source))

    def messages(self, topics: set[str] | None) -> Iterator[RawMessage]:
        return self.inner.messages(topics)

    def recorded_windows(self, window_ns: int) -> Windows:
        return self.inner.recorded_windows(window_ns)

    def close(self) -> None:
        try:
            self.inner.close()
        finally:
            for tmp in self._temps:
                tmp.cleanup()


@dataclass
class _Closing:
    """A source to close with an :class:`_Unpacked` one (as if it were a temporary folder)."""

    source: _Source

    def cleanup(self) -> None:
        self.source.close()


def _wanted_types(
    topics: dict[tuple[str, str], _Topic], names: set[str] | None
) -> dict[tuple[str, str], tuple[str, str, Encoding]]:
    """``(topic, msgtype) -> (topic, msgtype, encoding)`` of the source's topics on ``names``
    (all when None)."""
    return {
        key: (info.topic, info.msgtype, info.encoding)
        for key, info in topics.items()
        if names is None or info.topic in names
    }


def _storage_messages(
    source: _RosbagsSource | _ReindexedSqliteSource,
    storages: list[Any],
    wanted: dict[tuple[str, str], tuple[str, str, Encoding]],
    unzstd: bool | None,
) -> Iterator[RawMessage]:
    """Messages of rosbag2 storage readers (rosbags' sqlite3 / mcap storage plugins), merged in
    log-time order, on the ``wanted`` (topic, normalised type) pairs.

    Each storage file's own connections are matched by topic and type only. rosbags' folder
    reader also compares the QoS profiles of metadata.yaml with those the storage file keeps,
    and real bags disagree (rosbag2's own talker test bag: infinite deadlines written as 0 in
    one and as 2147483647 s in the other), so it yields none of their messages. ``unzstd``:
    payloads are zstd-compressed (``compression_mode: message``); None: unknown (a reindexed
    bag), a payload is decompressed when it starts with the zstd magic bytes, which no CDR
    payload does (CDR starts with its encapsulation header, 0x00 first). A compressed payload
    that expands beyond the message cap is skipped with a warning on ``source``.
    """
    path = source.path
    streams = []
    for storage in storages:
        conns = [
            conn
            for conn in storage.connections
            if (conn.topic, normalize_msgtype(conn.msgtype)) in wanted
        ]
        if conns:
            streams.append(_one_storage(source, storage, conns, wanted, unzstd))
    if not streams:
        return
    merged: Iterator[RawMessage] = (
        streams[0] if len(streams) == 1 else heapq.merge(*streams, key=attrgetter("log_time_ns"))
    )
    try:
        yield from merged
    except LogFormatError:
        raise
    except Exception as exc:  # rosbags, apsw / sqlite3, struct and zstd errors
        raise LogFormatError(
            f"{path}: cannot read messages ({exc})",
            hint="the storage files may be corrupt or truncated",
        ) from exc


def _one_storage(
    source: _RosbagsSource | _ReindexedSqliteSource,
    storage: Any,
    conns: list[Any],
    wanted: dict[tuple[str, str], tuple[str, str, Encoding]],
    unzstd: bool | None,
) -> Iterator[RawMessage]:
    from formats.limits import OverLimitError
    from formats.mcap_records import iso

    meta = {conn.id: wanted[conn.topic, normalize_msgtype(conn.msgtype)] for conn in conns}
    cap = source._limits.max_message_bytes
    for conn, t_ns, data in storage.messages(conns):
        topic, msgtype, encoding = meta[conn.id]
        if unzstd or (unzstd is None and data[:4] == _ZSTD_MAGIC):
            try:
                data = _unzstd(data, cap)
            except OverLimitError as exc:
                warning = f"{source.path.name}: a message on {topic} at {iso(t_ns)} skipped: {exc}"
                if warning not in source.warnings:
                    source.warnings.append(warning)
                continue
        elif type(data) is not bytes:
            data = bytes(data)
        if len(data) > cap:
            from formats.limits import message_over_limit

            warning = (
                f"{source.path.name}: a message on {topic} at {iso(t_ns)} skipped: "
                f"{message_over_limit(len(data), cap)}"
            )
            if warning not in source.warnings:
                source.warnings.append(warning)
            continue
        yield RawMessage(topic, msgtype, t_ns, data, encoding)


def _unzstd(data: bytes | memoryview, cap: int) -> bytes:
    """One zstd-compressed message payload (with or without the content size in its frame),
    decompressed to at most ``cap`` bytes (:class:`formats.limits.OverLimitError` beyond)."""
    from formats.limits import ChunkError, OverLimitError, decompress, message_over_limit

    try:
        return decompress(bytes(data), "zstd", 0, cap)
    except OverLimitError:
        raise message_over_limit(cap + 1, cap) from None
    except ChunkError as exc:
        raise ValueError(f"cannot decompress a zstd message payload ({exc})") from exc


def _open_rosbags(path: Path, kind: str, limits: ReadLimits) -> Any:
    """An open rosbags Reader for ``path`` (ROS 1 bags: :class:`formats.bag_reader.BagReader`
    with ``limits``), with rosbags errors turned into LogFormatError."""
    if kind == "bag":
        from formats.bag_reader import BagReader

        reader: Any = BagReader(path, limits)
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
    (or their ``metadata.yaml`` / storage files), rosbag2 storage files without
    ``metadata.yaml`` (a folder of them, or one ``.db3``), zstd-compressed storage files
    (``*.mcap.zstd``, ``*.db3.zstd``, read through a decompressed temporary copy); otherwise
    the file's first bytes decide (through zstd too)."""
    from formats import rosbag2_storage as storage

    check_regular_input(path, "log", hint=_LOG_HINT)  # a FIFO or /dev/zero: before any read
    if not path.exists():
        raise LogFormatError(f"no such file or folder: {path}", hint="check the log path")
    if path.is_dir():
        for entry in path.iterdir():  # what a rosbag2 reader would open
            if entry.name == "metadata.yaml" or (
                Path(storage.inner_name(entry)).suffix.lower() in storage.STORAGE_SUFFIXES
            ):
                check_regular_input(entry, "log", hint=_LOG_HINT)
        if (path / "metadata.yaml").is_file() or storage.storage_files(path):
            return "rosbag2", path
        found = sorted(p.name for p in path.iterdir())[:5]
        raise LogFormatError(
            f"{path} is a folder but not a rosbag2 bag (no metadata.yaml, no storage files)",
            hint="pass a .mcap or .bag file, or a rosbag2 folder; the folder holds: "
            + (", ".join(found) if found else "nothing"),
        )
    if path.stat().st_size == 0:
        raise LogFormatError(f"{path} is empty (0 bytes)", hint="the recording was not written")
    compressed = storage.is_zstd(path)
    suffix = Path(storage.inner_name(path)).suffix.lower()
    beside_metadata = (path.parent / "metadata.yaml").is_file()
    if path.name == "metadata.yaml" or (
        beside_metadata and (suffix == ".db3" or (compressed and suffix == ".mcap"))
    ):
        return "rosbag2", path.parent
    if not compressed:
        if suffix == ".mcap":
            return "mcap", path
        if suffix == ".bag":
            return "bag", path
        if suffix == ".db3":
            return "rosbag2", path  # one storage file alone: reindexed
    kind = storage.sniff(path)
    if kind == "mcap":
        return ("rosbag2" if compressed else "mcap"), path
    if kind == "bag":
        return "bag", path
    if kind == "sqlite3":
        return "rosbag2", path
    if compressed:
        raise LogFormatError(
            f"{path} is zstd-compressed but holds no log aion reads",
            hint="aion reads zstd-compressed rosbag2 storage files (.mcap.zstd, .db3.zstd)",
        )
    raise LogFormatError(
        f"cannot tell the log format of {path}",
        hint="aion reads .mcap, ROS 1 .bag and rosbag2 folders; use --log-format mcap|bag|rosbag2",
    )


def _open_sources(path: Path, fmt: str | None, limits: ReadLimits) -> list[_Source]:
    """The sources of one path: one file, the storage files of a rosbag2 folder, or storage
    files without metadata.yaml (reindexed in memory)."""
    from formats import rosbag2_storage as storage

    if fmt is not None and fmt not in FORMATS:
        raise LogFormatError(
            f"unknown log format {fmt!r}", hint=f"use one of: {', '.join(FORMATS)}"
        )
    guessed, target = guess_format(path)
    kind = fmt or guessed
    if (
        target.is_file()
        and storage.is_zstd(target)
        and not (kind == "rosbag2" and (target.parent / "metadata.yaml").is_file())
    ):
        return _open_compressed(target, kind, limits)
    if kind == "mcap":
        if target.is_dir():
            files = sorted(target.glob("*.mcap"))
            if len(files) != 1:
                raise LogFormatError(
                    f"{target} holds {len(files)} .mcap files", hint="pass one .mcap file"
                )
            target = files[0]
        return [_open_mcap(target, limits=limits)]
    if kind == "bag":
        return [_RosbagsSource(target, "bag", limits)]
    folder = target.parent if target.is_file() else target
    if not (folder / "metadata.yaml").is_file():
        if target.is_file():
            return _reindexed_sources([target], target, limits)  # one storage file alone
        sources = _reindexed_sources(storage.storage_files(folder), folder, limits)
        sources[-1].warnings.append(
            f"{folder}: no metadata.yaml; indexed in memory from its {_files(sources)}, "
            "as `ros2 bag reindex` would"
        )
        return sources
    try:
        source = _RosbagsSource(folder, "rosbag2", limits)
    except LogFormatError as exc:
        # A recording killed before it finished leaves mcap storage files without a summary,
        # which rosbags refuses, or a metadata.yaml that does not match the files: index the
        # storage files themselves; the mcap reader recovers what was written.
        files = storage.storage_files(folder)
        if not files:
            raise
        try:
            sources = _reindexed_sources(files, folder, limits)
        except LogFormatError:
            raise exc from None
        sources[-1].warnings.append(
            f"{folder}: metadata.yaml not used ({exc.message}); indexed in memory from its "
            f"{_files(sources)}"
        )
        return sources
    found = source.mcap_storage()
    if found is not None:
        # rosbag2 with mcap storage: aion's MCAP reader (faster than rosbags' mcap plugin,
        # and bounded); a whole-file compressed bag is read from rosbags' decompressed copies,
        # which live until the last of these sources is closed
        mcap_files, unzstd = found
        keep = any(original is not None for _, original in mcap_files)
        if not keep:
            source.close()
        mcaps: list[_Source] = []
        try:
            for plain, original in mcap_files:
                mcap = _open_mcap(plain, fmt_name="rosbag2-mcap", limits=limits, unzstd=unzstd)
                mcaps.append(mcap if original is None else _Unpacked(mcap, [], original))
            if keep:
                last = mcaps[-1]
                assert isinstance(last, _Unpacked)
                last.owns(source)
        except BaseException:
            for opened in mcaps:
                opened.close()
            if keep:
                source.close()
            raise
        counted: Counter[tuple[str, str]] = Counter()
        for opened in mcaps:
            for key, t in opened.topics.items():
                counted[key] += t.count
        busy = [m.file for m in mcaps if m.file.message_count]
        warning = _metadata_warning(
            folder,
            min((f.start_ns for f in busy), default=0),
            max((f.end_ns for f in busy), default=0),
            sum(counted.values()),
            counted,
        )
        if warning:
            mcaps[0].warnings.append(warning)
        return mcaps
    return [source]


def _metadata_warning(
    folder: Path, start: int, last: int, total: int, counts: Mapping[tuple[str, str], int]
) -> str | None:
    """A warning when the folder's metadata.yaml states figures its storage files contradict
    (aion uses the storage files: first and last message time ``start`` / ``last``, ``total``
    messages, ``counts`` per (topic, normalised type)); None when they agree."""
    from formats import rosbag2_storage as storage

    figures = storage.metadata_figures(folder)
    if figures is None:
        return None
    found = storage.metadata_disagreements(figures, start, last, total, counts, normalize_msgtype)
    if not found:
        return None
    more = f"; and {len(found) - 4} more" if len(found) > 4 else ""
    return (
        f"{folder.name}: metadata.yaml disagrees with its storage files, which aion uses "
        f"instead: {'; '.join(found[:4])}{more}"
    )


def _files(sources: list[_Source]) -> str:
    n = sum(getattr(s, "file_count", 1) for s in sources)
    return f"{n} storage file" + ("" if n == 1 else "s")


def _open_compressed(path: Path, kind: str, limits: ReadLimits) -> list[_Source]:
    """A zstd-compressed file given alone (a rosbag2 storage file from a bag recorded with
    ``compression_mode: file``, or a compressed .bag / .mcap): read through a decompressed
    temporary copy that closing the source removes."""
    from formats import rosbag2_storage as storage

    if kind == "rosbag2":
        return _reindexed_sources([path], path, limits)
    tmp, inner = storage.decompress_to_temp(path)
    try:
        source: _Source = (
            _open_mcap(inner, limits=limits)
            if kind == "mcap"
            else _RosbagsSource(inner, "bag", limits)
        )
    except BaseException:
        tmp.cleanup()
        raise
    return [_Unpacked(source, [tmp], path)]


def _reindexed_sources(files: list[Path], shown: Path, limits: ReadLimits) -> list[_Source]:
    """rosbag2 storage files without (a usable) metadata.yaml, indexed from the files
    themselves: the sqlite3 ones as one source (shown as ``shown``: the folder, or the one
    file), each mcap one as its own (read with the mcap reader, which recovers files without a
    summary); zstd-compressed files are read through decompressed temporary copies."""
    from formats import rosbag2_storage as storage

    temps: dict[Path, Any] = {}
    opened: list[_Source] = []
    try:
        readable: list[tuple[Path, Path]] = []  # (the file on disk, the file to read)
        for f in files:
            if storage.is_zstd(f):
                tmp, inner = storage.decompress_to_temp(f)
                temps[f] = tmp
                readable.append((f, inner))
            else:
                readable.append((f, f))
        sqlite: list[tuple[Path, Path]] = []
        for original, plain in readable:
            kind = storage.sniff(plain)
            if kind == "sqlite3":
                sqlite.append((original, plain))
            elif kind == "mcap":
                mcap: _Source = _open_mcap(plain, fmt_name="rosbag2-mcap", limits=limits)
                if original in temps:
                    mcap = _Unpacked(mcap, [temps[original]], original)
                opened.append(mcap)
            else:
                raise LogFormatError(
                    f"{original} is not a rosbag2 storage file (neither SQLite nor MCAP)",
                    hint="pass the bag's .db3 / .mcap storage files, or its folder",
                )
        if sqlite and opened:
            raise LogFormatError(
                f"{shown} holds both sqlite3 and mcap storage files: not the files of one bag",
                hint="pass the storage files one by one",
            )
        if sqlite:
            originals = [o for o, _ in sqlite]
            db: _Source = _ReindexedSqliteSource(
                shown, [p for _, p in sqlite], originals, limits
            )
            owned = [temps[o] for o in originals if o in temps]
            opened.insert(0, _Unpacked(db, owned) if owned else db)
    except BaseException:
        for source in opened:
            source.close()
        for tmp in temps.values():
            tmp.cleanup()
        raise
    return opened


def reindex(path: Path | str) -> dict[str, Any]:
    """What ``ros2 bag reindex`` would write into ``metadata.yaml`` for the rosbag2 storage
    files at ``path`` (a folder of them, or one storage file; zstd-compressed or not), built
    from the files themselves: the ``rosbag2_bagfile_information`` mapping (storage,
    relative file paths, start and duration, counts per topic with type, serialization and
    offered QoS profiles, per-file figures, whole-file compression). Any metadata.yaml beside
    the files is ignored."""
    from formats import rosbag2_storage as storage

    target = Path(path)
    if not target.exists():
        raise LogFormatError(f"no such file or folder: {target}", hint="check the path")
    files = storage.storage_files(target) if target.is_dir() else [target]
    if not files:
        raise LogFormatError(
            f"{target} holds no rosbag2 storage files", hint="pass .db3 / .mcap storage files"
        )
    sources = _reindexed_sources(files, target, ReadLimits.from_env())
    try:
        return _bag_metadata(sources, files)
    finally:
        for source in sources:
            source.close()


def _bag_metadata(sources: list[_Source], files: list[Path]) -> dict[str, Any]:
    from formats import rosbag2_storage as storage

    per_file: list[tuple[str, int, int, int]] = []  # name, first, last, count
    topics: dict[tuple[str, str], _Topic] = {}
    kinds = set()
    for source in sources:
        inner = source.inner if isinstance(source, _Unpacked) else source
        if isinstance(inner, _ReindexedSqliteSource):
            per_file.extend(inner.per_file)
            kinds.add("sqlite3")
        else:
            f = source.file
            per_file.append((f.path.name, f.start_ns, f.end_ns, f.message_count))
            kinds.add("mcap")
        for key, t in source.topics.items():
            merged = topics.setdefault(key, _Topic(t.topic, t.msgtype, t.encoding, "", qos=t.qos))
            merged.count += t.count
            merged.qos = merged.qos or t.qos
    order = {p.name: k for k, p in enumerate(files)}
    per_file.sort(key=lambda item: order.get(item[0], len(order)))
    with_messages = [f for f in per_file if f[3] > 0]
    start = min((f[1] for f in with_messages), default=0)
    end = max((f[2] for f in with_messages), default=0)
    compressed = any(storage.is_zstd(f) for f in files)

    def span(first: int, last: int, count: int) -> dict[str, Any]:
        return {
            "starting_time": {"nanoseconds_since_epoch": first if count else 0},
            "duration": {"nanoseconds": last - first if count else 0},
        }

    return {
        "version": 9,
        "storage_identifier": "/".join(sorted(kinds)),
        "relative_file_paths": [f.name for f in files],
        **span(start, end, len(with_messages)),
        "message_count": sum(f[3] for f in per_file),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": t.topic,
                    "type": t.msgtype,
                    "serialization_format": t.encoding,
                    "offered_qos_profiles": t.qos,
                },
                "message_count": t.count,
            }
            for t in sorted(topics.values(), key=attrgetter("topic", "msgtype"))
        ],
        "compression_format": "zstd" if compressed else "",
        "compression_mode": "file" if compressed else "",
        "files": [
            {"path": name, **span(first, last, count), "message_count": count}
            for name, first, last, count in per_file
        ],
    }


def _open_mcap(
    path: Path,
    fmt_name: str | None = None,
    limits: ReadLimits | None = None,
    *,
    unzstd: bool = False,
) -> _McapSource:
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
    return _McapSource(path, fmt_name, limits, unzstd=unzstd)


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
        file, merged in log-time order (ties keep file order).

        A file is opened only when the merged stream reaches the first message time its index
        gives, and closed when its messages are used up (an MCAP file with a summary is even
        opened per chunk), so a set of thousands of consecutive files holds few file handles
        at a time."""
        if self._closed:
            raise ValueError("messages() on a closed LogSet")
        selected = None if topics is None else set(topics)
        if len(self._sources) == 1:
            return self._sources[0].messages(selected)
        return _merge_by_start(self._sources, selected)

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

    def definition(self, topic: str, msgtype: str, encoding: str) -> tuple[str, bool]:
        """The message definition the log embeds for ``topic`` carrying ``msgtype`` in
        ``encoding``: ``(text, is ROS 2 IDL)``, ``("", False)`` when it embeds none."""
        return self._definitions.get((topic, msgtype, encoding), ("", False))

    def typestore(self, topic: str, msgtype: str, encoding: str) -> Typestore:
        """A rosbags typestore that decodes ``topic`` with the log's own definition of
        ``msgtype`` (aion's shipped definitions when the log embeds none);
        :class:`MessageDecodeError` when there is neither or the definition is malformed."""
        definition, idl = self.definition(topic, msgtype, encoding)
        return _store_with_definition(self._stores, encoding, msgtype, definition, idl)

    def _make_decoder(self, msg: RawMessage) -> Callable[[bytes], Any]:
        store = self.typestore(msg.topic, msg.msgtype, msg.encoding)
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


def _merge_by_start(sources: list[_Source], topics: set[str] | None) -> Iterator[RawMessage]:
    """The messages of ``sources`` merged by log time, ties in source order; a source's
    stream is started only once the merge reaches its first message time (or nothing earlier
    is left), so files that follow one another are read one after the other."""
    order = sorted(range(len(sources)), key=lambda k: (sources[k].file.start_ns, k))
    heap: list[tuple[int, int, int, RawMessage, Iterator[RawMessage]]] = []
    seq = 0
    nxt = 0
    while nxt < len(order) or heap:
        if nxt < len(order) and (
            not heap or sources[order[nxt]].file.start_ns <= heap[0][0]
        ):
            k = order[nxt]
            nxt += 1
            stream = sources[k].messages(topics)
            first = next(stream, None)
            if first is not None:
                heapq.heappush(heap, (first.log_time_ns, k, seq, first, stream))
                seq += 1
            continue
        _, k, _, msg, stream = heap[0]
        yield msg
        following = next(stream, None)
        if following is None:
            heapq.heappop(heap)
        else:
            heapq.heapreplace(heap, (following.log_time_ns, k, seq, following, stream))
            seq += 1


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


def open_logs(
    paths: Iterable[Path | str], fmt: str | None = None, *, limits: ReadLimits | None = None
) -> LogSet:
    """Open ``paths`` (files or rosbag2 folders) as one :class:`LogSet`; ``fmt`` (``"mcap"``,
    ``"bag"``, ``"rosbag2"``) overrides the format guessed from each path. ``limits``: what
    one decompressed chunk and one message may take (:class:`formats.limits.ReadLimits`;
    default: ``AION_MAX_CHUNK_MB`` / ``AION_MAX_MESSAGE_MB`` or 512 / 256 MiB).

    Special files (FIFOs, devices, sockets) are refused before anything is read from them.
    Raises :class:`LogFormatError` for missing, empty, unreadable or message-less logs.
    """
    read_limits = limits if limits is not None else ReadLimits.from_env()
    sources: list[_Source] = []
    try:
        for p in paths:
            sources.extend(_open_sources(Path(p), fmt, read_limits))
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
