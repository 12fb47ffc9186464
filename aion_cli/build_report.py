"""What a build tells its caller: the :class:`BuildReport`, the :class:`ProgressSink` it
reports progress to, and the checks that turn the detection counts into the report's per-topic
counts, warnings and errors.

Why a module of its own: the CLI (``aion build``, its summary and ``--format json``) and the
Python API read the report without the build's machinery, and the rules that decide when a
build's losses are a warning and when they are its error (:func:`check_decoding`,
:func:`check_usable`, :data:`LOSS_WARN_SHARE`) live beside the fields they fill. The warnings
that judge the map as a whole (detections far from the scene graph, faster than people) are
:mod:`aion_cli.build_plausibility`'s.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from aion_cli.build_hints import no_detection_hint
from aion_cli.build_plausibility import fast_people_warning
from aion_cli.detection_feed import HEADING_SOURCES
from aion_cli.engine.detection_sketch import DetectionSketch
from aion_cli.engine.types import I64
from aion_cli.errors import InputError, LogFormatError, MessageDecodeError
from aion_cli.listing import first_few
from aion_cli.number_text import counted
from aion_cli.stamp_warnings import FAR_STAMPS, OFF_STAMPS, stamp_warnings

if TYPE_CHECKING:
    from aion_cli.detection_feed import DetectionCounts, TopicFeeders
    from aion_cli.manifest import Manifest
    from aion_cli.topics import TopicPlan

__all__ = [
    "LOSS_WARN_SHARE",
    "BuildReport",
    "NoProgress",
    "ProgressSink",
    "check_decoding",
    "check_usable",
    "record_detections",
    "topic_counts",
    "unread_detections",
]

LOSS_WARN_SHARE = 0.5
"""A detection topic that loses more than this share of the detections read from it (dropped
after decoding for any reason: no transform, a non-finite or out-of-range position, a closed
window) gets a warning with the counts, even with ``-q``. Messages that cannot be decoded, or
whose log times are stray, are warned about separately, whatever their number."""

#: Drops of detections once read (the class filter of vision_msgs is a choice, not a loss).
_DETECTION_DROPS = frozenset({"no_transform", "nan", "out_of_range", "before_window"})


class ProgressSink(Protocol):
    """Where the build reports progress (the CLI adapts a rich progress bar)."""

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        """A new phase with ``total`` ``unit`` (messages, MiB) to go."""

    def advance(self, n: int) -> None:
        """``n`` more units of the current phase are done."""


class NoProgress:
    """The progress sink of a build nobody watches (the default of ``build_map``)."""

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        return None

    def advance(self, n: int) -> None:
        return None


@dataclass
class BuildReport:
    """What a build did; ``to_dict`` is the JSON printed by ``aion build --format json``."""

    output: Path
    detections_read: int = 0
    detections_used: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    cells: int = 0
    nodes: int = 0
    nodes_with_flow: int = 0
    bound_cells: int = 0
    windows: int = 0
    hours_observed: str | None = None  # per kind of day, as aion info MAP shows them
    timezone: str = "UTC"  # the map's zone, whose clock the CLI shows the messages' times on
    start_ns: int | None = None
    end_ns: int | None = None
    map_bytes: int = 0
    observation: str = "fixed"
    graph_source: str = "none"
    graph_messages: int = 0  # graphs applied to the map (decoded or reused)
    graph_skipped: int = 0  # damaged, skipped
    graph_decoded: int = 0  # spark_dsg decodes
    graphs_skipped_identical: int = 0  # applied without decoding: the last payload again
    graphs_read_by_changes: int = 0  # of graph_decoded: only the node records changed re-read
    graphs_skipped_period: int = 0  # within --graph-period of the graph before: not applied
    graph_period_ns: int = 0
    graph_layer: str | None = None  # the navigational layer taken, e.g. "MESH_PLACES (3[1])"
    dsg_version: str | None = None
    detection_topics: list[str] = field(default_factory=list)
    graph_topics: list[str] = field(default_factory=list)
    inputs: list[dict[str, Any]] = field(default_factory=list)
    continued: bool = False
    #: detections (read, used) in the map written, a continued map's before included
    map_detections: tuple[int, int] = (0, 0)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    headings: dict[str, int] = field(default_factory=dict)
    speed_micro: int = 0  # µm/s, over the detections with a speed (DetectionCounts)
    speed_n: int = 0
    empty_messages: int = 0  # detection messages that held no detection (DetectionCounts)
    #: items a mapping's filter dropped, by the value its field held (not in the JSON; the
    #: error of a build that kept none names them: DetectionCounts.filter_seen)
    filter_seen: dict[str, int] = field(default_factory=dict)
    detection_decoding: dict[str, dict[str, Any]] = field(default_factory=dict)
    by_topic: dict[str, dict[str, Any]] = field(default_factory=dict)
    time_dropped: dict[str, dict[str, int]] = field(default_factory=dict)
    tf_undecodable: int = 0
    #: a parallel build's shards: logs, worker, seconds, peak memory, detections used
    workers: list[dict[str, Any]] = field(default_factory=list)
    fold_seconds: float = 0.0  # the parent's joins of the shards
    # per detection topic: the orientation rule's (first, last) state (DetectionFeeder.yaw_rule)
    yaw_rule: dict[str, tuple[float, float]] = field(default_factory=dict)
    # the scene-graph version and layer the stream pinned (GraphFeed.pins)
    graph_pins: tuple[str | None, str | None] = (None, None)
    #: fixed-sensor observation: (windows, first window, last window, window ns)
    fixed_windows: tuple[int, int, int, int] | None = None
    #: fixed sensor: each log file's own time, (path, first window, last window) from its
    #: first to its last recorded window (``fixed_sensor.recording_window_count`` adds them up)
    recording_spans: list[tuple[str, int, int]] = field(default_factory=list)
    #: --observed: the windows without a message its spans added (None without --observed;
    #: a parallel build adds its shards' up into one note, ``observed_spans.observed_note``)
    observed_added: int | None = None
    #: whether those spans are the ones the logs record (aion convert --observed), not
    #: --observed: the note then says the windows hold the logs' empty markers
    observed_from_logs: bool = False
    #: --observed: where the windows its spans added begin, when before the first message
    declared_start_ns: int | None = None
    declared_end_ns: int | None = None  # and end, when after the last (a shard's: its own)
    #: a robot trajectory: its windows without a detection message (None without one; a
    #: parallel build adds its shards' up into one note, ``build_observation.silent_note``)
    silent_windows: tuple[int, int] | None = None  # (windows, window ns)
    #: beside a robot: the logs it did not observe, read as fixed sensors, and their windows
    #: as ``fixed_windows`` (a parallel build names them in one note, ``shard_reports``)
    unposed: tuple[list[str], tuple[int, int, int, int]] | None = None
    #: the earliest detection time of the first batch learnt (not in the JSON): whether the
    #: logs start before a continued map's data ends (``log_order.overlap_note``)
    first_detection_ns: int | None = None
    #: the earliest time of the data a continued map's closed windows would refuse, per kind
    #: ("detection": stamps, "scene graph"; not in the JSON): a parallel build's fold checks
    #: its shards by them as a sequential build checks its batches (``shard_fold``)
    data_starts: dict[str, int] = field(default_factory=dict)
    #: per detection topic, its ``TopicCounts`` (not in the JSON): a parallel build adds its
    #: shards' up and warns of off stamps once, from the sums (``shard_reports``)
    stamp_counts: dict[str, Any] = field(default_factory=dict)
    #: a sample of the detections fed to the map (not in the JSON; the manifest's
    #: ``recordings``): whether they are a recording a map holds already (``recording_twins``)
    sketch: DetectionSketch = field(default_factory=DetectionSketch)

    def mean_speed(self) -> float | None:
        """The mean speed of the detections with one (m/s); None when none has."""
        return self.speed_micro / 1e6 / self.speed_n if self.speed_n else None

    def __repr__(self) -> str:
        """What the build did in one line (not its inputs' checksums and per-topic counts,
        which a notebook would print whole, for every log): the map, the detections used of
        those read, from how many logs, the entries and windows, and how many notes and
        warnings (:attr:`notes`, :attr:`warnings`)."""

        return (
            f"<aion.BuildReport {self.output}: {self.detections_used:,} of "
            f"{counted(self.detections_read, 'detection')} used from "
            f"{counted(len(self.inputs), 'log')}; {counted(self.nodes, 'node')}, "
            f"{counted(self.cells, 'cell')}, {counted(self.windows, 'window')}; "
            f"{counted(len(self.notes), 'note')}, {counted(len(self.warnings), 'warning')}>"
        )

    def to_dict(self) -> dict[str, Any]:
        span = (
            None
            if self.start_ns is None or self.end_ns is None
            else (self.end_ns - self.start_ns) / 1e9
        )
        return {
            "map": str(self.output),
            "map_bytes": self.map_bytes,
            "continued": self.continued,
            "detections": {
                "read": self.detections_read,
                "used": self.detections_used,
                "dropped": dict(sorted(self.dropped.items())),
            },
            "map_detections": dict(zip(("read", "used"), self.map_detections, strict=True)),
            "detections_by_topic": self.by_topic,
            "cells": self.cells,
            "nodes": self.nodes,
            "nodes_with_flow": self.nodes_with_flow,
            "bound_cells": self.bound_cells,
            "windows": self.windows,
            "hours_observed": self.hours_observed,
            "time_span": {"start_ns": self.start_ns, "end_ns": self.end_ns, "seconds": span},
            "observation": self.observation,
            "graph": {
                "source": self.graph_source,
                "layer": self.graph_layer,
                "messages": self.graph_messages,
                "skipped": self.graph_skipped,
                "decoded": self.graph_decoded,
                "skipped_identical": self.graphs_skipped_identical,
                "read_by_changes": self.graphs_read_by_changes,
                "skipped_period": self.graphs_skipped_period,
                "period_s": self.graph_period_ns / 1e9,
                "dsg_version": self.dsg_version,
                "topics": self.graph_topics,
            },
            "detection_topics": self.detection_topics,
            "detection_decoding": self.detection_decoding,
            "log_times_dropped": self.time_dropped,
            "tf_undecodable": self.tf_undecodable,
            "headings": {k: int(self.headings.get(k, 0)) for k in HEADING_SOURCES},
            "mean_speed_m_s": self.mean_speed(),
            "inputs": self.inputs,
            "workers": self.workers,
            "notes": self.notes,
            "warnings": self.warnings,
        }


def topic_counts(
    report: BuildReport,
    feeders: TopicFeeders,
    used: I64,
    mapper_drops: I64,
    total_used: int,
) -> None:
    """Per detection topic: detections read, used (``used``: per topic) and dropped (by
    reason: the feeder's, plus the Mapper's ``mapper_drops``, topic x ``DROP_REASONS``) into
    the report's ``detections_by_topic``; a topic that lost more than :data:`LOSS_WARN_SHARE`
    of the detections read from it is a warning with the counts (a build that loses most of a
    sensor must not look like a clean one; what a filter leaves out by choice, a class or a
    marker that draws no person, is no loss) — unless the build used none at all
    (``total_used``), which :func:`check_usable` makes an error."""
    from aion_cli.engine.state import DROP_REASONS

    for i, topic in enumerate(feeders.topics):
        counts = feeders.counts[topic]
        read, n_used = counts.read, int(used[i])
        dropped = Counter({k: int(v) for k, v in counts.dropped.items() if v})
        for reason, n in zip(DROP_REASONS, mapper_drops[i].tolist(), strict=True):
            if n:
                dropped[reason] += int(n)
        report.by_topic[topic] = {
            "read": read,
            "used": n_used,
            "dropped": dict(sorted(dropped.items())),
        }
        lost = sum(v for k, v in dropped.items() if k in _DETECTION_DROPS)
        if read and lost > LOSS_WARN_SHARE * read and total_used > 0:
            reasons = ", ".join(
                f"{k} {v:,}" for k, v in sorted(dropped.items()) if k in _DETECTION_DROPS
            )
            why = counts.no_transform_why if dropped.get("no_transform") else None
            report.warnings.append(
                f"{topic}: {lost:,} of its {read:,} detections ({100 * lost / read:.0f} %) "
                f"could not be used (dropped: {reasons})" + (f": {why}" if why else "")
            )


def record_detections(
    report: BuildReport, feeders: TopicFeeders, used: I64, mapper_drops: I64, plan: TopicPlan
) -> DetectionCounts:
    """The stream's totals into the report: detections read, used (``used``: per topic) and
    dropped (the feeders' reasons plus the Mapper's ``mapper_drops``), heading sources, the
    decoding checks, the per-topic counts and notes on stamps taken from log times. Returns
    the totals."""
    from aion_cli.engine.state import DROP_REASONS

    c = feeders.total()
    c.used = int(used.sum())
    for reason, n in zip(DROP_REASONS, mapper_drops.sum(axis=0).tolist(), strict=True):
        if n:
            c.dropped[reason] += int(n)
    report.detections_read = c.read
    report.detections_used = c.used
    report.dropped = dict(c.dropped)
    report.headings = dict(c.headings)
    report.speed_micro, report.speed_n = c.speed_micro, c.speed_n
    report.empty_messages = c.empty_messages
    report.filter_seen = dict(c.filter_seen)
    fast = fast_people_warning(report)
    if fast is not None:
        report.warnings.append(fast)
    for topic, feeder in feeders.feeders.items():
        report.yaw_rule.update(feeder.yaw_rule())
        if feeder.frames.unframed:
            report.notes.append(
                f"detections on {topic} name no frame (an empty frame_id): their positions "
                f"are taken as in the map frame {feeder.frames.map_frame!r}"
            )
    check_decoding(report, c, plan)
    topic_counts(report, feeders, used, mapper_drops, c.used)
    if c.stamp_fallbacks:
        report.notes.append(
            f"{counted(c.stamp_fallbacks, 'detection')} had a zero header stamp: "
            + ("its message's log time was used" if c.stamp_fallbacks == 1
               else "their messages' log times were used")
        )
    if c.log_times:
        report.notes.append(
            f"{counted(c.log_times, 'detection')} came from "
            + ("a message without a header (as mapped): its log time was used"
               if c.log_times == 1
               else "messages without a header (as mapped): their messages' log times were used")
        )
    report.stamp_counts = dict(c.topics)
    report.warnings.extend(stamp_warnings(c.topics))
    return c


def check_decoding(report: BuildReport, counts: DetectionCounts, plan: TopicPlan) -> None:
    """Per detection topic: every message undecodable is the build's error (with the first
    failure's reason); some undecodable is a warning with the counts."""
    for info in plan.detections:
        tc = counts.topics.get(info.topic)
        entry = report.detection_decoding.setdefault(info.topic, {})
        if tc is None:
            entry.update(messages=0, undecodable=0)
            continue
        entry.update(messages=tc.messages, undecodable=tc.undecodable)
        if tc.undecodable == 0:
            continue
        reason = tc.first_error or "unknown reason"
        if tc.undecodable == tc.messages:
            raise MessageDecodeError(
                f"none of the {tc.messages:,} messages on {info.topic} ({info.msgtype}) "
                f"could be decoded: {reason}",
                hint=tc.first_hint
                or "the log's definition of the type may differ from what aion reads",
            )
        report.warnings.append(
            f"{tc.undecodable:,} of {tc.messages:,} messages on {info.topic} could not be "
            f"decoded and were skipped (first: {reason})"
        )


def check_usable(
    report: BuildReport,
    counts: DetectionCounts,
    previous: Manifest | None,
    outcome: str | None = None,
    lost: tuple[int, int, list[str]] | None = None,
) -> None:
    """A build without a single usable detection is an error, never a success: it names
    what became of the detections read, and nothing is written (a continued map, whose
    manifest is ``previous``, is left as it was, its new logs not recorded, so they can be
    added once fixed). The one exception: a continued map that holds detections already may
    take logs in which nobody was seen (a note: their observed windows are real zeros), not
    logs of which no message could be read.
    ``outcome`` replaces the hint's words on the map (a reading that writes no map).
    ``lost``: (messages of the detection topics the readers could not read, the messages
    their indexes hold, the readers' warnings): when no detection was read because the
    messages were lost (damaged chunks, a truncated file), the error says so and why, not
    that the topics carry nobody."""
    c = counts
    if c.used > 0:
        return
    drops = ", ".join(f"{k} {v:,}" for k, v in sorted(c.dropped.items()) if v)
    messages = sum(t.messages for t in c.topics.values())
    before = previous.counts if previous is not None else {}
    unreadable = lost is not None and lost[0] > 0 and messages == 0  # all lost, none empty
    if int(before.get("used", 0)) > 0 and c.read == 0 and not drops and not unreadable:
        report.notes.append(
            f"no person in the {messages:,} detection messages: only observed-empty "
            "windows were added to the map"
        )
        return
    written = outcome or (
        "no map was written"
        if previous is None
        else "the map was left as it was and the logs were not added"
    )
    if c.read == 0 and lost is not None and lost[0] > 0 and lost[2]:
        from aion_cli.formats.logs import first_reasons

        raise LogFormatError(
            f"no people detection could be read: {lost[0]:,} of the {lost[1]:,} messages of "
            f"{', '.join(report.detection_topics)} were lost reading the logs"
            + first_reasons(lost[2]),
            hint=f"the logs are damaged where the reason says; {written}",
        )
    if c.passed_filters() == 0:
        # the readers' warnings (a file cut short, a damaged chunk) are printed only with a
        # map: without one, the error is the only line, so it names them (the people may be
        # in what could not be read)
        read_warnings = lost[2] if lost is not None else []
        raise InputError(
            f"no people detection in the {messages:,} messages of "
            f"{', '.join(report.detection_topics)}"
            + (f" (dropped: {drops})" if drops else "")
            + (
                f"; the logs were read with warnings ({first_few(read_warnings, 1, '; ')})"
                if read_warnings
                else ""
            ),
            hint=(
                "where a warning says a log was cut short or damaged, the people may be in "
                "what was not read; otherwise "
                if read_warnings
                else ""
            )
            + no_detection_hint(report.detection_topics, c.dropped, c.filter_seen)
            + written,
        )  # fmt: skip
    hint = written
    if c.dropped.get("no_transform"):
        why = f"{c.no_transform_why}; " if c.no_transform_why else ""
        hint = f"{why}check --map-frame and the log's TF; {hint}"
    far = (
        [w for w in report.warnings if FAR_STAMPS in w or OFF_STAMPS in w]
        if c.dropped.get("before_window")
        else []
    )
    if far:  # the stamps' clock is why: the error says so (its warning is not printed)
        hint = f"{'; '.join(far)}; {hint}"
    raise InputError(
        f"none of the {c.read:,} people detections read could be used (dropped: "
        f"{drops or 'none'})",
        hint=hint,
    )


def unread_detections(
    report: BuildReport, counts: DetectionCounts, expected: int, warnings: list[str]
) -> tuple[int, int, list[str]]:
    """``lost`` for :func:`check_usable`: the messages on the report's detection topics the
    readers could not read (the ``expected`` messages their indexes hold, less those decoded
    and those the time checks dropped on purpose), ``expected``, and the readers'
    ``warnings``, which say why."""
    topics = set(report.detection_topics)
    decoded = sum(t.messages for name, t in counts.topics.items() if name in topics)
    dropped = sum(
        sum(stats.values()) for name, stats in report.time_dropped.items() if name in topics
    )
    return expected - decoded - dropped, expected, list(warnings)
