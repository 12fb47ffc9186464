"""The build orchestration: logs -> scene graphs, detections and TF -> Mapper -> map file.

No click here: the CLI hands over :class:`BuildOptions` and a :class:`ProgressSink`, and gets a
:class:`BuildReport` back. Steps of :func:`build_map`:

1. open the logs (``formats.logs.open_logs``) and pick topics by type (:func:`select_topics`):
   detection topics with a supported adapter (all of them, or those named), the scene-graph
   topic(s) (``hydra_msgs/DsgUpdate``), ``/tf`` and ``/tf_static``;
2. read TF first into a ``TfBuffer``, and in the same pass the log times of every topic the
   build uses; the time-sanity rules (:mod:`aion_cli.log_times`) drop messages with stray or
   unrepresentable log times (counted, warned) and give the build's time span (from the
   messages used, never from other topics or a summary); the observation mask comes from the
   robot trajectory ``map -> base_link``, else from the scene graph's agent layer, else the
   log is treated as a fixed sensor over the windows in which it recorded any message within
   that span (the report says which);
3. with ``--derive-graph`` and no scene graph, one extra pass counts where people walk and
   :mod:`aion_cli.derive_graph` turns that into a navigational graph;
4. stream detection and scene-graph messages in log-time order: detection messages are
   collected into chunks of ``batch_size`` (flushed before every scene graph, so the Mapper sees
   everything in time order; decoded in jobs of ``batch_size`` messages however often the
   graphs come, :mod:`aion_cli.detection_feed`), decoded per topic and type with numpy,
   transformed to the map frame, given headings, and fed to the Mapper, which says per row
   what it dropped (so a topic that loses most of its detections is a warning); a continued
   map refuses data in the windows it has already closed (logs are added in time order);
5. write the map atomically (``formats.mapfile.write_map``) with a manifest recording the
   config, the inputs' provenance (path, size, sha256), the time span and the counts.

:func:`load_map` (from :mod:`aion_cli.mapquery`) reads a map back for ``predict``, ``plan``
and ``export``; :mod:`aion_cli.topics`, :mod:`aion_cli.detection_feed` and
:mod:`aion_cli.provenance` hold the steps' parts.
"""

from __future__ import annotations

import dataclasses
from array import array
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np
import numpy.typing as npt

from aion_cli.detection_feed import (
    HEADING_SOURCES,
    DetectionCounts,
    DetectionFeeder,
    chunks,
    decoded_chunks,
    log_adapters,
)
from aion_cli.detection_feed import TopicFeeders as _TopicFeeders
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.errors import (
    ConfigError,
    InputError,
    MessageDecodeError,
    TopicNotFoundError,
    TransformError,
)
from aion_cli.engine.mapper import TIME_RANGE_TEXT
from aion_cli.engine.types import I64, DetectionBatch, GraphSnapshot, Trajectory
from aion_cli.log_times import TopicTimes, iso, stray_mask
from aion_cli.mapquery import LoadedMap, load_map, state_counts
from aion_cli.provenance import provenance, provenance_size
from aion_cli.topics import TopicPlan, select_topics

if TYPE_CHECKING:
    from aion_cli.engine.mapper import Mapper
    from formats.raw import RawMessage
    from formats.tf import TfBuffer

__all__ = [
    "BuildOptions",
    "BuildReport",
    "LoadedMap",
    "ProgressSink",
    "build_map",
    "load_map",
    "select_topics",
]

MAP_SUFFIX = ".aion"

LOSS_WARN_SHARE = 0.5
"""A detection topic that loses more than this share of the detections read from it (dropped
after decoding for any reason: no transform, a non-finite or out-of-range position, a closed
window) gets a warning with the counts, even with ``-q``. Messages that cannot be decoded, or
whose log times are stray, are warned about separately, whatever their number."""

#: Drops of detections once read (the class filter of vision_msgs is a choice, not a loss).
_DETECTION_DROPS = frozenset({"no_transform", "nan", "out_of_range", "before_window"})

DEFAULT_GRAPH_PERIOD_NS = 5_000_000_000
"""``--graph-period`` default: 5 s of log time. Why: a graph matters to the map through its
place nodes, and a node takes part only once it has been stable for ``stability_s`` (30 s by
default) — cells bind to it at graph times, adding their state, never overwriting it — so a
graph used up to 5 s late shifts a bind by at most a sixth of that wait and moves no detection
out of its 600-s window's counts; a 1 Hz Hydra stream costs a fifth. Use ``0`` for every
graph."""


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


class ProgressSink(Protocol):
    """Where the build reports progress (the CLI adapts a rich progress bar)."""

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        """A new phase with ``total`` ``unit`` (messages, MiB) to go."""

    def advance(self, n: int) -> None:
        """``n`` more units of the current phase are done."""


class _NoProgress:
    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        return None

    def advance(self, n: int) -> None:
        return None


@dataclass(frozen=True)
class BuildOptions:
    """Everything ``aion build`` can be told. Empty / None fields mean "choose for me"."""

    logs: tuple[Path, ...]
    output: Path | None = None
    config: ModelConfig | None = None
    log_format: str | None = None
    detection_topics: tuple[str, ...] = ()
    graph_topic: str | None = None
    map_frame: str = "map"
    base_frame: str = "base_link"
    graph_file: Path | None = None
    nav_layer: str | None = None  # --nav-layer NAME|KEY (None: MESH_PLACES if any, else PLACES)
    derive_graph: bool = False
    continue_from: Path | None = None
    dsg_version: str | None = None
    batch_size: int = 4000
    timezone: str | None = None
    detections_mapping: Path | None = None
    #: ``--graph-period``: log time between the scene graphs a build uses (0: every one);
    #: see :func:`graph_schedule`
    graph_period_ns: int = DEFAULT_GRAPH_PERIOD_NS
    #: internal switch (tests): a payload identical to the last decoded one reuses its graph
    #: instead of being decoded again (same map either way)
    skip_identical_graphs: bool = True

    def output_path(self) -> Path:
        """``-o``, else the continued map, else the first log's name with ``.aion``."""
        if self.output is not None:
            return self.output
        if self.continue_from is not None:
            return self.continue_from
        first = self.logs[0]
        base = first.parent / (first.name.rstrip("/") if first.is_dir() else first.stem)
        return base.with_name(base.name + MAP_SUFFIX)


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
    start_ns: int | None = None
    end_ns: int | None = None
    map_bytes: int = 0
    observation: str = "fixed"
    graph_source: str = "none"
    graph_messages: int = 0  # graphs applied to the map (decoded or reused)
    graph_skipped: int = 0  # damaged, skipped
    graph_decoded: int = 0  # spark_dsg decodes
    graphs_skipped_identical: int = 0  # applied without decoding: the last payload again
    graphs_skipped_period: int = 0  # within --graph-period of the graph before: not applied
    graph_period_ns: int = 0
    graph_layer: str | None = None  # the navigational layer taken, e.g. "MESH_PLACES (3[1])"
    dsg_version: str | None = None
    detection_topics: list[str] = field(default_factory=list)
    graph_topics: list[str] = field(default_factory=list)
    inputs: list[dict[str, Any]] = field(default_factory=list)
    continued: bool = False
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    headings: dict[str, int] = field(default_factory=dict)
    detection_decoding: dict[str, dict[str, Any]] = field(default_factory=dict)
    by_topic: dict[str, dict[str, Any]] = field(default_factory=dict)
    time_dropped: dict[str, dict[str, int]] = field(default_factory=dict)
    tf_undecodable: int = 0

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
            "detections_by_topic": self.by_topic,
            "cells": self.cells,
            "nodes": self.nodes,
            "nodes_with_flow": self.nodes_with_flow,
            "bound_cells": self.bound_cells,
            "windows": self.windows,
            "time_span": {"start_ns": self.start_ns, "end_ns": self.end_ns, "seconds": span},
            "observation": self.observation,
            "graph": {
                "source": self.graph_source,
                "layer": self.graph_layer,
                "messages": self.graph_messages,
                "skipped": self.graph_skipped,
                "decoded": self.graph_decoded,
                "skipped_identical": self.graphs_skipped_identical,
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
            "inputs": self.inputs,
            "notes": self.notes,
            "warnings": self.warnings,
        }


# -- the build ---------------------------------------------------------------------------------
class _GraphTimes(TopicTimes):
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


@dataclass
class _TfStats:
    """TF messages read and skipped as undecodable (with the first failure)."""

    messages: int = 0
    undecodable: int = 0
    first_error: MessageDecodeError | None = None


def _read_tf_and_times(
    logset: Any,
    plan: TopicPlan,
    timed: set[str],
    progress: ProgressSink,
    graph_topics: set[str] | None = None,
) -> tuple[TfBuffer | None, TopicTimes, _TfStats]:
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
    here: MCAP chunks interleave topics, so reading them with TF costs little more than TF.
    With ``graph_topics`` the times are a :class:`_GraphTimes`, which also keeps those topics'
    log times in read order (for :func:`graph_schedule`)."""
    import logging

    from formats.tf import TfBuffer
    from formats.tf_fast import decode_tf_messages, layout_matches

    tf_topics = plan.names("tf") if plan.tf else set()
    times = (
        _GraphTimes(timed | tf_topics, graph_topics)
        if graph_topics
        else TopicTimes(timed | tf_topics)
    )
    stats = _TfStats()
    topics = tf_topics | timed
    if not topics:
        return None, times, stats
    progress.start(
        "reading TF and log times" if tf_topics else "reading log times", logset.total(topics)
    )
    buffer = TfBuffer() if tf_topics else None
    generic = 0
    fast_ok: dict[tuple[str, str, str], bool] = {}

    def fast(m: RawMessage) -> bool:
        key = (m.topic, m.msgtype, m.encoding)
        ok = fast_ok.get(key)
        if ok is None:
            ok = fast_ok[key] = layout_matches(m.msgtype, m.encoding, *logset.definition(*key))
        return ok

    def add(chunk: list[RawMessage]) -> None:
        nonlocal generic
        assert buffer is not None
        stats.messages += len(chunk)
        static = np.fromiter((m.topic.endswith("_static") for m in chunk), bool, len(chunk))
        try:
            if not all(map(fast, chunk)):
                raise MessageDecodeError("the log defines TF in another layout")
            arrays = decode_tf_messages(chunk)
        except MessageDecodeError:
            generic += 1
            for m, st in zip(chunk, static.tolist(), strict=True):
                try:
                    decoded = logset.decode(m)
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

    chunk: list[RawMessage] = []
    done = 0
    for msg in logset.messages(topics):
        done += 1
        if done == 4096:
            progress.advance(done)
            done = 0
        if not times.add(msg.topic, msg.log_time_ns) or msg.topic not in tf_topics:
            continue
        chunk.append(msg)
        if len(chunk) == 4096:
            add(chunk)
            chunk = []
    if chunk:
        add(chunk)
    progress.advance(done)
    if generic:
        logging.getLogger(__name__).info("TF: %d chunk(s) read by the generic decoder", generic)
    return buffer, times, stats


def _robot_trajectory(
    tf: TfBuffer | None, opts: BuildOptions, warnings: list[str]
) -> Trajectory | None:
    """The robot's ``map_frame -> base_frame`` poses, without stray ones (the time-sanity
    rule of :func:`aion_cli.log_times.stray_mask` on the poses' own stamps: a pose a day
    away from the rest of the trajectory would make its far window an observed one)."""
    if tf is None:
        return None
    try:
        traj = tf.trajectory(opts.map_frame, opts.base_frame)
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


class _Build:
    """One run of ``aion build`` (state shared by the phases)."""

    def __init__(self, opts: BuildOptions, progress: ProgressSink) -> None:
        self.opts = opts
        self.progress = progress
        self.counts = DetectionCounts()
        self.report = BuildReport(output=opts.output_path())
        self.previous: LoadedMap | None = None
        self.dsg_version = opts.dsg_version
        self._nav_pin: str | None = None  # the layer key the log's first graph chose
        self._agents_until = np.iinfo(np.int64).min
        self._first_graph_error: MessageDecodeError | None = None
        self._graph_used: npt.NDArray[np.bool_] | None = None  # graph_schedule (None: all)
        self._last_graph: tuple[bytes, GraphSnapshot] | None = None  # payload, snapshot
        self._first_graph: tuple[str, int, GraphSnapshot] | None = None  # decoded early
        self._adapters: dict[tuple[str, str, str], Any] = {}
        self._factory: Any = None
        self._logs: tuple[Path, ...] = tuple(opts.logs)  # the distinct logs (by sha256)
        self._times = TopicTimes(()).check(())
        self._map_open: int | None = None  # a continued map's open window when loaded
        self._used = np.zeros(0, np.int64)  # detections used, per detection topic
        self._mapper_drops = np.zeros((0, 0), np.int64)  # per topic x DROP_REASONS

    def config(self) -> ModelConfig:
        """The model config: ``--config`` (or the defaults) with ``--tz`` as its time zone
        for a new map; the map's own for a continued one (which neither may change)."""
        given = self.opts.config
        zone = self.opts.timezone
        if self.previous is None:
            config = given or ModelConfig()
            if zone is None or zone == config.timezone:
                return config
            if given is not None and given.timezone != ModelConfig().timezone:
                raise ConfigError(
                    f"--tz {zone} differs from the config's timezone {given.timezone}",
                    hint="give the zone once, with --tz or in the config file",
                )
            return config.replace(timezone=zone)
        old = self.previous.config
        if given is not None and given != old:
            raise ConfigError(
                "--config differs from the config the map was built with",
                hint="a map keeps its model parameters; build a new map to change them",
            )
        if zone is not None and zone != old.timezone:
            raise ConfigError(
                f"the map's days and profiles follow the time zone {old.timezone}; "
                f"--tz {zone} differs",
                hint="a map keeps its time zone; build a new map to change it",
            )
        return old

    def run(self) -> BuildReport:
        """The build, holding the output map's lock from start to end."""
        from formats.mapfile import MapWriteError, check_map_target, map_lock

        out = self.report.output
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise MapWriteError(
                f"cannot write map {out}: folder {folder} does not exist",
                hint="create the folder first or choose another output path",
            )
        resolved = out.resolve()
        if any(resolved == p.resolve() for p in self.opts.logs):
            raise InputError(
                f"the map would overwrite the log {out}",
                hint="choose another output with -o (maps end in .aion)",
            )
        check_map_target(out)  # a device, FIFO or foreign file fails now, not after hashing
        # Held from reading a continued map to writing the result: two builds extending the
        # same map would otherwise both start from the old map, and the later write would
        # silently drop the other build's logs.
        with map_lock(out):
            return self._run()

    def _run(self) -> BuildReport:
        from aion_cli.engine.mapper import Mapper
        from formats.logs import open_logs

        opts = self.opts
        if opts.continue_from is not None:
            self.previous = load_map(opts.continue_from, writable=True)
            self.report.continued = True
            self._map_open = self.previous.state.open_window
        config = self.config()
        inputs = self._inputs()
        out = self.report.output
        if out.exists() and self.previous is None:
            self.report.notes.append(
                f"{out.name} existed and is replaced (use --map {out.name} to extend a map)"
            )
        mappings = _load_mappings(opts.detections_mapping)
        with open_logs(list(self._logs), opts.log_format) as logset:
            plan = select_topics(
                logset.topics, opts.detection_topics, opts.graph_topic, mappings
            )
            if not plan.detections:
                raise _no_detection_topic(logset, plan)
            self.report.detection_topics = sorted(plan.names("detections"))
            self.report.notes.extend(getattr(logset, "warnings", []))
            self._adapters, self._factory, notes = log_adapters(
                logset, plan.detections, plan.mappings
            )
            self.report.notes.extend(notes)
            self.report.detection_decoding = {
                info.topic: {
                    "type": info.msgtype,
                    "why": plan.reasons.get(info.topic, ""),
                    "decoder": self._adapters[info.topic, info.msgtype, info.encoding].kind,
                }
                for info in plan.detections
            }
            mapper = Mapper(config, self.previous.state if self.previous else None)
            tf = self._read_times(logset, plan)
            self._observation(mapper, tf, plan, logset)
            fixed_graph = self._fixed_graph(logset, plan, tf, config)
            if fixed_graph is not None:
                mapper.add_graph(fixed_graph)
            self._stream(logset, plan, tf, mapper, fixed_graph is not None)
            end = self._times.end_ns
            if end is not None:
                # the last message aion uses, never a container's summary or another topic
                mapper.advance(end)
            self._span()
            # readers also warn while streaming (a corrupt chunk ends a file early)
            self.report.notes.extend(w for w in logset.warnings if w not in self.report.notes)
        self._write(mapper, config, inputs)
        return self.report

    def _read_times(self, logset: Any, plan: TopicPlan) -> TfBuffer | None:
        """TF into a buffer and the log times of every topic the build uses, then the
        time-sanity rules (:mod:`aion_cli.log_times`) over them: their warnings go to the
        report, and :attr:`_times` filters the later reads. The build's time span comes from
        the detection, scene-graph and (dynamic) TF topics only: unrelated topics and
        container summaries have no say."""
        graphs = plan.names("graph") if self.opts.graph_file is None else set()
        timed = plan.names("detections") | graphs
        thinned = graphs if self.opts.graph_period_ns > 0 else set()
        tf, times, stats = _read_tf_and_times(logset, plan, timed, self.progress, thinned)
        tf_topics = plan.names("tf") if plan.tf else set()
        span = timed | {t for t in tf_topics if not t.endswith("_static")}
        self._times = times.check(span)
        if isinstance(times, _GraphTimes):
            from aion_cli.engine.windows import window_ns

            self._graph_used = graph_schedule(
                times.stream_times(self._times.strays),
                self.opts.graph_period_ns,
                window_ns(self.config().window_s),
            )
        self.report.warnings.extend(self._times.warnings(decoded=tf_topics))
        self.report.time_dropped = {
            topic: {
                "out_of_range": int(self._times.out_of_range.get(topic, 0)),
                "stray": int(self._times.strays[topic].size) if topic in self._times.strays else 0,
            }
            for topic in sorted(set(self._times.out_of_range) | set(self._times.strays))
            if self._times.out_of_range.get(topic) or topic in self._times.strays
        }
        detection_topics = plan.names("detections")
        dropped = sum(self._times.out_of_range.get(t, 0) for t in detection_topics)
        if dropped and not any(self._times.kept.get(t, 0) for t in detection_topics):
            raise InputError(
                f"every one of the {dropped:,} detection messages has a log time outside "
                f"{TIME_RANGE_TEXT} ({', '.join(sorted(detection_topics))})",
                hint="log times are nanoseconds since 1970 (UTC); the recorder's clock or the "
                "file is broken; no map was written",
            )
        self._check_tf(stats, tf_topics)
        return tf

    def _check_tf(self, stats: _TfStats, tf_topics: set[str]) -> None:
        """Undecodable TF messages were skipped: a warning with the count; when none of them
        could be decoded the build stops (without its TF the map would silently change its
        frames and its observation)."""
        if stats.undecodable == 0 or stats.first_error is None:
            return
        names = ", ".join(sorted(tf_topics))
        self.report.tf_undecodable = stats.undecodable
        if stats.undecodable == stats.messages:
            raise MessageDecodeError(
                f"none of the {stats.messages:,} messages on {names} could be decoded: "
                f"{stats.first_error.message}",
                hint=stats.first_error.hint,
            )
        self.report.warnings.append(
            f"{stats.undecodable:,} of {stats.messages:,} messages on {names} could not be "
            f"decoded and were skipped (first: {stats.first_error.message})"
        )

    def _inputs(self) -> list[dict[str, Any]]:
        """Provenance of the logs (checked, then hashed): a log given twice, or a byte-identical
        copy, is used once (a note); a log the continued map holds already is an error."""
        for path in self.opts.logs:
            _check_log_path(path)
        sizes = [provenance_size(p) for p in self.opts.logs]
        self.progress.start("hashing logs", max(sum(sizes) >> 20, 1), "MiB")
        new: list[dict[str, Any]] = []
        logs: list[Path] = []
        first_of: dict[str, str] = {}
        for path, size in zip(self.opts.logs, sizes, strict=True):
            entry = provenance(path)
            self.progress.advance(size >> 20)
            seen = first_of.get(entry["sha256"])
            if seen is not None:
                self.report.notes.append(
                    f"{path} is the same log as {seen} (same sha256): it is used once"
                )
                continue
            first_of[entry["sha256"]] = str(path)
            new.append(entry)
            logs.append(path)
        self._logs = tuple(logs)
        old = list(self.previous.manifest.get("inputs", [])) if self.previous else []
        known = {entry.get("sha256") for entry in old}
        for entry in new:
            if entry["sha256"] in known:
                raise InputError(
                    f"{entry['name']} is already in the map (same sha256)",
                    hint="each log may be added to a map only once",
                )
        self.report.inputs = new
        return old + new

    def _observation(
        self, mapper: Mapper, tf: TfBuffer | None, plan: TopicPlan, logset: Any
    ) -> None:
        traj = _robot_trajectory(tf, self.opts, self.report.warnings)
        if tf is not None and traj is None:
            frames = ", ".join(sorted(tf.frames)[:12])
            self.report.notes.append(
                f"TF has no {self.opts.map_frame}->{self.opts.base_frame} chain for the robot "
                f"trajectory (frames: {frames}); see --map-frame / --base-frame"
            )
        if traj is not None:
            mapper.add_trajectory(traj)
            self.report.observation = f"tf {self.opts.map_frame}->{self.opts.base_frame}"
        elif plan.graph and self.opts.graph_file is None and self._graph_has_agents(logset, plan):
            self.report.observation = "scene-graph agent layer"  # fed per snapshot
        else:
            self.report.observation = self._fixed_sensor_windows(mapper, logset)
            self.report.notes.append(
                "no robot trajectory (TF map->base_link or scene-graph agents): the log is "
                "treated as a fixed sensor that saw everything in the windows in which it "
                "recorded any message, within the time of the topics aion uses"
            )

    def _fixed_sensor_windows(self, mapper: Mapper, logset: Any) -> str:
        """A fixed sensor observes exactly the windows in which the logs recorded something
        (any message on any topic: a tracker that publishes only when it sees someone still
        records its laser's scans) — never the time between two recordings, within one file
        or across files — so ``build A B`` records the same empty windows as ``build A`` then
        ``--map B``. Only windows inside the runs of the topics aion uses count (one message
        of an unrelated topic years away must not become an observed empty window), plus the
        windows of those topics' own messages (the data, even where an index omits them).
        Returns the report's description of the observation."""
        from aion_cli.engine.windows import window_ns
        from formats.recorded import windows_of

        delta = window_ns(mapper.state.config.window_s)
        recorded = logset.recorded_windows(delta)
        inside = self._times.within_runs(recorded, delta)
        outside = int(np.count_nonzero(~inside))
        if outside:
            first = int(recorded[~inside][0]) * delta
            self.report.notes.append(
                f"{outside:,} recorded window(s) outside the time of the topics aion uses are "
                f"not taken as observed (first: {iso(first)})"
            )
        windows = np.union1d(recorded[inside], windows_of(self._times.span_times, delta))
        mapper.set_fixed_windows(windows)
        if len(windows) == 0:
            return "fixed sensor (no message recorded)"
        span = int(windows[-1] - windows[0] + 1)
        return (
            f"fixed sensor over the {len(windows):,} windows with messages "
            f"({len(windows) * delta / 3.6e12:.1f} h of a {span * delta / 3.6e12:.1f} h span)"
        )

    def _graph_has_agents(self, logset: Any, plan: TopicPlan) -> bool:
        """Whether the first scene graph of the log carries robot poses (its agent layer).
        Its snapshot is kept for the stream, which then does not decode it again."""
        first = next(iter(self._times.filter(logset.messages(plan.names("graph")))), None)
        if first is None:
            return False
        snapshot = self._decode_graph(logset, first)
        self._first_graph = (first.topic, first.log_time_ns, snapshot)
        agents = snapshot.agents
        return agents is not None and len(agents) > 0

    def _fixed_graph(
        self, logset: Any, plan: TopicPlan, tf: TfBuffer | None, config: ModelConfig
    ) -> GraphSnapshot | None:
        """The graph from ``--graph FILE`` or ``--derive-graph`` (added once, at the start)."""
        opts = self.opts
        start = self._times.start_ns
        if start is None:
            start = int(logset.start_ns)
        if opts.graph_file is not None:
            from formats.dsg import load_graph

            if plan.graph:
                self.report.notes.append("--graph given: scene graphs in the log are ignored")
                plan.graph = []
            self.report.graph_source = f"file {opts.graph_file.name}"
            loaded = load_graph(opts.graph_file, start, opts.nav_layer)
            self.report.graph_layer = str(loaded.nav.layer)
            self.report.notes.extend(loaded.notes())
            return loaded.snapshot
        if plan.graph:
            self.report.graph_source = "log"
            self.report.graph_topics = sorted(plan.names("graph"))
            if opts.derive_graph:
                self.report.notes.append("--derive-graph ignored: the log has scene graphs")
            return None
        if opts.nav_layer is not None:
            self.report.notes.append("--nav-layer ignored: no scene graph is read")
        if self.previous is not None and self.previous.graph is not None:
            self.report.graph_source = "continued map"
            return None
        if not opts.derive_graph:
            self.report.notes.append(
                "no scene graph: flows are kept on hash cells (try --graph FILE or --derive-graph)"
            )
            return None
        self.report.graph_source = "derived from walking people"
        return self._derive(logset, plan, tf, config, start)

    def _derive(
        self, logset: Any, plan: TopicPlan, tf: TfBuffer | None, config: ModelConfig, start: int
    ) -> GraphSnapshot:
        from aion_cli.derive_graph import OccupancyGrid

        grid = OccupancyGrid(config.derive_spacing)
        scratch = DetectionCounts()
        feeder = self._feeder(tf, scratch, link=False)
        topics = plan.names("detections")
        self.progress.start("deriving graph", logset.total(topics))
        messages = self._times.filter(logset.messages(topics))
        for chunk, _ in chunks(messages, set(), self.opts.batch_size):
            grid.add(feeder.decode(chunk).xyz)
            self.progress.advance(len(chunk))
        graph = grid.graph(config.derive_min_detections, start)
        if len(graph.places) == 0:
            self.report.notes.append(
                "--derive-graph: no grid cell reached derive_min_detections; no graph derived"
            )
        return graph

    def _feeder(
        self, tf: TfBuffer | None, counts: DetectionCounts, link: bool = True
    ) -> DetectionFeeder:
        """A feeder with the adapters chosen for the log's detection topics; ``link``: link
        id-less detections into tracks (headings from motion)."""
        return DetectionFeeder(
            tf, self.opts.map_frame, counts, self._adapters, self._factory, linker=link
        )

    def _stream(
        self, logset: Any, plan: TopicPlan, tf: TfBuffer | None, mapper: Mapper, fixed: bool
    ) -> None:
        feeders = _TopicFeeders(
            lambda counts: self._feeder(tf, counts), sorted(plan.names("detections"))
        )
        from aion_cli.engine.state import DROP_REASONS

        self._used = np.zeros(len(feeders.topics), np.int64)
        self._mapper_drops = np.zeros((len(feeders.topics), len(DROP_REASONS)), np.int64)
        graph_topics = plan.names("graph")
        topics = plan.names("detections") | graph_topics
        self.progress.start("building map", logset.total(topics))
        use_agents = self.report.observation.startswith("scene-graph")
        messages = self._thin_graphs(self._times.filter(logset.messages(topics)), graph_topics)
        stream = chunks(messages, graph_topics, self.opts.batch_size)
        # duck-typed: decoded_chunks only calls decode()
        for batch, n_messages, graph_msg in decoded_chunks(stream, cast(Any, feeders)):
            if batch is not None:
                self._feed(mapper, batch, feeders.topics_of(batch))
                self.progress.advance(n_messages)
            if graph_msg is not None:
                self._take_graph(logset, mapper, graph_msg, use_agents)
                self.progress.advance(1)
        self._check_graph_skips()
        c = self.counts = feeders.total()
        c.used = int(self._used.sum())
        for reason, n in zip(DROP_REASONS, self._mapper_drops.sum(axis=0).tolist(), strict=True):
            if n:
                c.dropped[reason] += int(n)
        self.report.detections_read = c.read
        self.report.detections_used = c.used
        self.report.dropped = dict(c.dropped)
        self.report.headings = dict(c.headings)
        self._check_decoding(plan)
        self._topic_counts(feeders)
        if c.stamp_fallbacks:
            self.report.notes.append(
                f"{c.stamp_fallbacks:,} detections had a zero header stamp: their messages' "
                "log times were used"
            )
        if c.log_times:
            self.report.notes.append(
                f"{c.log_times:,} detections came from messages without a header (as mapped): "
                "their messages' log times were used"
            )
        self._check_usable()
        if use_agents and self.report.graph_messages == 0:
            self.report.observation = self._fixed_sensor_windows(mapper, logset)

    def _topic_counts(self, feeders: _TopicFeeders) -> None:
        """Per detection topic: detections read, used and dropped (by reason) into the
        report's ``detections_by_topic``; a topic that lost more than
        :data:`LOSS_WARN_SHARE` of the detections read from it is a warning with the counts
        (a build that loses most of a sensor must not look like a clean one)."""
        from aion_cli.engine.state import DROP_REASONS

        for i, topic in enumerate(feeders.topics):
            counts = feeders.counts[topic]
            read, used = counts.read, int(self._used[i])
            dropped = Counter({k: int(v) for k, v in counts.dropped.items() if v})
            for reason, n in zip(DROP_REASONS, self._mapper_drops[i].tolist(), strict=True):
                if n:
                    dropped[reason] += int(n)
            self.report.by_topic[topic] = {
                "read": read,
                "used": used,
                "dropped": dict(sorted(dropped.items())),
            }
            lost = read - used
            if read and lost > LOSS_WARN_SHARE * read and self.counts.used > 0:
                reasons = ", ".join(
                    f"{k} {v:,}" for k, v in sorted(dropped.items()) if k in _DETECTION_DROPS
                )
                self.report.warnings.append(
                    f"{topic}: {lost:,} of its {read:,} detections ({100 * lost / read:.0f} %) "
                    f"could not be used (dropped: {reasons})"
                )

    def _check_decoding(self, plan: TopicPlan) -> None:
        """Per detection topic: every message undecodable is the build's error (with the first
        failure's reason); some undecodable is a warning with the counts."""
        for info in plan.detections:
            tc = self.counts.topics.get(info.topic)
            entry = self.report.detection_decoding.setdefault(info.topic, {})
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
            self.report.warnings.append(
                f"{tc.undecodable:,} of {tc.messages:,} messages on {info.topic} could not be "
                f"decoded and were skipped (first: {reason})"
            )

    def _check_usable(self) -> None:
        """A build without a single usable detection is an error, never a success: it names
        what became of the detections read, and nothing is written (a continued map is left
        as it was, its new logs not recorded, so they can be added once fixed). The one
        exception: a continued map that holds detections already may take logs in which
        nobody was seen (a note: their observed windows are real zeros)."""
        c = self.counts
        if c.used > 0:
            return
        drops = ", ".join(f"{k} {v:,}" for k, v in sorted(c.dropped.items()) if v)
        messages = sum(t.messages for t in c.topics.values())
        before = self.previous.manifest.get("counts", {}) if self.previous is not None else {}
        if int(before.get("used", 0)) > 0 and c.read == 0 and not drops:
            self.report.notes.append(
                f"no person in the {messages:,} detection messages: only observed-empty "
                "windows were added to the map"
            )
            return
        written = (
            "no map was written"
            if self.previous is None
            else "the map was left as it was and the logs were not added"
        )
        if c.read == 0:
            raise InputError(
                f"no people detection in the {messages:,} messages of "
                f"{', '.join(self.report.detection_topics)}"
                + (f" (dropped: {drops})" if drops else ""),
                hint="the topics carry no detections (check the class filter of vision_msgs, "
                f"or choose other topics with --detections-topic); {written}",
            )
        hint = written
        if c.dropped.get("no_transform"):
            hint = f"check --map-frame and the log's TF; {hint}"
        raise InputError(
            f"none of the {c.read:,} people detections read could be used (dropped: "
            f"{drops or 'none'})",
            hint=hint,
        )

    def _add_agent_poses(self, mapper: Mapper, agents: Trajectory | None) -> None:
        """Feed the robot poses of a snapshot's agent layer that are newer than those fed
        before (every Hydra snapshot repeats the whole trajectory)."""
        if agents is None or len(agents) == 0:
            return
        t = np.asarray(agents.t_ns, dtype=np.int64)
        new = t > self._agents_until
        if new.any():
            mapper.add_trajectory(Trajectory(t[new], np.asarray(agents.xyz)[new]))
            self._agents_until = int(t[new].max())

    def _feed(self, mapper: Mapper, batch: DetectionBatch, topics: I64) -> None:
        """Detections to the Mapper; what it drops is counted per reason and per topic
        (``topics``: the topic index of each row)."""
        from aion_cli.engine.mapper import ACCEPTED
        from aion_cli.engine.state import DROP_REASONS

        if len(batch) == 0:
            return
        self._check_after_map(batch.t_ns, "detection")
        codes = np.empty(len(batch), np.int8)
        mapper.add_detections(batch, codes)
        n_topics = len(self._used)
        self._used += np.bincount(topics[codes == ACCEPTED], minlength=n_topics)
        dropped = codes != ACCEPTED
        if dropped.any():
            pairs = np.bincount(
                topics[dropped] * len(DROP_REASONS) + codes[dropped],
                minlength=n_topics * len(DROP_REASONS),
            ).reshape(n_topics, len(DROP_REASONS))
            self._mapper_drops += pairs

    def _check_after_map(self, t_ns: I64, what: str) -> None:
        """A continued map has closed every window before its open one: a log with data
        there would lose it (``before_window``) and yet be recorded as added, so it can never
        be added again. The build stops instead, before anything is written."""
        if self._map_open is None or len(t_ns) == 0:
            return
        from aion_cli.engine.windows import window_ns

        delta = window_ns(self.previous.config.window_s) if self.previous else 1
        open_start = self._map_open * delta
        early = int(np.count_nonzero(t_ns < open_start))
        if early == 0:
            return
        inputs = self.previous.manifest.get("inputs", []) if self.previous else []
        names = [str(e.get("name", "?")) for e in inputs]
        listed = " ".join([*names[:3], *(["..."] if len(names) > 3 else [])])
        listed += " " + " ".join(str(p) for p in self._logs[:3])
        raise InputError(
            f"the {what}s of {', '.join(p.name for p in self._logs)} start at "
            f"{iso(int(t_ns.min()))}, but {self.report.output.name} has already closed every "
            f"window before {iso(open_start)}: logs must be added to a map in time order; "
            "nothing was added",
            hint=f"rebuild the map from all logs at once (aion build {listed} -o NEW.aion)",
        )

    def _thin_graphs(
        self, messages: Iterator[RawMessage], graph_topics: set[str]
    ) -> Iterator[RawMessage]:
        """The stream without the scene graphs :func:`graph_schedule` leaves out
        (``--graph-period``; counted, the progress bar still advances). They go before the
        detection chunks are cut, so a skipped graph neither cuts the Mapper's feed into
        smaller pieces nor is decoded. Every message passes when every graph is used."""
        used = self._graph_used
        if used is None or bool(used.all()):
            yield from messages
            return
        flags = used.tolist()
        k = 0
        for msg in messages:
            if msg.topic in graph_topics:
                keep = k >= len(flags) or flags[k]
                k += 1
                if not keep:
                    self.report.graphs_skipped_period += 1
                    self.progress.advance(1)
                    continue
            yield msg

    def _take_graph(self, logset: Any, mapper: Mapper, msg: RawMessage, use_agents: bool) -> None:
        """One scene-graph message of the stream (one :func:`graph_schedule` kept): decoded
        (or its last payload's graph reused, :meth:`_decode_graph`) and applied to the map;
        damaged ones are skipped (:meth:`_decode_graph_or_skip`)."""
        snapshot = self._decode_graph_or_skip(logset, msg)
        if snapshot is None:
            return
        self._check_after_map(np.array([snapshot.t_ns], np.int64), "scene graph")
        mapper.add_graph(snapshot)
        if use_agents:
            self._add_agent_poses(mapper, snapshot.agents)
        self.report.graph_messages += 1

    def _decode_graph_or_skip(self, logset: Any, msg: RawMessage) -> GraphSnapshot | None:
        """A damaged scene-graph message is skipped and counted (the graph stays as it was
        until the next full graph, which Hydra repeats every few seconds); with the version
        pinned by ``--dsg-version`` a failure is the user's to fix and stops the build."""
        try:
            return self._decode_graph(logset, msg)
        except MessageDecodeError as exc:
            if self.opts.dsg_version is not None:
                raise
            self.report.graph_skipped += 1
            if self._first_graph_error is None:
                self._first_graph_error = exc
            return None

    def _check_graph_skips(self) -> None:
        """Skipped graphs are a note; when no scene graph at all could be decoded the first
        failure is the build's error (a map without the log's graph would mislead). Graphs
        left out by ``--graph-period`` or reused unchanged are a note with the counts."""
        r = self.report
        seen = r.graph_messages + r.graph_skipped + r.graphs_skipped_period
        if seen:
            r.graph_period_ns = self.opts.graph_period_ns
        if r.graphs_skipped_period or r.graphs_skipped_identical:
            r.notes.append(
                f"scene graphs: {r.graph_messages:,} of {seen:,} applied "
                f"({r.graph_decoded:,} decoded, {r.graphs_skipped_identical:,} identical to "
                f"the payload before and not decoded again); {r.graphs_skipped_period:,} left "
                f"out by --graph-period {r.graph_period_ns / 1e9:g}s"
            )
        if self.report.graph_skipped == 0 or self._first_graph_error is None:
            return
        if self.report.graph_messages == 0:
            raise self._first_graph_error
        self.report.notes.append(
            f"{self.report.graph_skipped:,} damaged scene-graph message(s) skipped (first: "
            f"{self._first_graph_error.message})"
        )

    def _decode_graph(self, logset: Any, msg: RawMessage) -> GraphSnapshot:
        """One DsgUpdate message as a snapshot, through the loader every command uses.

        The navigational layer is ``--nav-layer``, else the one the first graph with places
        chose by name, kept for the rest of the log (an early graph that has 3D places but no
        2D places yet must not make the map switch layers later); when a later graph lacks
        that layer it is chosen again.

        Decoding is skipped twice: the log's first graph when :meth:`_graph_has_agents`
        decoded it already, and a payload byte-identical to the last one decoded (a fixed
        sensor's static map, Hydra repeating an unchanged graph): its snapshot is reused with
        the message's own time (counted as ``skipped_identical``). The payload is compared
        byte for byte with a copy of the last one: exact, where a digest could collide, and
        cheaper (0.1 ms for a 1.9 MB, 5,000-place payload; blake2b takes 3.4 ms).
        """
        from formats.dsg import GraphLayerError, decode_dsg

        first = self._first_graph
        if first is not None and first[:2] == (msg.topic, msg.log_time_ns):
            self._first_graph = None  # decoded already, for the observation
            return first[2]
        decoded = logset.decode(msg)
        payload = np.asarray(decoded.layer_contents, dtype=np.uint8)
        stamp = decoded.header.stamp
        t_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) or msg.log_time_ns
        data = b""
        if self.opts.skip_identical_graphs:
            data = payload.tobytes()
            last = self._last_graph
            if last is not None and last[0] == data:
                # The same bytes decode to the same graph with the same pinned version and
                # layer: only its time differs. It is still applied (add_graph closes windows
                # and checks binds at its time), so the map equals decoding it again.
                self.report.graphs_skipped_identical += 1
                return dataclasses.replace(last[1], t_ns=t_ns)
        layer = self.opts.nav_layer or self._nav_pin
        try:
            result = decode_dsg(payload, t_ns, self.dsg_version, layer)
        except GraphLayerError as exc:
            if self.opts.nav_layer is not None or self._nav_pin is None:
                raise GraphLayerError(f"{msg.topic}: {exc.message}", hint=exc.hint) from exc
            result = decode_dsg(payload, t_ns, self.dsg_version)
        if self.dsg_version is None:  # pin the version that worked for the rest of the log
            self.dsg_version = result.version
        if self.opts.nav_layer is None and self._nav_pin is None and len(result.snapshot.places):
            self._nav_pin = result.layer.key
        self.report.dsg_version = result.version
        self.report.graph_layer = str(result.layer)
        self.report.graph_decoded += 1
        if self.opts.skip_identical_graphs:
            self._last_graph = (data, result.snapshot)
        return result.snapshot

    def _span(self) -> None:
        """The map's time span: the first and last message the build used (detections, scene
        graphs, dynamic TF; strays and out-of-range times left out), joined with a continued
        map's."""
        start, end = self._times.start_ns, self._times.end_ns
        if self.previous is not None:
            old = self.previous.manifest.get("time_span", {})
            if old.get("start_ns") is not None:
                start = int(old["start_ns"]) if start is None else min(start, int(old["start_ns"]))
            if old.get("end_ns") is not None:
                end = int(old["end_ns"]) if end is None else max(end, int(old["end_ns"]))
        self.report.start_ns, self.report.end_ns = start, end

    def _cumulative_counts(self) -> dict[str, Any]:
        """Detections read / used / dropped over every build of the map."""
        new = self.report.to_dict()["detections"]
        if self.previous is None:
            return new
        return _add_counts(self.previous.manifest.get("counts", {}), new)

    def _write(self, mapper: Mapper, config: ModelConfig, inputs: list[dict[str, Any]]) -> None:
        from formats.mapfile import write_map

        state = mapper.state
        arrays, meta = state.to_arrays(lazy=True)
        stats = state_counts(state)
        self.report.cells = stats["cells"]
        self.report.nodes = stats["nodes"]
        self.report.nodes_with_flow = stats["nodes_with_flow"]
        self.report.bound_cells = stats["bound_cells"]
        self.report.windows = stats["windows"]
        manifest = {
            "state": meta,
            "config": config.to_dict(),
            "inputs": inputs,
            "time_span": {"start_ns": self.report.start_ns, "end_ns": self.report.end_ns},
            "counts": self._cumulative_counts() | stats,
            "last_build": self.report.to_dict()["detections"],
            "graph_source": self.report.graph_source,
            "observation": self.report.observation,
        }
        manifest["timezone"] = config.timezone  # the default zone of predict / plan / export
        manifest["families"] = state.family_summary()
        out = self.report.output
        write_map(out, arrays, manifest, lock=False)  # run() holds the lock
        self.report.map_bytes = out.stat().st_size


def _check_log_path(path: Path) -> None:
    """A log must exist and be a regular file or a folder (a rosbag2 folder): a FIFO, a
    device or a socket would make hashing block or read forever (``/dev/zero``), so it is
    refused (:func:`formats.raw.check_regular_input`, ``os.stat`` only) before any byte is
    read."""
    from formats.raw import check_regular_input

    if not path.exists():
        raise InputError(f"log not found: {path}", hint="check the path")
    check_regular_input(path, "log", hint="give a log file (MCAP, .bag) or a rosbag2 folder")


def _load_mappings(path: Path | None) -> list[Any]:
    """The [[topic]] tables of ``--detections-mapping`` (none without it)."""
    if path is None:
        return []
    from formats.detections.mapping import load_mapping

    return load_mapping(Path(path))


def _no_detection_topic(logset: Any, plan: TopicPlan) -> TopicNotFoundError:
    """The error for a log with no detection topic to use: what it has, why generic topics
    were skipped, and how to read another type."""
    found = [f"{t.topic} ({t.msgtype})" for t in logset.topics]
    if plan.skipped:
        first = plan.skipped[0]
        hint = (
            f"{plan.reasons[first.topic]}; or map another type with --detections-mapping FILE"
        )
    else:
        hint = (
            "the log has: "
            + ", ".join(found[:8] + (["..."] if len(found) > 8 else []))
            + "; map a type with --detections-mapping FILE (`aion info LOG --suggest-mapping "
            "TOPIC` writes one)"
        )
    return TopicNotFoundError(
        "the log has no people-detection topic of a supported type", candidates=found, hint=hint
    )


def _add_counts(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    dropped = dict(old.get("dropped", {}))
    for reason, n in new["dropped"].items():
        dropped[reason] = int(dropped.get(reason, 0)) + int(n)
    return {
        "read": int(old.get("read", 0)) + new["read"],
        "used": int(old.get("used", 0)) + new["used"],
        "dropped": dict(sorted(dropped.items())),
    }


def build_map(opts: BuildOptions, progress: ProgressSink | None = None) -> BuildReport:
    """Run a build (see the module docstring) and return its report."""
    if not opts.logs:
        raise InputError("no log given", hint="aion build LOG... -o MAP")
    if opts.batch_size < 1:
        raise InputError("batch size must be >= 1")
    return _Build(opts, progress or _NoProgress()).run()
