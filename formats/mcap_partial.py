"""Reading an MCAP chunk only up to a tail its reader will drop unread.

A live Hydra log holds a scene graph of megabytes in almost every chunk, and a recorder closes
a chunk once it has outgrown its size, so that graph is the chunk's *last* record. A build that
thins the graphs (``--graph-period``, every fifth of a 1 Hz stream by default) drops most of
them without looking at them, yet decompressing the chunks for the detections between them
decompressed every graph too: nearly all of the bytes read (issue 15).

:func:`read_head` decompresses a chunk only up to its *droppable tail*: the longest run of
messages at its end that the reader's caller does not want (other channels) or said it drops
unread (:class:`formats.raw.UnreadHint`). Where the messages lie comes from the chunk's
MessageIndex records (one read of the bytes after the chunk). The messages of the tail on
wanted channels are yielded in their place with :data:`formats.raw.UNREAD` as their data, so
the stream has the same messages in the same order as a whole read.

A chunk read this way cannot be checked against its CRC-32 (which covers all of its
decompressed bytes), so it is read in part only when the tail is at least half of it
(:data:`_SMALLEST_TAIL`), and the head must agree with the index: its records end exactly where
the tail begins and hold as many messages as the index lists before it. Anything else — no
index, a damaged one, a head that disagrees — returns None, and the caller reads the whole
chunk as before (CRC-checked).
"""

from __future__ import annotations

from operator import itemgetter
from typing import IO, Any, cast

import numpy as np
import numpy.typing as npt

from aion_cli.formats import limits as caps
from aion_cli.formats import mcap_records as mr
from aion_cli.formats import recorded
from aion_cli.formats.raw import UNREAD, Payload

_SMALLEST_TAIL = 0.5
"""The least share of a chunk's decompressed bytes a droppable tail must have for the chunk to
be read in part (the rest is read whole: CRC-checked)."""

Selected = list[tuple[int, int, Payload]]


def read_head(
    f: IO[bytes],
    size_of_file: int,
    index: Any,
    head: mr.ChunkHead,
    wanted: set[int],
    unread_channels: set[int],
    unread_times: npt.NDArray[np.int64],
    limits: caps.ReadLimits,
    views: frozenset[int] = frozenset(),
) -> tuple[Selected, list[mr.Oversized]] | None:
    """The chunk's wanted messages as :func:`formats.mcap_records.chunk_messages` gives them
    (sorted by log time, ``(log_time, channel_id, data)``; and those over the message cap),
    with the droppable tail left compressed and its wanted messages' data :data:`UNREAD`;
    None when the chunk is to be read whole (see the module docstring). ``size_of_file``: the
    bytes of the file ``f`` reads; ``index``: the chunk's
    ChunkIndex record; ``head``: its chunk record (:func:`formats.mcap_records.read_chunk_head`);
    messages on ``unread_channels`` logged at ``unread_times`` (sorted) may be left unread;
    ``views``: as :func:`formats.mcap_records.chunk_messages`'s."""
    size = int(head.uncompressed_size)
    if size <= 0 or head.compression not in ("", "zstd", "lz4") or size > limits.max_chunk_bytes:
        return None
    parts = _index_parts(f, size_of_file, index)
    if not parts:
        return None
    channel, log_time, offset = _entries(parts)
    if not _last_droppable(channel, log_time, offset, wanted, unread_channels, unread_times):
        return None  # most chunks end with a message that is needed: decided in a few us
    order = np.argsort(offset, kind="stable")
    channel, log_time, offset = channel[order], log_time[order], offset[order]
    if offset.size == 0 or np.any(offset[1:] <= offset[:-1]) or int(offset[-1]) >= size:
        return None
    is_wanted = _among(channel, wanted)
    unread = _among(channel, unread_channels) & _listed(log_time, unread_times)
    droppable = ~is_wanted | unread
    keep = np.flatnonzero(~droppable)
    first = int(keep[-1]) + 1 if keep.size else 0  # the tail: entries [first, n)
    if first == offset.size:
        return None
    cut = int(offset[first])
    if size - cut < _SMALLEST_TAIL * size:
        return None
    try:
        buf = _decompressed_head(f, head, cut)
    except Exception:  # zstandard.ZstdError, lz4's RuntimeError, OSError: read whole, which
        return None  # says why with the whole read's checks and warnings
    if buf is None:
        return None
    try:
        selected, big, seen = mr.chunk_messages(buf, wanted, limits.max_message_bytes, views)
    except caps.ChunkError:
        return None
    if seen + len(big) != first:
        return None
    tail = np.arange(first, offset.size)[is_wanted[first:]]
    if tail.size:
        selected.extend((int(log_time[k]), int(channel[k]), UNREAD) for k in tail.tolist())
        selected.sort(key=itemgetter(0))  # stable: the tail follows the head, as in the chunk
    return selected, big


def unread_chunk(
    index: Any,
    counts: dict[int, int] | None,
    wanted: set[int],
    unread_channels: set[int],
    unread_times: npt.NDArray[np.int64],
) -> Selected | None:
    """The chunk's wanted messages, every one :data:`UNREAD`, from its ChunkIndex ``index``
    and its message counts per channel (``counts``, from its MessageIndex records, checked
    against the statistics at open) alone, when they are on one channel of ``unread_channels``
    and all logged at one time (the chunk's start and end time) that ``unread_times`` lists:
    a chunk of a graph the build leaves out and nothing else it reads (a log of scene graphs
    alone). None otherwise: the chunk is read. Nothing of the chunk is read, as nothing of a
    tail :func:`read_head` leaves unread is (no CRC either way)."""
    if index is None or not counts or index.message_start_time != index.message_end_time:
        return None
    on = [c for c, n in counts.items() if n > 0 and c in wanted]
    if len(on) != 1 or on[0] not in unread_channels:
        return None
    t = np.asarray(index.message_start_time, np.int64).reshape(1)
    if not _listed(t, unread_times)[0]:
        return None
    return [(int(t[0]), on[0], UNREAD)] * counts[on[0]]


def may_leave_a_tail(index: Any, wanted: set[int], unread_channels: set[int]) -> bool:
    """Whether the chunk of ``index`` (its ChunkIndex, or None) holds messages a read may leave
    unread: on channels not wanted, or on those of an unread hint (its MessageIndex records
    list its channels); :func:`read_head` is worth calling only then."""
    if index is None or not index.message_index_offsets:
        return False
    return any(c not in wanted or c in unread_channels for c in index.message_index_offsets)


def _among(channel: npt.NDArray[np.int64], ids: set[int]) -> npt.NDArray[np.bool_]:
    """Mask of the ``channel`` ids found in ``ids`` (a table over the ids: channel ids are
    16-bit, and np.isin's sorting costs more than the rest of a chunk's plan)."""
    top = int(channel.max(initial=-1))
    table = np.zeros(top + 1, dtype=bool)
    table[[c for c in ids if 0 <= c <= top]] = True
    found: npt.NDArray[np.bool_] = table[channel]
    return found


def _listed(t: npt.NDArray[np.int64], times: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
    """Mask of ``t`` found in the sorted ``times``."""
    if times.size == 0:
        return np.zeros(t.shape, dtype=bool)
    at = np.minimum(np.searchsorted(times, t), times.size - 1)
    found: npt.NDArray[np.bool_] = times[at] == t
    return found


IndexParts = list[tuple[int, npt.NDArray[Any]]]
"""Per channel of a chunk, its MessageIndex entries (``log_time``, ``offset``)."""


def _index_parts(f: IO[bytes], size: int, index: Any) -> IndexParts | None:
    """The chunk's MessageIndex records, per channel (of a file of ``size`` bytes); None
    without them or when they cannot be read."""
    offsets = index.message_index_offsets
    if not offsets or index.message_index_length <= 0:
        return None
    try:
        parts = recorded.read_message_index(f, size, index, offsets)
    except OSError:
        return None
    if parts is None:
        return None
    return [(int(cid), p) for cid, p in zip(offsets, parts, strict=True) if len(p)]


def _last_droppable(
    channel: npt.NDArray[np.int64],
    log_time: npt.NDArray[np.int64],
    offset: npt.NDArray[np.int64],
    wanted: set[int],
    unread_channels: set[int],
    unread_times: npt.NDArray[np.int64],
) -> bool:
    """Whether the chunk's last message (the largest offset its index lists; :func:`_entries`'
    arrays, not empty) may be left unread: on a channel not wanted, or named by the hint at a
    listed time. One ``argmax`` over the entries of every channel, then Python on that one
    entry: it was a maximum per channel, an ``argmax`` over their list and numpy calls on
    one-element arrays, about 45,000 of the 683,000 instructions of a :func:`read_head` call
    on a chunk of the 1-hour 5,000-place stream (callgrind, stop 69)."""
    last = int(offset.view(np.uint64).argmax())  # the index's own unsigned offsets
    c = int(channel[last])
    if c not in wanted:
        return True
    if c not in unread_channels:
        return False
    return bool(_listed(log_time[last : last + 1], unread_times)[0])


def _entries(
    parts: IndexParts,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Channel, log time and offset (in the decompressed chunk) of every message listed."""
    channel = np.concatenate([np.full(len(p), cid, np.int64) for cid, p in parts])
    log_time = np.concatenate([p["log_time"] for _, p in parts]).astype(np.int64)
    offset = np.concatenate([p["offset"] for _, p in parts]).astype(np.int64)
    return channel, log_time, offset


def _decompressed_head(f: IO[bytes], head: mr.ChunkHead, n: int) -> bytes | None:
    """The first ``n`` decompressed bytes of the chunk; None when it holds fewer."""
    if not head.compression:
        f.seek(head.data_offset)
        data = f.read(n) if n <= head.data_length else b""
        return data if len(data) == n else None
    if head.compression == "zstd":  # read only as much of the compressed data as the head needs
        out = _zstd_prefix(_Window(f, head.data_offset, head.data_length), n)
        return out if len(out) == n else None
    f.seek(head.data_offset)
    data = f.read(head.data_length)
    if len(data) < head.data_length:
        return None
    out = _lz4_prefix(data, n)
    return out if len(out) == n else None


class _Window:
    """The ``length`` bytes of ``f`` from ``start``, as a file the zstd stream reader pulls
    from: it never reads past them (the next record is no part of the frame)."""

    def __init__(self, f: IO[bytes], start: int, length: int) -> None:
        self.f, self.pos, self.end = f, start, start + length

    def read(self, size: int = -1) -> bytes:
        left = self.end - self.pos
        if size < 0 or size > left:
            size = left
        if size <= 0:
            return b""
        self.f.seek(self.pos)
        data = self.f.read(size)
        self.pos += len(data)
        return data


_ZSTD_READ = 1 << 14
"""Compressed bytes the zstd stream reader takes at a time for a chunk's head: a tracker's
messages before a scene graph compress to a few KiB, so one or two reads instead of the
chunk's whole compressed data (megabytes of graph)."""


def _zstd_prefix(source: _Window, n: int) -> bytes:
    """At most the first ``n`` bytes the zstd data in ``source`` decompresses to."""
    reader = caps.zstd_decompressor().stream_reader(
        cast("IO[bytes]", source), read_size=_ZSTD_READ, read_across_frames=True, closefd=False
    )  # it calls read(size) only
    parts = []
    got = 0
    while got < n:
        part = reader.read(n - got)
        if not part:
            break
        parts.append(part)
        got += len(part)
    return b"".join(parts)


def _lz4_prefix(data: bytes, n: int) -> bytes:
    """At most the first ``n`` bytes the lz4 ``data`` decompresses to (the rest is left
    compressed; zstd is read from the file by :func:`_zstd_prefix`)."""
    import lz4.frame  # type: ignore[import-untyped]

    return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=n))
