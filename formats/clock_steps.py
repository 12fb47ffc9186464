"""A log whose log times go back: the recording's clock stepped back (an NTP correction), so the
minutes it covers twice hold messages of two moments, which a build reads together in time
order. Found per channel (topic) in file order without reading a message payload: between
chunks from their stated time ranges (MCAP chunk indexes, ROS 1 bag chunk infos), inside an
MCAP chunk from its MessageIndex records (only chunks that span more than a step: a few bytes
per message), inside a ROS 1 bag chunk from its index entries in offset order, in an MCAP file
without a summary while its opening scan reads it (:class:`ScanSteps`), and in a rosbag2
sqlite3 storage file from its ``timestamp`` column in insertion (``id``) order. A log written
out of time order (which reads as the same map) looks the same, so the warning names both."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from itertools import chain, islice
from operator import itemgetter
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np
import numpy.typing as npt

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


class Step(NamedTuple):
    """A step back in log time: how far, the latest time before it, the time after it, and
    whether it lies between two messages (inside a chunk, or a file without chunks) rather
    than between chunks."""

    back_ns: int
    before_ns: int
    after_ns: int
    inside: bool = False


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


def _largest_back(times: npt.NDArray[np.uint64]) -> tuple[int, int, int] | None:
    """The largest step back of ``times`` (one channel's log times in file order) from the
    latest time before it, when more than :data:`BACK_STEP_NS` and at most
    :data:`BACK_STEP_MAX_NS`: ``(step, latest time before, time)``; None otherwise."""
    if times.size < 2:
        return None
    before = np.maximum.accumulate(times)[:-1]
    after = times[1:]
    back = np.where(before > after, before - after, np.uint64(0))  # no wrap-around kept
    back[back > BACK_STEP_MAX_NS] = 0
    i = int(np.argmax(back))
    return (int(back[i]), int(before[i]), int(after[i])) if back[i] > BACK_STEP_NS else None


def inside_mcap_chunks(stream: IO[bytes], size: int, indexes: Sequence[Any]) -> Step | None:
    """The largest step back inside one chunk of an MCAP file (``stream`` of ``size`` bytes;
    ``indexes``: its mcap ChunkIndex records), per channel in the order of the messages in
    the chunk (their MessageIndex offsets); only chunks spanning more than
    :data:`BACK_STEP_NS` can hold one, and only their index records are read. Chunks without
    readable MessageIndex records are not looked into."""
    from aion_cli.formats import recorded

    best: Step | None = None
    for index in indexes:
        span = int(index.message_end_time) - int(index.message_start_time)
        if span <= BACK_STEP_NS or not index.message_index_offsets:
            continue
        parts = recorded.read_message_index(stream, size, index, index.message_index_offsets)
        for entries in parts or ():
            order = np.argsort(entries["offset"], kind="stable")
            found = _largest_back(np.asarray(entries["log_time"], np.uint64)[order])
            if found is not None and (best is None or found[0] > best.back_ns):
                best = Step(*found, inside=True)
    return best


def _inside_chunk(times: npt.NDArray[np.uint64], channels: npt.NDArray[Any]) -> Step | None:
    """The largest step back of one chunk's messages (``times`` and ``channels`` in the order
    they are in the chunk), per channel; None when there is none (or the chunk spans no
    more than :data:`BACK_STEP_NS`: then it holds none)."""
    if times.size < 2 or int(times.max()) - int(times.min()) <= BACK_STEP_NS:
        return None
    best: Step | None = None
    for cid in np.unique(channels):
        found = _largest_back(times[channels == cid])
        if found is not None and (best is None or found[0] > best.back_ns):
            best = Step(*found, inside=True)
    return best


def _larger(a: Step | None, b: Step | None) -> Step | None:
    return b if a is None or (b is not None and b.back_ns > a.back_ns) else a


class ScanSteps:
    """Steps back in log time met while an MCAP file without a summary is scanned (no chunk
    index to look at): each chunk's time range and channels (the steps between chunks, as
    :func:`mcap_step_warning` finds them from chunk indexes), the steps inside each chunk
    (its messages in the order they are in it), and those between messages outside chunks."""

    def __init__(self) -> None:
        self._spans: list[ChunkSpan] = []
        self._inside: Step | None = None
        self._bare: list[tuple[int, int]] = []  # (log time, channel) outside chunks

    def chunk(self, position: int, times: Sequence[int], channels: Sequence[int]) -> None:
        """A chunk at ``position`` holding messages of ``times`` on ``channels`` (in the
        order they are in it)."""
        if not times:
            return
        t = np.asarray(times, np.uint64)
        c = np.asarray(channels, np.int64)
        self._spans.append(ChunkSpan(position, int(t.min()), int(t.max()), set(c.tolist())))
        self._inside = _larger(self._inside, _inside_chunk(t, c))

    def message(self, log_time: int, channel: int) -> None:
        """A message record outside chunks."""
        self._bare.append((log_time, channel))

    def warning(self, name: str) -> str | None:
        """The warning for the log ``name`` of the largest step found; None if none."""
        between = backward_step(self._spans)
        best = _larger(Step(*between) if between is not None else None, self._inside)
        if self._bare:
            bare = np.array(self._bare, np.uint64)
            best = _larger(best, _inside_chunk(bare[:, 0], bare[:, 1]))
        return None if best is None else _warning(name, best)


def bag_step_warning(
    name: str, chunks: Sequence[Any], indexes: Mapping[int, Sequence[Any]]
) -> str | None:
    """The warning for the ROS 1 bag ``name`` whose log times step back, between its chunks
    (``chunks``: its chunk infos) or inside one: per connection, in the order its messages
    were written (their offsets in the chunk; ``indexes``: each connection's index entries,
    ``(time, chunk_pos, offset)``). Only the entries of chunks spanning more than
    :data:`BACK_STEP_NS` are looked at (only those can hold a step); None if none."""
    spans = [ChunkSpan(i.pos, i.start_time, i.end_time, i.connection_counts) for i in chunks]
    between = backward_step(spans)
    best = Step(*between) if between is not None else None
    wide = np.array(
        [i.pos for i in chunks if i.end_time - i.start_time > BACK_STEP_NS], np.uint64
    )
    for entries in indexes.values() if wide.size else ():
        if len(entries) < 2:
            continue
        flat = np.fromiter(chain.from_iterable(entries), np.uint64, 3 * len(entries))
        table = flat.reshape(-1, 3)  # time, chunk_pos, offset
        if wide.size < len(chunks):  # only the wide chunks' entries
            table = table[np.isin(table[:, 1], wide)]
        table = table[np.lexsort((table[:, 2], table[:, 1]))]  # by chunk, then offset
        cuts = np.flatnonzero(np.diff(table[:, 1])) + 1
        for times in np.split(table[:, 0], cuts):  # one chunk's, in the order written
            found = _largest_back(times)
            best = _larger(best, Step(*found, inside=True) if found is not None else None)
    return None if best is None else _warning(name, best)


def mcap_step_warning(path: Path, size: int, indexes: Sequence[Any]) -> str | None:
    """The warning for the MCAP file ``path`` (``size`` bytes) whose chunks (``indexes``,
    mcap ChunkIndex records) step back in log time, between them or inside one; None if
    not."""
    spans = [
        ChunkSpan(
            c.chunk_start_offset, c.message_start_time, c.message_end_time,
            c.message_index_offsets or {},
        )
        for c in indexes
    ]  # fmt: skip
    between = backward_step(spans)
    steps = [Step(*between)] if between is not None else []
    try:
        with path.open("rb") as stream:  # own handle: a few index reads
            inside = inside_mcap_chunks(stream, size, indexes)
    except OSError:
        inside = None
    steps += [inside] if inside is not None else []
    return _warning(path.name, max(steps, key=lambda s: s.back_ns)) if steps else None


#: the largest step back in log time of each topic of a rosbag2 sqlite3 storage file, in the
#: order the messages were written (``id``), within the bounds of a clock step
_SQLITE_STEP = """
SELECT latest - timestamp, latest, timestamp FROM (
  SELECT timestamp, MAX(timestamp) OVER (
    PARTITION BY topic_id ORDER BY id ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING
  ) AS latest FROM messages
) WHERE latest - timestamp > ?1 AND latest - timestamp <= ?2
ORDER BY latest - timestamp DESC LIMIT 1
"""


#: the ``timestamp`` column in the order the messages were written: the table's own (rowid)
#: order, so no sort; read :data:`_BLOCK` rows at a time
_SQLITE_TIMES = "SELECT timestamp FROM messages ORDER BY id"
_BLOCK = 1 << 16


def _may_step_back(connection: Any) -> bool:
    """Whether the ``timestamp``s of all topics together, in the order the messages were
    written, go back more than :data:`BACK_STEP_NS` from the latest before them anywhere:
    needed for a step of one topic (its latest time before a message is at most all topics'),
    so a file without it has none. One pass over the table in blocks (the running maximum
    carried from block to block), about a fifth of the cost of the per-topic window query,
    which then runs only for files that pass this."""
    times = map(itemgetter(0), connection.execute(_SQLITE_TIMES))
    latest: list[int] = []  # the latest time of the blocks before, once there is one
    while (block := np.fromiter(islice(times, _BLOCK), np.int64)).size:
        joined = np.concatenate((np.array(latest, np.int64), block))
        running = np.maximum.accumulate(joined)
        if np.any(joined[1:] < running[:-1] - BACK_STEP_NS):  # running >= any time: no wrap
            return True
        latest = [int(running[-1])]
    return False


def sqlite_step_warning(name: str, connection: Any) -> str | None:
    """The warning for the rosbag2 sqlite3 storage file ``name`` (``connection``: open on it)
    whose ``timestamp``s step back in the order its messages were written; None if not, or
    when SQLite cannot say (no window functions before 3.25, a damaged table: the reading
    says what it can). Files whose messages of all topics keep their order within a step
    (:func:`_may_step_back`) are not asked the per-topic query."""
    try:
        if not _may_step_back(connection):
            return None
        row = connection.execute(_SQLITE_STEP, (BACK_STEP_NS, BACK_STEP_MAX_NS)).fetchone()
    except Exception:  # sqlite3 / apsw errors: no step said, the read reports the damage
        return None
    if row is None:
        return None
    back, before, after = (int(v) for v in row)
    return _warning(name, Step(back, before, after, inside=True))


def storage_step_warnings(storages: Iterable[Any], names: Iterable[str] | None = None) -> list[str]:
    """:func:`sqlite_step_warning` of each rosbag2 sqlite3 storage file of ``storages``
    (rosbags storage readers; mcap ones are skipped: aion's MCAP reader checks them), named
    ``names`` (default: their files' names)."""
    storages = list(storages)
    shown = list(names) if names is not None else [Path(s.path).name for s in storages]
    out = []
    for storage, name in zip(storages, shown, strict=True):
        db = getattr(storage, "dbconn", None)
        warning = sqlite_step_warning(name, db) if db is not None else None
        out += [warning] if warning is not None else []
    return out


def _warning(name: str, step: Step) -> str:
    from aion_cli.engine.time_text import iso_utc

    where = (
        f"a message logged {iso_utc(step.after_ns)} follows one logged {iso_utc(step.before_ns)}"
        if step.inside
        else f"a chunk starting {iso_utc(step.after_ns)} follows one ending "
        f"{iso_utc(step.before_ns)}"
    )
    return (
        f"{name}: its log times go back at least {step.back_ns / 6e10:.1f} min ({where}): the "
        "clock stepped back while recording (NTP?), or the messages were written out of time "
        "order; if the clock stepped, the minutes the log covers twice hold messages of two "
        "moments, read together in time order, so the people seen then count twice in their "
        "windows"
    )
