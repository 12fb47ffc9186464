"""Which scene graphs of a log a build uses (``--graph-period``): :func:`graph_schedule` over
the graph messages' log times, which :class:`GraphTimes` gathers before the stream (from the
containers' indexes, or while reading TF). Apart from :mod:`aion_cli.graph_feed`, which
applies the schedule to the stream and decodes the graphs used: the schedule is decided on
times alone."""

from __future__ import annotations

import re
from array import array
from collections import Counter
from collections.abc import Iterable
from decimal import Decimal, InvalidOperation
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import I64
from aion_cli.log_times import TopicTimes, in_range_mask

if TYPE_CHECKING:
    from aion_cli.formats.stream_times import StreamTimes

DEFAULT_GRAPH_PERIOD_NS = 5_000_000_000
"""``--graph-period`` default: 5 s of log time. Why: a graph matters to the map through its
place nodes, and a node takes part only once it has been stable for ``stability_s`` (30 s by
default) — cells bind to it at graph times, adding their state, never overwriting it — so a
graph used up to 5 s late shifts a bind by at most a sixth of that wait and moves no detection
out of its 600-s window's counts; a 1 Hz Hydra stream costs a fifth. Use ``0`` for every
graph."""

#: ``--graph-period`` units (seconds each); ``ms`` besides the units of ``--time``'s offsets.
_PERIOD_UNITS = {
    "ms": Decimal("0.001"),
    "s": Decimal(1),
    "sec": Decimal(1),
    "m": Decimal(60),
    "min": Decimal(60),
    "h": Decimal(3600),
    "d": Decimal(86400),
}
_PERIOD_RE = re.compile(r"(\d+(?:\.\d+)?)\s*([a-z]+)")
#: Longest accepted period: a year (anything longer thins a log to its first and last graphs
#: just the same).
MAX_GRAPH_PERIOD_NS = 366 * 86_400 * 1_000_000_000


def parse_period_ns(text: str) -> int:
    """A duration as the CLI's other durations are written (``5s``, ``1m``, ``1m30s``,
    ``500ms``, ``2.5``: seconds without a unit) -> integer nanoseconds, exactly (decimal
    arithmetic). Negative, unreadable or longer than a year: a one-line error (exit 2)."""
    from aion_cli.timeparse import TimeFormatError, refuse_capital_m

    refuse_capital_m(text, "--graph-period")
    hint = "e.g. --graph-period 5s, 1m, 500ms or 0 (every graph)"
    token = text.strip().lower().replace(" ", "")
    total: Decimal
    try:
        total = Decimal(token) if re.fullmatch(r"\d+(?:\.\d+)?", token) else Decimal(-1)
    except InvalidOperation:
        total = Decimal(-1)
    if total < 0:
        parts = _PERIOD_RE.findall(token)
        if not parts or "".join(a + u for a, u in parts) != token:
            raise TimeFormatError(f"cannot read the period {text!r}", hint)
        total = Decimal(0)
        for amount, unit in parts:
            if unit not in _PERIOD_UNITS:
                raise TimeFormatError(f"unknown unit {unit!r} in --graph-period {text!r}", hint)
            total += Decimal(amount) * _PERIOD_UNITS[unit]
    ns = int(total * 1_000_000_000)
    if ns > MAX_GRAPH_PERIOD_NS:
        raise TimeFormatError(f"--graph-period {text!r} is longer than a year", hint)
    return ns


def graph_schedule(t_ns: I64, period_ns: int, window_ns: int = 0) -> npt.NDArray[np.bool_]:
    """Which scene-graph messages (log times, in stream order) a build uses with
    ``--graph-period`` ``period_ns``; True = used.

    The first graph is used, and then one graph per *period boundary*: at ``b = t + period``
    after a used graph at ``t`` the newest graph logged at or before ``b`` that came after the
    used one (it was pending) is used and the next boundary is ``b + period``; when none came
    the next graph to arrive is used and the next boundary is its time + period. So the map
    is never more than one period behind the newest graph, graphs are at least a period apart
    on a steady stream (1 Hz, 5 s: every fifth), and the last graph of the log is always used
    (the final map shows it). With ``window_ns`` the last graph logged in each window is used
    too, so every window closes with the newest graph (and, where the robot poses come from
    the graphs' agent layer, with all its poses). Used graphs are applied at their own place
    in the stream, in time order, exactly as if the log held only them. ``period_ns <= 0``:
    every graph. One ``searchsorted`` per graph used (times made non-decreasing first)."""
    t = np.maximum.accumulate(np.asarray(t_ns, dtype=np.int64)) if len(t_ns) else t_ns
    n = len(t)
    used = np.zeros(n, dtype=bool)
    if n == 0:
        return used
    if period_ns <= 0:
        used[:] = True
        return used
    top = int(np.iinfo(np.int64).max)
    last = 0
    used[0] = True
    boundary = min(int(t[0]) + int(period_ns), top)
    while last < n - 1:
        newest = int(np.searchsorted(t, np.int64(boundary), side="right")) - 1  # at or before b
        if newest > last:
            last = newest
            boundary = min(boundary + int(period_ns), top)
        else:
            last += 1  # nothing pending: the next graph, whenever it comes
            boundary = min(int(t[last]) + int(period_ns), top)
        used[last] = True
    if window_ns > 0:
        w = t // np.int64(window_ns)
        used[:-1] |= w[1:] != w[:-1]
    return used


class GraphTimes(TopicTimes):
    """:class:`TopicTimes` that also keeps the log times of the scene-graph messages, with
    their topics, in read order: what :func:`graph_schedule` decides on before the stream
    (it must know when the next graph comes to choose the newest one of a period)."""

    def __init__(self, topics: Iterable[str], graph_topics: set[str]) -> None:
        super().__init__(topics)
        self.graph_topics = sorted(graph_topics)
        self._index = {t: i for i, t in enumerate(self.graph_topics)}
        self.graph_t: array[int] = array("q")
        self.graph_topic: array[int] = array("h")

    def add(self, topic: str, t_ns: int) -> bool:
        ok = super().add(topic, t_ns)
        k = self._index.get(topic)
        if ok and k is not None:
            self.graph_t.append(t_ns)
            self.graph_topic.append(k)
        return ok

    def add_stream(self, times: StreamTimes) -> None:
        """Record log times read from a log's index (:meth:`TopicTimes.add_stream`), the
        scene-graph ones also in stream order, with their topics, as :meth:`add` does."""
        super().add_stream(times)
        graph_of = np.array([self._index.get(topic, -1) for topic in times.topics], np.int16)
        topic = graph_of[times.code] if len(times) else np.zeros(0, np.int16)
        keep = (topic >= 0) & in_range_mask(times.t)
        self.graph_t.frombytes(times.t[keep].astype(np.int64).tobytes())
        self.graph_topic.frombytes(topic[keep].tobytes())

    def stream_times(self, strays: dict[str, I64]) -> I64:
        """The graph log times in the order the build's stream yields them: the strays the
        time check drops are dropped here too (the first messages of each stray
        ``(topic, time)``, as :meth:`aion_cli.log_times.TimeCheck.filter` does)."""
        t = np.frombuffer(self.graph_t, dtype=np.int64) if len(self.graph_t) else np.zeros(0)
        t = t.astype(np.int64)  # a copy: the array's buffer stays appendable
        pending = Counter(
            (self._index[topic], int(x))
            for topic, times in strays.items()
            if topic in self._index
            for x in times.tolist()
        )
        if not pending:
            return t
        keep = np.ones(len(t), dtype=bool)
        topics = np.frombuffer(self.graph_topic, dtype=np.int16)
        for i in np.flatnonzero(np.isin(t, [x for _, x in pending])).tolist():
            key = (int(topics[i]), int(t[i]))
            if pending.get(key, 0) > 0:
                pending[key] -= 1
                keep[i] = False
        return t[keep]
