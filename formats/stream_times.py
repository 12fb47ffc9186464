"""The log times of a log's messages on some topics, in the order its stream yields them, read
from the container's indexes instead of from the messages.

Why: ``aion build`` needs the log time of every message it will use before its stream starts
(the time-sanity rules, the build's span, the ``--graph-period`` schedule:
:mod:`aion_cli.log_times`, :mod:`aion_cli.graph_feed`). Reading the messages for that costs
about as much as the stream itself (every chunk decompressed and CRC-checked), while MCAP
MessageIndex records, the ROS 1 bag index and the rosbag2 sqlite3 ``timestamp`` column hold
those times for a few bytes per message. The readers (``index_times`` of
:class:`formats.log_source._Source`) give a :class:`StreamTimes` only when the index says
exactly what their stream will yield, in the same order, and None otherwise (the build then
reads the messages, as before).

What an index cannot show is a chunk that fails its CRC or does not decompress: a reader
*vouches* for the chunks whose times came from their index alone (:attr:`StreamTimes.chunks`,
:meth:`formats.logs.LogSet.index_times`), and raises
:class:`~aion_cli.errors.StaleIndexError` if it later meets one it cannot read; the build
starts over then (``pipeline._Build.learn``).

Everything here is numpy over whole arrays (and the query of a rosbag2 sqlite3 file on its open
connection); no file is opened here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import chain
from typing import Any

import numpy as np
import numpy.typing as npt

Times = npt.NDArray[Any]
"""Log times as the container stores them: uint64 (MCAP) or int64 (ROS 1 bags, rosbag2)."""

_TOP = np.uint64(2**63)


@dataclass(frozen=True)
class StreamTimes:
    """Log times ``t`` of a source's (or a log set's) messages on ``topics``, in the order its
    ``messages(topics)`` yields them, each with the index of its topic in ``topics``
    (``code``). ``chunks``: the chunks (MCAP chunk offsets, bag chunk positions) whose times
    come from their index alone, which the reader vouches for once the times are used."""

    topics: tuple[str, ...]
    t: Times
    code: npt.NDArray[np.int32]
    chunks: frozenset[int] = field(default=frozenset())

    def __len__(self) -> int:
        return int(self.t.size)

    def of(self, topic: str) -> Times:
        """The log times of ``topic``'s messages, in stream order."""
        if topic not in self.topics:
            return self.t[:0]
        return self.t[self.code == self.topics.index(topic)]

    def sorted(self) -> bool:
        """Whether the times never decrease (exactly, uint64 and int64 alike)."""
        return bool(np.all(self.t[1:] >= self.t[:-1]))


def empty(topics: Sequence[str] = ()) -> StreamTimes:
    """No message."""
    return StreamTimes(tuple(topics), np.zeros(0, np.int64), np.zeros(0, np.int32))


def from_channels(
    t: Times, channels: npt.NDArray[Any], topic_of: Mapping[int, str], chunks: frozenset[int]
) -> StreamTimes:
    """:class:`StreamTimes` of messages given by channel or connection id (``channels``,
    non-negative ints, each a key of ``topic_of``). The ids are looked up in their sorted
    array, not a table as long as the largest: a ROS 1 bag's connection ids are uint32, and a
    damaged one (2^30) asked for a 4 GiB table."""
    topics = tuple(sorted(set(topic_of.values())))
    if not len(channels):
        return StreamTimes(topics, t, np.zeros(0, np.int32), chunks)
    ids = np.sort(np.fromiter(topic_of.keys(), np.int64, len(topic_of)))
    codes = np.array([topics.index(topic_of[int(i)]) for i in ids], np.int32)
    at = np.minimum(np.searchsorted(ids, channels), ids.size - 1)
    code = np.where(ids[at] == channels, codes[at], np.int32(-1)).astype(np.int32)
    return StreamTimes(topics, t, code, chunks)


def merged(parts: Sequence[StreamTimes]) -> StreamTimes | None:
    """The times of several sources as :func:`formats.log_merge.merge_by_start` yields their
    messages: merged by log time, ties in source order. That merge is a stable sort by
    ``(time, source)`` exactly when every source's own stream is in time order (it starts a
    source only once the merge reaches the source's first time), so a part that is not in
    order gives None: only its messages can say how the merge interleaves it."""
    if len(parts) == 1:
        return parts[0]
    if not all(p.sorted() for p in parts):
        return None
    negative = any(p.t.dtype != np.uint64 and bool((p.t < 0).any()) for p in parts)
    huge = any(p.t.dtype == np.uint64 and bool((p.t >= _TOP).any()) for p in parts)
    if negative and huge:
        return None  # no one dtype holds both (and no real log has either)
    topics = tuple(sorted({name for p in parts for name in p.topics}))
    codes = []
    for p in parts:
        remap = np.array([topics.index(name) for name in p.topics], np.int32)
        codes.append(remap[p.code] if len(p) else p.code)
    hi, lo = zip(*(_keys(p.t) for p in parts), strict=True)
    order = np.lexsort((np.concatenate(lo), np.concatenate(hi)))  # stable: ties keep sources
    dtype = np.int64 if negative else np.uint64
    t = np.concatenate([p.t.astype(dtype) for p in parts])
    return StreamTimes(topics, t[order], np.concatenate(codes)[order])


def _keys(t: Times) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.int64]]:
    """Two int keys that order uint64 and int64 times together as Python ints do: whether a
    time is at least 2**63 (only uint64 ones can be), then the rest as int64."""
    if t.dtype == np.uint64:
        high = t >= _TOP
        return high, np.where(high, t - _TOP, t).astype(np.int64)
    return np.zeros(t.size, bool), t.astype(np.int64)


def bag_index(
    indexes: Mapping[int, Sequence[tuple[int, ...]]], connections: Sequence[int]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """``(log times, connection ids, chunk positions)`` of the entries of a ROS 1 bag index as
    rosbags loads it at open (per connection, ``(time, chunk_pos, offset)`` sorted) in the
    order :meth:`formats.bag_reader.BagReader.iter_messages` merges them for ``connections``:
    by time, ties in the order of ``connections``. About 20 ns per entry, no chunk read."""
    lists = [indexes.get(cid, ()) for cid in connections]
    n = sum(len(entries) for entries in lists)
    flat = np.fromiter(
        chain.from_iterable(chain.from_iterable(lists)), np.int64, 3 * n
    ).reshape(n, 3)
    cids = np.repeat(np.array(connections, np.int64), [len(entries) for entries in lists])
    order = np.argsort(flat[:, 0], kind="stable")
    return flat[order, 0], cids[order], flat[order, 1]


def storage_times(
    storages: list[Any], wanted: Mapping[tuple[str, str], Any], max_bytes: int
) -> StreamTimes | None:
    """The log times of rosbag2 sqlite3 storage readers' (rosbags') messages of the ``wanted``
    (topic, normalised type) pairs, merged as the rosbag2 sources yield them, from each file's
    ``timestamp`` column (:func:`sqlite_times`); None for a storage that is no sqlite3 file,
    or a payload over ``max_bytes``."""
    from aion_cli.formats.raw import normalize_msgtype

    parts = []
    for storage in storages:
        conns = [
            c for c in storage.connections if (c.topic, normalize_msgtype(c.msgtype)) in wanted
        ]
        if not conns:
            continue
        db = getattr(storage, "dbconn", None)
        if db is None:
            return None
        t, ids, sizes = sqlite_times(db, [c.id for c in conns])
        if (sizes > max_bytes).any():
            return None
        parts.append(from_channels(t, ids, {c.id: c.topic for c in conns}, frozenset()))
    return merged(parts) if parts else empty()


def sqlite_times(
    connection: Any, topic_ids: Sequence[int]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """``(log times, topic ids, payload sizes)`` of the messages on ``topic_ids`` of a rosbag2
    sqlite3 storage file (``connection``: an open sqlite3 or apsw connection), in the order
    rosbags' sqlite3 reader yields them: the same query, with the payloads' lengths in place
    of the payloads (SQLite reads a blob's length from its record header)."""
    marks = ",".join("?" for _ in topic_ids)
    rows = connection.execute(
        "SELECT topics.id,messages.timestamp,length(messages.data) "
        "FROM messages JOIN topics ON messages.topic_id=topics.id "
        f"WHERE topics.id IN ({marks}) ORDER BY timestamp",
        tuple(topic_ids),
    )
    flat = np.fromiter(chain.from_iterable(rows), np.int64).reshape(-1, 3)
    return flat[:, 1], flat[:, 0], flat[:, 2]
