"""Track batches -> robot-style logs (MCAP or bag) that ``aion build`` reads like any other.

:func:`tracks_to_log` turns a batch (plus optionally a Hydra graph and the observed spans,
written as empty detection messages at :func:`formats.observed_marks.observed_stamps`) into a
log of spencer ``TrackedPersons`` (serialized with numpy, :func:`tracked_person_records` /
:func:`tracked_persons_many`: a chunk's messages at once) or ``PoseArray`` messages;
:func:`stream_tracks_to_log` does the same for a file read
:data:`formats.track_csv.CHUNK_ROWS` lines at a time. Reading the files is
:mod:`formats.tracks`' job; this module only writes.
"""

from __future__ import annotations

from array import array
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.types import I64, DetectionBatch
from aion_cli.errors import InputError
from aion_cli.formats.observed_marks import _declared_metadata, _lone_graph_ns, observed_stamps
from aion_cli.formats.track_csv import CHUNK_ROWS, track_chunks
from aion_cli.formats.track_messages import (
    pose_records,
    tracked_person_records,
    tracked_persons_bytes,
    tracked_persons_many,
)
from aion_cli.formats.track_types import (
    DistinctIds,
    FarRows,
    NegativeTrackIdError,
    RepeatedRows,
    _utc,
    merge_spans,
)
from aion_cli.formats.tracks import read_tracks

SPENCER_TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"


@dataclass(frozen=True)
class TracksLogSummary:
    """What :func:`tracks_to_log` wrote: messages with detections, empty "still observing"
    messages over the ``observed`` spans, scene-graph messages, and the time span of all
    messages (``start_ns``..``end_ns``, inclusive)."""

    path: Path
    detection_messages: int
    detections: int
    graph_messages: int
    start_ns: int
    end_ns: int
    observed_messages: int = 0
    observed_spans: int = 0
    observed_ns: int = 0
    #: distinct track ids among the detections
    tracks: int = 0
    #: times of the first and the last detection (None: the log holds none)
    first_detection_ns: int | None = None
    last_detection_ns: int | None = None
    #: robot poses of the graph file's agent layer left out of the log's scene graph
    graph_agents_dropped: int = 0
    #: what reading the graph file said (a file read leniently and what it skipped)
    graph_notes: tuple[str, ...] = ()
    #: rows left out for repeating an earlier row's time and track id (of them elsewhere)
    repeated_rows: int = 0
    repeated_elsewhere: int = 0
    #: rows more than ``track_types.FAR_M`` from the origin, and the first such coordinate
    far_rows: int = 0
    far_example: float = 0.0
    #: log times of the messages on the detections topic (detections and empty marks)
    topic_times: I64 = field(default_factory=lambda: np.zeros(0, np.int64))


def _group_keys(t_ns: I64, group_ns: int, t0: int) -> I64:
    """The message each time-sorted row goes into: one message per distinct time, or per
    ``group_ns`` bin counted from ``t0`` (the first detection) when ``group_ns > 0``."""
    return t_ns if group_ns <= 0 else (t_ns - np.int64(t0)) // group_ns


def _group_bounds(t_ns: I64, group_ns: int, t0: int | None = None) -> tuple[I64, I64]:
    """Message stamps and split points of time-sorted rows (:func:`_group_keys`; a bin's
    message is stamped at its first detection)."""
    key = _group_keys(t_ns, group_ns, int(t_ns[0]) if t0 is None else t0)
    _, first = np.unique(key, return_index=True)
    return t_ns[first], first[1:]


def tracks_to_log(
    batch: DetectionBatch,
    out_path: str | Path,
    graph_file: str | Path | None = None,
    container: str = "mcap",
    topic: str = "/people_tracker/tracked_persons",
    msgtype: str = SPENCER_TRACKED,
    frame_id: str = "map",
    group_ns: int = 0,
    graph_topic: str = "/hydra/backend/dsg",
    graph_period_s: float = 60.0,
    overwrite: bool = False,
    observed: Iterable[tuple[int, int]] = (),
    headings: bool = True,
    timezone: str | None = None,
    graph_clock: bool = False,
) -> TracksLogSummary:
    """Write ``batch`` as a people-tracking log that ``aion build`` reads like a robot's.

    One ``msgtype`` message (spencer ``TrackedPersons`` with velocity from heading and speed,
    or ``PoseArray`` with the heading as yaw) per distinct timestamp, or per ``group_ns`` bin;
    positions are in ``frame_id`` (the map, so no ``/tf`` is needed). With ``graph_file``, a
    ``hydra_msgs/DsgUpdate`` carrying the whole graph (mesh included) is written with the first
    detection message and again with the first one at least ``graph_period_s`` later, so a
    reader joining late still gets it and the graph marks no time the detections do not
    (:class:`_Messages`; without detections, once at the first span's start);
    ``graph_clock=True`` writes it every ``graph_period_s`` from the first message whatever
    the messages, as a robot's Hydra does (a test's robot log).
    Unknown headings / speeds are marked with the spencer "unset" variance. ``headings=False``
    (``PoseArray`` only) writes every pose without an orientation (the all-zero quaternion),
    as an id-less detector publishes them (a leg detector's ``/leg_cluster_positions``): the
    build then has to link the detections into tracks for their directions.

    ``observed`` lists the half-open ``[start, end)`` ns spans in which the sensor was
    recording. A fixed sensor's log counts as observed only in the windows in which it holds
    a message, so over these spans empty messages (same topic and type, no people) are
    written as a running tracker publishes them, at :func:`observed_stamps` (every
    :data:`formats.observed_marks.OBSERVED_INTERVAL_NS`), merged in time order with the
    detection messages.
    Without spans only the detections are written: windows without one count as unobserved.
    The batch may be empty when spans are given (the sensor ran, nobody came).

    ``timezone`` (an IANA name): the zone the data's days and hours follow, stored in the log
    (:mod:`formats.log_zone`) so that ``aion build`` takes it without ``--tz``; the
    ``observed`` spans are stored so too, and ``aion build`` reads them as ``--observed``
    spans (:mod:`aion_cli.log_observed`), the markers kept for other readers.

    Times must lie in ``0 .. 2^63 - 1`` ns (:class:`formats.writers.LogTimeError`, raised
    before anything is written). The messages are built :data:`CHUNK_ROWS` rows at a time
    (:func:`stream_tracks_to_log` reads the file that way too).
    """
    if len(batch) == 0 and not merge_spans(observed):
        raise InputError("no detections to write", hint="the tracks file has no rows")
    data = batch.sorted_by_time()
    n, step = len(data), CHUNK_ROWS
    chunks = (data.select(np.arange(a, min(a + step, n))) for a in range(0, n, step))
    return _write_tracks(
        chunks, out_path, graph_file=graph_file, container=container, topic=topic,
        msgtype=msgtype, frame_id=frame_id, group_ns=group_ns, graph_topic=graph_topic,
        graph_period_s=graph_period_s, overwrite=overwrite, observed=observed, headings=headings,
        timezone=timezone, nobody=n == 0, graph_clock=graph_clock,
    )


def stream_tracks_to_log(
    tracks: str | Path,
    out_path: str | Path,
    layout: str = "canonical",
    start_ns: int = 0,
    rows: int | None = None,
    **options: Any,
) -> TracksLogSummary:
    """:func:`tracks_to_log` of a canonical / ATC / THÖR file (:data:`STREAM_LAYOUTS`) read
    ``rows`` lines (default :data:`CHUNK_ROWS`) at a time: memory for one chunk, whatever the
    file's length, and the same log as reading the whole file. That needs the file in time
    order, chunk after chunk (rows within a chunk may be in any order); if a chunk starts
    before the previous one ended, the partial log is thrown away and the file is read whole
    (memory ~70 bytes per row) and sorted, as :func:`read_tracks` does. ``options``: those
    of :func:`tracks_to_log`."""
    chunks = (c.sorted_by_time() for c in track_chunks(tracks, layout, start_ns, rows))
    try:
        return _write_tracks(chunks, out_path, **options)
    except _UnsortedError:
        return tracks_to_log(read_tracks(tracks, layout, start_ns), out_path, **options)


class _UnsortedError(Exception):
    """A chunk starts before the previous one ended (streamed input out of time order)."""


def _check_log_times(t_ns: I64, what: str) -> None:
    """Log times are nanoseconds since 1970 in ``0 .. 2^63 - 1`` (int64 holds no more):
    a time before 1970 is a :class:`formats.writers.LogTimeError` naming it."""
    if len(t_ns) and int(t_ns.min()) < 0:
        from aion_cli.formats.writers import MAX_LOG_TIME_NS, LogTimeError

        first = int(t_ns.min())
        raise LogTimeError(
            f"{what} have times before 1970, the first at log time {first} ns "
            f"({_utc(first)} UTC): log times are nanoseconds since 1970 in "
            f"0..{MAX_LOG_TIME_NS} (1970-01-01 to 2262-04-11)",
            hint="shift the times (--start for layouts that count from 0) or drop those rows",
        )


@dataclass
class _Messages:
    """Writes the messages of a tracks log in time order: detection messages (a group of
    rows each), the empty "still observing" messages at ``marks`` (after a detection message
    of the same time), and the scene graph with a detection message: at the first, then at
    the first one at least ``period`` ns after the graph before (so at each recorded
    session's start and about every period within it). A graph shares its stamp with a
    detection message, so it makes no window observed that the detections do not (a graph a
    robot's log holds means it was recording; one convert adds does not). Without any
    detection, the graph goes once at ``lone_graph_ns`` (a marker's stamp), if given.
    ``graph_clock``: every ``period`` ns from the first message instead, whatever the
    messages, as a robot's Hydra publishes (tests emulate such a log)."""

    writer: Any
    kind: str
    topic: str
    frame_id: str
    marks: I64
    payload: bytes | None
    graph_topic: str
    period: int
    next_mark: int = 0
    seq: int = 0  # detection and mark messages written (their ROS 1 header seq)
    lone_graph_ns: int | None = None
    graph_clock: bool = False
    graph_next: int | None = None
    graphs: int = 0
    first_ns: int | None = None
    last_ns: int | None = None
    #: 8 bytes a message (array of int64), not a Python int's 36: a streamed file's memory
    topic_times: array = field(default_factory=lambda: array("q"))

    def rows(self, data: DetectionBatch, stamps: I64, splits: I64, first_id: int) -> None:
        """One message per group of ``data`` (time-sorted rows, groups split at ``splits``
        and stamped ``stamps``); ``first_id`` numbers the rows (TrackedPerson ids)."""
        cdr = self.writer.ros_version == 2
        bounds = np.concatenate([[0], splits, [len(data)]]).tolist()
        # the markers each message follows: a message's header seq counts them too
        after = np.maximum(np.searchsorted(self.marks, stamps, "left"), self.next_mark)
        seqs = self.seq + np.arange(len(stamps)) + (after - self.next_mark)
        records = tracked_person_records(data, cdr, first_id) \
            if self.kind == SPENCER_TRACKED else pose_records(data)
        raws = tracked_persons_many(records, bounds, stamps, seqs, self.frame_id, cdr)
        for t, mark_end in zip(stamps.tolist(), after.tolist(), strict=True):
            if mark_end > self.next_mark:
                self.marks_before(t)
            self._before(t, detection=True)
            self.writer.write_raw(self.topic, self.kind, next(raws), t)
            self.seq += 1

    def marks_before(self, t: int | None) -> None:
        """The empty messages stamped before ``t`` (all that are left when None)."""
        end = len(self.marks) if t is None else int(np.searchsorted(self.marks, t, "left"))
        cdr = self.writer.ros_version == 2
        for m in self.marks[self.next_mark : end].tolist():
            self._before(m, detection=m == self.lone_graph_ns)
            none = _NO_RECORDS[cdr] if self.kind == SPENCER_TRACKED else _NO_POSES
            empty = tracked_persons_bytes(none, m, self.frame_id, cdr, self.seq)
            self.writer.write_raw(self.topic, self.kind, empty, m)
            self.seq += 1
        self.next_mark = max(self.next_mark, end)

    def _before(self, t: int, detection: bool) -> None:
        """Bookkeeping before a message at ``t``: the scene graph, if one is due and the
        message is a detection message (or the lone graph's marker)."""
        self.topic_times.append(t)
        if self.first_ns is None:
            self.first_ns = t
            self.graph_next = t if self.payload is not None else None
        self.last_ns = t
        while (detection or self.graph_clock) and self.graph_next is not None \
                and self.graph_next <= t:
            from aion_cli.formats.writers import stamp

            g = self.graph_next if self.graph_clock else t
            self.writer.write(
                self.graph_topic,
                DSG_UPDATE,
                {
                    "header": {"stamp": stamp(g), "frame_id": self.frame_id},
                    "layer_contents": self.payload,
                    "full_update": True,
                    "sequence_number": self.graphs,
                },
                g,
            )
            self.graphs += 1
            self.graph_next = g + self.period


_NO_RECORDS = {cdr: np.zeros(0, dtype=tracked_person_records(DetectionBatch.empty(), cdr).dtype)
               for cdr in (True, False)}
_NO_POSES = pose_records(DetectionBatch.empty())


def _write_tracks(
    chunks: Iterable[DetectionBatch],
    out_path: str | Path,
    graph_file: str | Path | None = None,
    container: str = "mcap",
    topic: str = "/people_tracker/tracked_persons",
    msgtype: str = SPENCER_TRACKED,
    frame_id: str = "map",
    group_ns: int = 0,
    graph_topic: str = "/hydra/backend/dsg",
    graph_period_s: float = 60.0,
    overwrite: bool = False,
    observed: Iterable[tuple[int, int]] = (),
    headings: bool = True,
    timezone: str | None = None,
    nobody: bool = False,
    graph_clock: bool = False,
) -> TracksLogSummary:
    """:func:`tracks_to_log` over time-sorted ``chunks`` (each sorted; a chunk starting
    before the previous one ended raises :class:`_UnsortedError`, the partial log thrown
    away). The rows of a chunk's last message are held back until the next chunk shows it is
    complete, so the messages are those of the concatenated rows. ``nobody``: the chunks hold
    no row (only the ``observed`` spans are marked), so the scene graph goes once, at the
    first marker, the first span's start (:class:`_Messages`). ``graph_clock``: the graph every
    ``graph_period_s`` from the first message, as a robot's Hydra publishes it."""
    from aion_cli.formats.dsg_files import graph_payload
    from aion_cli.formats.raw import normalize_msgtype
    from aion_cli.formats.writers import LogWriter, check_stamps

    kind = normalize_msgtype(msgtype)
    if kind not in (SPENCER_TRACKED, POSE_ARRAY):
        raise InputError(
            f"cannot write tracks as {msgtype!r}", hint=f"use {SPENCER_TRACKED} or {POSE_ARRAY}"
        )
    if not graph_period_s > 0:
        raise InputError(f"graph period must be > 0 s, got {graph_period_s}")
    if not headings and kind != POSE_ARRAY:  # TrackedPersons carry an id and a velocity
        raise InputError(
            f"detections without ids or headings are written as {POSE_ARRAY}, not {kind}"
        )
    spans = merge_spans(observed)
    marks = observed_stamps(spans)
    _check_log_times(marks, "the observed spans")
    def check(last_ns: int, what: str) -> None:
        """The container's limit (a scene graph's DsgUpdate messages hold the same)."""
        check_stamps(last_ns, container, what)

    if len(marks):
        check(int(marks.max()), "the observed spans")
    payload, agents, graph_notes = (
        graph_payload(graph_file) if graph_file is not None else (None, 0, ())
    )
    rows = groups = 0
    track_ids = DistinctIds()
    with LogWriter(out_path, container, overwrite=overwrite) as writer:
        declared = _declared_metadata(timezone, spans)
        if declared:  # before the first message: a ROS 1 bag's latched topics
            from aion_cli.formats.log_zone import RECORD

            writer.add_metadata(RECORD, declared)
        out = _Messages(
            writer, kind, topic, frame_id, marks, payload, graph_topic, round(graph_period_s * 1e9),
            lone_graph_ns=_lone_graph_ns(spans) if nobody else None, graph_clock=graph_clock,
        )
        held: DetectionBatch | None = None  # the rows of the last, maybe unfinished, message
        repeats, far = RepeatedRows(), FarRows()
        t0: int | None = None
        last_detection: int | None = None
        for chunk in chunks:
            if len(chunk) == 0:
                continue
            _check_chunk(chunk, kind, held)
            if not headings:  # the ids stay for counting tracks and repeats; PoseArray has none
                nan = np.full(len(chunk), np.nan)
                chunk = DetectionBatch(chunk.t_ns, chunk.xyz, nan, nan.copy(), chunk.track_id)
            far.count(chunk)
            check(int(chunk.t_ns[-1]), "the tracks")
            t0 = int(chunk.t_ns[0]) if t0 is None else t0
            last_detection = int(chunk.t_ns[-1])
            track_ids.add(chunk.track_id)
            data = chunk if held is None else DetectionBatch.concat([held, chunk])
            keys = _group_keys(data.t_ns, group_ns, t0)
            cut = int(np.searchsorted(keys, keys[-1], "left"))  # the last message's rows
            if cut > 0:  # whole messages: every row of a time is in one of them
                done = repeats.drop(data.select(np.arange(cut)))
                stamps, splits = _group_bounds(done.t_ns, group_ns, t0)
                out.rows(done, stamps, splits, rows)
                rows, groups = rows + len(done), groups + len(stamps)
            held = data.select(np.arange(cut, len(data)))
        if held is not None:
            held = repeats.drop(held)
            stamps, splits = _group_bounds(held.t_ns, group_ns, t0)
            out.rows(held, stamps, splits, rows)
            rows, groups = rows + len(held), groups + len(stamps)
        if rows == 0 and not spans:
            raise InputError("no detections to write", hint="the tracks file has no rows")
        out.marks_before(None)
    assert out.first_ns is not None
    assert out.last_ns is not None
    return TracksLogSummary(
        Path(out_path),
        groups,
        rows,
        out.graphs,
        out.first_ns,
        out.last_ns,
        observed_messages=len(marks),
        observed_spans=len(spans),
        observed_ns=sum(b - a for a, b in spans),
        tracks=len(track_ids),
        first_detection_ns=t0,
        last_detection_ns=last_detection,
        graph_agents_dropped=agents,
        graph_notes=graph_notes,
        repeated_rows=repeats.rows,
        repeated_elsewhere=repeats.elsewhere,
        far_rows=far.rows,
        far_example=far.example,
        topic_times=np.frombuffer(out.topic_times, dtype=np.int64).copy(),
    )


def _check_chunk(chunk: DetectionBatch, kind: str, held: DetectionBatch | None) -> None:
    """A chunk may be written: times in range, in order after what came before, track ids
    where TrackedPersons needs them."""
    if held is not None and int(chunk.t_ns[0]) < int(held.t_ns[-1]):
        raise _UnsortedError
    _check_log_times(chunk.t_ns, "the tracks")
    if kind == SPENCER_TRACKED and (chunk.track_id < 0).any():
        raise NegativeTrackIdError(
            f"TrackedPersons needs track ids of 0 or more, a row has {int(chunk.track_id.min())}",
            hint=f"write the rows without ids: --message-type {POSE_ARRAY}",
        )
