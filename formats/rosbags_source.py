"""ROS 1 bags and rosbag2 folders read with the rosbags readers, as one
:class:`formats.log_source._Source`: :class:`_RosbagsSource`.

ROS 1 bags go through :class:`formats.bag_reader.BagReader` (rosbags' reader with aion's size
caps), rosbag2 folders through rosbags' folder reader, their storage files matched to the
folder's topics by topic and type, not by QoS (:mod:`formats.rosbag2_messages`, which the in-memory
reindexed sqlite3 source of :mod:`formats.rosbag2_reindex` reads through too). Counts and time
ranges come from the storage files; :func:`formats.rosbag2_storage.metadata_warning` says where
metadata.yaml disagrees with them. A rosbag2 folder with uncompressed or file-compressed mcap
storage is read with aion's MCAP reader instead (:meth:`_RosbagsSource.mcap_storage` says
which files).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.errors import LogFormatError, StaleIndexError
from aion_cli.formats import clock_steps, recorded
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_source import (
    _MESSAGE_ENCODINGS,
    LogFile,
    _Source,
    _Topic,
)
from aion_cli.formats.raw import Encoding, RawMessage, UnreadHint, normalize_msgtype
from aion_cli.formats.rosbag2_messages import _storage_messages, _storage_topic, _wanted_types
from aion_cli.formats.rosbag2_storage import metadata_warning

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.recorded import Windows
    from aion_cli.formats.stream_times import StreamTimes


_NO: frozenset[int] = frozenset()


class _RosbagsSource(_Source):
    """A ROS 1 bag or a rosbag2 folder, read with the rosbags readers."""

    def __init__(self, path: Path, kind: str, limits: ReadLimits | None = None) -> None:
        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self._reader = _open_rosbags(path, kind, self._limits)
        reader = self._reader
        self._index_times: npt.NDArray[np.int64] | None = None
        # bag chunks whose log times a build took from the index (formats.stream_times):
        # one that cannot be read raises StaleIndexError
        self._vouched: frozenset[int] = frozenset()
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
            self.warnings.extend(reader.open_warnings())
            reader.suspend()  # no file handle held between reads
        else:
            storages = getattr(reader.storage, "storages", [])
            mcap = any("mcap" in type(x).__name__.lower() for x in storages)
            fmt_name = "rosbag2-mcap" if mcap else "rosbag2-sqlite3"
            # its storage files, as `ros2 bag info` and an mcap-storage bag's size count:
            # not metadata.yaml, nor other files someone left in the folder
            size = sum(Path(x.path).stat().st_size for x in storages)
            start, end = self._count_storages(storages, reader)
            if storages:
                counts = {key: t.count for key, t in self.topics.items()}
                warning = metadata_warning(path, start, end - 1, sum(counts.values()), counts)
                if warning:
                    self.warnings.append(warning)
            self.warnings += clock_steps.storage_step_warnings(storages)  # sqlite3 storage
        total = sum(t.count for t in self.topics.values())
        start = start if total else 0
        end = max(end - 1, start) if total else 0  # rosbags' end is exclusive
        self.file = LogFile(path, fmt_name, size, start, end, total, self._compression(kind))

    def _compression(self, kind: str) -> tuple[str, ...]:
        """A bag's chunk compressions (``none``, ``bz2``, ``lz4``), from the chunk headers
        read at open (``none`` for a bag without chunks, which holds nothing compressed, as an
        MCAP file without chunks); a rosbag2 bag's metadata.yaml ``compression_format`` and
        ``compression_mode`` (``zstd (file)``), or ``none``."""
        reader = self._reader
        if kind == "bag":
            return tuple(sorted({c for c, _ in reader.chunk_meta.values()})) or ("none",)
        fmt = reader.compression_format
        mode = str(reader.compression_mode or "file").lower()
        return (f"{fmt} ({mode})",) if fmt else ("none",)

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
                key = (conn.topic, normalize_msgtype(conn.msgtype))
                counted[key] += conn.msgcount
                if key not in self.topics:  # metadata.yaml names another type (or none)
                    self.topics[key] = _storage_topic(conn, self.topics)
        stored = {topic for topic, _ in counted}
        for key, info in list(self.topics.items()):
            info.count = counted.get(key, 0)
            if key not in counted and key[0] in stored:  # the files keep another type
                del self.topics[key]
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

    def messages(
        self,
        topics: set[str] | None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        """See :meth:`_Source.messages` (``unread`` is not used: every message is read)."""
        if self.file.format != "bag":
            storages = getattr(self._reader.storage, "storages", None)
            if isinstance(storages, list):
                wanted = _wanted_types(self.topics, topics)
                if not wanted:
                    return iter(())
                unzstd = self._reader.compression_mode == "message"
                return _storage_messages(self, storages, wanted, unzstd, between)
        conns = [
            conn
            for info in self.topics.values()
            if topics is None or info.topic in topics
            for conn in info.keys
        ]
        if not conns:
            return iter(())
        return self._messages(conns, between)

    def skips_by_time(self) -> bool:
        """ROS 1 bags find the messages of a time range in their index, rosbag2 storage files
        with a query (sqlite3's timestamp column) or their chunk index (mcap)."""
        return True

    def _messages(
        self, conns: list[Any], between: tuple[int, int] | None = None
    ) -> Iterator[RawMessage]:
        """Through :class:`formats.bag_reader.BagReader` (ROS 1 bags): the file open while
        the iteration runs, chunks that cannot be read skipped with a warning."""
        meta = {
            conn.id: (info.topic, info.msgtype, info.encoding)
            for info in self.topics.values()
            for conn in info.keys
            if conn in conns
        }
        names = {conn.id: conn.topic for conn in self._reader.connections}
        reader = self._reader

        def bad_chunk(pos: int, why: str, lost: dict[int, int]) -> None:
            warning = self._chunk_skipped(pos, why, lost, names)
            if warning not in self.warnings:
                self.warnings.append(warning)
            if pos in self._vouched:
                raise StaleIndexError(
                    f"{self.path.name}: the chunk at byte {pos} cannot be read, but its log "
                    "times were taken from the bag's index",
                    hint="aion reads the log again in full",
                )

        def oversized(conn: Any, t_ns: int, size: int) -> None:
            from aion_cli.engine.time_text import iso_utc
            from aion_cli.formats import limits as caps

            warning = (
                f"{self.path.name}: a message on {conn.topic} at {iso_utc(t_ns)} skipped: "
                + str(caps.message_over_limit(size, self._limits.max_message_bytes))
            )
            if warning not in self.warnings:
                self.warnings.append(warning)

        try:
            reader.resume()
            for conn, t_ns, data in reader.iter_messages(conns, bad_chunk, oversized, between):
                topic, msgtype, encoding = meta[conn.id]
                yield RawMessage(topic, msgtype, t_ns, data, encoding)
        except (LogFormatError, StaleIndexError):
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

    def index_times(self, topics: set[str]) -> StreamTimes | None:
        """The log times :meth:`messages` would yield on ``topics``, without reading a
        message (:mod:`formats.stream_times`). ROS 1 bags: from the index rosbags loaded at
        open; None when a chunk holding those messages may hold one over the message cap (or
        declares no size). rosbag2 folders: per sqlite3 storage file, its ``timestamp``
        column in rosbags' own query; None for mcap storage read through rosbags, payloads
        compressed one by one, and a payload over the cap (the stream skips those)."""
        from aion_cli.formats import stream_times

        if self.file.format == "bag":
            conns = [c for i in self.topics.values() if i.topic in topics for c in i.keys]
            t, cids, chunks = stream_times.bag_index(self._reader.indexes, [c.id for c in conns])
            positions = frozenset(np.unique(chunks).tolist())
            if any(self._chunk_room(pos) > self._limits.max_message_bytes for pos in positions):
                return None
            return stream_times.from_channels(t, cids, {c.id: c.topic for c in conns}, positions)
        storages = getattr(self._reader.storage, "storages", None)
        if not isinstance(storages, list) or self._reader.compression_mode == "message":
            return None
        wanted = _wanted_types(self.topics, topics)
        return stream_times.storage_times(storages, wanted, self._limits.max_message_bytes)

    def _chunk_room(self, pos: int) -> int:
        """The most bytes the records of the bag chunk at ``pos`` may take."""
        compression, declared = self._reader.chunk_meta[pos]
        if compression == "none":
            return int(self._reader.chunks[pos].datasize)
        return int(declared) or 2**63

    def vouch(self, chunks: frozenset[int]) -> None:
        self._vouched = self._vouched | chunks

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


def _open_rosbags(path: Path, kind: str, limits: ReadLimits) -> Any:
    """An open rosbags Reader for ``path`` (ROS 1 bags: :class:`formats.bag_reader.BagReader`
    with ``limits``), with rosbags errors turned into LogFormatError."""
    if kind == "bag":
        from aion_cli.formats.bag_reader import BagReader
        from aion_cli.formats.log_format import other_log, other_log_hint
        from aion_cli.formats.log_magic import check_bag_magic

        other = other_log(path, "bag")
        if other is not None:  # a renamed MCAP, --log-format bag on a .db3 or a folder
            raise LogFormatError(
                f"{path}: not a readable ROS 1 bag (it is {other[0]})",
                hint=other_log_hint(other[1]),
            )
        check_bag_magic(path)  # a text file is not a damaged bag: no `rosbag reindex`
        reader: Any = BagReader(path, limits)
        what = "ROS 1 bag"
        hint = "the bag may be truncated or corrupt; try `rosbag reindex` on a copy"
    else:
        from rosbags.rosbag2 import Reader as Reader2

        from aion_cli.formats.rosbag2_storage import metadata_type_error

        reader = Reader2(path)
        what = "rosbag2 folder"
        hint = "check metadata.yaml and the storage files (.db3 / .mcap) next to it"
        if (wrong := metadata_type_error(path)) is not None:  # rosbags takes any value
            raise LogFormatError(f"{path}: not a readable {what} ({wrong})", hint=hint)
    try:
        reader.open()
    except Exception as exc:  # rosbags ReaderError and the errors of its storage plugins
        from aion_cli.formats.bag_reader import plain_reason
        from aion_cli.formats.rosbag2_storage import uncompressed_files_note

        # rosbags' "Unable to decompress Zstandard data" names no file: name the plain ones
        why = (kind != "bag" and uncompressed_files_note(path)) or plain_reason(exc)
        raise LogFormatError(f"{path}: not a readable {what} ({why})", hint=hint) from exc
    return reader
