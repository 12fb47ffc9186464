"""What a fixed sensor observed: a build's observation when its logs have no robot trajectory.

Without TF ``map -> base_link`` or a scene graph's agents, a log is a fixed sensor that saw
everything in the windows in which it recorded any message, never the time between two
recordings unless the user declared it with ``--observed``. This module finds
those windows (:func:`fixed_sensor_windows`), counts them over maps learnt in parts
(:func:`fixed_sensor_summary`, :func:`map_observation_text`) and writes and reads the
one-line description the report and the manifest carry (:func:`fixed_sensor_text`,
:func:`fixed_sensor_share`).

Why apart from :mod:`aion_cli.build_observation`, which decides *which* observation a build
has (from the TF :mod:`aion_cli.tf_feed` reads): what a fixed sensor's observation is, and how
it is described and added up across builds, merges and time shards, is a job of its own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.time_text import utc_text
from aion_cli.engine.types import I64
from aion_cli.fixed_sensor_text import (
    DECLARED,
    FIXED_SENSOR_OVER,
    SILENT_HINT,
    fixed_sensor_share,
    fixed_sensor_text,
    share_text,
    silent_advice,
)
from aion_cli.log_times import TimeCheck
from aion_cli.observed_spans import declared_windows, observed_note

if TYPE_CHECKING:
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.observation import ObservationSource

__all__ = [
    "DECLARED",
    "FIXED_SENSOR_OVER",
    "SILENT_HINT",
    "UNPOSED_NOTE",
    "fixed_sensor_share",
    "fixed_sensor_summary",
    "fixed_sensor_text",
    "fixed_sensor_windows",
    "map_observation_text",
    "recording_bounds",
    "recording_window_count",
    "share_text",
    "silent_advice",
    "unposed_note",
]


def fixed_sensor_windows(
    mapper: Mapper,
    logset: Any,
    times: TimeCheck,
    notes: list[str],
    report: Any = None,
    declared: tuple[tuple[int, int], ...] = (),
    fill: tuple[int | None, int | None] = (None, None),
    marks: I64 | None = None,
) -> str:
    """The observation of a log without a robot trajectory (neither TF nor scene-graph
    agents), from its log times: a fixed sensor observes exactly the windows in which the logs
    recorded something (any message on any topic: a tracker that publishes only when it sees
    someone still records its laser's scans) — never the time between two recordings, within
    one file or across files — so ``build A B`` records the same empty windows as ``build A``
    then ``--map B``. Only windows inside the runs of the topics aion uses count (``times``;
    one message of an unrelated topic years away must not become an observed empty window),
    plus the windows of those topics' own messages (the data, even where an index omits
    them). ``declared``: spans ``[lo, hi)`` of log time the user says the sensor was
    recording (``build --observed``, for a tracker that publishes only when it sees someone):
    their windows count too, from the first log's first recorded window to the last log's
    last, the time between the logs included; ``fill`` widens that range (a new map's first
    declared window, the window after a continued map's reach:
    :func:`aion_cli.log_observed.fill_start`; a parallel shard's share of the time between
    the logs: :func:`aion_cli.observed_spans.declared_windows`). A window a log starts or
    ends inside counts for the part of it recorded (:func:`recording_bounds`;
    ``ModelConfig.exposure``), so a four-minute log is four minutes of watching, not ten; a
    window without a message counts for the part the declared spans cover (a span to 12:02:
    0.2 of 12:00-12:10), also one only marker messages hold (``marks``:
    :func:`~aion_cli.log_observed.marker_times`). Sets the Mapper's windows, notes the windows
    left out, and returns the observation's text."""
    from aion_cli.engine.windows import window_ns
    from aion_cli.formats.recorded import windows_of
    from aion_cli.log_observed import declared_end_ns, declared_start_ns

    delta = window_ns(mapper.state.config.window_s)
    recorded = logset.recorded_windows(delta)
    recorded = recorded[times.inside_limits(recorded * delta)]  # a time shard's (window starts)
    inside = times.within_runs(recorded, delta)
    outside = int(np.count_nonzero(~inside))
    if outside:
        first = int(recorded[~inside][0]) * delta
        notes.append(
            f"{outside:,} recorded window(s) outside the time of the topics aion uses are "
            f"not taken as observed (first: {utc_text(first)})"
        )
    recorded = recorded[inside]
    if marks is not None and marks.size:  # the windows only markers hold: without a message
        from aion_cli.log_observed import without_markers

        times, only_marks = without_markers(times, marks, delta)
        recorded = np.setdiff1d(recorded, only_marks)
    read = windows_of(times.span_times, delta)  # the windows of the messages aion reads
    windows = np.union1d(recorded, read)
    spans = _file_spans(logset, times, delta) if declared or report is not None else []
    added: I64 = np.zeros(0, np.int64)
    if declared:
        extra = declared_windows(declared, spans, delta, fill)
        extra = extra[times.inside_limits(extra * delta)]
        added = np.setdiff1d(extra, windows, assume_unique=True)
        from_logs = marks is not None and marks.size > 0  # the logs' spans, not --observed
        files = len({path for path, _, _ in spans})
        notes.append(observed_note(added.size, delta, files, from_logs))
        if report is not None:  # a parallel build adds its shards' up
            report.observed_added = int(added.size)
            report.observed_from_logs = from_logs
            report.declared_start_ns = declared_start_ns(added, declared, delta)
            report.declared_end_ns = declared_end_ns(added, declared, delta)
        windows = np.union1d(windows, extra)
    within = recording_bounds(logset, times, windows, delta, read)
    lo = np.array([int(a) for a, _ in declared], np.int64)
    hi = np.array([int(b) for _, b in declared], np.int64)
    within = (np.concatenate([within[0], lo]), np.concatenate([within[1], hi]))
    mapper.set_fixed_windows(np.setdiff1d(windows, added, assume_unique=True), within)
    # a window without a message is observed for the part the spans declare, whatever file
    # was open around it (a silent tracker's open file is not its recording): a span ending
    # at 12:02 observed 0.2 of the window 12:00-12:10, as a log that stopped then did
    # (merge_observed fills the windows between part maps so too)
    mapper.set_fixed_windows(added, (lo, hi))
    if len(windows) == 0:
        return "fixed sensor (no message recorded)"
    summary = (len(windows), int(windows[0]), int(windows[-1]), delta)
    if report is not None:  # a parallel build adds its shards' windows up
        report.fixed_windows = summary
        report.recording_spans = spans
    return fixed_sensor_text(*summary, declared=bool(declared))


def unposed_log_windows(
    mapper: Mapper,
    logset: Any,
    times: TimeCheck,
    robot: Callable[[int, int], bool],
    notes: list[str],
    report: Any = None,
    whole: TimeCheck | None = None,
) -> tuple[str | None, int | None]:
    """Beside a robot's observation, the logs it does not observe: the logs, grouped as a
    parallel build groups them into shards (:func:`aion_cli.parallel_build.plan_shards`: logs
    that overlap or touch in time stay together), of which ``robot(first, last)`` (the
    group's first and last recorded window) says that the robot did not observe them (no
    pose of its TF trajectory in those windows; no agent layer in the group's first scene
    graph) are each a fixed sensor over the windows they recorded, as a build of those logs
    alone observes them (continuing a robot's map with them, a parallel shard of them): a
    log without any robot trajectory is a fixed sensor, also when another log of the build
    has one. Sets the Mapper's windows for them and returns the report's description of that
    observation, or None when the robot observes every group, and the first window of those
    groups over the whole logs (None: none); a note names those logs (a robot log whose
    localisation was not recorded is read so too).

    ``whole``: a time shard's check without its limits (``times`` is limited to the part,
    :meth:`~aion_cli.log_times.TimeCheck.limited`). A group is judged by all its windows,
    as one pass judges it, and only its windows inside the part become fixed: judged by the
    part's windows alone, a part after the robot's last pose (or before its first) read a
    group the robot observes as a fixed sensor."""
    from aion_cli.engine.windows import window_ns
    from aion_cli.formats.recorded import windows_of
    from aion_cli.parallel_build import plan_shards

    spans = logset.recording_times()
    if len(spans) < 2:
        return None, None
    delta = window_ns(mapper.state.config.window_s)
    keys = dict.fromkeys(logset.recordings)  # in the order recorded_windows_by_recording joins
    held: dict[int, I64] = {}
    names: dict[int, str] = {}
    judged: dict[int, I64] = {}  # each log's windows over the whole logs' time
    joined = logset.recorded_windows_by_recording(delta)
    for key, (file, recorded) in zip(keys, joined, strict=True):
        judged[key] = recorded[(whole or times).within_runs(recorded, delta)]
        recorded = recorded[times.inside_limits(recorded * delta)]
        held[key] = recorded[times.within_runs(recorded, delta)]
        names[key] = file.path.name
    read = windows_of(times.span_times, delta)
    parts = []
    fixed: list[str] = []
    first: int | None = None  # the first window of those groups, over the whole logs
    for group in plan_shards([(key, lo, hi) for key, (lo, hi) in spans.items()], delta):
        seen = np.concatenate([judged[key] for key in group])
        if seen.size == 0 or robot(int(seen.min()), int(seen.max())):
            continue  # the robot's poses say what these logs observed
        first = int(seen.min()) if first is None else min(first, int(seen.min()))
        recorded = np.unique(np.concatenate([held[key] for key in group]))
        if recorded.size == 0:  # (a time shard's part holds none of its windows)
            continue
        lo, hi = int(recorded[0]), int(recorded[-1])
        parts.append(np.union1d(recorded, read[(read >= lo) & (read <= hi)]))
        fixed.extend(names[key] for key in group)
    if not parts:
        return None, first
    notes.append(unposed_note(fixed))
    windows: I64 = np.unique(np.concatenate(parts))
    mapper.set_fixed_windows(windows, recording_bounds(logset, times, windows, delta, read))
    summary = (len(windows), int(windows[0]), int(windows[-1]), delta)
    if report is not None:  # a parallel build adds its shards' up (shard_reports)
        report.unposed = (fixed, summary)
    return fixed_sensor_text(*summary), first


UNPOSED_NOTE = " log(s) of other times than the robot's hold no robot pose ("


def unposed_note(names: list[str]) -> str:
    """The note naming the logs beside a robot's that are read as fixed sensors."""
    from aion_cli.listing import first_few

    return (
        f"{len(names):,}{UNPOSED_NOTE}{first_few(names, 3)}): "
        "each is treated as a fixed sensor that saw everything in the windows in which it "
        "recorded any message, as a build of it alone would (a robot log whose localisation "
        "was not recorded is read so too)"
    )


EDGE_STEPS = 60
"""A log's first and last message are placed to 1/60 of a window (10 s of the default 600 s)
when its observed share of the windows it starts and ends in is measured."""


def recording_bounds(
    logset: Any, times: TimeCheck, windows: I64, delta: int, read: I64 | None = None
) -> tuple[I64, I64]:
    """Each log file's recorded time ``[first, last)`` (the storage files of one rosbag2 bag
    are one file: ``LogSet.recorded_windows_by_recording``): from the start of the step of
    ``delta / EDGE_STEPS`` (the largest divisor of ``delta`` up to that) holding its first
    message to the end of the step holding its last, among its messages in ``windows`` (the
    observed windows: strays and other time shards' windows left out). Only a file's own start
    and end cut a window: a pause inside one file leaves the windows at its edges whole, as a
    tracker that publishes only when it sees someone stops at the last person, not when it
    stops recording (its first and last message cut the file's first and last window alone).
    In a time shard (``times.limits``) a file that recorded before or after the shard's part
    reaches to the part's edge, so every shard cuts the windows as one pass does. Read from
    the containers' indexes, like the recorded windows; extended by the runs of the messages
    the build reads (:func:`_message_runs` over ``read``, the windows holding them), which an
    index that lies cannot shorten: outward only (:func:`_beyond_files`), since a run joins
    every file's messages and must not fill the time between two files."""
    from aion_cli.formats.recorded import windows_of

    step = edge_step(delta)
    file_starts, file_ends = file_bounds(logset, windows, delta, times.limits)
    held = windows_of(times.span_times, delta) if read is None else read
    runs = np.intersect1d(held, windows)
    run_starts, run_ends = _message_runs(times.span_times, runs, delta, step)
    run_starts, run_ends = _beyond_files(run_starts, run_ends, file_starts, file_ends)
    return (
        np.concatenate([file_starts, run_starts]),
        np.concatenate([file_ends, run_ends]),
    )


def edge_step(delta: int) -> int:
    """The step a log's first and last message are placed to: ``delta / EDGE_STEPS``, or the
    largest divisor of ``delta`` up to that."""
    return next(delta // k for k in range(EDGE_STEPS, 0, -1) if delta % k == 0)


def file_bounds(
    logset: Any, windows: I64, delta: int, limits: tuple[int, int] | None = None
) -> tuple[I64, I64]:
    """Each log file's recorded time ``[first, last)`` among its messages in ``windows``, to
    the :func:`edge_step` (the part of :func:`recording_bounds` read from the containers'
    indexes alone; ``limits``: a time shard's part, which a file reaching past it fills)."""
    step = edge_step(delta)
    lo_limit, hi_limit = limits if limits is not None else (None, None)
    starts, ends = [], []
    for _file, slots in logset.recorded_windows_by_recording(step):
        inside = slots[np.isin(slots // (delta // step), windows)]
        if inside.size == 0:
            continue
        first, last = int(inside[0]) * step, (int(inside[-1]) + 1) * step
        if lo_limit is not None and int(slots[0]) * step < lo_limit:
            first = min(first, lo_limit)
        if hi_limit is not None and (int(slots[-1]) + 1) * step > hi_limit:
            last = max(last, hi_limit)
        starts.append(first)
        ends.append(last)
    return np.array(starts, np.int64), np.array(ends, np.int64)


def _beyond_files(
    run_starts: I64, run_ends: I64, file_starts: I64, file_ends: I64
) -> tuple[I64, I64]:
    """The parts of the message runs ``[run_starts, run_ends)`` before the first and after
    the last file span that overlaps each run (a whole run where none does): the messages read
    extend a file its index cuts short, but a run joins the messages of every file, so the
    time between two files in it (a log that stopped at 08:14 and the next that started at
    08:16) is not recording."""
    out_s: list[int] = []
    out_e: list[int] = []
    for rs, re in zip(run_starts.tolist(), run_ends.tolist(), strict=True):
        hit = (file_starts < re) & (file_ends > rs)
        if not hit.any():
            out_s.append(rs)
            out_e.append(re)
            continue
        lo, hi = int(file_starts[hit].min()), int(file_ends[hit].max())
        if rs < lo:
            out_s.append(rs)
            out_e.append(lo)
        if hi < re:
            out_s.append(hi)
            out_e.append(re)
    return np.array(out_s, np.int64), np.array(out_e, np.int64)


_BLOCK = 1 << 20
"""Message times handled at a time by :func:`_message_runs` (a few MB of temporaries)."""


def _message_runs(times: I64, windows: I64, delta: int, step: int) -> tuple[I64, I64]:
    """Spans ``[start, end)`` over the runs of consecutive ``windows`` (sorted; each holds
    one of ``times`` at least), each from the step of ``step`` ns holding the first of
    ``times`` in its first window to the end of the step holding the last in its last
    window (a window without one: its edge). The build's own messages: a chunk whose index
    a far message spoils (an end time past int64) records nothing from the index, and its
    log must not end there. Only the runs' first and last windows are looked at, in blocks
    of times, without sorting them."""
    w = np.asarray(windows, np.int64)
    if w.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    breaks = np.flatnonzero(np.diff(w) > 1)
    head = w[np.concatenate([[0], breaks + 1])]
    tail = w[np.concatenate([breaks, [w.size - 1]])]
    edges = np.union1d(head, tail)  # sorted: a run of one window is both
    big = np.iinfo(np.int64).max
    first, last = np.full(edges.size, big), np.full(edges.size, -1, np.int64)
    for a in range(0, times.size, _BLOCK):
        t = times[a : a + _BLOCK]
        tw = t // delta
        hit = np.isin(tw, edges)
        if hit.any():
            at = np.searchsorted(edges, tw[hit])
            np.minimum.at(first, at, t[hit])
            np.maximum.at(last, at, t[hit])
    lo, hi = first[np.searchsorted(edges, head)], last[np.searchsorted(edges, tail)]
    start = np.where(lo < big, lo // step * step, head * delta)
    end = np.where(hi >= 0, (hi // step + 1) * step, (tail + 1) * delta)
    return start.astype(np.int64), end.astype(np.int64)


def _file_spans(logset: Any, times: TimeCheck, delta: int) -> list[tuple[str, int, int]]:
    """Each log file's own time as (path, first, last window; a rosbag2 bag split into
    storage files is one): its first to its last
    recorded window inside the runs of the topics aion uses (a time shard: of its part)."""
    out = []
    for file, recorded in logset.recorded_windows_by_recording(delta):
        inside = recorded[times.within_runs(recorded, delta)]
        if inside.size:
            out.append((str(file.path), int(inside[0]), int(inside[-1])))
    return out


def recording_window_count(spans: list[tuple[str, int, int]], after: int | None = None) -> int:
    """The windows of the logs' own time: each file from its first window to its last over
    all the parts that read it (a log cut into time shards is one span again), then the
    union over files (the time between two files is not a sensor's to observe). ``after``:
    count only the windows after that one (a continued map's logs reached it already)."""
    by_file: dict[str, tuple[int, int]] = {}
    for path, first, last in spans:
        lo, hi = by_file.get(path, (first, last))
        by_file[path] = (min(lo, first), max(hi, last))
    count, reach = 0, after
    for first, last in sorted(by_file.values()):
        start = first if reach is None else max(first, reach + 1)
        if last >= start:
            count += last - start + 1
        reach = last if reach is None else max(reach, last)
    return count


def map_observation_text(texts: list[str], observation: ObservationSource, delta: int) -> str:
    """The observation of a map learnt in parts (``texts``: each part's description, in time
    order: a continued map's and its new logs', or a merge's inputs'). When every part was a
    fixed sensor, the windows it recorded are counted over the map's own fixed-sensor
    intervals (the union of every part's), so the description is the one a single build of
    every log gives; otherwise the parts' distinct descriptions, in order."""
    if texts and all(t.startswith(FIXED_SENSOR_OVER) for t in texts):
        summary = fixed_sensor_summary(observation, delta)
        if summary is not None:
            return fixed_sensor_text(*summary, declared=any(DECLARED in t for t in texts))
    distinct = list(dict.fromkeys(texts))
    return " + ".join(distinct) if distinct else "none"


def fixed_sensor_summary(
    observation: ObservationSource, delta: int
) -> tuple[int, int, int, int] | None:
    """(windows, first, last, ``delta``) of the windows of ``delta`` ns that the fixed-sensor
    intervals of ``observation`` overlap (None: it has none); a window two intervals share
    counts once."""
    starts, ends = observation.merged_fixed()
    if starts.size == 0:
        return None
    w0 = starts // np.int64(delta)
    w1 = -((-ends) // np.int64(delta))  # exclusive: ceil(end / delta)
    # sorted and disjoint in time, so only an interval's first window can be its
    # predecessor's last
    before = np.concatenate([[np.iinfo(np.int64).min], np.maximum.accumulate(w1)[:-1]])
    count = int(np.maximum(w1 - np.maximum(w0, before), 0).sum())
    return count, int(w0[0]), int(w1.max()) - 1, int(delta)
