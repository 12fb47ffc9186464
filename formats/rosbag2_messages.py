"""The messages of rosbag2 storage files (rosbags' sqlite3 / mcap storage plugins), matched to
a source's topics by topic and type and merged in log-time order.

:func:`_storage_messages` is what both rosbag2 sources read through: the folder source of
:mod:`formats.rosbags_source` and the in-memory reindexed sqlite3 source of
:mod:`formats.rosbag2_reindex`; :func:`_wanted_types` says which (topic, type) pairs a read
wants and :func:`_storage_topic` how a storage file keeps a topic. They are apart from
:mod:`formats.rosbags_source` because the matching, the zstd payloads and the per-message
size cap are one job both sources share, independent of how a source was opened.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from operator import attrgetter
from typing import TYPE_CHECKING, Any

from aion_cli.errors import LogFormatError
from aion_cli.formats.log_source import _ZSTD_MAGIC, _Topic, _unzstd
from aion_cli.formats.raw import Encoding, RawMessage, normalize_msgtype

if TYPE_CHECKING:
    from aion_cli.formats.rosbag2_reindex import (
        _ReindexedSqliteSource,  # annotations only: no cycle
    )
    from aion_cli.formats.rosbags_source import _RosbagsSource


def _storage_topic(conn: Any, topics: dict[tuple[str, str], _Topic]) -> _Topic:
    """A topic as a storage file keeps it (its type and definition), for a topic whose type
    metadata.yaml names otherwise; its serialization as metadata.yaml gives it (CDR else)."""
    named = next((t for (topic, _), t in topics.items() if topic == conn.topic), None)
    definition = conn.msgdef.data if conn.msgdef is not None else ""
    idl = conn.msgdef is not None and conn.msgdef.format.name == "IDL"
    encoding: Encoding = named.encoding if named is not None else "cdr"
    return _Topic(conn.topic, normalize_msgtype(conn.msgtype), encoding, definition or "", idl)


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
    between: tuple[int, int] | None = None,
) -> Iterator[RawMessage]:
    """Messages of rosbag2 storage readers (rosbags' sqlite3 / mcap storage plugins), merged in
    log-time order, on the ``wanted`` (topic, normalised type) pairs (``between``: only those
    logged in ``[lo, hi)``, which the storage readers select themselves).

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
            streams.append(_one_storage(source, storage, conns, wanted, unzstd, between))
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
    between: tuple[int, int] | None = None,
) -> Iterator[RawMessage]:
    from aion_cli.engine.time_text import iso_utc
    from aion_cli.formats.limits import OverLimitError

    meta = {conn.id: wanted[conn.topic, normalize_msgtype(conn.msgtype)] for conn in conns}
    cap = source._limits.max_message_bytes
    start, stop = between if between is not None else (None, None)
    for conn, t_ns, data in storage.messages(conns, start, stop):
        topic, msgtype, encoding = meta[conn.id]
        if unzstd or (unzstd is None and data[:4] == _ZSTD_MAGIC):
            try:
                data = _unzstd(data, cap)
            except OverLimitError as exc:
                warning = (
                    f"{source.path.name}: a message on {topic} at {iso_utc(t_ns)} skipped: {exc}"
                )
                if warning not in source.warnings:
                    source.warnings.append(warning)
                continue
        elif type(data) is not bytes:
            data = bytes(data)
        if len(data) > cap:
            from aion_cli.formats.limits import message_over_limit

            warning = (
                f"{source.path.name}: a message on {topic} at {iso_utc(t_ns)} skipped: "
                f"{message_over_limit(len(data), cap)}"
            )
            if warning not in source.warnings:
                source.warnings.append(warning)
            continue
        yield RawMessage(topic, msgtype, t_ns, data, encoding)
