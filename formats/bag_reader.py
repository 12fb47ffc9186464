"""ROS 1 bags read with bounded memory, skipping the chunks that cannot be read.

rosbags' ROS 1 reader decompresses a chunk whole with ``bz2.decompress`` / ``lz4.frame.decompress``
(a 6 KB bag can hold a bz2 chunk that expands to a gigabyte), refuses a whole bag for one chunk
in an unknown compression, and stops the read at the first chunk whose data is damaged.
:class:`BagReader` keeps rosbags' parsing of the bag header, connections and index (what it does
well) and replaces the rest:

- each chunk record's ``size`` field (the uncompressed size ROS 1 writes into every chunk header)
  is read at open: a chunk that declares more than the cap (:mod:`formats.limits`), or that is
  compressed with an unknown method, is dropped from the index then, with its message counts;
- a chunk is decompressed with a bounded output (:func:`formats.limits.decompress`), so a size
  field that lies cannot blow up either;
- :meth:`BagReader.iter_messages` merges the index itself and skips a chunk that fails to
  decompress or parse (the callback says which and how many messages were lost), and leaves out
  messages over the message cap;
- :meth:`BagReader.suspend` closes the file between reads (the index stays in memory), so a
  LogSet over thousands of bags does not hold thousands of file handles.
"""

from __future__ import annotations

import heapq
import io
import os
import re
import struct
from collections import Counter
from collections.abc import Callable, Collection, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Reader
from rosbags.rosbag1.reader import (
    Chunk,
    Header,
    ReaderError,
    RecordType,
    read_bytes,
    read_uint32,
)

from aion_cli.formats import limits as caps

BadChunk = Callable[[int, str, dict[int, int]], None]
"""Called with a chunk's position, why it is skipped, and its lost messages per connection."""

Oversized = Callable[[Any, int, int], None]
"""Called with the connection, log time and size of a message left out for its size."""

#: errors of a chunk whose decompressed records do not parse
_PARSE_ERRORS = (ReaderError, struct.error, AssertionError, KeyError, ValueError, IndexError)


class BagReader(Reader):
    """A rosbags ROS 1 reader that checks chunk sizes at open, decompresses with a bounded
    output and skips unreadable chunks (see the module text)."""

    def __init__(self, path: Path, limits: caps.ReadLimits) -> None:
        super().__init__(path)
        self._file = path
        self.limits = limits
        # chunk position -> (compression, declared uncompressed size)
        self.chunk_meta: dict[int, tuple[str, int]] = {}
        # chunks dropped at open: position -> (why, lost messages per connection id)
        self.refused: dict[int, tuple[str, dict[int, int]]] = {}
        # per connection: its index entries' times, and whether they are in time order
        self._times: dict[int, tuple[np.ndarray, bool]] = {}
        # where the bag's index (the last of its records) ends
        self._index_end: int | None = None
        # the chunk whose head (and the index records after it) open() reads last
        self._chunk_at: int | None = None
        # the warning of a bag indexed from its chunks (formats.bag_reindex), and of chunks
        # whose index entries fall short of their chunk info (_check_index)
        self._reindexed: str | None = None
        self._gaps: list[str] = []

    def read_chunk(self) -> Chunk:
        """The chunk record header at the file position (as rosbags reads it), remembering its
        compression and declared size; an unknown compression is not an error here (the chunk
        is refused after the index is read)."""
        assert self.bio
        pos = self._chunk_at = self.bio.tell()
        header = Header.read(self.bio, RecordType.CHUNK)
        compression = header.get_string("compression")
        size = header.get_uint32("size") if "size" in header else 0
        datasize = read_uint32(self.bio)
        datapos = self.bio.tell()
        self.bio.seek(datasize, os.SEEK_CUR)
        self.chunk_meta[pos] = (compression, size)
        return Chunk(datasize, datapos, _no_decompressor)

    @property
    def name(self) -> str:
        """The bag's file name."""
        return self._file.name

    def read_chunk_info(self) -> Any:
        """A chunk info record of the index (as rosbags reads it), remembering where it ends:
        the last one ends the bag."""
        assert self.bio
        info = super().read_chunk_info()
        self._index_end = self.bio.tell()
        return info

    def open_warnings(self) -> list[str]:
        """What opening the bag found: its index rebuilt from its chunks
        (:mod:`formats.bag_reindex`); the file going on after the index, its last record
        (another bag appended to it, garbage: those bytes are not read)."""
        from aion_cli.formats.clock_steps import bag_step_warning
        from aion_cli.formats.log_format import trailing_warning

        path = self._file
        size = path.stat().st_size
        found = [*self._gaps] if self._reindexed is None else [self._reindexed]
        if self._index_end is not None and self._index_end < size:
            found.append(trailing_warning(path, self._index_end, size))
        # the clock stepped back while recording: between chunks or inside one
        step = bag_step_warning(path.name, self.chunk_infos, self.indexes)
        return [*found, step] if step is not None else found

    def open(self) -> None:
        """Open the bag and read its index (rosbags), then drop the chunks that declare more
        than the chunk cap or use an unknown compression."""
        try:
            super().open()
        except (AssertionError, struct.error, ReaderError) as exc:
            if self._chunk_at is None:  # before the chunks: the header, the index
                self._reindex(exc)
                return
            # rosbags reads each chunk's head and the index records after it (asserting
            # their size, with no message): name the chunk, and read what the chunks hold
            reason = str(exc) or "an index record of the wrong size"
            self._reindex(
                exc,
                f"the chunk at byte {self._chunk_at} or the index records after it do not "
                f"parse: {reason}; the chunk's length may be damaged",
            )
            return
        self._check_index()
        self._refuse()
        self._check_entry_times()

    def _check_index(self) -> None:
        """Warn of chunks whose messages the index lists fewer of than their chunk info
        counts (a damaged record length makes rosbags read another place as the chunk's
        index records, without an error): those messages cannot be found, and are not read."""
        listed: Counter[tuple[int, int]] = Counter()
        for cid, entries in self.indexes.items():
            for pos, n in Counter(e.chunk_pos for e in entries).items():
                listed[pos, cid] = n
        for info in self.chunk_infos:
            missing = sum(
                max(n - listed[info.pos, cid], 0) for cid, n in info.connection_counts.items()
            )
            if missing:
                total = sum(info.connection_counts.values())
                self._gaps.append(unindexed_text(self._file.name, info.pos, total, missing))

    def _check_entry_times(self) -> None:
        """Repair index entries whose time lies outside their chunk info's range while most of
        the chunk's entries lie inside it: a damaged entry (a flipped byte of an IndexData
        record put a 2015 message in 1981, and the bag's span with it). The message record
        in the chunk keeps its own time, which is used instead, with a warning; rosbags
        stops the read at such an entry. A chunk whose entries mostly lie outside its info
        keeps them (the info is the damaged one) and so does a chunk that cannot be read."""
        from aion_cli.engine.time_text import iso_utc

        infos = {info.pos: info for info in self.chunk_infos}
        outside: dict[int, list[tuple[int, int]]] = {}  # chunk -> (connection, entry index)
        listed: Counter[int] = Counter()
        for cid, entries in self.indexes.items():
            for k, e in enumerate(entries):
                listed[e.chunk_pos] += 1
                info = infos.get(e.chunk_pos)
                if info is not None and not info.start_time <= e.time <= info.end_time:
                    outside.setdefault(e.chunk_pos, []).append((cid, k))
        changed: set[int] = set()
        for pos, bad in sorted(outside.items()):
            if 2 * len(bad) >= listed[pos]:
                continue
            try:
                buf = io.BytesIO(self._chunk_bytes(pos))
                times = [_record_time(buf, self.indexes[cid][k].offset) for cid, k in bad]
            except (caps.ChunkError, *_PARSE_ERRORS):
                continue  # the read skips the chunk, with its own warning
            wrong = [(ck, t) for ck, t in zip(bad, times, strict=True)
                     if t != self.indexes[ck[0]][ck[1]].time]  # fmt: skip
            if not wrong:
                continue  # the records agree with the index: the chunk info is off
            bad, times = [ck for ck, _ in wrong], [t for _, t in wrong]
            cid, k = bad[0]
            self._gaps.append(
                f"{self._file.name}: its index gives {len(bad):,} message"
                f"{'' if len(bad) == 1 else 's'} of the chunk at byte {pos} a time outside the "
                f"chunk's (first: {iso_utc(self.indexes[cid][k].time)}; a damaged index entry): "
                f"the message's own time is used ({iso_utc(times[0])})"
            )
            for (cid, k), t in zip(bad, times, strict=True):
                self.indexes[cid][k] = self.indexes[cid][k]._replace(time=t)
                changed.add(cid)
        for cid in changed:  # in time order again, as rosbags sorts them (stable)
            self.indexes[cid].sort(key=_time_of)

    def _refuse(self) -> None:
        """Drop the chunks that declare more than the chunk cap or use an unknown compression
        from the index, with their message counts (``refused``)."""
        limit = self.limits.max_chunk_bytes
        for info in self.chunk_infos:
            compression, size = self.chunk_meta.get(info.pos, ("none", 0))
            why = None
            if compression not in ("none", "bz2", "lz4"):
                why = str(caps.UnknownCompressionError(f"unknown compression {compression[:40]!r}"))
            elif size > limit:
                why = str(caps.chunk_over_limit(size, limit))
            elif compression == "none" and self.chunks[info.pos].datasize > limit:
                why = str(caps.chunk_over_limit(self.chunks[info.pos].datasize, limit))
            if why is not None:
                self.refused[info.pos] = (why, dict(info.connection_counts))
        if self.refused:
            self.indexes = {
                cid: [e for e in entries if e.chunk_pos not in self.refused]
                for cid, entries in self.indexes.items()
            }
            self.connections = [
                conn._replace(msgcount=len(self.indexes.get(conn.id, ())))
                for conn in self.connections
            ]

    def _reindex(self, exc: Exception, why: str | None = None) -> None:
        """Index the bag from its chunks (:mod:`formats.bag_reindex`) when its own index
        cannot be read (``exc``: why rosbags could not; ``why``: that said for the user);
        re-raise ``exc`` for a file that is no bag at all (another magic, an encrypted bag),
        a ReaderError saying ``why`` when no message of its chunks can be read."""
        from aion_cli.formats.bag_reindex import reindex

        reason = plain_reason(exc)
        with self._file.open("rb") as f:
            if f.read(len(_MAGIC)) != _MAGIC or "encryption" in reason:
                raise exc
        why = why or _cut_before_index(self._file) or (
            "it is not indexed (a recording that was not closed)"
            if "not indexed" in reason
            else f"its index cannot be read ({reason})"
        )
        self.bio = self._file.open("rb")  # rosbags closed it
        self.connections, self.indexes, self.chunk_infos, self.chunks = [], {}, [], {}
        self.chunk_meta = {}
        try:
            self._reindexed = reindex(self, why)
        except (ReaderError, struct.error) as again:
            self.close()
            raise ReaderError(str(again)) from exc
        self._refuse()

    def suspend(self) -> None:
        """Close the file and drop the cached chunk; the index stays (see :meth:`resume`)."""
        self.current_chunk = (-1, io.BytesIO())
        if self.bio is not None:
            bio, self.bio = self.bio, None
            bio.close()

    def resume(self) -> None:
        """Reopen the file after :meth:`suspend`."""
        if self.bio is None:
            self.bio = self.path.open("rb")

    def close(self) -> None:
        """Close the bag (suspended or not: a suspended one needs no file to be reopened)."""
        if self.bio is None:
            self.bio = io.BytesIO()  # what rosbags' close closes
        super().close()

    def iter_messages(
        self,
        connections: Collection[Any],
        bad_chunk: BadChunk,
        oversized: Oversized,
        between: tuple[int, int] | None = None,
    ) -> Iterator[tuple[Any, int, bytes]]:
        """``(connection, log time, data)`` of the messages on ``connections`` in log-time
        order (the index merged as rosbags merges it: ties keep connection order). A chunk
        that cannot be decompressed or parsed is skipped: ``bad_chunk`` hears of it once, with
        the messages of it not yet read (on every connection); messages over the message cap
        go to ``oversized``.
        ``between``: only the messages the index puts in ``[lo, hi)`` (their chunks only)."""
        assert self.bio is not None
        connmap = {c.id: c for c in self.connections}
        wanted = [c.id for c in connections]
        infos = {info.pos: info for info in self.chunk_infos}
        read: Counter[tuple[int, int]] = Counter()
        bad: set[int] = set()
        pos, buf = -1, io.BytesIO()
        limit = self.limits.max_message_bytes

        def lost(at: int) -> dict[int, int]:
            # every connection of the chunk, not only those this pass reads: the line is
            # the same whichever pass meets the chunk first (a build reads TF, then people)
            counts = infos[at].connection_counts if at in infos else {}
            return {c: n - read[at, c] for c, n in counts.items() if n > read[at, c]}

        merged = heapq.merge(
            *[[(e, cid) for e in self._entries(cid, between)] for cid in wanted], key=_time
        )
        for entry, cid in merged:
            if entry.chunk_pos in bad:
                continue
            try:
                if entry.chunk_pos != pos:
                    pos, buf = entry.chunk_pos, io.BytesIO(self._chunk_bytes(entry.chunk_pos))
                size = _message_at(buf, entry.offset)
                if size > limit:
                    oversized(connmap[cid], entry.time, size)
                    buf.seek(size, os.SEEK_CUR)
                    read[entry.chunk_pos, cid] += 1
                    continue
                data = read_bytes(buf, size)
            except caps.ChunkError as exc:
                bad.add(entry.chunk_pos)
                bad_chunk(entry.chunk_pos, str(exc), lost(entry.chunk_pos))
                pos, buf = -1, io.BytesIO()
                continue
            except _PARSE_ERRORS as exc:
                bad.add(entry.chunk_pos)
                why = f"its records do not parse ({exc})"
                bad_chunk(entry.chunk_pos, why, lost(entry.chunk_pos))
                pos, buf = -1, io.BytesIO()
                continue
            read[entry.chunk_pos, cid] += 1
            yield connmap[cid], entry.time, data

    def _entries(self, cid: int, between: tuple[int, int] | None) -> Sequence[Any]:
        """The index entries of connection ``cid`` (not copied), those in ``[lo, hi)`` with
        ``between`` (found by bisection where the entries are in time order, as rosbags
        sorts them)."""
        entries = self.indexes.get(cid, [])
        if between is None or not entries:
            return entries
        known = self._times.get(cid)
        if known is None:
            times = np.fromiter((e.time for e in entries), np.int64, len(entries))
            known = self._times[cid] = (times, not np.any(times[1:] < times[:-1]))
        times, in_order = known
        if not in_order:
            return [e for e, t in zip(entries, times.tolist(), strict=True)
                    if between[0] <= t < between[1]]
        lo, hi = np.searchsorted(times, between, "left").tolist()
        return entries[lo:hi]

    def _chunk_bytes(self, pos: int) -> bytes:
        """The decompressed records of the chunk at ``pos``, bounded by the chunk cap."""
        assert self.bio is not None
        chunk = self.chunks[pos]
        compression, size = self.chunk_meta[pos]
        self.bio.seek(chunk.datapos)
        raw = self.bio.read(chunk.datasize)
        if len(raw) < chunk.datasize:
            raise caps.ChunkError("the file ends inside its data")
        # rosbags's lz4 is the frame format; "none" is stored as it is
        return caps.decompress(raw, compression, size, self.limits.max_chunk_bytes)


_MAGIC = b"#ROSBAG V2.0\n"


def plain_reason(exc: Exception) -> str:
    """An exception's text with the tuples rosbags wraps inner reasons in unwrapped:
    ``Bag index looks damaged: ('Header could not be read from file.',)`` reads
    ``Bag index looks damaged: Header could not be read from file.``; on one line, its
    lines joined by ``; `` as an error's are (a YAML parser's error spans four, with a
    caret line under the text it quotes, which a warning printed as ``\\n`` escapes)."""
    text = re.sub(r"\('((?:[^'\\]|\\.)*)',\)", r"\1", str(exc))
    lines = [line.strip() for line in text.splitlines()]
    return "; ".join(line for line in lines if line.strip("^ "))


def _cut_before_index(path: Path) -> str | None:
    """Why a bag whose index cannot be read cannot be: the file ends before the index its
    header points at (a copy or a recording cut short); None when it does not."""
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(4096 + 13)  # the magic and the bag header record, padded to 4 KiB
    at = head.find(b"index_pos=")
    if at < 0 or len(head) < at + 18:
        return None
    (index_pos,) = struct.unpack_from("<Q", head, at + 10)
    if index_pos < size:
        return None
    lost = index_pos - size
    if not lost:
        return f"the file ends at byte {size:,}, where its index should begin: it was cut short"
    return (
        f"the file ends at byte {size:,}, before its index at byte {index_pos:,}: it was cut "
        f"short, the last {lost:,} bytes of its data and all of its index missing"
    )


def _time(item: tuple[Any, int]) -> int:
    return int(item[0].time)


def _message_at(buf: io.BytesIO, offset: int) -> int:
    """The data size of the message data record at ``offset`` of a chunk's records
    (connection records before it are stepped over, as rosbags does); the buffer is left at
    the start of the data."""
    _message_header(buf, offset)
    return read_uint32(buf)


def _record_time(buf: io.BytesIO, offset: int) -> int:
    """The log time the message data record at ``offset`` of a chunk's records keeps."""
    return int(_message_header(buf, offset).get_time("time"))


def _message_header(buf: io.BytesIO, offset: int) -> Header:
    """The header of the message data record at ``offset`` (connection records before it
    stepped over); the buffer is left at its data length."""
    buf.seek(offset)
    while True:
        header = Header.read(buf)
        op = header.get_uint8("op")
        if op != RecordType.CONNECTION:
            break
        buf.seek(read_uint32(buf), os.SEEK_CUR)
    if op != RecordType.MSGDATA:
        raise ReaderError("expected message data")
    return header


def _time_of(entry: Any) -> int:
    return int(entry.time)


def _no_decompressor(data: bytes) -> bytes:
    raise caps.ChunkError("chunks are decompressed by BagReader._chunk_bytes")


def unindexed_text(name: str, pos: int, total: int, missing: int) -> str:
    """The warning of a chunk at byte ``pos`` whose index lists ``missing`` fewer of its
    ``total`` messages than its chunk info counts (:meth:`BagReader._check_index`)."""
    from aion_cli.number_text import counted

    return (
        f"{name}: its index lists {total - missing:,} of the {counted(total, 'message')} its "
        f"chunk info gives the chunk at byte {pos} (a damaged record length?): "
        f"{counted(missing, 'message')} cannot be found and {'is' if missing == 1 else 'are'} "
        "not read"
    )
