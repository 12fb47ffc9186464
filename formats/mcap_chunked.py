"""Reading an MCAP file's messages through its chunk indexes: chunk after chunk in time order
when the indexed chunks do not overlap (:meth:`_McapChunked._chunk_batches`, skipping chunks
outside a time part or without wanted channels, leaving a tail of messages hinted unread),
merged in log-time order when they do (:meth:`_McapChunked._records_merged`); a chunk that
cannot be read is skipped alone with a warning. One part of
:class:`formats.mcap_source._McapSource`, beside :mod:`formats.mcap_indexed` and
:mod:`formats.mcap_linear`.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

# mcap_linear._decompress is looked up at call time (tests replace it)
from aion_cli.formats import mcap_linear
from aion_cli.formats.mcap_indexed import _McapIndexed
from aion_cli.formats.mcap_linear import _why

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.mcap_records import Record
    from aion_cli.formats.raw import Payload

_Skip = tuple[set[int], "npt.NDArray[np.int64]", frozenset[int]]
"""Messages a chunk read may leave unread: their channels and sorted log times; and the
channels whose payloads may be views (:attr:`formats.raw.UnreadHint.views`)."""


class _McapChunked(_McapIndexed):
    """The chunk-index reads of an MCAP source (module docstring)."""

    _by_chunk: bool  # indexed chunks that do not overlap in time: read chunk after chunk

    def _records(self, wanted: set[int]) -> Iterator[Record]:
        """The messages of the ``wanted`` channels by the fastest path the file allows."""
        if self._chunk_indexes is None:
            return self._records_linear(wanted)
        if not self._by_chunk:
            return self._records_merged(wanted)
        return (record for batch in self._chunk_batches(wanted) for record in batch)

    def _selected(self, index: Any, wanted: set[int]) -> bool:
        """Whether the chunk of ``index`` may hold a wanted message (its index lists the
        channels it holds, checked against the data at open) and can be read."""
        if index.chunk_start_offset in self._bad_chunks:
            return False
        return not (index.message_index_offsets and wanted.isdisjoint(index.message_index_offsets))

    def _chunk_batches(
        self,
        wanted: set[int],
        between: tuple[int, int] | None = None,
        skip: _Skip | None = None,
    ) -> Iterator[list[Record]]:
        """Time order by chunk: chunk indexes sorted by start time do not overlap, so each
        chunk's messages sorted by log time (one list per chunk) continue the stream. With
        ``between`` (``[lo, hi)``), chunks whose index puts every message outside are
        skipped; with ``skip`` (channels, sorted log times), a chunk's tail of such messages
        is left unread (:func:`formats.mcap_partial.read_head`) and payloads on its view
        channels that fill most of their chunk are views of it."""
        assert self._chunk_indexes is not None
        for index in self._chunk_indexes:
            if between is not None and (
                index.message_end_time < between[0] or index.message_start_time >= between[1]
            ):
                continue
            if self._selected(index, wanted):
                selected = self._read_indexed(index.chunk_start_offset, wanted, index, skip)
                if selected:
                    yield selected

    def _read_indexed(
        self, offset: int, wanted: set[int], index: Any = None, skip: _Skip | None = None
    ) -> list[Record]:
        """The wanted messages of the indexed chunk at ``offset``, sorted by log time; [] (and
        a warning) when it cannot be read. Opens the file for this chunk only. With ``index``
        (its ChunkIndex) and ``skip``, only its head where a tail of messages on channels not
        wanted or named by ``skip`` can be left unread (:func:`formats.mcap_partial.read_head`),
        nothing where its index says all of it can (:func:`formats.mcap_partial.unread_chunk`)."""
        from aion_cli.formats import mcap_partial
        from aion_cli.formats import mcap_records as mr

        views = skip[2] if skip is not None else frozenset()
        if skip is not None and skip[1].size:  # a chunk of graphs left out: its index says so
            counts = self._chunk_counts.get(offset)
            alone = mcap_partial.unread_chunk(index, counts, wanted, *skip[:2])
            if alone is not None:
                return alone
        try:
            with self.path.open("rb") as f:
                head = mr.read_chunk_head(f, offset, self._size, self._lengths.get(offset))
                if skip is not None and mcap_partial.may_leave_a_tail(index, wanted, skip[0]):
                    part = mcap_partial.read_head(
                        f, self._size, index, head, wanted, *skip[:2], self._limits, views
                    )
                    if part is not None:
                        self._oversized(part[1])
                        return self._as_indexed(offset, index, part[0])
                buf = mr.read_chunk(f, head, self._limits, mcap_linear._decompress)
            cap = self._limits.max_message_bytes
            selected, big, _ = mr.chunk_messages(buf, wanted, cap, views)
        except ValueError as exc:  # ChunkError and the head's ValueError
            self._bad_chunks[offset] = _why(exc)
            self._chunk_lost(offset)
            self._stale(offset)
            return []
        self._oversized(big)
        return self._as_indexed(offset, index, selected)

    def _records_merged(self, wanted: set[int]) -> Iterator[Record]:
        """Overlapping chunks, merged in log-time order: a chunk is read when the stream
        reaches its start time, so only the chunks overlapping one moment are held; ties keep
        chunk order."""
        assert self._chunk_indexes is not None
        chunks = [c for c in self._chunk_indexes if self._selected(c, wanted)]
        heap: list[tuple[int, int, int, Payload]] = []
        seq = 0
        k = 0
        while k < len(chunks) or heap:
            if k < len(chunks) and (not heap or chunks[k].message_start_time <= heap[0][0]):
                for log_time, channel_id, data in self._read_indexed(
                    chunks[k].chunk_start_offset, wanted, chunks[k]
                ):
                    heapq.heappush(heap, (log_time, seq, channel_id, data))
                    seq += 1
                k += 1
                continue
            log_time, _, channel_id, data = heapq.heappop(heap)
            yield log_time, channel_id, data
