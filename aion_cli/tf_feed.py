"""The TF feed of a build: one read of ``/tf`` and ``/tf_static`` into a ``TfBuffer``, with
the log times of every other topic the build uses taken in the same pass (and the time-sanity
rules over them, :func:`check_times`), and the observation mask they give: the robot
trajectory (``map -> base_link``), or without one the windows a fixed sensor recorded in.

Why a module of its own, beside :mod:`aion_cli.detection_feed` and
:mod:`aion_cli.graph_feed`: TF is read before the stream (the detections need their
transforms, the time-sanity rules need every log time), with its own fast decoder and its own
failure rules (:func:`check_tf`), none of which the build orchestration
(:mod:`aion_cli.pipeline`) needs to know.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import compress
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.mapper import TIME_RANGE_TEXT
from aion_cli.engine.types import I64, Trajectory
from aion_cli.errors import InputError, MessageDecodeError, TransformError
from aion_cli.graph_schedule import GraphTimes
from aion_cli.log_times import TimeCheck, TopicTimes, iso, stray_mask

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.observation import ObservationSource
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.topics import TopicPlan

FIXED_SENSOR_OVER = "fixed sensor over"
"""How the description of a fixed sensor's recorded windows starts (:func:`fixed_sensor_text`)."""

__all__ = [
    "TfReader",
    "TfStats",
    "check_tf",
    "check_times",
    "fixed_sensor_windows",
    "observe",
    "read_tf_and_times",
    "robot_trajectory",
]


@dataclass
class TfStats:
    """TF messages read and skipped as undecodable (with the first failure)."""

    messages: int = 0
    undecodable: int = 0
    first_error: MessageDecodeError | None = None


def read_tf_and_times(
    logset: Any,
    plan: TopicPlan,
    timed: set[str],
    progress: ProgressSink,
    graph_topics: set[str] | None = None,
    *,
    use_index: bool = True,
) -> tuple[TfBuffer | None, TopicTimes, TfStats]:
    """One read of the TF topics and of the other topics in ``timed`` (those the build uses):
    every TF message into one buffer, and the log time of every message of ``timed``
    (:class:`aion_cli.log_times.TopicTimes`: what the time-sanity rules are applied to).

    TF messages are decoded with numpy 4096 at a time (:mod:`formats.tf_fast`, ~50x faster
    than rosbags) where the log's definition of the TF type is the layout that decoder reads
    (:func:`formats.tf_fast.layout_matches`); messages of other topics, and a chunk the fast
    decoder rejects (e.g. big-endian CDR, a corrupt payload), are decoded message by message
    with the log's own definitions, and a message that cannot be decoded is skipped and
    counted (like a bad detection or scene-graph message). A TF message whose log time is out
    of the representable range is not decoded. The other topics' payloads are not decoded
    here. Where the logs' indexes give the log times the stream will yield
    (:meth:`formats.logs.LogSet.index_times`, ``use_index``) only the TF topics are read, and
    the other topics' times come as arrays from the index, without a message; otherwise
    every message of those topics is read with TF. With ``graph_topics`` the times are a
    :class:`GraphTimes`, which also keeps those topics' log times in read order (for
    :func:`aion_cli.graph_schedule.graph_schedule`)."""
    import logging

    from aion_cli.formats.tf import TfBuffer

    tf_topics = plan.names("tf") if plan.tf else set()
    times = (
        GraphTimes(timed | tf_topics, graph_topics)
        if graph_topics
        else TopicTimes(timed | tf_topics)
    )
    stats = TfStats()
    topics = tf_topics | timed
    if not topics:
        return None, times, stats
    indexed = logset.index_times(timed - tf_topics) if use_index and timed - tf_topics else None
    if indexed is not None:
        times.add_stream(indexed)
        topics = tf_topics
    progress.start(
        "reading TF and log times" if tf_topics else "reading log times", logset.total(topics)
    )
    reader = TfReader(logset, TfBuffer(), stats) if tf_topics else None
    buffer = reader.buffer if reader is not None else None

    def add(chunk: list[RawMessage]) -> None:
        assert reader is not None
        reader.add(chunk)

    pending: list[RawMessage] = []  # TF messages whose times are not recorded yet
    ready: list[RawMessage] = []  # TF messages in range, decoded 4096 at a time
    done = 0
    for msg in logset.messages(topics) if topics else ():
        done += 1
        if done == 4096:
            progress.advance(done)
            done = 0
        if msg.topic not in tf_topics:
            times.add(msg.topic, msg.log_time_ns)
            continue
        pending.append(msg)
        if len(pending) == 4096:
            ready += _in_range(times, pending)
            pending = []
            while len(ready) >= 4096:
                add(ready[:4096])
                ready = ready[4096:]
    ready += _in_range(times, pending)
    for start in range(0, len(ready), 4096):
        add(ready[start : start + 4096])
    progress.advance(done)
    if reader is not None and reader.generic:
        logging.getLogger(__name__).info(
            "TF: %d chunk(s) read by the generic decoder", reader.generic
        )
    return buffer, times, stats


class TfReader:
    """TF messages into ``buffer``, a chunk at a time: decoded with numpy
    (:mod:`formats.tf_fast`) where the log's definition of the TF type is the layout that
    decoder reads, else (and for a chunk it rejects) message by message with the log's own
    definitions, a message that cannot be decoded skipped and counted in ``stats``. Topics
    named ``*_static`` hold static transforms."""

    def __init__(self, logset: Any, buffer: TfBuffer, stats: TfStats) -> None:
        self.logset = logset
        self.buffer = buffer
        self.stats = stats
        self.generic = 0  # chunks read by the generic decoder
        self._fast_ok: dict[tuple[str, str, str], bool] = {}

    def _fast(self, key: tuple[str, str, str]) -> bool:
        from aion_cli.formats.tf_fast import layout_matches

        ok = self._fast_ok.get(key)
        if ok is None:
            ok = self._fast_ok[key] = layout_matches(
                key[1], key[2], *self.logset.definition(*key)
            )
        return ok

    def add(self, chunk: list[RawMessage]) -> None:
        from aion_cli.formats.tf_fast import decode_tf_messages

        stats, buffer = self.stats, self.buffer
        stats.messages += len(chunk)
        static = np.fromiter((m.topic.endswith("_static") for m in chunk), bool, len(chunk))
        try:
            if not all(map(self._fast, {(m.topic, m.msgtype, m.encoding) for m in chunk})):
                raise MessageDecodeError("the log defines TF in another layout")
            arrays = decode_tf_messages(chunk)
        except MessageDecodeError:
            self.generic += 1
            for m, st in zip(chunk, static.tolist(), strict=True):
                try:
                    decoded = self.logset.decode(m)
                except MessageDecodeError as exc:
                    stats.undecodable += 1
                    if stats.first_error is None:
                        stats.first_error = exc
                    continue
                buffer.add_message(decoded, static=st)
        else:
            rows_static = static[arrays.msg_index]
            for flag in (True, False):  # like TfBuffer's own batches: static rows first
                for parent, child, rows in arrays.select(
                    arrays.usable() & (rows_static == flag)
                ).by_edge():
                    buffer.add_transforms(
                        parent, child, rows.t_ns, rows.translation, rows.quat_xyzw, flag
                    )


def _in_range(times: TopicTimes, messages: list[RawMessage]) -> list[RawMessage]:
    """Record the log times of ``messages`` (TF, in read order) topic by topic as arrays
    (:meth:`TopicTimes.add_array`); the messages whose times are in range."""
    if not messages:
        return messages
    t = np.array([m.log_time_ns for m in messages])
    if t.dtype.kind not in "iu":  # ints beyond both int64 and uint64: one by one
        return [m for m in messages if times.add(m.topic, m.log_time_ns)]
    topics = [m.topic for m in messages]
    names = set(topics)
    if len(names) == 1:
        ok = times.add_array(topics[0], t)
    else:
        of = np.array(topics)
        ok = np.empty(len(messages), bool)
        for name in sorted(names):
            mine = of == name
            ok[mine] = times.add_array(name, t[mine])
    return messages if ok.all() else list(compress(messages, ok.tolist()))


def robot_trajectory(
    tf: TfBuffer | None, map_frame: str, base_frame: str, warnings: list[str]
) -> Trajectory | None:
    """The robot's ``map_frame -> base_frame`` poses (``--map-frame``, ``--base-frame``),
    without stray ones (the time-sanity rule of :func:`aion_cli.log_times.stray_mask` on the
    poses' own stamps: a pose a day away from the rest of the trajectory would make its far
    window an observed one)."""
    if tf is None:
        return None
    try:
        traj = tf.trajectory(map_frame, base_frame)
    except TransformError:
        return None
    if len(traj) == 0:
        return None
    t = np.asarray(traj.t_ns, dtype=np.int64)
    stray = stray_mask(t)
    if stray.any():
        warnings.append(
            f"{int(stray.sum()):,} robot pose(s) ignored: stamped more than a day away from "
            f"the rest of the trajectory (first: {iso(int(t[stray].min()))})"
        )
        keep = ~stray
        traj = Trajectory(t[keep], np.asarray(traj.xyz)[keep])
    return traj


def observe(
    mapper: Mapper,
    tf: TfBuffer | None,
    frames: tuple[str, str],
    graph_agents: Callable[[], bool],
    logset: Any,
    times: TimeCheck,
    report: BuildReport,
    declared: tuple[tuple[int, int], ...] = (),
) -> None:
    """The observation of a build, said in ``report.observation``: the robot trajectory
    ``frames`` (``--map-frame``, ``--base-frame``) from TF, added to ``mapper``; else the scene
    graphs' agent layer when the first graph has one (``graph_agents``; its poses are fed
    per snapshot); else a fixed sensor over the windows it recorded in and the ``declared``
    spans (:func:`fixed_sensor_windows`; with a robot's observation they are ignored, with
    a warning: its poses say what it saw)."""
    map_frame, base_frame = frames
    traj = robot_trajectory(tf, map_frame, base_frame, report.warnings)
    if tf is not None and traj is None:
        report.notes.append(
            f"TF has no {map_frame}->{base_frame} chain for the robot trajectory (frames: "
            f"{', '.join(sorted(tf.frames)[:12])}); see --map-frame / --base-frame"
        )
    if traj is not None:
        part = times.inside_limits(traj.t_ns)  # a time shard observes with its own poses
        if not part.all():
            traj = Trajectory(np.asarray(traj.t_ns)[part], np.asarray(traj.xyz)[part])
        mapper.add_trajectory(traj)
        report.observation = f"tf {map_frame}->{base_frame}"
        _ignored(declared, report.observation, report.warnings)
    elif graph_agents():
        report.observation = "scene-graph agent layer"  # fed per snapshot
        _ignored(declared, report.observation, report.warnings)
    else:
        report.observation = fixed_sensor_windows(
            mapper, logset, times, report.notes, report, declared
        )
        report.notes.append(
            "no robot trajectory (TF map->base_link or scene-graph agents): the log is "
            "treated as a fixed sensor that saw everything in the windows in which it "
            "recorded any message, within the time of the topics aion uses"
        )


def _ignored(declared: tuple[tuple[int, int], ...], observation: str, warnings: list[str]) -> None:
    if declared:
        warnings.append(
            f"--observed ignored: the logs have a robot trajectory ({observation}), whose "
            "poses say which places the sensor saw in each window"
        )


def check_tf(stats: TfStats, tf_topics: set[str], report: BuildReport) -> None:
    """Undecodable TF messages were skipped: a warning with the count; when none of them
    could be decoded the build stops (without its TF the map would silently change its
    frames and its observation)."""
    if stats.undecodable == 0 or stats.first_error is None:
        return
    names = ", ".join(sorted(tf_topics))
    report.tf_undecodable = stats.undecodable
    if stats.undecodable == stats.messages:
        raise MessageDecodeError(
            f"none of the {stats.messages:,} messages on {names} could be decoded: "
            f"{stats.first_error.message}",
            hint=stats.first_error.hint,
        )
    report.warnings.append(
        f"{stats.undecodable:,} of {stats.messages:,} messages on {names} could not be "
        f"decoded and were skipped (first: {stats.first_error.message})"
    )


def check_times(
    times: TopicTimes, plan: TopicPlan, timed: set[str], report: BuildReport
) -> TimeCheck:
    """The time-sanity rules (:mod:`aion_cli.log_times`) over the log times read with TF:
    their warnings and per-topic drops go to the report, and the returned
    :class:`~aion_cli.log_times.TimeCheck` filters the build's later reads. The build's time
    span comes from the topics in ``timed`` (detections, scene graphs) and the dynamic TF
    topics only: unrelated topics, ``/tf_static`` and container summaries have no say. When
    every detection message has an unrepresentable log time the build stops."""
    tf_topics = plan.names("tf") if plan.tf else set()
    span = timed | {t for t in tf_topics if not t.endswith("_static")}
    checked = times.check(span)
    report.warnings.extend(checked.warnings(decoded=tf_topics))
    report.time_dropped = {
        topic: {
            "out_of_range": int(checked.out_of_range.get(topic, 0)),
            "stray": int(checked.strays[topic].size) if topic in checked.strays else 0,
        }
        for topic in sorted(set(checked.out_of_range) | set(checked.strays))
        if checked.out_of_range.get(topic) or topic in checked.strays
    }
    detection_topics = plan.names("detections")
    dropped = sum(checked.out_of_range.get(t, 0) for t in detection_topics)
    if dropped and not any(checked.kept.get(t, 0) for t in detection_topics):
        raise InputError(
            f"every one of the {dropped:,} detection messages has a log time outside "
            f"{TIME_RANGE_TEXT} ({', '.join(sorted(detection_topics))})",
            hint="log times are nanoseconds since 1970 (UTC); the recorder's clock or the "
            "file is broken; no map was written",
        )
    return checked


def fixed_sensor_windows(
    mapper: Mapper,
    logset: Any,
    times: TimeCheck,
    notes: list[str],
    report: Any = None,
    declared: tuple[tuple[int, int], ...] = (),
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
    their windows count too, within each log file's own time (:func:`_declared_windows`).
    Sets the Mapper's windows, adds a note for windows left out, and returns the report's
    description of the observation."""
    from aion_cli.engine.windows import window_ns
    from aion_cli.formats.recorded import windows_of

    delta = window_ns(mapper.state.config.window_s)
    recorded = logset.recorded_windows(delta)
    recorded = recorded[times.inside_limits(recorded * delta)]  # a time shard's (window starts)
    inside = times.within_runs(recorded, delta)
    outside = int(np.count_nonzero(~inside))
    if outside:
        first = int(recorded[~inside][0]) * delta
        notes.append(
            f"{outside:,} recorded window(s) outside the time of the topics aion uses are "
            f"not taken as observed (first: {iso(first)})"
        )
    windows = np.union1d(recorded[inside], windows_of(times.span_times, delta))
    if declared:
        extra = _declared_windows(declared, logset, times, delta)
        added = np.setdiff1d(extra, windows, assume_unique=True)
        notes.append(
            f"--observed: {added.size:,} window(s) without a message taken as observed "
            f"({added.size * delta / 3.6e12:,.1f} h), within each log's own time"
        )
        windows = np.union1d(windows, extra)
    mapper.set_fixed_windows(windows)
    if len(windows) == 0:
        return "fixed sensor (no message recorded)"
    summary = (len(windows), int(windows[0]), int(windows[-1]), delta)
    if report is not None:  # a parallel build adds its shards' windows up
        report.fixed_windows = summary
        report.recording_spans = _file_spans(logset, times, delta)
    return fixed_sensor_text(*summary, declared=bool(declared))


def _file_spans(logset: Any, times: TimeCheck, delta: int) -> list[tuple[str, int, int]]:
    """Each log file's own time as (path, first, last window): its first to its last
    recorded window inside the runs of the topics aion uses (a time shard: of its part)."""
    out = []
    for file, recorded in logset.recorded_windows_by_file(delta):
        inside = recorded[times.within_runs(recorded, delta)]
        if inside.size:
            out.append((str(file.path), int(inside[0]), int(inside[-1])))
    return out


def recording_window_count(spans: list[tuple[str, int, int]]) -> int:
    """The windows of the logs' own time: each file from its first window to its last over
    all the parts that read it (a log cut into time shards is one span again), then the
    union over files (the time between two files is not a sensor's to observe)."""
    by_file: dict[str, tuple[int, int]] = {}
    for path, first, last in spans:
        lo, hi = by_file.get(path, (first, last))
        by_file[path] = (min(lo, first), max(hi, last))
    count, reach = 0, None
    for first, last in sorted(by_file.values()):
        start = first if reach is None else max(first, reach + 1)
        if last >= start:
            count += last - start + 1
        reach = last if reach is None else max(reach, last)
    return count


def _declared_windows(
    spans: tuple[tuple[int, int], ...], logset: Any, times: TimeCheck, delta: int
) -> I64:
    """The windows of ``delta`` ns that the spans ``[lo, hi)`` overlap within each log file's
    own time: from its first to its last recorded window inside the runs of the topics aion
    uses (so a stray message adds no decades of empty windows, and the time between two
    files stays unobserved: building A and B at once then equals building A and continuing
    with B), and within a time shard's part."""
    parts = []
    for _, first, last in _file_spans(logset, times, delta):
        for lo, hi in spans:
            a = max(int(lo) // delta, first)
            b = min(-(-int(hi) // delta) - 1, last)  # the last window [lo, hi) overlaps
            if b >= a:
                parts.append(np.arange(a, b + 1, dtype=np.int64))
    if not parts:
        return np.zeros(0, np.int64)
    out: I64 = np.unique(np.concatenate(parts))
    return out[times.inside_limits(out * delta)]


def fixed_sensor_share(observation: str, recording_windows: int | None = None) -> float | None:
    """The share of its time a fixed sensor observed, read from a description that
    :func:`fixed_sensor_text` wrote (``the N windows ... (A h of a B h span)``): of its logs'
    own time when ``recording_windows`` says how long that was (a manifest's
    ``counts.recording_windows``), else of the span; None for any other description."""
    import re

    found = re.search(r"\(([\d.,]+) h of a ([\d.,]+) h span\)", observation)
    if not observation.startswith(FIXED_SENSOR_OVER) or found is None:
        return None
    windows = re.search(r"the ([\d,]+) windows?", observation)
    if recording_windows and windows is not None:
        return min(1.0, int(windows.group(1).replace(",", "")) / int(recording_windows))
    seen, span = (float(g.replace(",", "")) for g in found.groups())
    return seen / span if span > 0 else None


SILENT_HINT = (
    "if its tracker is silent when nobody is there, declare the spans it was recording with "
    "aion build --observed"
)
"""Where a fixed sensor observed little of its span: windows without any message are
unknown, not empty, unless the user says the sensor was recording."""


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


DECLARED = "or --observed"
"""In a fixed sensor's description when ``build --observed`` declared some of its windows."""


def fixed_sensor_text(
    count: int, first: int, last: int, delta: int, declared: bool = False
) -> str:
    """The report's description of fixed-sensor observation: ``count`` windows of
    ``delta`` ns with messages (``declared``: or declared by ``--observed``), from window
    ``first`` to ``last``."""
    span = last - first + 1
    why = f"with messages {DECLARED}" if declared else "with messages"
    return (
        f"{FIXED_SENSOR_OVER} the {count:,} window{'' if count == 1 else 's'} {why} "
        f"({count * delta / 3.6e12:.1f} h of a {span * delta / 3.6e12:.1f} h span)"
    )
