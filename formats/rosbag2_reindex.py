"""rosbag2 storage files without a (usable) metadata.yaml, indexed in memory from the files
themselves as ``ros2 bag reindex`` would: a folder of them, one ``.db3`` given alone, a folder
whose metadata.yaml rosbags refuses, and zstd-compressed storage files (through decompressed
temporary copies).

:func:`_reindexed_sources` opens them (the sqlite3 files as one
:class:`_ReindexedSqliteSource`, each mcap file with the MCAP reader of
:mod:`formats.mcap_source`, which recovers files without a summary); :func:`reindex` returns
the metadata ``ros2 bag reindex`` would write for them.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from operator import attrgetter
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.errors import LogFormatError
from aion_cli.formats import recorded
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_source import _MESSAGE_ENCODINGS, LogFile, _Source, _Topic, _Unpacked
from aion_cli.formats.mcap_source import _open_mcap
from aion_cli.formats.raw import RawMessage, UnreadHint, normalize_msgtype
from aion_cli.formats.rosbag2_messages import _storage_messages, _wanted_types
from aion_cli.formats.sqlite_salvage import (
    DamagedStorageError,
    cut_short,
    salvage_damaged,
    salvage_to_temp,
)

if TYPE_CHECKING:
    from aion_cli.formats.recorded import Windows
    from aion_cli.formats.stream_times import StreamTimes


class _ReindexedSqliteSource(_Source):
    """rosbag2 sqlite3 storage files without metadata.yaml, indexed in memory from the files
    themselves, as ``ros2 bag reindex`` would: topics, types, serialization, offered QoS and
    message counts from each file's ``topics`` table and SQL counts over ``messages`` (no
    payload is read), the time range from the indexed ``timestamp`` column, the message
    definitions from ``message_definitions`` where the file has them. The files' messages are
    merged in log-time order; zstd-compressed payloads (a bag recorded with message
    compression) are recognised by their magic bytes.
    """

    def __init__(
        self,
        path: Path,
        files: list[Path],
        originals: list[Path],
        limits: ReadLimits | None = None,
    ) -> None:
        from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

        self.path = path
        self.warnings = []
        self._limits = limits if limits is not None else ReadLimits.from_env()
        self.file_count = len(files)
        self._storages: list[Any] = []
        for plain, original in zip(files, originals, strict=True):
            storage = Sqlite3Reader(plain)
            try:
                storage.open()
            except Exception as exc:  # rosbags ReaderError, apsw errors
                self.close()
                raise DamagedStorageError(
                    f"{original}: not a readable rosbag2 sqlite3 storage file ({exc})",
                    hint="the storage file may be truncated or corrupt",
                    file=original,
                    reason=str(exc),
                ) from exc
            self._storages.append(storage)
        self.topics = {}
        # per file: name, first and last message time, message count (what reindex writes)
        self.per_file: list[tuple[str, int, int, int]] = []
        for storage, original in zip(self._storages, originals, strict=True):
            qos = _sqlite_qos(storage)
            count = 0
            for conn in storage.connections:
                fmt = getattr(conn.ext, "serialization_format", "cdr")
                if fmt not in _MESSAGE_ENCODINGS:
                    self.warnings.append(
                        f"{original.name}: topic {conn.topic} skipped: serialization {fmt!r} "
                        "is not CDR"
                    )
                    continue
                msgtype = normalize_msgtype(conn.msgtype)
                info = self.topics.get((conn.topic, msgtype))
                if info is None:
                    msgdef = conn.msgdef
                    known = msgdef is not None and msgdef.format.name != "NONE"
                    info = self.topics[conn.topic, msgtype] = _Topic(
                        conn.topic,
                        msgtype,
                        _MESSAGE_ENCODINGS[fmt],
                        (msgdef.data or "") if known else "",
                        known and msgdef.format.name == "IDL",
                    )
                info.count += conn.msgcount
                info.keys.append(conn)
                info.qos = info.qos or qos.get(conn.id, "")
                count += conn.msgcount
            meta = storage.metadata  # rosbags: end_time is exclusive
            first, last = (meta.start_time, meta.end_time - 1) if count else (0, 0)
            self.per_file.append((original.name, first, last, count))
        from aion_cli.formats.clock_steps import storage_step_warnings

        self.warnings += storage_step_warnings(self._storages, [o.name for o in originals])
        total = sum(t.count for t in self.topics.values())
        with_messages = [f for f in self.per_file if f[3] > 0]
        start = min((f[1] for f in with_messages), default=0)
        end = max((f[2] for f in with_messages), default=0)
        size = sum(o.stat().st_size for o in originals)
        # zstd payloads (a bag recorded with message compression): found by their magic
        # bytes; None: unknown (a damaged file the query fails on)
        self._zstd: bool | None = None
        with contextlib.suppress(Exception):  # apsw / sqlite3 errors on a damaged file
            self._zstd = any(
                storage.dbconn.execute(
                    "SELECT 1 FROM messages WHERE substr(data,1,4)=x'28b52ffd' LIMIT 1"
                ).fetchone()
                for storage in self._storages
            )
        self.file = LogFile(
            path, "rosbag2-sqlite3", size, start, end, total, _packing(originals, self._zstd)
        )

    def messages(
        self,
        topics: set[str] | None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        """See :meth:`_Source.messages` (``unread`` is not used: every message is read)."""
        wanted = _wanted_types(self.topics, topics)
        if not wanted:
            return iter(())
        return _storage_messages(self, self._storages, wanted, None, between)

    def index_times(self, topics: set[str]) -> StreamTimes | None:
        """The log times :meth:`messages` would yield on ``topics``, from each storage file's
        ``timestamp`` column (:func:`formats.stream_times.storage_times`); None when a
        payload is zstd-compressed (the stream decompresses those and skips one that expands
        over the cap)."""
        if self._zstd is not False:
            return None
        wanted = _wanted_types(self.topics, topics)
        from aion_cli.formats.stream_times import storage_times

        return storage_times(self._storages, wanted, self._limits.max_message_bytes)

    def skips_by_time(self) -> bool:
        """Its storage files select a time range themselves (sqlite3: a query)."""
        return True

    def recorded_windows(self, window_ns: int) -> Windows:
        """Per storage file, SQLite computes the windows over the indexed ``timestamp``
        column (no payload is read)."""
        try:
            return recorded.union(
                recorded.sqlite_windows(storage.dbconn, window_ns) for storage in self._storages
            )
        except Exception as exc:  # apsw errors on a damaged file
            raise LogFormatError(
                f"{self.path}: cannot read message times ({exc})",
                hint="the storage files may be corrupt or truncated",
            ) from exc

    def close(self) -> None:
        storages, self._storages = self._storages, []
        for storage in storages:
            if storage.dbconn is not None:
                storage.close()


def _sqlite_qos(storage: Any) -> dict[int, str]:
    """``topic id -> offered_qos_profiles`` text of a rosbag2 sqlite3 file (schema 2 and later
    keep it in the topics table), {} where it has none."""
    if storage.schema < 2:
        return {}
    rows = storage.dbconn.execute("SELECT id, offered_qos_profiles FROM topics")
    return {int(cid): str(text or "") for cid, text in rows}


def _reindexed_sources(files: list[Path], shown: Path, limits: ReadLimits) -> list[_Source]:
    """rosbag2 storage files without (a usable) metadata.yaml, indexed from the files
    themselves: the sqlite3 ones as one source (shown as ``shown``: the folder, or the one
    file), each mcap one as its own (read with the mcap reader, which recovers files without a
    summary); zstd-compressed files are read through decompressed temporary copies."""
    from aion_cli.formats import rosbag2_storage as storage

    temps: dict[Path, list[Any]] = {}
    opened: list[_Source] = []
    unpacked: list[tuple[Path, Path]] = []  # (compressed file, its decompressed copy)
    try:
        readable: list[tuple[Path, Path]] = []  # (the file on disk, the file to read)
        for f in files:
            if storage.is_zstd(f):
                tmp, inner = storage.decompress_to_temp(f)
                temps[f] = [tmp]
                readable.append((f, inner))
                unpacked.append((f, inner))
            else:
                readable.append((f, f))
        sqlite: list[tuple[Path, Path]] = []
        salvaged: list[str] = []  # the warnings of files cut short, read as far as they go
        for original, plain in readable:
            kind = storage.sniff(plain)
            if kind == "sqlite3":
                cut = cut_short(plain)
                if cut is not None:
                    tmp, plain, warning = salvage_to_temp(plain, cut, original)
                    temps.setdefault(original, []).append(tmp)
                    salvaged.append(warning)
                sqlite.append((original, plain))
            elif kind == "mcap":
                packed = _open_mcap(plain, fmt_name="rosbag2-mcap", limits=limits)
                packed.sniff_payloads()  # compression_mode: message, which only the yaml says
                mcap: _Source = packed
                if original in temps:
                    mcap = _Unpacked(mcap, temps[original], original)
                opened.append(mcap)
            else:
                from aion_cli.formats.log_format import other_log, other_log_hint
                from aion_cli.formats.log_magic import not_a_log

                other = other_log(original, "rosbag2")  # a ROS 1 bag given as rosbag2
                if other is not None:
                    raise LogFormatError(
                        f"{original} is not a rosbag2 storage file (neither SQLite nor MCAP)"
                        f": it is {other[0]}",
                        hint=other_log_hint(other[1]),
                    )
                raise not_a_log(
                    original, "a rosbag2 storage file", "the SQLite or MCAP magic bytes",
                    "pass the bag's .db3 / .mcap storage files, or its folder",
                )  # fmt: skip
        if sqlite and opened:
            raise LogFormatError(
                f"{shown} holds both sqlite3 and mcap storage files: not the files of one bag",
                hint="pass the storage files one by one",
            )
        if sqlite:
            originals = [o for o, _ in sqlite]
            db = _open_salvaging(shown, sqlite, limits, temps, salvaged)
            db.warnings.extend(salvaged)
            owned = [tmp for o in originals for tmp in temps.get(o, [])]
            opened.insert(0, _Unpacked(db, owned) if owned else db)
    except BaseException as exc:
        for source in opened:
            source.close()
        for held in temps.values():
            for tmp in held:
                tmp.cleanup()
        for original, plain in unpacked:
            storage.name_original(exc, original, plain)
        raise
    return opened


def _open_salvaging(
    shown: Path,
    sqlite: list[tuple[Path, Path]],
    limits: ReadLimits | None,
    temps: dict[Path, list[Any]],
    salvaged: list[str],
) -> _Source:
    """The sqlite3 files ``sqlite`` ((file on disk, file to read) pairs) as one source; a
    file SQLite refuses for damage inside is replaced by what it reads past the damage
    (:func:`formats.sqlite_salvage.salvage_damaged`, its warning into ``salvaged``, its
    temporary folder into ``temps``); one of which it reads no message is refused."""
    tried: set[Path] = set()
    while True:
        try:
            return _ReindexedSqliteSource(
                shown, [p for _, p in sqlite], [o for o, _ in sqlite], limits
            )
        except DamagedStorageError as exc:
            if exc.file in tried:
                raise
            tried.add(exc.file)
            k = next(i for i, (o, _) in enumerate(sqlite) if o == exc.file)
            tmp, plain, warning = salvage_damaged(sqlite[k][1], exc.file, exc.reason)
            temps.setdefault(exc.file, []).append(tmp)
            salvaged.append(warning)
            sqlite[k] = (exc.file, plain)


def _packing(originals: list[Path], payloads: bool | None) -> tuple[str, ...]:
    """What ``aion info`` says of the compression of sqlite3 storage files read without
    metadata.yaml, each once, in file order: ``zstd (file)`` for a file compressed whole,
    ``none`` for a plain one whose payloads are plain, then ``zstd (message)`` when payloads
    are compressed (``payloads``: None when unknown). A file-compressed recording killed
    before its last file was compressed leaves plain and compressed files side by side."""
    from aion_cli.formats.rosbag2_storage import is_zstd

    found = ["zstd (file)" if is_zstd(o) else "none" for o in originals]
    if payloads is not False:
        found = [c for c in found if c != "none"]
    if payloads:
        found.append("zstd (message)")
    return tuple(dict.fromkeys(found))


def reindex(path: Path | str) -> dict[str, Any]:
    """What ``ros2 bag reindex`` would write into ``metadata.yaml`` for the rosbag2 storage
    files at ``path`` (a folder of them, or one storage file; zstd-compressed or not), built
    from the files themselves: the ``rosbag2_bagfile_information`` mapping (storage,
    relative file paths, start and duration, counts per topic with type, serialization and
    offered QoS profiles, per-file figures, whole-file compression). Any metadata.yaml beside
    the files is ignored."""
    from aion_cli.formats import rosbag2_storage as storage

    target = Path(path)
    if not target.exists():
        raise LogFormatError(f"no such file or folder: {target}", hint="check the path")
    files = storage.storage_files(target) if target.is_dir() else [target]
    if not files:
        raise LogFormatError(
            f"{target} holds no rosbag2 storage files", hint="pass .db3 / .mcap storage files"
        )
    sources = _reindexed_sources(files, target, ReadLimits.from_env())
    try:
        return _bag_metadata(sources, files)
    finally:
        for source in sources:
            source.close()


def _bag_metadata(sources: list[_Source], files: list[Path]) -> dict[str, Any]:
    from aion_cli.formats import rosbag2_storage as storage

    per_file: list[tuple[str, int, int, int]] = []  # name, first, last, count
    topics: dict[tuple[str, str], _Topic] = {}
    kinds = set()
    for source in sources:
        inner = source.inner if isinstance(source, _Unpacked) else source
        if isinstance(inner, _ReindexedSqliteSource):
            per_file.extend(inner.per_file)
            kinds.add("sqlite3")
        else:
            f = source.file
            per_file.append((f.path.name, f.start_ns, f.end_ns, f.message_count))
            kinds.add("mcap")
        for key, t in source.topics.items():
            merged = topics.setdefault(key, _Topic(t.topic, t.msgtype, t.encoding, "", qos=t.qos))
            merged.count += t.count
            merged.qos = merged.qos or t.qos
    order = {p.name: k for k, p in enumerate(files)}
    per_file.sort(key=lambda item: order.get(item[0], len(order)))
    with_messages = [f for f in per_file if f[3] > 0]
    start = min((f[1] for f in with_messages), default=0)
    end = max((f[2] for f in with_messages), default=0)
    compressed = any(storage.is_zstd(f) for f in files)

    def span(first: int, last: int, count: int) -> dict[str, Any]:
        return {
            "starting_time": {"nanoseconds_since_epoch": first if count else 0},
            "duration": {"nanoseconds": last - first if count else 0},
        }

    return {
        "version": 9,
        "storage_identifier": "/".join(sorted(kinds)),
        "relative_file_paths": [f.name for f in files],
        **span(start, end, len(with_messages)),
        "message_count": sum(f[3] for f in per_file),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": t.topic,
                    "type": t.msgtype,
                    "serialization_format": t.encoding,
                    "offered_qos_profiles": t.qos,
                },
                "message_count": t.count,
            }
            for t in sorted(topics.values(), key=attrgetter("topic", "msgtype"))
        ],
        "compression_format": "zstd" if compressed else "",
        "compression_mode": "file" if compressed else "",
        "files": [
            {"path": name, **span(first, last, count), "message_count": count}
            for name, first, last, count in per_file
        ],
    }
