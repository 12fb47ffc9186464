"""The observed spans a build takes from its logs (:mod:`formats.log_zone`: the spans ``aion
convert --observed`` records beside the empty "still observing" messages it writes).

Without ``--observed`` a build counts the spans its logs record as if given by
``--observed`` (the spans of several logs together), and the empty marker messages at
:func:`formats.observed_marks.observed_stamps` of those spans as no message: a window only
markers hold counts for the share the spans cover, as ``build --observed`` counts a window
without a message, so converting with ``--observed`` and building equals converting without
it and building with ``--observed``. ``--observed`` given replaces the logs' spans (their
markers then count as any message does, as in logs converted by older aion or written by
other tools, which record no spans).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.build_options import BuildOptions
from aion_cli.engine.types import I64
from aion_cli.log_times import TimeCheck, TopicTimes
from aion_cli.manifest import Manifest

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport

Spans = tuple[tuple[int, int], ...]

NO_MARKS: I64 = np.zeros(0, np.int64)
"""No message marks a span (:func:`marker_times` of a build whose logs record none)."""
NO_MARKS.flags.writeable = False


def with_logs_observed(opts: BuildOptions) -> tuple[BuildOptions, list[str]]:
    """``opts`` with the observed spans its logs record (:func:`logs_observed`), and the
    notes to give. A part map continued (``--part --map PART``) fills with the spans its
    earlier builds stored too (its manifest: :func:`continued_manifest`), as one build given
    them all and ``aion merge`` do: an earlier span may reach past the part's logs into the
    new ones' time."""
    from aion_cli.manifest import part_spans

    observed, marked, notes = logs_observed(opts.observed, opts.logs)
    if observed and opts.part and opts.continue_from is not None:
        observed = part_spans(continued_manifest(opts.continue_from), observed)
    return replace(opts, observed=observed, observed_marked=marked), notes


def continued_manifest(path: Path) -> Manifest | None:
    """The manifest of the map at ``path`` (a part map's holds its ``observed_spans``); None
    where it cannot be read (the build's own load of the map then says why)."""
    from aion_cli.errors import AionError
    from aion_cli.formats.mapfile import read_manifest

    try:
        return Manifest.from_dict(read_manifest(path))
    except (OSError, AionError):
        return None


def logs_observed(given: Spans, logs: Sequence[Path]) -> tuple[Spans, Spans, list[str]]:
    """The spans a build declares and, of them, those whose windows the logs mark with empty
    messages (``given``: ``--observed``, which takes precedence), and the notes to give."""
    from aion_cli.formats.log_zone import declared_spans
    from aion_cli.formats.track_types import merge_spans

    recorded = declared_spans(logs)
    if not recorded:
        return given, (), []
    names = ", ".join(Path(p).name for p in recorded)
    verb = "records" if len(recorded) == 1 else "record"
    if given:
        return given, (), [
            f"--observed replaces the observed spans {names} {verb} (aion convert --observed); "
            "their empty marker messages count as any message"
        ]
    # each log's spans as it marked them (merged): a span two logs record, twice
    each = tuple(sorted(s for spans in recorded.values() for s in merge_spans(spans)))
    return tuple(merge_spans(each)), each, [
        f"{names} {verb} the spans the sensor was observing "
        "(aion convert --observed): taken as --observed spans, a window only its empty marker "
        "messages hold counting for the share the spans cover (give --observed to replace them)"
    ]


def marker_times(marked: Spans, times: TopicTimes, strays: dict[str, I64]) -> I64:
    """The log times of the messages that only mark the ``marked`` spans (sorted, a time once
    per message): the empty marker messages (each log's spans as it marked them:
    :func:`formats.observed_marks.observed_stamps` of each alone, since two logs' touching spans
    are marked apart, and a stamp two logs' overlapping spans share is two messages), and
    the scene graphs of ``times`` (``GraphTimes``: the build reads its logs' graphs;
    ``strays`` left out, as the build drops them) that share a marker's stamp: the one ``aion
    convert --graph`` writes in a log of spans without detections, at its first marker, is
    no detection message either (a graph convert writes with a detection message shares the
    detection's stamp, which then stays)."""
    from aion_cli.formats.observed_marks import observed_stamps
    from aion_cli.graph_schedule import GraphTimes

    if not marked:
        return NO_MARKS
    marks = np.sort(np.concatenate([observed_stamps([span]) for span in marked]))
    if not isinstance(times, GraphTimes):
        return marks
    graphs = times.stream_times(strays)
    out: I64 = np.sort(np.concatenate([marks, graphs[np.isin(graphs, marks)]]))
    return out


def unmarked_times(times: I64, marks: I64) -> I64:
    """``times`` (log times, any order) without one message at each of the ``marks``
    (:func:`marker_times`, sorted; a time there twice: two messages; a detection message at
    a marker's stamp stays), sorted."""
    t = np.sort(np.asarray(times, np.int64))
    if marks.size == 0 or t.size == 0:
        return t
    stamps, count = np.unique(marks[(marks >= t[0]) & (marks <= t[-1])], return_counts=True)
    lo = np.searchsorted(t, stamps, "left")
    n = np.minimum(count, np.searchsorted(t, stamps, "right") - lo)  # messages to drop there
    first = np.repeat(lo, n)
    drop = first + np.arange(first.size) - np.repeat(np.cumsum(n) - n, n)
    keep = np.ones(t.size, bool)
    keep[drop] = False
    out: I64 = t[keep]
    return out


def without_markers(times: TimeCheck, marks: I64, delta: int) -> tuple[TimeCheck, I64]:
    """``times`` without the messages that only mark spans (``marks``: :func:`marker_times`;
    :func:`unmarked_times`), and the windows of ``delta`` ns that only those held."""
    from aion_cli.formats.recorded import windows_of

    kept = unmarked_times(times.span_times, marks)
    only = np.setdiff1d(windows_of(times.span_times, delta), windows_of(kept, delta))
    return replace(times, span_times=kept, _pending=Counter()), only


def observed_fill(
    opts: BuildOptions, previous: Manifest | None, delta: int
) -> tuple[int | None, int | None]:
    """How far ``--observed`` spans may fill beyond a build's logs (windows of ``delta`` ns):
    a parallel shard's share of the time between the logs (set by its parent in
    ``opts.observed_fill``), else from :func:`fill_start` to :func:`fill_end` (the last shard
    too), so building A and B at once equals building A and continuing with B."""
    lo, hi = opts.observed_fill
    if lo is None:
        lo = fill_start(opts.observed, delta, previous, opts.part)
    if hi is None:
        hi = fill_end(opts.observed, delta, opts.part)
    return lo, hi


def fill_start(
    declared: Spans, delta: int, previous: Manifest | None, part: bool
) -> int | None:
    """The first window the ``declared`` spans may fill from: the window after a continued
    map's logs stopped (``previous.recording_reach``); for a new map the first declared
    window, so a span that starts before the first log's first message is observed whole,
    as in a log ``aion convert --observed`` wrote (its marker messages start the log's time
    at the span's start); None, from the logs' own first window: a part map (``aion
    merge`` fills the time before it from its spans, as far as the maps before it reach) and
    a continued map whose logs' reach is unknown."""
    if previous is not None:
        reach = previous.recording_reach
        return None if reach is None else reach + 1
    if part or not declared:
        return None
    return min(int(lo) for lo, _ in declared) // delta


def fill_end(declared: Spans, delta: int, part: bool) -> int | None:
    """The last window the ``declared`` spans may fill to: their last window, so a span that
    ends after the last log's last message is observed whole, as in a log ``aion convert
    --observed`` wrote (its marker messages run to the span's end), a continued map's too;
    None, to the logs' own last window: a part map (``aion merge`` fills the time after the
    last part from the parts' spans) and a build without spans."""
    if part or not declared:
        return None
    return max(-(-int(hi) // delta) for _, hi in declared) - 1


def declared_start_ns(added: I64, declared: Spans, delta: int) -> int | None:
    """Where the windows of ``delta`` ns without a message that the ``declared`` spans made
    observed (``added``, sorted) begin: the first one's start, or later where the spans
    start inside it (a span from 07:05 observes 07:00-07:10 from 07:05); None without any.
    A build's time span starts there when it is before the first message, as a log ``aion
    convert --observed`` wrote starts at its first marker, the span's start."""
    if added.size == 0 or not declared:
        return None
    begin = int(added[0]) * delta
    return max(begin, min(int(lo) for lo, hi in declared if int(hi) > begin))


def declared_end_ns(added: I64, declared: Spans, delta: int) -> int | None:
    """Where the windows of ``delta`` ns without a message that the ``declared`` spans made
    observed (``added``, sorted) end: the last one's end, or earlier where the spans end
    inside it (a span to 12:02 observes 12:00-12:10 to 12:02); None without any. A build's
    time span ends there (at its last instant, the last nanosecond before it) when that is
    after the last message, as a log ``aion convert --observed`` wrote ends at its last
    marker, the span's last instant."""
    if added.size == 0 or not declared:
        return None
    end = (int(added[-1]) + 1) * delta
    return min(end, max(int(hi) for lo, hi in declared if int(lo) < end))


def declared_span(
    start: int | None, end: int | None, report: BuildReport
) -> tuple[int | None, int | None]:
    """A build's time span from its first and last message (``start``, ``end``) and the
    windows its declared spans added (``report.declared_start_ns``, ``declared_end_ns``): a
    span declared before the first message starts it there, one declared after the last
    message ends it at its last instant."""
    first, after = report.declared_start_ns, report.declared_end_ns
    if first is not None and (start is None or first < start):
        start = first
    if after is not None and (end is None or after - 1 > end):
        end = after - 1
    return start, end
