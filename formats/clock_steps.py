"""A log whose log times go back between its chunks: the recording's clock stepped back (an NTP
correction), so the minutes it covers twice hold messages of two moments, which a build reads
together in time order. Found from the chunks' stated time ranges in file order (MCAP chunk
indexes, ROS 1 bag chunk infos) without reading a message; a step inside one chunk is not
seen, and a log written out of time order (which reads as the same map) looks the same, so the
warning names both."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np

#: how far log times may go back from one chunk to the next (in file order) before it is a
#: clock step: writers of several threads reorder by milliseconds, not seconds
BACK_STEP_NS = 10 * 1_000_000_000
#: ... and the most: a step of more than a day is a stray message's time (the build's stray
#: rule drops and warns of it), not a clock that stepped back
BACK_STEP_MAX_NS = 86_400 * 1_000_000_000


class ChunkSpan(NamedTuple):
    """A chunk's place in the file (any number that grows along it), its first and last log
    time, and the channels (connections) it holds messages of."""

    position: int
    start_ns: int
    end_ns: int
    channels: Iterable[int]


def backward_step(chunks: Sequence[ChunkSpan]) -> tuple[int, int, int] | None:
    """The largest step back in log time between the chunks of one channel in file order (a
    chunk starting before an earlier chunk of the channel ended), when more than
    :data:`BACK_STEP_NS` and at most :data:`BACK_STEP_MAX_NS`: ``(step, earlier chunk's end,
    chunk's start)``; None otherwise."""
    ordered = sorted(chunks, key=lambda c: c.position)
    by_channel: dict[int, list[int]] = {}
    for k, chunk in enumerate(ordered):
        for cid in chunk.channels:
            by_channel.setdefault(cid, []).append(k)
    starts = np.array([c.start_ns for c in ordered], np.uint64)  # may pass int64
    ends = np.array([c.end_ns for c in ordered], np.uint64)
    best: tuple[int, int, int] | None = None
    for rows in by_channel.values():
        if len(rows) < 2:
            continue
        mine = np.asarray(rows)
        before = np.maximum.accumulate(ends[mine])[:-1]  # the latest end of the chunks before
        after = starts[mine][1:]
        back = np.where(before > after, before - after, np.uint64(0))  # no wrap-around kept
        back[back > BACK_STEP_MAX_NS] = 0
        i = int(np.argmax(back))
        if back[i] > BACK_STEP_NS and (best is None or back[i] > best[0]):
            best = (int(back[i]), int(before[i]), int(after[i]))
    return best


def step_warning(name: str, chunks: Sequence[ChunkSpan]) -> str | None:
    """The warning for the log ``name`` whose ``chunks`` step back in time; None if not."""
    from aion_cli.formats.mcap_records import iso

    step = backward_step(chunks)
    if step is None:
        return None
    back, end, start = step
    return (
        f"{name}: its log times go back at least {back / 6e10:.1f} min (a chunk starting "
        f"{iso(start)} follows one ending {iso(end)}): the clock stepped back while recording "
        "(NTP?), or the messages were written out of time order; if the clock stepped, the "
        "minutes the log covers twice hold messages of two moments, read together in time "
        "order, so the people seen then count twice in their windows"
    )
