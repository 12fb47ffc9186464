"""The linear read of an MCAP file: record by record in file order, what aion does with a file
that has no usable summary (truncated, written by a recorder that was killed, or a summary that
disagrees with the data section), and the chunk reading and warnings the indexed read of
:mod:`formats.mcap_chunked` shares with it.

:class:`_McapLinearRead` holds that half of :class:`formats.mcap_source._McapSource` (which
derives from it and sets the state it uses when it opens the file): the opening scan that
counts messages and keeps their log times, the passes that read chunk after chunk up to the
first record whose framing is broken, the heap that puts messages written out of log-time
order in order, and the warnings for chunks and messages that are skipped.

Every MCAP chunk is decompressed through :func:`_decompress` of this module, looked up here at
call time (tests replace it to prove that no chunk is decompressed).
"""

from __future__ import annotations

import heapq
import io
import struct
from array import array
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_source import _Source
from aion_cli.formats.mcap_records import MAGIC
from aion_cli.number_text import counted

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.clock_steps import ScanSteps


_MCAP_MAGIC = MAGIC  # the name the readers import
_MCAP_READ_ERRORS = (
    EOFError,
    ValueError,
    KeyError,
    struct.error,
    OSError,
    MemoryError,
    OverflowError,  # a damaged record length too large to read
)


class _McapLinearRead(_Source):
    """The linear read and the warnings of an MCAP source; :class:`formats.mcap_source.
    _McapSource` sets these attributes when it opens the file (see its ``__init__``)."""

    path: Path
    channel_topics: dict[int, str]
    _size: int
    _limits: ReadLimits
    _bad_chunks: dict[int, str]
    _chunk_counts: dict[int, dict[int, int]]
    _stop_offset: int | None
    _unclosed: bool
    _scanned_times: npt.NDArray[np.uint64] | None
    _scanned_channels: npt.NDArray[np.uint16] | None
    _later_min: npt.NDArray[np.int64] | None
    _chunk_indexes: list[Any] | None
    _chunk_kinds: set[str]
    _unzstd: bool
    _steps: ScanSteps | None
    _profile: str
    _pending_big: list[tuple[int, int, int]] | None

    # -- linear scan -----------------------------------------------------------------------

    def _scan(self) -> tuple[Any, Any, dict[int, int], int, int]:
        """Read the whole file linearly to count messages and keep their log times and
        channels (for :meth:`recorded_windows` and :meth:`index_times`); note where an
        unreadable record stops the read (truncated or corrupt file), and where log times
        step back (:class:`formats.clock_steps.ScanSteps`: the check a summary's chunk
        indexes give a file that has one)."""
        from mcap.records import Channel, Header, Schema

        from aion_cli.formats.clock_steps import ScanSteps

        channels: dict[int, Any] = {}
        schemas: dict[int, Any] = {}
        counts: dict[int, int] = {}
        times = array("Q")
        channel_ids = array("H")
        group_starts = array("Q")  # earliest log time of each record group holding messages
        start, end, n = 2**63 - 1, 0, 0
        steps = self._steps = ScanSteps()
        for group in self._linear_groups(None, scanning=True):
            first = 2**64 - 1
            for record in group:
                if type(record) is tuple:
                    log_time, cid = record[0], record[1]
                    counts[cid] = counts.get(cid, 0) + 1
                    times.append(log_time)
                    channel_ids.append(cid)
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
        self._scanned_times = np.frombuffer(times, dtype=np.uint64)
        self._scanned_channels = np.frombuffer(channel_ids, dtype=np.uint16)
        if np.any(np.diff(self._scanned_times.astype(np.int64)) < 0):
            # messages out of log-time order in the file: what a linear read may still hold
            # back is bounded by the earliest message of every later group
            starts = np.frombuffer(group_starts, dtype=np.uint64).astype(np.int64)
            self._later_min = np.minimum.accumulate(starts[::-1])[::-1]
        self._steps = None
        step = steps.warning(self.path.name)
        if step is not None and self._chunk_indexes is None:  # else the indexes said it
            self._warn(step)
        if self._stop_offset is not None:
            self._warn(
                f"{self.path.name}: truncated or corrupt MCAP: read stopped at byte "
                f"{self._stop_offset} of {self._size} after {counted(n, 'message')}; "
                "the rest of the file is ignored"
            )
        elif self._unclosed:
            self._warn(
                f"{self.path.name}: truncated MCAP: the file ends at byte {self._size} after "
                f"{counted(n, 'message')}, between two records, without the records that close a "
                "recording (DataEnd, summary, footer): it was cut short (a recorder killed, a "
                "copy made while recording); what it holds is read, anything recorded after "
                "it is not in the file"
            )
        # the file's span in int64, as every time in aion: a log time no int64 holds (a
        # damaged one, up to 2^64 - 1) is the latest one that does; the build drops the
        # message itself as out of range
        last = 2**63 - 1
        return channels, schemas, counts, min(start if n else 0, last), min(end, last)

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
        from aion_cli.formats import mcap_records as mr

        counts: dict[int, int] | None = None  # message index counts of the last chunk
        with self.path.open("rb") as f:  # own handle, held while this pass runs
            records = mr.walk(f, len(_MCAP_MAGIC), self._size)
            while True:
                try:
                    offset, opcode, length = next(records)
                except StopIteration as done:
                    if scanning and done.value is not None:  # the DataEnd (or Footer)
                        self._check_end(f, done.value)
                    elif scanning:  # the file ends between two records, before its DataEnd
                        self._unclosed = True
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
        from aion_cli.formats import mcap_records as mr

        if offset in self._bad_chunks:
            return None
        try:
            head = mr.read_chunk_head(f, offset, self._size)
            if scanning:
                self._chunk_kinds.add(head.compression or "none")
            buf = mr.read_chunk(f, head, self._limits, _decompress)
            if scanning:
                return self._chunk_definitions(buf, offset)
            selected, big, seen = mr.chunk_messages(buf, wanted, self._limits.max_message_bytes)
        except ValueError as exc:  # ChunkError and the head's ValueError
            self._bad_chunks[offset] = _why(exc)
            if not scanning:
                self._chunk_lost(offset)
            return None
        self._oversized(big)
        return selected if seen else None

    def _chunk_definitions(self, buf: bytes, offset: int) -> list[Any] | None:
        """Schemas and channels (mcap records) and messages (``(log_time, channel_id, b"")``)
        of the decompressed chunk at ``offset``, definitions first, messages by log time;
        None when it holds neither. :class:`formats.limits.ChunkError` for records that do
        not parse. The messages' log times in the order they are in the chunk go to the
        scan's clock step check."""
        from mcap.records import Channel, Schema

        from aion_cli.formats import mcap_records as mr

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
        if self._steps is not None:
            self._steps.chunk(offset, [m[0] for m in messages], [m[1] for m in messages])
        messages.sort(key=_first)
        items.extend(messages)
        return items or None

    def _bare_message(
        self, f: IO[bytes], offset: int, length: int, wanted: set[int] | None, scanning: bool
    ) -> list[Any] | None:
        """A Message record outside chunks as a group, None when it is malformed or over the
        message cap (that one said in a warning, its payload never read)."""
        from aion_cli.formats import mcap_records as mr

        if length < mr.MESSAGE_PREFIX:
            return None
        f.seek(offset + 9)
        cid, log_time = mr.message_fields(f.read(mr.MESSAGE_PREFIX), 0)
        size = length - mr.MESSAGE_PREFIX
        if size > self._limits.max_message_bytes:
            self._oversized([(cid, log_time, size)])
            return None
        if scanning:
            if self._steps is not None:
                self._steps.message(log_time, cid)
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

        from aion_cli.formats import mcap_records as mr

        kinds = {mr.OP_HEADER: Header, mr.OP_SCHEMA: Schema, mr.OP_CHANNEL: Channel}
        f.seek(offset + 9)
        try:
            return [_parse_record(kinds[opcode], f.read(length))]
        except ValueError as exc:
            self._warn(f"{self.path.name}: record at byte {offset} skipped: {exc}")
            return None

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

    def _linear_times(self, wanted: set[int]) -> tuple[npt.NDArray[np.uint64], npt.NDArray[Any]]:
        """``(log times, channel ids)`` of the messages on ``wanted`` channels in the order
        :meth:`_records_linear` yields them, from what the opening scan kept (no second read):
        the scan's order, which is file order with each chunk sorted by log time; when the scan
        found messages out of order, the heap of :meth:`_records_linear` sorts them by log
        time, ties in file order (its bound only ever holds messages back)."""
        times, channels = self._scanned_times, self._scanned_channels
        if times is None or channels is None:
            return np.zeros(0, np.uint64), np.zeros(0, np.uint16)
        keep = np.isin(channels, np.fromiter(wanted, np.int64, len(wanted)))
        times, channels = times[keep], channels[keep]
        if self._later_min is not None:
            order = np.argsort(times, kind="stable")
            times, channels = times[order], channels[order]
        return times, channels

    # -- warnings --------------------------------------------------------------------------

    def _compression(self) -> tuple[str, ...]:
        """The chunks' compressions (``zstd``, ``lz4``, ``none``) from the summary's chunk
        indexes, or from the chunk records a linear scan met (``none`` without a chunk), and
        ``zstd (message)`` for a rosbag2 bag's compressed payloads."""
        found = (
            {c.compression or "none" for c in self._chunk_indexes}
            if self._chunk_indexes is not None
            else set(self._chunk_kinds)
        )
        if not found:
            found = {"none"}  # no chunk: an unchunked (or empty) file
        if self._unzstd:  # chunks of compressed payloads: the payloads' compression says it
            return (*sorted(found - {"none"}), "zstd (message)")
        return tuple(sorted(found))

    def _check_end(self, f: IO[bytes], start: int) -> None:
        """Warn when the MCAP whose records go on from byte ``start`` (its DataEnd, or its
        summary section) ends before the file does: what follows is not read (another log
        appended to it, garbage)."""
        from aion_cli.formats.log_format import trailing_warning
        from aion_cli.formats.mcap_records import end_of_log

        end = end_of_log(f, start, self._size)
        if end is not None and end < self._size:
            self._warn(trailing_warning(self.path, end, self._size))

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
        from aion_cli.engine.time_text import iso_utc
        from aion_cli.formats import limits as caps

        if self._pending_big is not None:
            self._pending_big.extend(big)
            return
        for cid, log_time, size in big:
            topic = self.channel_topics.get(cid, f"channel {cid}")
            self._warn(
                f"{self.path.name}: a message on {topic} at {iso_utc(log_time)} skipped: "
                + str(caps.message_over_limit(size, self._limits.max_message_bytes))
            )


def _why(exc: Exception) -> str:
    """Why a chunk cannot be read, for :meth:`_McapSource._chunk_lost`: damage is marked as
    such; a chunk over the cap or in an unknown compression is not corrupt."""
    from aion_cli.formats.limits import OverLimitError, UnknownCompressionError
    from aion_cli.formats.mcap_records import CORRUPT

    if isinstance(exc, OverLimitError | UnknownCompressionError):
        return str(exc)
    return CORRUPT + str(exc)


def _noun_and_reason(why: str) -> tuple[str, str]:
    from aion_cli.formats.mcap_records import CORRUPT

    if why.startswith(CORRUPT):
        return "corrupt chunk", why.removeprefix(CORRUPT)
    return "chunk", why


def _decompress(data: bytes | memoryview, compression: str, declared: int, limit: int) -> bytes:
    """Every MCAP chunk's records go through here (:func:`formats.limits.decompress`: the
    declared size checked against ``limit`` first, the output bounded)."""
    from aion_cli.formats import limits as caps

    return caps.decompress(data, compression, declared, limit)


def _parse_record(kind: Any, body: bytes) -> Any:
    """An mcap library record (Header, Schema, Channel) from its body bytes;
    :class:`formats.limits.ChunkError` when it does not parse."""
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError

    from aion_cli.formats.limits import ChunkError

    try:
        return kind.read(ReadDataStream(io.BytesIO(body)))
    except (McapError, *_MCAP_READ_ERRORS, UnicodeDecodeError) as exc:  # EndOfFile: too short
        raise ChunkError(f"a {kind.__name__} record does not parse ({exc})") from exc


def _first(item: tuple[int, int, bytes]) -> int:
    return item[0]
