"""The log times an MCAP file's stream will yield, from its indexes, without decompressing a
chunk (:class:`formats.stream_times.StreamTimes`; used by
:meth:`formats.mcap_source._McapSource.index_times`).

A file with a summary :func:`formats.mcap_summary.check_summary` agreed with is read through its
chunk indexes (:mod:`formats.mcap_source`): chunks in the order of their index (start time,
then offset), each chunk's messages sorted by log time (ties in record order), merged over
chunks that overlap. The MessageIndex records after each chunk list, per channel, the log
time and record offset of its messages: when every chunk's messages lie within the time range
its index states, that stream is the sort of all index entries by ``(log time, chunk,
offset)``, whether the chunks overlap or not (:func:`indexed_times`).

The index is used only where it says exactly what the reader will yield; otherwise
:func:`indexed_times` gives None and the caller reads the messages (as before):

* a chunk that may hold a wanted message has no message index, or its index is damaged, lists
  another number of messages per channel than the records after the chunk (what the summary
  check counted and compared with the statistics), lists an offset twice or outside the
  chunk's records, or a time outside the chunk's stated range;
* a chunk is large enough to hold a message over the message cap (the reader leaves those out).

Chunks the reader skips (refused at open, damaged records) are skipped here too. A chunk whose
CRC or compressed data is damaged cannot be told from its index: the chunks used are returned
for the reader to vouch for (:mod:`formats.stream_times`).
"""

from __future__ import annotations

from collections.abc import Container, Mapping, Sequence
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from aion_cli.formats import recorded

_RECORD_HEAD = 9
_MESSAGE_PREFIX = 2 + 4 + 8 + 8


def indexed_times(
    f: IO[bytes],
    size: int,
    indexes: Sequence[Any],
    skipped: Container[int],
    counts: Mapping[int, Mapping[int, int]],
    max_message: int,
    wanted: Container[int],
) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint16], frozenset[int]] | None:
    """``(log times, channel ids, chunks used)`` of the messages on the ``wanted`` channels in
    the order the indexed read yields them, from the MessageIndex records of the chunks
    ``indexes`` (sorted as the reader visits them) other than ``skipped``; ``counts``: the
    messages per channel of each chunk counted at open; None where the index cannot be
    trusted to say that (see the module docstring). ``f``: the file, ``size`` bytes."""
    times, channels, offsets, sizes = [], [], [], []
    used: list[int] = []
    chunks: list[Any] = []
    for index in indexes:
        listed = index.message_index_offsets
        if index.chunk_start_offset in skipped or (
            listed and not any(c in wanted for c in listed)
        ):
            continue  # the reader skips it too
        if not listed or index.message_index_length <= 0 or _largest(index) > max_message:
            return None
        found = _chunk_entries(f, size, index, [c for c in listed if c in wanted], counts)
        if found is None:
            return None
        for records, cid in found:
            times.append(records["log_time"])
            offsets.append(records["offset"])
            channels.append(np.full(len(records), cid, np.uint16))
        sizes.append(sum(len(records) for records, _ in found))
        used.append(index.chunk_start_offset)
        chunks.append(index)
    if not times:
        return np.zeros(0, np.uint64), np.zeros(0, np.uint16), frozenset(used)
    t, off = np.concatenate(times).astype(np.uint64), np.concatenate(offsets).astype(np.uint64)
    n = np.array(sizes)
    chunk_no = np.repeat(np.arange(len(chunks)), n)
    if not _consistent(t, off, chunk_no, chunks, n):
        return None
    order = np.lexsort((off, chunk_no, t))
    return t[order], np.concatenate(channels)[order], frozenset(used)


def _largest(index: Any) -> int:
    """The most bytes the chunk's records may take (its declared uncompressed size; stored
    data as it is; a compressed chunk that declares no size may expand to anything)."""
    if not index.compression:
        return int(index.compressed_size)
    return int(index.uncompressed_size) or 2**63


def _chunk_entries(
    f: IO[bytes],
    size: int,
    index: Any,
    channels: list[int],
    counts: Mapping[int, Mapping[int, int]],
) -> list[tuple[npt.NDArray[Any], int]] | None:
    """The MessageIndex entries (``log_time``, ``offset``) of each of ``channels`` in the
    chunk of ``index``, with the channel; None when the records are damaged or list another
    number of messages than were counted after the chunk at open."""
    records = recorded.read_message_index(f, size, index, channels)
    if records is None:
        return None
    counted = counts.get(index.chunk_start_offset, {})
    if any(len(r) != counted.get(c, 0) for c, r in zip(channels, records, strict=True)):
        return None
    return list(zip(records, channels, strict=True))


def _consistent(
    t: npt.NDArray[np.uint64],
    off: npt.NDArray[np.uint64],
    chunk_no: npt.NDArray[Any],
    chunks: list[Any],
    n: npt.NDArray[Any],
) -> bool:
    """Whether every entry lies in its chunk's stated time range and records, and no two
    entries of a chunk name the same record (entry ``i`` of chunk ``chunks[chunk_no[i]]``;
    ``n`` entries per chunk)."""
    first = np.array([c.message_start_time for c in chunks], np.uint64)
    last = np.array([c.message_end_time for c in chunks], np.uint64)
    records = np.array([_largest(c) for c in chunks], np.int64) - _RECORD_HEAD - _MESSAGE_PREFIX
    if (records < 0).any() or (t < np.repeat(first, n)).any() or (t > np.repeat(last, n)).any():
        return False
    if (off > np.repeat(records, n).astype(np.uint64)).any():
        return False
    by_record = np.lexsort((off, chunk_no))
    same = (np.diff(chunk_no[by_record]) == 0) & (np.diff(off[by_record]) == 0)
    return not same.any()
