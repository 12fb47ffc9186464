"""The time span ``aion info`` shows, without the stray log times ``aion build`` drops.

Why: one message with a damaged log time (a rosbag2 sqlite3 ``timestamp`` 100 days late) made
``info`` show a log of seconds as 100 days long, without a word, while ``build`` drops that
message by its time check (:mod:`aion_cli.log_times`: a run of at most ten messages more
than a day from its topic's others). :func:`span_without_strays` applies the same rule
(:meth:`~aion_cli.log_times.TopicTimes.check`, over every topic but static transforms, as the
build's span leaves those out) to the log times the containers' indexes give, so ``info``
shows the span the build will have and names the strays in one warning; the time recorded
leaves them out too, recording by recording (:func:`_recorded_ns`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aion_cli.engine.mapper import TIME_RANGE_TEXT
from aion_cli.engine.time_text import utc_ends, utc_text
from aion_cli.engine.types import I64


@dataclass(frozen=True)
class SpanCheck:
    """The first and last kept log time, the stray log times per topic (sorted), the log
    times outside the representable range per topic (count, first), and how long the logs
    recorded without either (the union of their recordings' spans, as
    :meth:`formats.logs.LogSet.recorded_total_ns` counts it)."""

    start_ns: int
    end_ns: int
    strays: dict[str, I64]
    recorded_ns: int
    out_of_range: dict[str, tuple[int, int]] = field(default_factory=dict)
    #: how long the recordings holding a topic recorded, for the topics whose recordings held
    #: a time left out (their rates are over it)
    topic_recorded_ns: dict[str, int] = field(default_factory=dict)
    #: every log time is left out: the span is the log's own, which no build will have
    nothing_kept: bool = False

    def warnings(self) -> list[str]:
        """One line naming every stray (topic, count, first time) and the span shown, and one
        naming every log time outside the range a build takes."""
        start, end = utc_ends(self.start_ns, self.end_ns)  # with decimals within a second
        shown = f"({start} .. {end})"
        out = []
        if self.out_of_range:
            named = "; ".join(
                f"{n:,} on {topic} (first: {utc_text(first)})"
                for topic, (n, first) in sorted(self.out_of_range.items())
            )
            if self.nothing_kept:
                return [
                    f"every log time lies outside {TIME_RANGE_TEXT}, the span shown too: "
                    f"{named}; aion build drops them all and has nothing to build from "
                    "(docs/ROBUSTNESS.md, time sanity)"
                ]
            out.append(
                f"log time(s) outside {TIME_RANGE_TEXT} left out of the span shown {shown}: "
                f"{named}; aion build drops them (docs/ROBUSTNESS.md, time sanity)"
            )
        if self.strays:
            named = "; ".join(
                f"{t.size:,} on {topic} (first: {utc_text(int(t[0]))})"
                for topic, t in sorted(self.strays.items())
            )
            out.append(
                f"stray log time(s) left out of the span shown {shown}: {named}: more than a "
                "day away from the topic's other messages; aion build drops them "
                "(docs/ROBUSTNESS.md, time sanity)"
            )
        return out


def span_without_strays(logset: Any) -> SpanCheck | None:
    """The span of ``logset``'s messages without the strays the build's time check drops,
    from the log times in the containers' indexes (no message read, nothing vouched for);
    None when there is no stray, or when an index cannot give the times."""
    from aion_cli.log_times import TopicTimes, in_range_mask

    topics = {t.topic for t in logset.topics}
    indexed = logset.index_times(topics, vouch=False) if topics else None
    if indexed is None:
        return None
    span = {t for t in topics if not t.rstrip("/").endswith("tf_static")}
    times = TopicTimes(topics)
    times.add_stream(indexed)
    checked = times.check(span, list(logset.recording_times().values()))
    out_of_range = {
        topic: (n, checked.first_out_of_range[topic])
        for topic, n in checked.out_of_range.items()
        if n
    }
    if not checked.strays and not out_of_range:
        return None
    kept = [checked.span_times]
    for topic in topics - span:  # static transforms: all their (representable) times
        t = indexed.of(topic)
        kept.append(t[in_range_mask(t)].astype(np.int64))
    joined = np.concatenate(kept)
    if joined.size == 0:  # every time left out: the log's own span shown, and said so
        if not out_of_range:
            return None
        return SpanCheck(
            int(logset.start_ns), int(logset.end_ns), checked.strays,
            int(logset.recorded_total_ns()), out_of_range, nothing_kept=True,
        )  # fmt: skip
    recorded, by_topic = _recorded_ns(logset, topics, span, checked.strays)
    return SpanCheck(
        int(joined.min()), int(joined.max()), checked.strays, recorded, out_of_range, by_topic
    )


def _recorded_ns(
    logset: Any, topics: set[str], span: set[str], strays: dict[str, I64]
) -> tuple[int, dict[str, int]]:
    """The union of the recordings' spans, a recording that holds a stray spanning its other
    messages (each recording of several logs, not only the whole set: one stray in one of
    two logs counted its year in the time recorded); and the same union per topic held by
    such a recording, over the recordings that hold the topic (its rate's time)."""
    from aion_cli.formats.log_times import covered_ns
    from aion_cli.log_times import in_range_mask

    spans = logset.recording_times()
    by_recording = logset.index_times_by_recording(topics)
    if by_recording is None:  # index_times gave the times just before: not expected
        return int(covered_ns(spans.values())), {}
    changed: set[str] = set()
    for key, part in by_recording.items():
        kept = []
        for topic in topics:
            t = part.of(topic)
            t = t[in_range_mask(t)].astype(np.int64)
            if topic in span and topic in strays:
                t = t[~np.isin(t, strays[topic])]
            kept.append(t)
        times = np.concatenate(kept) if kept else np.zeros(0, np.int64)
        if key in spans and 0 < times.size < part.t.size:
            spans[key] = (int(times.min()), int(times.max()))
            changed |= {topic for topic in topics if part.of(topic).size}
    per_topic = {
        topic: int(covered_ns(
            spans[key] for key, part in by_recording.items()
            if key in spans and part.of(topic).size
        ))
        for topic in changed
    }  # fmt: skip
    return int(covered_ns(spans.values())), per_topic
