"""What one opened log is to :class:`formats.logs.LogSet`: the :class:`_Source` interface
every container reader implements (its :class:`LogFile`, its topics as :class:`_Topic`, its
messages in log-time order, its recorded windows, its warnings), and what the readers share.

The readers live one per container: :mod:`formats.mcap_source` (MCAP files and rosbag2 mcap
storage), :mod:`formats.rosbags_source` (ROS 1 bags and rosbag2 folders through rosbags) and
:mod:`formats.rosbag2_reindex` (rosbag2 storage files without metadata.yaml). Here too:
:class:`_Unpacked`, a source read from decompressed temporary copies of zstd-compressed files,
and :func:`_unzstd`, the bounded decompression of one zstd-compressed message payload (rosbag2
``compression_mode: message``), which the MCAP and the rosbag2 storage readers both need.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Self, SupportsIndex

from aion_cli.formats.raw import Encoding, RawMessage, UnreadHint

if TYPE_CHECKING:
    from aion_cli.formats.recorded import Windows
    from aion_cli.formats.stream_times import StreamTimes


_MESSAGE_ENCODINGS: dict[str, Encoding] = {"cdr": "cdr", "ros1": "ros1"}
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"


@dataclass(frozen=True)
class LogFile:
    """One opened file: container format (``mcap-ros2``, ``mcap-ros1``, ``mcap`` for an MCAP
    with neither a ROS profile nor a ROS topic, ``bag``, ``rosbag2-sqlite3``,
    ``rosbag2-mcap``), size on disk, time range and message count."""

    path: Path
    format: str
    size_bytes: int
    start_ns: int
    end_ns: int
    message_count: int
    compression: tuple[str, ...] = ()
    """How its data is compressed, from its index or summary (no data decompressed): its
    chunks' compressions (``none``, ``bz2``, ``lz4``, ``zstd``; several when they differ),
    and a rosbag2 bag's own ``zstd (file)`` / ``zstd (message)``; empty when unknown."""


@dataclass
class _Topic:
    """What a source knows about one of its topics."""

    topic: str
    msgtype: str
    encoding: Encoding
    definition: str
    idl: bool = False  # definition is ROS 2 IDL rather than .msg text
    count: int = 0
    keys: list[Any] = field(default_factory=list)  # channel ids or rosbags connections
    qos: str = ""  # rosbag2's offered_qos_profiles (YAML text) where the storage keeps it


@dataclass(frozen=True)
class OtherChannel:
    """Messages of a topic in an encoding no ROS reader decodes (an MCAP channel of JSON,
    protobuf, ...): listed by ``aion info``, never read."""

    topic: str
    schema: str  # the schema's name ("" without a schema)
    encoding: str  # the channel's message encoding, as the file names it
    count: int


class _Source:
    """One log file or rosbag2 folder behind :class:`LogSet`."""

    file: LogFile
    topics: dict[tuple[str, str], _Topic]  # by (topic, msgtype)
    warnings: list[str]
    #: topics the file holds but no ROS reader can decode (other encodings), and why (none,
    #: read-only, unless a reader sets its own)
    unreadable_topics: Mapping[str, str] = MappingProxyType({})
    #: those topics' channels with their message counts
    other_channels: tuple[OtherChannel, ...] = ()

    def messages(
        self,
        topics: set[str] | None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        """This source's messages on ``topics`` (all when None), in log-time order.
        ``between``: only messages with log times in ``[lo, hi)`` are wanted, a hint a reader
        may use to skip whole chunks (callers still filter: messages outside may come).
        ``unread``: messages the caller drops unread, which a reader may yield with
        :data:`formats.raw.UNREAD` as their data (a hint too: they may come read)."""
        raise NotImplementedError

    def recorded_windows(self, window_ns: int) -> Windows:
        """Sorted unique windows ``floor(t / window_ns)`` (``window_ns`` already checked) that
        hold at least one message of this source, any topic, from its indexes where it has
        them."""
        raise NotImplementedError

    def skips_by_time(self) -> bool:
        """Whether :meth:`messages` with ``between`` reads only the part of the source near
        that time (the default: no, it reads from the start)."""
        return False

    def index_times(self, topics: set[str]) -> StreamTimes | None:
        """The log times :meth:`messages` would yield on ``topics``, in its order, read from
        the container's index without the messages (:mod:`formats.stream_times`); None when
        the index cannot say exactly that (the default: read the messages)."""
        return None

    def vouch(self, chunks: frozenset[int]) -> None:
        """Log times of :meth:`index_times` are used: a chunk of ``chunks`` that later cannot
        be read raises :class:`~aion_cli.errors.StaleIndexError` (the default: nothing to
        vouch for)."""

    def close(self) -> None:
        """Release the file handles."""


class _Unpacked(_Source):
    """A source read from decompressed temporary copies of zstd-compressed files: shown as the
    compressed file (``path``, its size on disk; the rosbag2 storage format for an mcap
    storage file), and removing the copies when closed."""

    def __init__(self, inner: _Source, temps: list[Any], path: Path | None = None) -> None:
        self.inner = inner
        self.topics = inner.topics
        if path is not None:  # warnings named the copy, removed by the time the user reads them
            inner.warnings = _ShownWarnings(inner.warnings, path, inner.file.path)
        self.warnings = inner.warnings
        self.unreadable_topics = inner.unreadable_topics
        self.other_channels = inner.other_channels
        self.file_count = getattr(inner, "file_count", 1)
        self._temps = temps
        f = inner.file
        if path is not None:
            fmt = f.format
            if fmt.startswith("mcap") and ".mcap" in path.name:
                fmt = "rosbag2-mcap"  # *.mcap.zstd: rosbag2's whole-file compression
            inner_chunks = tuple(c for c in f.compression if c not in ("none", "zstd (file)"))
            f = replace(f, path=path, format=fmt, size_bytes=path.stat().st_size,
                        compression=("zstd (file)", *inner_chunks))  # fmt: skip
        self.file = f

    def owns(self, source: _Source) -> None:
        """Close ``source`` too when this one is closed (what keeps the copies alive)."""
        self._temps.append(_Closing(source))

    def messages(
        self,
        topics: set[str] | None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        return self.inner.messages(topics, between, unread)

    def recorded_windows(self, window_ns: int) -> Windows:
        return self.inner.recorded_windows(window_ns)

    def skips_by_time(self) -> bool:
        return self.inner.skips_by_time()

    def index_times(self, topics: set[str]) -> StreamTimes | None:
        return self.inner.index_times(topics)

    def vouch(self, chunks: frozenset[int]) -> None:
        self.inner.vouch(chunks)

    def close(self) -> None:
        try:
            self.inner.close()
        finally:
            for tmp in self._temps:
                tmp.cleanup()


class _ShownWarnings(list[str]):
    """The warnings of a source read from ``inner``, the decompressed temporary copy of
    ``original``: each, those there already and those added later, naming ``original``
    (:func:`formats.rosbag2_storage.shown_text`), not the copy."""

    def __init__(self, lines: Iterable[str], original: Path, inner: Path) -> None:
        self._original, self._inner = original, inner
        super().__init__(self._shown(w) for w in lines)

    def _shown(self, text: str) -> str:
        from aion_cli.formats.rosbag2_storage import shown_text

        return shown_text(text, self._original, self._inner)

    def __contains__(self, text: object) -> bool:
        return super().__contains__(self._shown(text) if isinstance(text, str) else text)

    def append(self, text: str, /) -> None:
        super().append(self._shown(text))

    def insert(self, index: SupportsIndex, text: str, /) -> None:
        super().insert(index, self._shown(text))

    def extend(self, lines: Iterable[str], /) -> None:
        super().extend(self._shown(w) for w in lines)

    def __iadd__(self, lines: Iterable[str]) -> Self:  # type: ignore[override,misc]
        self.extend(lines)
        return self


@dataclass
class _Closing:
    """A source to close with an :class:`_Unpacked` one (as if it were a temporary folder)."""

    source: _Source

    def cleanup(self) -> None:
        self.source.close()


def _unzstd(data: bytes | memoryview, cap: int) -> bytes:
    """One zstd-compressed message payload (with or without the content size in its frame),
    decompressed to at most ``cap`` bytes (:class:`formats.limits.OverLimitError` beyond)."""
    from aion_cli.formats.limits import ChunkError, OverLimitError, decompress, message_over_limit

    try:
        return decompress(bytes(data), "zstd", 0, cap)
    except OverLimitError:
        raise message_over_limit(cap + 1, cap) from None
    except ChunkError as exc:
        raise ValueError(f"cannot decompress a zstd message payload ({exc})") from exc
