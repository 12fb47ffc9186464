"""When a :class:`formats.logs.LogSet` recorded, from the containers' indexes without the
messages: the time spans of each recording (a path given; the storage files of one rosbag2 bag
joined), the windows in which anything was recorded (:mod:`formats.recorded`), and the log
times :meth:`formats.logs.LogSet.messages` will yield (:mod:`formats.stream_times`). A part of
:class:`formats.logs.LogSet`, which sets the attributes declared here.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from aion_cli.formats import recorded
from aion_cli.formats.log_source import LogFile, _Source

if TYPE_CHECKING:
    from aion_cli.formats.recorded import Windows
    from aion_cli.formats.stream_times import StreamTimes


def covered_ns(spans: Iterable[tuple[int, int]]) -> int:
    """The length of the union of ``(start, end)`` spans (ns): overlaps counted once."""
    total, reach = 0, None
    for lo, hi in sorted(spans):
        lo = lo if reach is None else max(lo, reach)
        if hi > lo:
            total += hi - lo
        reach = hi if reach is None else max(reach, hi)
    return total


class _RecordedTimes:
    """The recording times and windows of a log set (module docstring)."""

    _sources: list[_Source]
    _recordings: list[int]
    files: list[LogFile]
    _closed: bool

    def recorded_ns(self, topic: str) -> int:
        """How long the files holding messages of ``topic`` recorded: the union of their
        spans (first to last message), so the time between two logs of other days is left
        out and two logs of one moment count it once; the storage files of one rosbag2 bag
        are joined first (:meth:`recording_times`: it recorded the time between them too)."""
        return covered_ns(self.recording_times([topic]).values())

    def recorded_total_ns(self) -> int:
        """How long the logs recorded: the union of the spans of :meth:`recording_times` (the
        storage files of one rosbag2 bag joined), so the days between two logs are left out
        and two logs of one moment count it once. :attr:`duration_ns` is the span from the
        first message to the last instead."""
        return covered_ns(self.recording_times().values())

    def recorded_windows(self, window_ns: int) -> Windows:
        """Sorted unique window indices ``floor(t / window_ns)`` holding at least one message
        (any topic, any file of the set, log time).

        What a fixed sensor observed: the windows in which it recorded something, never the
        time between two recordings within a file or between files. Read from the containers'
        indexes without message payloads where they have them (MCAP summaries, ROS 1 bag
        indexes, rosbag2 sqlite3); :class:`ConfigError` for a window that is not a positive
        number of nanoseconds.
        """
        return recorded.union(w for _, w in self.recorded_windows_by_file(window_ns))

    def recorded_windows_by_file(self, window_ns: int) -> list[tuple[LogFile, Windows]]:
        """:meth:`recorded_windows` of each entry of :attr:`files`, in the same order (a rosbag2
        folder is one entry; its mcap storage files are one entry each)."""
        if self._closed:
            raise ValueError("recorded_windows() on a closed LogSet")
        size = recorded.window_size(window_ns)
        return [(s.file, s.recorded_windows(size)) for s in self._sources]

    @property
    def recordings(self) -> list[int]:
        """Per entry of :attr:`files`, the recording it belongs to (:func:`open_logs`: the
        position of the path it was opened from; the storage files of one bag share it)."""
        return list(self._recordings)

    def recording_times(self, topics: Iterable[str] | None = None) -> dict[int, tuple[int, int]]:
        """Per recording (:attr:`recordings`: a path given, the storage files of one bag
        joined), the first and last message time its files' indexes or summaries give;
        recordings without a message are left out. ``topics``: of the files that hold a
        message of one of them only (the files' whole spans)."""
        if topics is None:
            return self._joined([file.message_count > 0 for file in self.files])
        selected = set(topics)
        return self._joined([
            any(t.topic in selected and t.count for t in s.topics.values())
            or any(c.topic in selected and c.count for c in s.other_channels)
            for s in self._sources
        ])

    def _joined(self, kept: list[bool]) -> dict[int, tuple[int, int]]:
        """Per recording, the first and last message time of its files that are ``kept``."""
        spans: dict[int, tuple[int, int]] = {}
        for key, file, keep in zip(self._recordings, self.files, kept, strict=True):
            if keep:
                lo, hi = spans.get(key, (file.start_ns, file.end_ns))
                spans[key] = (min(lo, int(file.start_ns)), max(hi, int(file.end_ns)))
        return spans

    def recorded_windows_by_recording(self, window_ns: int) -> list[tuple[LogFile, Windows]]:
        """:meth:`recorded_windows_by_file` with the storage files of one rosbag2 bag joined
        (the first file stands for the bag): a recorder that split its bag by size or duration
        recorded the time between the last message of one file and the first of the next,
        which a tracker publishing only when it sees someone leaves without a message."""
        by_file = self.recorded_windows_by_file(window_ns)
        joined: dict[int, tuple[LogFile, list[Windows]]] = {}
        for key, (file, windows) in zip(self._recordings, by_file, strict=True):
            joined.setdefault(key, (file, []))[1].append(windows)
        return [(file, recorded.union(parts)) for file, parts in joined.values()]

    def index_times(self, topics: Iterable[str], vouch: bool = True) -> StreamTimes | None:
        """The log times :meth:`messages` would yield on ``topics``, in its order, read from
        the containers' indexes without the messages (:mod:`formats.stream_times`), or None
        when one file's index cannot say exactly that. Each reader then vouches for the
        chunks whose times came from their index alone: reading one of them later fails with
        :class:`~aion_cli.errors.StaleIndexError` (unless ``vouch`` is False: ``aion info``)."""
        if self._closed:
            raise ValueError("index_times() on a closed LogSet")
        from aion_cli.formats import stream_times

        selected = set(topics)
        parts = []
        for source in self._sources:
            part = source.index_times(selected)
            if part is None:
                return None
            parts.append(part)
        found = stream_times.merged(parts)
        if found is not None and vouch:
            for source, part in zip(self._sources, parts, strict=True):
                source.vouch(part.chunks)
        return found

    def index_times_by_recording(self, topics: Iterable[str]) -> dict[int, StreamTimes] | None:
        """:meth:`index_times` per recording (the keys of :meth:`recording_times`), nothing
        vouched for; None when one file's index cannot give the times."""
        from aion_cli.formats import stream_times

        selected = set(topics)
        parts: dict[int, list[StreamTimes]] = {}
        for key, source in zip(self._recordings, self._sources, strict=True):
            part = source.index_times(selected)
            if part is None:
                return None
            parts.setdefault(key, []).append(part)
        joined: dict[int, StreamTimes] = {}
        for key, found in parts.items():
            merged = stream_times.merged(found)
            if merged is None:
                return None
            joined[key] = merged
        return joined
