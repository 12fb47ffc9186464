"""MCAP files (both ROS profiles, and the storage files of rosbag2 folders with mcap storage) as
one :class:`formats.log_source._Source`: :class:`_McapSource` and :func:`_open_mcap`.

MCAP files are read with aion's own record reader (:mod:`formats.mcap_records`) rather than
through rosbags (which refuses ROS 1-profile MCAP; the raw bytes are what the numpy adapters
want). At open, the summary is checked against the data section; when it agrees, chunks are
read through the chunk indexes in time order, chunks without requested channels skipped without
decompressing them, overlapping chunks merged, a chunk that cannot be read skipped alone with a
warning (:mod:`formats.mcap_chunked`, a part of the class). Otherwise the file is read
linearly (:mod:`formats.mcap_linear`, another part). :meth:`_McapSource.recorded_windows`
answers from the chunk indexes and MessageIndex records where it can, and
:meth:`_McapSource.index_times` gives the log times its stream will yield from them, or from
the opening scan of a file read linearly (:mod:`formats.mcap_indexed`, the fourth part).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from aion_cli.errors import LogFormatError
from aion_cli.formats import clock_steps
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_source import (
    _MESSAGE_ENCODINGS,
    _ZSTD_MAGIC,
    LogFile,
    OtherChannel,
    _Topic,
    _unzstd,
)
from aion_cli.formats.mcap_chunked import _McapChunked, _Skip
from aion_cli.formats.mcap_linear import _MCAP_MAGIC, _MCAP_READ_ERRORS
from aion_cli.formats.raw import Encoding, RawMessage, UnreadHint, normalize_msgtype, raw_message
from aion_cli.number_text import counted

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.mcap_records import Record


def _schema_encoding_ok(encoding: str) -> bool:
    return encoding in ("ros1msg", "ros2msg", "ros2idl", "")


class _McapSource(_McapChunked):
    """An MCAP file read with aion's own record reader (:mod:`formats.mcap_records`; both ROS
    profiles), holding no file open between reads.

    The summary is used only after :func:`formats.mcap_summary.check_summary` found it in
    agreement with the data section: then chunks are visited in time order through the chunk
    indexes, skipping chunks without requested channels, and a chunk that cannot be read
    (CRC mismatch, unknown compression, over the size cap, damaged) is skipped alone with a
    warning naming it and the messages lost. Without a summary, or when it disagrees with the
    data (chunks or channels it leaves out, statistics that do not match), the file is read
    linearly, chunk by chunk, up to the first record whose framing is broken; so is a file
    with messages outside chunks beside chunked ones (valid MCAP, which chunk indexes cannot
    list), without a warning.
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

        from aion_cli.formats import mcap_summary

        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self._unzstd = unzstd
        self._size = path.stat().st_size
        # the mcap library reads the summary section (its errors: McapError)
        self._errors: tuple[type[BaseException], ...] = (McapError, *_MCAP_READ_ERRORS)
        self._chunk_indexes: list[Any] | None = None
        self._chunk_kinds: set[str] = set()  # chunk compressions a linear scan met
        # read chunk after chunk in time order: indexed chunks that do not overlap in time
        self._by_chunk = False
        # chunks that cannot be read (offset -> why) and their message counts per channel
        # (from the message index records after each chunk)
        self._bad_chunks: dict[int, str] = {}
        self._chunk_counts: dict[int, dict[int, int]] = {}
        # chunks whose record states a wrong length: read with their index's (offset -> length)
        self._lengths: dict[int, int] = {}
        self._stop_offset: int | None = None
        self._unclosed = False  # the linear scan met the file's end before its DataEnd
        # log times of every message, kept by the linear scan of a file without a usable
        # summary: recorded_windows then needs no second read (8 bytes per message)
        self._scanned_times: npt.NDArray[np.uint64] | None = None
        self._scanned_channels: npt.NDArray[np.uint16] | None = None
        # chunks whose log times a build took from their index without reading them
        # (formats.stream_times): reading one that fails raises StaleIndexError
        self._vouched: frozenset[int] = frozenset()
        # with messages out of order in a file read linearly: the earliest log time of each
        # group of records holding messages and of all after it (see _records_linear)
        self._later_min: npt.NDArray[np.int64] | None = None
        self._steps: clock_steps.ScanSteps | None = None  # while the linear scan runs
        self._profile = ""
        self.channel_topics: dict[int, str] = {}
        # messages over the cap met while opening, said once the channels' topics are known
        self._pending_big: list[tuple[int, int, int]] | None = []
        with path.open("rb") as f:
            summary = self._read_summary(f)
            check = None
            if summary is not None:
                names = {cid: c.topic for cid, c in summary.channels.items()}
                check = mcap_summary.check_summary(
                    f, self._size, summary.chunk_indexes, summary.statistics, names
                )
                # the footer at the end of the file points at a summary section: the log
                # ends after the footer that section leads to (two logs joined end to end
                # lead to the first's)
                f.seek(self._size - len(_MCAP_MAGIC) - 20)
                self._check_end(f, int.from_bytes(f.read(8), "little"))
        distrust = check is not None and (
            bool(check.problems) or check.unsure or check.bare_messages > 0
        )
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
            self._by_chunk = not mcap_summary.chunks_overlap(self._chunk_indexes)
            step = clock_steps.mcap_step_warning(path, self._size, self._chunk_indexes)
            if step is not None:  # between chunks or inside one
                self._warn(step)
            self._bad_chunks.update(check.bad_chunks)
            for index in self._chunk_indexes:  # what the index says is refused already
                why = mcap_summary.refused(index, self._limits)
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
        unreadable: dict[str, str] = {}
        self.unreadable_topics = unreadable
        others: dict[tuple[str, str, str], int] = {}
        for cid, channel in sorted(channels.items()):
            schema = schemas.get(channel.schema_id)
            encoding = _MESSAGE_ENCODINGS.get(channel.message_encoding)
            if schema is None or encoding is None or not _schema_encoding_ok(schema.encoding):
                enc = schema.encoding if schema is not None else "none"
                n = counts.get(cid, 0)
                key = (channel.topic, schema.name if schema else "", channel.message_encoding)
                others[key] = others.get(key, 0) + n
                unreadable[channel.topic] = (
                    f"message encoding {channel.message_encoding!r} with schema encoding "
                    f"{enc!r} is not ROS"
                )
                self.warnings.append(
                    f"{path.name}: topic {channel.topic} skipped ({n:,} message"
                    f"{'' if n == 1 else 's'}): message encoding "
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
        self.other_channels = tuple(OtherChannel(*key, n) for key, n in others.items())
        if fmt_name is not None:
            fmt = fmt_name
        elif self._profile == "ros1" or (not self._profile and _all_ros1(self.topics)):
            fmt = "mcap-ros1"
        elif not self._profile and not self.topics:
            fmt = "mcap"  # neither a ROS profile nor a ROS topic: not a ROS 2 log either
        else:
            fmt = "mcap-ros2"
        total = sum(counts.values())
        self.file = LogFile(
            path, fmt, self._size, start if total else 0, end, total, self._compression()
        )

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
                f"chunks themselves instead (linear scan): {counted(total, 'message')}"
            )
        elif total != stats.message_count:
            held = "its data section holds" if check.bare_messages else "its chunks hold"
            self._warn(
                f"{self.path.name}: its statistics count {stats.message_count:,} messages but "
                f"{held} {total:,}; aion read the chunks themselves (linear scan)"
            )

    # -- reading ---------------------------------------------------------------------------

    def messages(
        self,
        topics: set[str] | None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        """See :meth:`_Source.messages`; with ``between``, indexed chunks whose messages all
        lie outside it are not read; with ``unread``, a chunk read by index is decompressed
        only up to a tail of such messages (:mod:`formats.mcap_partial`), and its ``views``
        are passed on (:func:`formats.mcap_records.chunk_messages`)."""
        wanted = {
            cid
            for cid, (topic, _, _) in self._channels.items()
            if topics is None or topic in topics
        }
        if not wanted:
            return iter(())
        skip: _Skip = (set(), np.zeros(0, np.int64), frozenset())
        if unread is not None:
            named = {cid for cid in wanted if self._channels[cid][0] in unread.topics}
            views = frozenset(named) if unread.views else frozenset()
            skip = (named if unread.times.size else set(), unread.times, views)
        return self._raw_messages(wanted, between, skip)

    def skips_by_time(self) -> bool:
        """Chunk-indexed files read by chunk (payloads not compressed one by one) skip the
        chunks outside ``between``."""
        return self._by_chunk and not self._unzstd

    def _raw_messages(
        self,
        wanted: set[int],
        between: tuple[int, int] | None = None,
        skip: _Skip | None = None,
    ) -> Iterator[RawMessage]:
        channels = self._channels
        if self._unzstd:
            yield from self._unzstd_messages(wanted)
            return
        if self._by_chunk:
            # the hot path: a chunk's messages at a time, each made by raw_message (issue 15)
            for selected in self._chunk_batches(wanted, between, skip):
                for log_time, channel_id, data in selected:
                    topic, msgtype, encoding = channels[channel_id]
                    yield raw_message(topic, msgtype, log_time, data, encoding)
            return
        for log_time, channel_id, data in self._records(wanted):
            topic, msgtype, encoding = channels[channel_id]
            yield RawMessage(topic, msgtype, log_time, data, encoding)

    def _unzstd_messages(self, wanted: set[int]) -> Iterator[RawMessage]:
        """Messages whose payloads are zstd-compressed, decompressed one by one within the
        message cap (one over it is skipped with a warning)."""
        from aion_cli.engine.time_text import iso_utc
        from aion_cli.formats.limits import OverLimitError

        cap = self._limits.max_message_bytes
        for log_time, channel_id, data in self._records(wanted):
            topic, msgtype, encoding = self._channels[channel_id]
            if data[:4] == _ZSTD_MAGIC:
                try:
                    data = _unzstd(data, cap)
                except OverLimitError as exc:
                    self._warn(f"{self.path.name}: a message on {topic} at {iso_utc(log_time)} "
                               f"skipped: {exc}")
                    continue
            yield RawMessage(topic, msgtype, log_time, data, encoding)

    def records(self, channel_ids: Iterable[int] | None = None) -> Iterator[Record]:
        """``(log_time, channel_id, data)`` of every message on ``channel_ids`` (all channels
        of the file when None, ROS or not: see :attr:`channel_topics`), in log-time order, read
        exactly as :meth:`messages` reads ROS topics. For tests of the MCAP reading itself on
        files whose channels are not ROS (the MCAP conformance suite)."""
        wanted = set(self.channel_topics if channel_ids is None else channel_ids)
        if not wanted:
            return iter(())
        return self._records(wanted)

    def close(self) -> None:
        """Nothing to release: the file is open only while a read runs."""


def _summary_lacks_records(channels: dict[int, Any], schemas: dict[int, Any], count: int) -> bool:
    """Whether a summary section leaves out channels its statistics count, or schemas its
    channels use (schema id 0: a channel without schema)."""
    if len(channels) < count:
        return True
    return any(c.schema_id != 0 and c.schema_id not in schemas for c in channels.values())


def _all_ros1(topics: dict[tuple[str, str], _Topic]) -> bool:
    return bool(topics) and all(t.encoding == "ros1" for t in topics.values())


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
        from aion_cli.formats.log_format import other_log, other_log_hint

        other = other_log(path, "mcap") if fmt_name is None else None
        if other is not None:  # a renamed bag, --log-format mcap on a .db3
            raise LogFormatError(
                f"{path} is not an MCAP file (it is {other[0]})",
                hint=other_log_hint(other[1]),
            )
        from aion_cli.formats.log_magic import not_a_log

        raise not_a_log(
            path, "an MCAP file", "the MCAP magic bytes",
            "check the file, or pass --log-format bag|rosbag2 if it is another log type",
        )  # fmt: skip
    return _McapSource(path, fmt_name, limits, unzstd=unzstd)
