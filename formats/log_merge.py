"""Several logs' messages as one stream in log-time order (:meth:`formats.logs.LogSet.messages`).

A k-way merge by each source's next message time, ties in the order the sources were given
(as one pass over the logs in that order would read them); a source is opened only when the
merge reaches its first message, so files that follow one another are read one at a time."""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aion_cli.formats.log_source import _Source
    from aion_cli.formats.raw import RawMessage, UnreadHint


def merge_by_start(
    sources: list[_Source],
    topics: set[str] | None,
    between: tuple[int, int] | None = None,
    unread: UnreadHint | None = None,
    recordings: list[int] | None = None,
) -> Iterator[RawMessage]:
    """The messages of ``sources`` merged by log time, ties in source order; a source's
    stream is started only once the merge reaches its first message time (or nothing earlier
    is left), so files that follow one another are read one after the other. ``recordings``:
    per source, the recording its messages are marked with (:func:`formats.raw.
    from_recording`; 0, the default, is left unmarked)."""
    from aion_cli.formats.raw import from_recording

    marks = recordings or [0] * len(sources)
    order = sorted(range(len(sources)), key=lambda k: (sources[k].file.start_ns, k))
    heap: list[tuple[int, int, int, RawMessage, Iterator[RawMessage]]] = []
    seq = 0
    nxt = 0
    while nxt < len(order) or heap:
        if nxt < len(order) and (
            not heap or sources[order[nxt]].file.start_ns <= heap[0][0]
        ):
            k = order[nxt]
            nxt += 1
            stream = sources[k].messages(topics, between, unread)
            first = next(stream, None)
            if first is not None:
                heapq.heappush(heap, (first.log_time_ns, k, seq, first, stream))
                seq += 1
            continue
        _, k, _, msg, stream = heap[0]
        yield from_recording(msg, marks[k]) if marks[k] else msg
        following = next(stream, None)
        if following is None:
            heapq.heappop(heap)
        else:
            heapq.heapreplace(heap, (following.log_time_ns, k, seq, following, stream))
            seq += 1
