"""Log times a build can trust: the span of the messages it uses, without stray messages.

Why: one message with a far-future (or far-past) log time used to stretch a build across
years — on a topic aion does not even read, or in a container summary whose end time lies —
and the fixed-sensor observation then counted the far window as an observed empty window
(flows dropped by a sixth for a one-hour log), or the time did not fit int64 at all (an
internal error). So a build takes its time span only from the messages it uses, and drops
(and counts) the messages of those topics whose log times cannot be right:

* **Representable**: a log time must lie in :data:`~aion_cli.engine.mapper.MIN_TIME_NS` ..
  :data:`~aion_cli.engine.mapper.MAX_TIME_NS` (1900-01-01 .. 2261-01-01 UTC, the range of
  ``--time``); MCAP stores unsigned times up to 2554, which int64 nanoseconds cannot hold.
* **Stray**: the log times of one topic (over every input of the build), sorted, are cut into
  *runs* wherever two consecutive messages are more than :data:`STRAY_GAP_NS` (one day) apart.
  A run is stray when the topic has a bulk — a run of more than :data:`STRAY_MAX_MESSAGES`
  (10) messages — and the run holds at most :data:`STRAY_MAX_MESSAGES` messages and at most
  :data:`STRAY_SHARE` (5 %) of the topic's messages. Recording sessions days apart (in one
  log or several) stay: each is a run of its own with more than ten messages. A topic whose
  messages are all sparse (one a day) has no bulk and loses nothing. The rule sees the inputs
  of one build together, except that a run which is all of one log's messages of the topic
  stays (:func:`own_recordings`): a log of at most ten messages on a topic, a day away from a
  bigger log, is kept in ``build A B`` as in ``build B --map A.aion`` and in a parallel
  build's shard of its own (a build of such a log alone keeps everything).

The same rule (:func:`stray_mask`) drops robot poses far from the rest of the trajectory, with
the same exemption for a run of poses stamped within one log holding TF, where no other pose
lies (:func:`aion_cli.tf_trajectory.robot_trajectory`).
Everything here is numpy over int64 arrays; the per-message part is one ``array.append``, or
none where the times come as arrays from a log's index (:meth:`TopicTimes.add_stream`).
"""

from __future__ import annotations

from array import array
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.mapper import MAX_TIME_NS, MIN_TIME_NS, TIME_RANGE_TEXT
from aion_cli.engine.time_text import utc_text
from aion_cli.engine.types import I64, BoolA

if TYPE_CHECKING:
    import numpy.typing as npt

    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.stream_times import StreamTimes

STRAY_GAP_NS = 86_400 * 1_000_000_000
"""Gap between consecutive messages of a topic that starts a new run (one day)."""
STRAY_MAX_MESSAGES = 10
"""A stray run holds at most this many messages (and the topic's bulk run more)."""
STRAY_SHARE = 0.05
"""A stray run holds at most this share of its topic's messages."""


def in_range(t_ns: int) -> bool:
    """Whether a log time lies in the representable range (inclusive)."""
    return MIN_TIME_NS <= t_ns <= MAX_TIME_NS


def in_range_mask(t_ns: npt.NDArray[Any]) -> BoolA:
    """:func:`in_range` over an array of log times: int64, or uint64 as MCAP stores them."""
    if t_ns.dtype == np.uint64:
        return t_ns <= np.uint64(MAX_TIME_NS)  # every uint64 lies above MIN_TIME_NS (< 0)
    return (t_ns >= MIN_TIME_NS) & (t_ns <= MAX_TIME_NS)


def stray_mask(times: I64) -> BoolA:
    """Mask of the stray entries of ``times`` (any order; see the module docstring)."""
    t = np.asarray(times, dtype=np.int64)
    n = t.size
    out = np.zeros(n, dtype=bool)
    if n <= STRAY_MAX_MESSAGES:
        return out
    order = np.argsort(t, kind="stable")
    ts = t[order]
    # int64 differences of in-range times cannot overflow (the range spans < 2**63 ns)
    cuts = np.flatnonzero(np.diff(ts) > STRAY_GAP_NS) + 1
    if cuts.size == 0:
        return out
    starts = np.concatenate([[0], cuts])
    sizes = np.diff(np.concatenate([starts, [n]]))
    if int(sizes.max()) <= STRAY_MAX_MESSAGES:
        return out  # no bulk: sparse messages, nothing stands out
    stray_run = (sizes <= STRAY_MAX_MESSAGES) & (sizes <= STRAY_SHARE * n)
    if not stray_run.any():
        return out
    out[order] = np.repeat(stray_run, sizes)
    return out


def own_recordings(t: I64, stray: BoolA, recordings: Sequence[tuple[int, int]]) -> BoolA:
    """``stray`` (a mask over the topic's times ``t``) without the stray runs that are all of
    one recording's messages of the topic: a run inside a recording's span (``recordings``:
    first and last message time of each) in which no other message of the topic lies is that
    log's own time, not a stray clock. A log built alone, added with ``--map`` or in a
    parallel shard keeps such a run (it is its topic's bulk), so a build of it beside other
    logs keeps it too."""
    if not recordings or not stray.any():
        return stray
    out = stray.copy()
    kept = np.sort(t[~stray])
    lo = np.array([a for a, _ in recordings], np.int64)
    hi = np.array([b for _, b in recordings], np.int64)
    firsts, lasts = runs(t[stray])
    for a, b in zip(firsts.tolist(), lasts.tolist(), strict=True):
        inside = (lo <= a) & (hi >= b)
        others = np.searchsorted(kept, hi[inside], "right") - np.searchsorted(kept, lo[inside])
        if (others == 0).any():
            out[(t >= a) & (t <= b)] = False
    return out


def runs(times: I64) -> tuple[I64, I64]:
    """``(first, last)`` log time of each run of ``times`` (sorted), gaps of more than
    :data:`STRAY_GAP_NS` between runs."""
    ts = np.sort(np.asarray(times, dtype=np.int64))
    if ts.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    cuts = np.flatnonzero(np.diff(ts) > STRAY_GAP_NS) + 1
    first = ts[np.concatenate([[0], cuts])]
    last = ts[np.concatenate([cuts - 1, [ts.size - 1]])]
    return first, last


class TopicTimes:
    """Collects the log times of the messages of some topics during one read of a log."""

    def __init__(self, topics: Iterable[str]) -> None:
        self._times: dict[str, array[int]] = {t: array("q") for t in topics}
        self.out_of_range: Counter[str] = Counter()
        self.first_out_of_range: dict[str, int] = {}

    @property
    def topics(self) -> set[str]:
        return set(self._times)

    def add(self, topic: str, t_ns: int) -> bool:
        """Record one message's log time; False (and counted) when it is out of range."""
        if MIN_TIME_NS <= t_ns <= MAX_TIME_NS:
            self._times[topic].append(t_ns)
            return True
        self.out_of_range[topic] += 1
        self.first_out_of_range.setdefault(topic, t_ns)
        return False

    def add_array(self, topic: str, t_ns: npt.NDArray[Any]) -> npt.NDArray[np.bool_]:
        """Record the log times ``t_ns`` (int64, or uint64 as MCAP stores them) of messages of
        ``topic`` in read order, as :meth:`add` does one by one; returns which were in range."""
        t = np.asarray(t_ns)
        ok = in_range_mask(t)
        bad = int(t.size - np.count_nonzero(ok))
        if bad:
            self.out_of_range[topic] += bad
            self.first_out_of_range.setdefault(topic, int(t[~ok][0]))
        self._times[topic].frombytes(t[ok].astype(np.int64).tobytes())
        return ok

    def add_stream(self, times: StreamTimes) -> None:
        """Record log times read from a log's index (:mod:`formats.stream_times`), topic by
        topic in stream order."""
        for k, topic in enumerate(times.topics):
            self.add_array(topic, times.t[times.code == k])

    def windows(self, topics: Iterable[str], window_ns: int) -> I64:
        """Sorted distinct windows ``floor(t / window_ns)`` holding a message of ``topics``
        (those recorded here)."""
        from aion_cli.formats.recorded import union, windows_of

        return union(
            windows_of(np.frombuffer(self._times[topic], dtype=np.int64), window_ns)
            for topic in sorted(set(topics) & set(self._times))
        )

    def count_inside(self, topics: Iterable[str], lo: int, hi: int) -> int:
        """Messages of ``topics`` (those recorded here) with log times in ``[lo, hi)``."""
        total = 0
        for topic in set(topics) & set(self._times):
            raw = self._times[topic]
            t = np.frombuffer(raw, dtype=np.int64) if len(raw) else np.zeros(0, np.int64)
            total += int(np.count_nonzero((t >= lo) & (t < hi)))
        return total

    def check(
        self, span_topics: Iterable[str], recordings: Sequence[tuple[int, int]] = ()
    ) -> TimeCheck:
        """The strays of ``span_topics`` (the topics whose times matter: a static transform's
        log time says nothing), and their runs and span; the other topics are only checked
        for range. ``recordings``: each input log's first and last message time, whose own
        runs are never strays (:func:`own_recordings`)."""
        strays: dict[str, I64] = {}
        firsts, lasts, kept_span = [], [], []
        span = set(span_topics)
        for topic, raw in self._times.items():
            t = np.frombuffer(raw, dtype=np.int64) if len(raw) else np.zeros(0, np.int64)
            mask = (
                own_recordings(t, stray_mask(t), recordings)
                if topic in span
                else np.zeros(t.size, dtype=bool)
            )
            if mask.any():
                strays[topic] = np.sort(t[mask])
                t = t[~mask]
            if topic in span and t.size:
                a, b = runs(t)
                firsts.append(a)
                lasts.append(b)
                kept_span.append(t)
        kept = {topic: len(raw) - len(strays.get(topic, ())) for topic, raw in self._times.items()}
        return TimeCheck(
            strays,
            dict(self.out_of_range),
            dict(self.first_out_of_range),
            kept,
            _joined(firsts),
            _joined(lasts),
            _joined(kept_span),
        )


def _joined(parts: list[I64]) -> I64:
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


@dataclass
class TimeCheck:
    """What :meth:`TopicTimes.check` found: stray log times per topic (sorted), messages out of
    range per topic (and the first such time), messages kept per topic, and the runs
    ``[first, last]`` of the topics that make the build's time span, and those topics' kept
    log times (any order). ``limits``: the part ``[lo, hi)`` of log time a time shard of a
    parallel build learns (:meth:`limited`); None for a whole build."""

    strays: dict[str, I64]
    out_of_range: dict[str, int]
    first_out_of_range: dict[str, int]
    kept: dict[str, int]
    run_first: I64
    run_last: I64
    span_times: I64
    _pending: Counter[tuple[str, int]] = field(default_factory=Counter, repr=False)
    limits: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        for topic, times in self.strays.items():
            self._pending.update((topic, int(t)) for t in times.tolist())

    def limited(self, lo: int, hi: int) -> TimeCheck:
        """This check for the part ``[lo, hi)`` of log time (a time shard of a parallel
        build, :mod:`aion_cli.time_shards`): the runs clipped to it (so a fixed sensor
        observes exactly the windows of the part that the whole log's runs cover), the span
        from the messages inside it, and :meth:`filter` keeps only messages inside it. The
        strays and the counts stay the whole log's (the rules look at every message). The part
        is kept within the representable range."""
        lo, hi = max(int(lo), MIN_TIME_NS), min(int(hi), MAX_TIME_NS + 1)
        keep = (self.run_last >= lo) & (self.run_first < hi)
        inside = (self.span_times >= lo) & (self.span_times < hi)
        return replace(
            self,
            run_first=np.maximum(self.run_first[keep], np.int64(lo)),
            run_last=np.minimum(self.run_last[keep], np.int64(hi - 1)),
            span_times=self.span_times[inside],
            _pending=Counter(),
            limits=(lo, hi),
        )

    @property
    def start_ns(self) -> int | None:
        if self.limits is not None:  # runs are clipped to the limits: the messages say
            return int(self.span_times.min()) if self.span_times.size else None
        return int(self.run_first.min()) if self.run_first.size else None

    @property
    def end_ns(self) -> int | None:
        if self.limits is not None:
            return int(self.span_times.max()) if self.span_times.size else None
        return int(self.run_last.max()) if self.run_last.size else None

    @property
    def clean(self) -> bool:
        """Nothing to drop: the stream filter can be skipped."""
        return not self.strays and not any(self.out_of_range.values()) and self.limits is None

    def inside_limits(self, t_ns: I64) -> BoolA:
        """Mask of the log times ``t_ns`` inside :attr:`limits` (all without limits)."""
        t = np.asarray(t_ns, dtype=np.int64)
        if self.limits is None:
            return np.ones(t.shape, dtype=bool)
        lo, hi = self.limits
        return (t >= lo) & (t < hi)

    def filter(self, messages: Iterator[RawMessage]) -> Iterator[RawMessage]:
        """``messages`` without those out of range and without the strays (each stray
        ``(topic, log time)`` is dropped as often as it was counted); ``messages`` itself
        when there is nothing to drop (:attr:`clean`), without a generator step per
        message."""
        if self.clean:
            return messages
        return self._filtered(messages)

    def _filtered(self, messages: Iterator[RawMessage]) -> Iterator[RawMessage]:
        pending = Counter(self._pending)  # a fresh copy: the log may be read several times
        # the representable range, or a time shard's part of it
        lo, hi = self.limits if self.limits is not None else (MIN_TIME_NS, MAX_TIME_NS + 1)
        for msg in messages:
            t = msg.log_time_ns
            if not lo <= t < hi:
                continue
            if pending:
                key = (msg.topic, t)
                left = pending.get(key, 0)
                if left:
                    if left == 1:
                        del pending[key]
                    else:
                        pending[key] = left - 1
                    continue
            yield msg

    def windows(self, delta_ns: int) -> tuple[I64, I64]:
        """Inclusive window ranges ``[a, b]`` covered by the span runs, merged and sorted."""
        if self.run_first.size == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        a = self.run_first // np.int64(delta_ns)
        b = self.run_last // np.int64(delta_ns)
        order = np.argsort(a, kind="stable")
        a, b = a[order], np.maximum.accumulate(b[order])  # b: the furthest end so far
        new = np.concatenate([[True], a[1:] > b[:-1] + 1])  # a range not touching the last
        last = np.concatenate([new[1:], [True]])
        return a[new], b[last]

    def within_runs(self, windows: I64, delta_ns: int) -> BoolA:
        """Mask of ``windows`` (window indices) that lie inside a span run's windows."""
        w = np.asarray(windows, dtype=np.int64)
        starts, ends = self.windows(delta_ns)
        if starts.size == 0 or w.size == 0:
            return np.zeros(w.size, dtype=bool)
        k = np.searchsorted(ends, w, side="left")  # first range ending at or after w
        inside = k < ends.size
        inside[inside] = starts[k[inside]] <= w[inside]
        return inside

    def warnings(self, decoded: Iterable[str] = ()) -> list[str]:
        """One line per topic that lost messages to the rules. ``decoded``: topics whose
        messages were decoded before the rules could be applied (TF): their strays are left
        out of the time span (and their poses out of the trajectory), not of the TF buffer."""
        decoded = set(decoded)
        out = []
        for topic, n in sorted(self.out_of_range.items()):
            if n:
                out.append(
                    f"{n:,} message(s) on {topic} dropped: log time outside {TIME_RANGE_TEXT} "
                    f"(first: {utc_text(self.first_out_of_range[topic])})"
                )
        for topic, times in sorted(self.strays.items()):
            what = "ignored for the time span" if topic in decoded else "dropped"
            out.append(
                f"{times.size:,} message(s) on {topic} {what}: log time more than a day away "
                f"from the topic's other messages (first: {utc_text(int(times[0]))}; "
                "docs/ROBUSTNESS.md, time sanity)"
            )
        return out
