"""What an MCAP file's indexes say without reading its messages: the log times its stream will
yield (:meth:`_McapIndexed.index_times`, :mod:`formats.mcap_times`), the windows in which it
recorded anything (:meth:`_McapIndexed.recorded_windows`), and the chunks whose index times a
build relies on (:meth:`_McapIndexed.vouch`: reading one of them that fails makes the build
start over). One part of :class:`formats.mcap_source._McapSource`, which sets the attributes
declared here when it opens the file; :mod:`formats.mcap_linear` is another.
"""

from __future__ import annotations

from typing import IO, TYPE_CHECKING, Any

import numpy as np

# mcap_linear._decompress is looked up at call time (tests replace it)
from aion_cli.formats import mcap_linear, recorded
from aion_cli.formats.mcap_linear import _McapLinearRead, _why

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.mcap_records import Record
    from aion_cli.formats.raw import Encoding
    from aion_cli.formats.recorded import Windows
    from aion_cli.formats.stream_times import StreamTimes


class _McapIndexed(_McapLinearRead):
    """The index-backed answers of an MCAP source (module docstring)."""

    _channels: dict[int, tuple[str, str, Encoding]]
    _unzstd: bool
    _chunk_indexes: list[Any] | None
    _lengths: dict[int, int]
    _errors: tuple[type[BaseException], ...]
    _vouched: frozenset[int]

    # -- log times from the indexes --------------------------------------------------------

    def index_times(self, topics: set[str]) -> StreamTimes | None:
        """The log times :meth:`messages` would yield on ``topics``, in its order, without
        reading a message (:mod:`formats.mcap_times`: from the MessageIndex records; a file
        read linearly: from its opening scan); None where the indexes cannot say that
        exactly, and for payloads compressed one by one (one may expand over the cap)."""
        from aion_cli.formats import mcap_times, stream_times

        wanted = {cid: t for cid, (t, _, _) in self._channels.items() if t in topics}
        if not wanted:
            return stream_times.empty()
        if self._unzstd:
            return None
        if self._chunk_indexes is None:
            times, channels = self._linear_times(set(wanted))
            return stream_times.from_channels(times, channels, wanted, frozenset())
        with self.path.open("rb") as f:
            found = mcap_times.indexed_times(
                f,
                self._size,
                self._chunk_indexes,
                self._bad_chunks,
                self._chunk_counts,
                self._limits.max_message_bytes,
                set(wanted),
            )
        if found is None:
            return None
        return stream_times.from_channels(*found[:2], wanted, found[2])

    def sniff_payloads(self) -> None:
        """Read the payloads as zstd-compressed one by one (a rosbag2 bag recorded with
        ``compression_mode: message``) when the first message's payload starts with the zstd
        magic bytes: for a rosbag2 mcap storage file read without metadata.yaml, which alone
        says so. A CDR payload starts with its encapsulation header (``00 01`` or ``00 00``),
        never with them. Reads the first chunk holding a message."""
        from dataclasses import replace

        from aion_cli.formats.rosbag2_storage import ZSTD_MAGIC

        first = next(iter(self.messages(None)), None)
        if first is not None and bytes(first.data[:4]) == ZSTD_MAGIC:
            self._unzstd = True
            self.file = replace(self.file, compression=self._compression())

    def vouch(self, chunks: frozenset[int]) -> None:
        """The build uses log times taken from the index of ``chunks`` (offsets): reading one
        of them that fails raises :class:`~aion_cli.errors.StaleIndexError`."""
        self._vouched = self._vouched | chunks

    def _stale(self, offset: int) -> None:
        """A chunk could not be read: if the build took its times from its index, they are
        not the stream's (the build starts over)."""
        if offset in self._vouched:
            from aion_cli.errors import StaleIndexError

            raise StaleIndexError(
                f"{self.path.name}: the chunk at byte {offset} cannot be read, but its log "
                "times were taken from its index",
                hint="aion reads the log again in full",
            )

    def _as_indexed(self, offset: int, index: Any, selected: list[Record]) -> list[Record]:
        """``selected``, the messages read of the chunk at ``offset`` sorted by log time, when
        they lie within the times of its chunk ``index``. In a chunk whose times the build took
        from its index, a message outside them (a log time damaged inside a chunk whose CRC
        still holds, or was rewritten: 2^64 - 1 ns, which no int64 holds) raises
        :class:`~aion_cli.errors.StaleIndexError`: the build reads every message again, and
        its time checks see the times the stream yields."""
        if (
            selected
            and index is not None
            and offset in self._vouched
            and not (
                index.message_start_time <= selected[0][0]
                and selected[-1][0] <= index.message_end_time
            )
        ):
            from aion_cli.errors import StaleIndexError

            raise StaleIndexError(
                f"{self.path.name}: the chunk at byte {offset} holds messages at log times "
                "outside those its index gives, which were taken from the index",
                hint="aion reads the log again in full",
            )
        return selected

    # -- recorded windows ------------------------------------------------------------------

    def recorded_windows(self, window_ns: int) -> Windows:
        """From the chunk indexes when the file has a summary: a chunk within one window or
        two adjacent ones records the windows of its first and last message; only wider chunks
        need their message times, from their MessageIndex records (a few bytes each; the chunk
        is decompressed only when it has none or they are damaged). Chunks that cannot be read
        record nothing. Without a summary, the log times the opening scan kept."""
        if self._chunk_indexes is None:
            scanned = self._scanned_times
            return recorded.windows_of(scanned if scanned is not None else [], window_ns)
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
        from aion_cli.formats import mcap_records as mr

        if index.message_index_offsets and index.message_index_length > 0:
            try:
                parts = recorded.read_message_index(
                    stream, self._size, index, index.message_index_offsets
                )
            except self._errors:
                parts = None
            if parts is not None:  # a damaged index does not mean a damaged chunk: read it
                times = [p["log_time"].astype(np.int64) for p in parts]
                return np.concatenate(times) if times else np.zeros(0, np.int64)
        offset = index.chunk_start_offset
        try:
            head = mr.read_chunk_head(stream, offset, self._size, self._lengths.get(offset))
            buf = mr.read_chunk(stream, head, self._limits, mcap_linear._decompress)
            return recorded.record_log_times(buf)
        except ValueError as exc:  # ChunkError, the head's and record_log_times' ValueError
            self._bad_chunks[offset] = _why(exc)
            self._chunk_lost(offset)
            self._stale(offset)
            return None
