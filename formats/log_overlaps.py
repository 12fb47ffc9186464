"""Files of a :class:`formats.logs.LogSet` that hold the same detection topics at the same
time (:func:`find_overlaps`), and the messages of one such file alone (:func:`file_messages`),
so that the build can compare what the two hold (``aion_cli.log_twins``) before warning that
they count the same people twice."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from aion_cli.formats.log_source import LogFile
from aion_cli.formats.raw import RawMessage

if TYPE_CHECKING:
    from aion_cli.formats.logs import LogSet


@dataclass(frozen=True)
class Overlap:
    """Two files of a :class:`LogSet` on the same topics at the same time
    (:meth:`LogSet.overlaps`): ``[start_ns, end_ns]`` is the time both cover; ``pair`` their
    positions in :attr:`LogSet.files`."""

    first: LogFile
    second: LogFile
    start_ns: int
    end_ns: int
    topics: tuple[str, ...]
    pair: tuple[int, int] = (0, 1)


def find_overlaps(logset: LogSet, topics: set[str], at_least_ns: int) -> list[Overlap]:
    """Pairs of files that both carry a topic of ``topics`` and whose time ranges (first
    to last message) share at least ``at_least_ns``, or at least half of the shorter
    one's (a log shorter than a window, converted twice into two containers, shares it
    whole): two logs of one moment on the same topic (two robots at once, two sensors or
    splits of one recording, or one recording twice: a copy, an excerpt, a merged file), in
    file order. Whether they hold the same people is for their messages to tell."""
    carried = _carried(logset, topics)
    files = logset.files
    out: list[Overlap] = []
    for i, a in enumerate(files):
        for j in range(i + 1, len(files)):
            b = files[j]
            shared = sorted(carried[i] & carried[j])
            lo, hi = max(a.start_ns, b.start_ns), min(a.end_ns, b.end_ns)
            shorter = min(a.end_ns - a.start_ns, b.end_ns - b.start_ns)
            if shared and hi > lo and hi - lo >= min(at_least_ns, shorter / 2):
                out.append(Overlap(a, b, lo, hi, tuple(shared), (i, j)))
    return out


def file_messages(
    logset: LogSet, index: int, topics: set[str], between: tuple[int, int]
) -> Iterator[RawMessage]:
    """The messages on ``topics`` of entry ``index`` of ``logset.files`` alone, log times in
    ``[lo, hi)`` (a reader may yield a few outside: filter), in log-time order."""
    return logset._sources[index].messages(topics, between, None)


def topics_at_once(logset: LogSet, topics: set[str]) -> list[str]:
    """The topics of ``topics`` that run at the same time as another of them: two carried by
    one file, or by two files whose time ranges (first to last message) meet. Streams of
    one kind under other names in logs of other times (a ROS 1 bag's and a ROS 2 MCAP's
    names for Hydra's scene graph, one log after the other) are one stream, read in time
    order; the same names at once are two streams. Sorted; empty when there is no such."""
    carried = _carried(logset, topics)
    files = logset.files
    out: set[str] = set()
    for i, a in enumerate(files):
        if len(carried[i]) > 1:
            out |= carried[i]
        for j in range(i + 1, len(files)):
            b = files[j]
            if carried[i] != carried[j] and carried[i] and carried[j] and \
                    max(a.start_ns, b.start_ns) <= min(a.end_ns, b.end_ns):
                out |= carried[i] | carried[j]
    return sorted(out)


def _carried(logset: LogSet, topics: set[str]) -> list[frozenset[str]]:
    """The topics of ``topics`` each entry of ``logset.files`` holds messages of (a topic its
    index lists with no message is not carried), in file order: what :func:`find_overlaps`
    and :func:`topics_at_once` compare, so that both read a file's streams alike."""
    return [
        frozenset(t.topic for t in s.topics.values() if t.topic in topics and t.count)
        for s in logset._sources
    ]
