"""Open robot logs of any supported container as one time-ordered stream of raw messages.

``open_logs(paths)`` accepts MCAP files (ROS 2 and ROS 1 profiles, also bare rosbag2 ``.mcap``
files), ROS 1 ``.bag`` files and rosbag2 folders (sqlite3 or mcap storage), guessing each file's
format from its path and first bytes. The :class:`LogSet` it returns lists topics with counts from
the files' indexes (no message is read for that), yields :class:`~formats.raw.RawMessage` records
merged over all files in log-time order, and decodes a message on request with the definitions the
log itself embeds.

MCAP files are read with the ``mcap`` library directly (rosbags refuses ROS 1-profile MCAP, and the
raw bytes are what the numpy adapters want): chunks that hold no requested topic are skipped
without decompressing them. A truncated or partly corrupt MCAP is read linearly up to the break,
and :attr:`LogSet.warnings` says where reading stopped; messages a file holds out of log-time
order come out in order. The storage files of rosbag2 folders with (uncompressed) mcap storage go
the same way; ROS 1 bags and sqlite3 or compressed rosbag2 folders are read with the rosbags
readers, a rosbag2 folder's storage files matched to its topics by topic and type (not by QoS).

rosbag2 storage files without ``metadata.yaml`` (a folder of them, one ``.db3`` given alone, or a
folder whose metadata.yaml is unusable) are indexed in memory from the files themselves, as
``ros2 bag reindex`` would (:func:`reindex` returns that metadata). Files compressed whole with
zstd (``*.db3.zstd``, ``*.mcap.zstd``: ``compression_mode: file``) given without their folder are
read through a decompressed temporary copy (:mod:`formats.rosbag2_storage`), removed on close.

:meth:`LogSet.recorded_windows` says which time windows the logs recorded anything in, from the
same indexes (:mod:`formats.recorded`), without reading message payloads where a container
indexes its messages; :meth:`LogSet.index_times` gives the log times :meth:`LogSet.messages`
will yield, in its order, from them (:mod:`formats.stream_times`), where they say exactly that
(these answers from the indexes are in :mod:`formats.log_times`).

This module is the public front: :func:`open_logs`, :class:`LogSet` and the time-ordered merge
of many files; :mod:`formats.log_paths` opens one path into its sources. The readers live one
module per container source: :mod:`formats.mcap_source` (with its linear read,
:mod:`formats.mcap_linear`), :mod:`formats.rosbags_source` (ROS 1 bags, rosbag2 folders),
:mod:`formats.rosbag2_reindex` (rosbag2 storage files without metadata.yaml,
:func:`~formats.rosbag2_reindex.reindex`), on the interface of :mod:`formats.log_source`;
format guessing is :mod:`formats.log_format`, decoding with the logs' own definitions
:mod:`formats.typestores`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from operator import attrgetter
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from aion_cli.errors import LogFormatError, MessageDecodeError, TopicNotFoundError
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_merge import merge_by_start
from aion_cli.formats.log_paths import open_sources
from aion_cli.formats.log_source import LogFile, OtherChannel, _Source
from aion_cli.formats.log_times import _RecordedTimes
from aion_cli.formats.raw import RawMessage, TopicInfo, UnreadHint, topic_spelling_hint
from aion_cli.formats.typestores import _store_with_definition

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

    from aion_cli.formats.log_overlaps import Overlap


# --- the merged set -------------------------------------------------------------------------


class LogSet(_RecordedTimes):
    """Several opened logs seen as one: topics, time range, merged message stream, decoding.

    Use as a context manager (or call :meth:`close`). Counts and the time range come from the
    files' indexes; :meth:`messages` reads only the requested topics and never decodes.
    """

    def __init__(self, sources: list[_Source], recordings: list[int] | None = None) -> None:
        self._sources = sources
        self.files: list[LogFile] = [s.file for s in sources]
        #: which recording each source belongs to: the storage files of one rosbag2 bag (a
        #: bag split by size or duration) are one recording, every other file its own
        self._recordings: list[int] = (
            list(range(len(sources))) if recordings is None else list(recordings)
        )
        if len(self._recordings) != len(sources):
            raise ValueError("one recording index per source is needed")
        merged: dict[tuple[str, str], TopicInfo] = {}
        self._definitions: dict[tuple[str, str, str], tuple[str, bool]] = {}
        for source in sources:
            for t in source.topics.values():
                key = (t.topic, t.msgtype)
                defkey = (t.topic, t.msgtype, t.encoding)
                if t.definition.strip() and defkey not in self._definitions:
                    self._definitions[defkey] = (t.definition, t.idl)
                prev = merged.get(key)
                src = str(source.file.path)
                if prev is None:
                    merged[key] = TopicInfo(
                        t.topic, t.msgtype, t.count, t.encoding, t.definition, src
                    )
                else:
                    merged[key] = TopicInfo(
                        t.topic,
                        t.msgtype,
                        prev.count + t.count,
                        prev.encoding,
                        prev.definition or t.definition,
                        f"{prev.source}, {src}",
                    )
        self.topics: list[TopicInfo] = sorted(merged.values(), key=attrgetter("topic"))
        with_messages = [f for f in self.files if f.message_count > 0]
        self.start_ns: int = min((f.start_ns for f in with_messages), default=0)
        self.end_ns: int = max((f.end_ns for f in with_messages), default=0)
        self._decoders: dict[tuple[str, str, str], Callable[[bytes], Any]] = {}
        self._stores: dict[str, Typestore] = {}
        #: the store of each (encoding, msgtype, definition, idl): topics of one type share it
        self._typestores: dict[tuple[str, str, str, bool], Typestore] = {}
        self._closed = False

    @property
    def warnings(self) -> list[str]:
        """Problems met so far (skipped topics, truncated files), one line each."""
        return [w for s in self._sources for w in s.warnings]

    @property
    def unreadable_topics(self) -> dict[str, str]:
        """Topics the files hold in encodings no ROS reader decodes, and why (``aion info``
        warns of them; naming one is an error that says so, not "not in the log")."""
        return {t: why for s in self._sources for t, why in s.unreadable_topics.items()}

    @property
    def other_channels(self) -> list[OtherChannel]:
        """The channels of :attr:`unreadable_topics` with their message counts, one per topic,
        schema and encoding over all files, by topic."""
        counts: dict[tuple[str, str, str], int] = {}
        for s in self._sources:
            for c in s.other_channels:
                key = (c.topic, c.schema, c.encoding)
                counts[key] = counts.get(key, 0) + c.count
        return [OtherChannel(*key, n) for key, n in sorted(counts.items())]

    @property
    def duration_ns(self) -> int:
        return max(self.end_ns - self.start_ns, 0)

    def overlaps(self, topics: set[str], at_least_ns: int) -> list[Overlap]:
        """Pairs of files on a topic of ``topics`` at the same time, at least ``at_least_ns``
        or half of the shorter one's (:func:`formats.log_overlaps.find_overlaps`)."""
        from aion_cli.formats.log_overlaps import find_overlaps

        return find_overlaps(self, topics, at_least_ns)

    def topic(self, name: str) -> TopicInfo:
        """The topic called ``name``; :class:`TopicNotFoundError` lists the log's topics."""
        for info in self.topics:
            if info.topic == name:
                return info
        unreadable = self.unreadable_topics.get(name)
        if unreadable is not None:
            raise unreadable_topic_error(name, unreadable)
        candidates = [f"{t.topic} ({t.msgtype})" for t in self.topics]
        hint = topic_spelling_hint(name, (t.topic for t in self.topics)) or "see `aion info LOG`"
        raise TopicNotFoundError(f"topic {name!r} is not in the log", candidates, hint)

    def total(self, topics: Iterable[str] | None = None) -> int:
        """Number of messages on ``topics`` (all when None), from the indexes."""
        selected = None if topics is None else set(topics)
        return sum(t.count for t in self.topics if selected is None or t.topic in selected)

    def messages(
        self,
        topics: Iterable[str] | None = None,
        between: tuple[int, int] | None = None,
        unread: UnreadHint | None = None,
    ) -> Iterator[RawMessage]:
        """Messages on ``topics`` (all when None; names not in the log are ignored) of every
        file, merged in log-time order (ties keep file order).

        A file is opened only when the merged stream reaches the first message time its index
        gives, and closed when its messages are used up (an MCAP file with a summary is even
        opened per chunk), so a set of thousands of consecutive files holds few file handles
        at a time. ``between``: only log times in ``[lo, hi)`` are wanted (a hint: readers
        may skip chunks outside it; the caller filters). ``unread``: messages the caller drops
        without looking at them, which may come with :data:`formats.raw.UNREAD` as their data
        (:class:`formats.raw.UnreadHint`)."""
        if self._closed:
            raise ValueError("messages() on a closed LogSet")
        selected = None if topics is None else set(topics)
        if len(self._sources) == 1:
            return self._sources[0].messages(selected, between, unread)
        return merge_by_start(self._sources, selected, between, unread, self._recordings)

    def recording_messages(
        self,
        recording: int,
        topics: Iterable[str] | None = None,
        between: tuple[int, int] | None = None,
    ) -> Iterator[RawMessage]:
        """:meth:`messages` of one recording only (:attr:`recordings`: a path given; the
        storage files of one bag together), marked with it; the other files are not opened."""
        if self._closed:
            raise ValueError("recording_messages() on a closed LogSet")
        chosen = [k for k, r in enumerate(self._recordings) if r == recording]
        selected = None if topics is None else set(topics)
        return merge_by_start(
            [self._sources[k] for k in chosen], selected, between, None, [recording] * len(chosen)
        )

    def skips_by_time(self) -> bool:
        """Whether ``messages(topics, between)`` reads only the files' parts near that time
        (every file an indexed MCAP read by chunk), so that reading a few seconds here and
        there costs a few chunks, not the files up to there."""
        return not self.read_from_start()

    def read_from_start(self) -> list[Path]:
        """The files :meth:`skips_by_time` fails for: read from their start whatever time is
        wanted (an MCAP without its chunk index, such as a truncated one), for notes naming them."""
        return [source.file.path for source in self._sources if not source.skips_by_time()]

    def decode(self, msg: RawMessage) -> Any:
        """``msg`` as a rosbags message object, decoded with the definition the log embeds for
        its topic (shipped definitions from :mod:`formats.msgdefs` when the log has none)."""
        key = (msg.topic, msg.msgtype, msg.encoding)
        decoder = self._decoders.get(key)
        if decoder is None:
            decoder = self._decoders[key] = self._make_decoder(msg)
        try:
            return decoder(bytes(msg.data))  # the same object for bytes; a view's copy
        except Exception as exc:  # rosbags raises struct, index and value errors on bad bytes
            raise MessageDecodeError(
                f"cannot decode a {msg.msgtype} message on {msg.topic} at {msg.log_time_ns} ns "
                f"({type(exc).__name__}: {exc})",
                hint="the payload does not match its definition; the log may be corrupt",
            ) from exc

    def definition(self, topic: str, msgtype: str, encoding: str) -> tuple[str, bool]:
        """The message definition the log embeds for ``topic`` carrying ``msgtype`` in
        ``encoding``: ``(text, is ROS 2 IDL)``, ``("", False)`` when it embeds none."""
        return self._definitions.get((topic, msgtype, encoding), ("", False))

    def typestore(self, topic: str, msgtype: str, encoding: str) -> Typestore:
        """A rosbags typestore that decodes ``topic`` with the log's own definition of
        ``msgtype`` (aion's shipped definitions when the log embeds none);
        :class:`MessageDecodeError` when there is neither or the definition is malformed."""
        definition, idl = self.definition(topic, msgtype, encoding)
        key = (encoding, msgtype, definition, idl)
        store = self._typestores.get(key)
        if store is None:
            store = _store_with_definition(self._stores, encoding, msgtype, definition, idl)
            self._typestores[key] = store
        return store

    def _make_decoder(self, msg: RawMessage) -> Callable[[bytes], Any]:
        store = self.typestore(msg.topic, msg.msgtype, msg.encoding)
        if msg.encoding == "ros1":
            des1 = store.deserialize_ros1
            return lambda data: des1(data, msg.msgtype)
        des2 = store.deserialize_cdr
        return lambda data: des2(data, msg.msgtype)

    def close(self) -> None:
        """Close every file."""
        self._closed = True
        for source in self._sources:
            source.close()

    def __enter__(self) -> LogSet:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def open_logs(
    paths: Iterable[Path | str],
    fmt: str | None = None,
    *,
    limits: ReadLimits | None = None,
    allow_empty: bool = False,
) -> LogSet:
    """Open ``paths`` (files or rosbag2 folders) as one :class:`LogSet`; ``fmt`` (``"mcap"``,
    ``"bag"``, ``"rosbag2"``) overrides the format guessed from each path. ``limits``: what
    one decompressed chunk and one message may take (:class:`formats.limits.ReadLimits`;
    default: ``AION_MAX_CHUNK_MB`` / ``AION_MAX_MESSAGE_MB`` or 512 / 256 MiB).

    Special files (FIFOs, devices, sockets) are refused before anything is read from them.
    Raises :class:`LogFormatError` for missing, empty, unreadable or message-less logs
    (``allow_empty``: a well-formed recording without messages opens, for ``aion info``).
    """
    read_limits = limits if limits is not None else ReadLimits.from_env()
    sources: list[_Source] = []
    recordings: list[int] = []  # the position of the path each source was opened from
    try:
        read_from: dict[Path, Path] = {}  # each file or bag read, and the path given for it
        for position, p in enumerate(paths):
            for source in open_sources(Path(p), fmt, read_limits):
                key = source.file.path.resolve()
                if key in read_from:  # a bag's folder and its storage file, or two of them
                    source.close()
                    warning = (
                        f"{p}: {source.file.path} is read already (given as "
                        f"{read_from[key]}): it is used once"
                    )
                    sources[-1].warnings.append(warning)  # the first path's never repeat
                    continue
                read_from[key] = Path(p)
                sources.append(source)
                recordings.append(position)
        if not sources:
            raise LogFormatError("no log given", hint="pass at least one log file or folder")
        logset = LogSet(sources, recordings)
        # an empty recording opens for ``aion info`` (allow_empty); one whose messages were
        # all lost (chunks over the limit, damage: the warnings say) never does
        if (not allow_empty or logset.warnings) and all(
            f.message_count == 0 for f in logset.files
        ):
            names = ", ".join(str(f.path) for f in logset.files)
            raise LogFormatError(
                f"{names}: no messages" + first_reasons(logset.warnings),
                hint="the recording holds no readable messages"
                if not logset.warnings
                else "none of its messages could be read: see the reason above",
            )
        for f in logset.files:
            if f.message_count == 0:
                sources[logset.files.index(f)].warnings.append(f"{f.path}: no messages")
        return logset
    except BaseException:
        for source in sources:
            source.close()
        raise


def unreadable_topic_error(
    name: str, why: str, candidates: list[str] | None = None
) -> TopicNotFoundError:
    """The error for topic ``name``, which the log holds in an encoding no ROS reader decodes
    (``why``, from :attr:`LogSet.unreadable_topics`): it is there, not missing."""
    return TopicNotFoundError(
        f"topic {name!r} is in the log, but aion cannot read it: {why}",
        candidates=candidates or [],
        hint="aion reads ROS messages (ROS 1 or CDR-encoded ROS 2 MCAP channels)",
    )


def first_reasons(warnings: list[str]) -> str:
    """`` (the first warning; and N more)`` for an error line, ``""`` without warnings: the
    error of a log with 50 skipped chunks names one and counts the others."""
    if not warnings:
        return ""
    more = len(warnings) - 1
    return f" ({warnings[0]}" + (f"; and {more:,} more warnings like it)" if more else ")")
