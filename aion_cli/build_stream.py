"""Step 4 of a build (:mod:`aion_cli.pipeline`): the stream of detection and scene-graph
messages, in log-time order, into the Mapper; and the extra pass of ``--derive-graph``.

Detection messages are collected into chunks of ``batch_size`` (flushed before every scene
graph, so the Mapper sees everything in time order; decoded in jobs however often the graphs
come, :mod:`aion_cli.detection_feed`), decoded per topic and type, transformed to the map
frame, given headings and fed to the Mapper, which says per row what it dropped (tallied per
topic, :class:`aion_cli.detection_counts.MapperTally`). Scene graphs are thinned by
``--graph-period`` and decoded with their version and layer pinned
(:mod:`aion_cli.graph_feed`); one that comes while linked rows wait for their heading
(:mod:`aion_cli.engine.heading_hold`) waits behind them, so the Mapper takes rows and graphs
in the stream's order. A continued map refuses data in the windows it has closed.

:class:`StreamStep` holds these methods of :class:`aion_cli.pipeline._Build`, which inherits
them: they share the build's state (its report, progress, time rules, graph feed), declared
here for the type checker.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from aion_cli.build_report import check_usable, record_detections, unread_detections
from aion_cli.detection_counts import MapperTally
from aion_cli.detection_feed import (
    DetectionCounts,
    DetectionFeeder,
    TopicFeeders,
    chunks,
    decoded_chunks,
)
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.detection_sketch import SketchFeed
from aion_cli.engine.heading_hold import HeadingHold
from aion_cli.engine.state import DROP_REASONS
from aion_cli.engine.types import F64, I64, DetectionBatch, GraphSnapshot
from aion_cli.fixed_sensor import fixed_sensor_windows
from aion_cli.log_order import check_after_open, other_clock_error, overlap_note
from aion_cli.times_apart import apart_warnings, joined_times

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.build_options import BuildOptions, ShardStart
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.engine.mapper import Mapper
    from aion_cli.graph_feed import GraphFeed
    from aion_cli.log_times import TimeCheck
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import LoadedMap
    from aion_cli.tf_trees import TfTrees
    from aion_cli.topics import TopicPlan


class StreamStep:
    """The stream step's methods (module docstring); :class:`aion_cli.pipeline._Build`
    sets the attributes below."""

    opts: BuildOptions
    progress: ProgressSink
    report: BuildReport
    graphs: GraphFeed
    counts: DetectionCounts
    shard: bool
    at: ShardStart
    time_part: tuple[int, int] | None
    previous: LoadedMap | None
    previous_manifest: Manifest | None
    _times: TimeCheck
    _whole_times: TimeCheck
    _marks: I64
    _part_total: int | None
    _map_open: int | None
    _logs: tuple[Path, ...]
    _adapters: dict[tuple[str, str, str], Any]
    _factory: Any
    _tally: MapperTally
    _sketch: SketchFeed
    #: what became of the output when no detection was usable (None: the build's own words,
    #: "no map was written"; a held-out reading writes nothing to begin with)
    unusable_outcome: str | None = None
    #: the continued map's graph, which the first scene graph the stream applies is checked
    #: against (``--lineage auto``: :meth:`continue_on_logs`); None once checked, or not to be
    _lineage_graph: GraphSnapshot | None = None
    #: the first and last robot pose of the agent layers the observation used (None: none)
    _agent_times: tuple[int, int] | None = None
    #: per later log whose graphs began another session, the node entries it released
    _session_breaks: list[int]

    def continue_on_logs(self, logset: Any, plan: TopicPlan, peek: bool = False) -> None:
        """Whether the logs' own scene graphs go on in the continued map's session (without
        ``--graph FILE``, :mod:`aion_cli.build_lineage`): ``--lineage different`` releases
        the map's node entries now; ``auto`` checks the first graph when the stream applies
        it (:meth:`_take_graph`), or, with ``peek`` (a parallel build's parent, whose shards
        do not see the map), that graph now (:func:`aion_cli.build_lineage.
        first_applied_graph`: the graph topics' times from the indexes, no extra pass where
        they have one)."""
        from aion_cli.build_lineage import check_log_graph, first_applied_graph, release_for_logs

        previous, name = self.previous, self._continued_name()
        if previous is None or self.shard or self.opts.graph_file is not None:
            return
        has_graphs = bool(plan.graph)
        release_for_logs(previous, name, has_graphs, self.opts.lineage, self.report.notes)
        if self.opts.lineage != "auto" or previous.graph is None or not has_graphs:
            return
        if not peek:
            self._lineage_graph = previous.graph
            return
        snapshot = first_applied_graph(
            list(self._logs), self.opts.log_format, logset, plan.names("graph"),
            lambda msg: self.graphs.peek(logset, msg),
        )  # fmt: skip
        if snapshot is not None:
            check_log_graph(
                previous.graph, name, snapshot, self._log_names(), previous.config.bind_radius
            )

    def _log_names(self) -> str:
        """This build's logs by name, for a message (the first three)."""
        names = [p.name for p in self._logs[:3]] + ["..."] * (len(self._logs) > 3)
        return ", ".join(names)

    def _derive(
        self, logset: Any, plan: TopicPlan, tf: TfTrees, config: ModelConfig, start: int
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
        self,
        tf: TfTrees,
        counts: DetectionCounts,
        link: bool = True,
        cell_size: float | None = None,
        apart: frozenset[int] = frozenset(),
    ) -> DetectionFeeder:
        """A feeder with the adapters chosen for the log's detection topics, moving rows with
        the logs' TF trees (``tf``); ``link``: link id-less detections into tracks (headings
        from motion); ``cell_size``: the map's, so rows it cannot place stop before linking;
        ``apart``: the recordings whose tracks are their own (:mod:`aion_cli.track_owners`)."""
        return DetectionFeeder(
            tf.shared,
            self.opts.map_frame,
            counts,
            self._adapters,
            self._factory,
            linker=link,
            yaw_seen=self.at.yaw_seen if link else None,
            cell_size=cell_size,
            trees=tf,
            apart=apart,
        )

    def _stream(self, logset: Any, plan: TopicPlan, tf: TfTrees, mapper: Mapper) -> None:
        from aion_cli.track_owners import tracks_apart

        apart = tracks_apart(logset, plan.names("detections"))  # robots at once: own tracks
        cell = mapper.state.config.cell_size
        feeders = TopicFeeders(
            lambda topic, counts: self._feeder(
                tf, counts, cell_size=cell, apart=apart.get(topic, frozenset())
            ),
            sorted(plan.names("detections")),
        )
        self._tally = MapperTally(len(feeders.topics))
        self._sketch = SketchFeed(self.report.sketch)  # flushed when the stream ends
        graph_topics = plan.names("graph")
        topics = plan.names("detections") | graph_topics
        total = logset.total(topics) if self._part_total is None else self._part_total
        self.progress.start("building map", total)
        use_agents = self.report.observation.startswith("scene-graph")
        unread = self.graphs.unread_hint(graph_topics)  # graphs thin() drops
        messages = self.graphs.thin(
            self._times.filter(logset.messages(topics, self.time_part, unread)),
            graph_topics,
            self.progress,
            logset,
        )
        stream = chunks(messages, graph_topics, self.opts.batch_size)
        # a linked track's first rows wait in the hold for its first displacement; rows
        # leave it in order, all of them at the end. A scene graph that comes while rows are
        # held waits behind them (decoded, with the number of rows before it) and is applied
        # once they have left: the Mapper takes rows and graphs in the stream's order, as
        # without the hold, and the held rows keep the heading that comes after the graph
        hold = HeadingHold()
        behind: deque[tuple[int, GraphSnapshot, bool]] = deque()
        self._session_breaks = []
        # duck-typed: decoded_chunks only calls decode()
        for batch, n_messages, graph_msg in decoded_chunks(stream, cast(Any, feeders)):
            if batch is not None:
                look = feeders.look_of(batch)
                out = hold.push(batch, feeders.topics_of(batch), look)
                self._leave(mapper, hold, behind, *out, use_agents=use_agents)
                self.progress.advance(n_messages)
            if graph_msg is not None:
                snapshot = self.graphs.decode_or_skip(logset, graph_msg)
                if snapshot is not None:
                    snapshot = self.graphs.sessions.join(graph_msg.recording, snapshot)
                    later = self.graphs.sessions.new_group  # a later log's first graph
                if snapshot is not None and len(hold):
                    _superseded_mesh(behind)
                    behind.append((hold.left + len(hold), snapshot, later))
                elif snapshot is not None:
                    self._take_graph(mapper, snapshot, use_agents, later)
                self.progress.advance(1)
        self._leave(mapper, hold, behind, *hold.release(), use_agents=use_agents)
        self._sketch.flush()
        feeders.count_settled(hold.settled)
        self.graphs.check_skips(stop_if_none=not self.shard)
        if self._session_breaks:
            from aion_cli.graph_notes import session_break_note

            tolerance = mapper.state.config.bind_radius
            self.report.notes.append(session_break_note(self._session_breaks, tolerance))
        self.report.graph_pins = self.graphs.pins
        c = self.counts = record_detections(
            self.report, feeders, self._tally.used, self._tally.drops, plan
        )
        if not self.shard:  # a parallel build checks the total of its parts
            check_usable(
                self.report,
                c,
                self.previous_manifest,
                self.unusable_outcome,
                lost=unread_detections(
                    self.report, c, logset.total(plan.names("detections")), logset.warnings
                ),
            )
        # (a time shard without graphs of its own still observes with the logs' agents)
        if use_agents and self.report.graph_messages == 0 and self.time_part is None:
            self.report.observation = fixed_sensor_windows(
                mapper, logset, self._times, self.report.notes, self.report, self.opts.observed,
                marks=self._marks,
            )
        if not self.shard:  # a parallel build's parent checks its shards' together
            self.report.warnings.extend(apart_warnings(
                self.opts, *self.times_apart(), self.report.observation,
                mapper.state.config.timezone,
            ))

    def times_apart(self) -> tuple[tuple[int, int] | None, tuple[int, int] | None]:
        """What :func:`aion_cli.times_apart.apart_warnings` checks: the whole logs' first and
        last message, and the first and last robot pose of the agent layers the stream used
        (None: none)."""
        first, last = self._whole_times.start_ns, self._whole_times.end_ns
        return (None if first is None or last is None else (first, last)), self._agent_times

    def _leave(
        self,
        mapper: Mapper,
        hold: HeadingHold,
        behind: deque[tuple[int, GraphSnapshot, bool]],
        batch: DetectionBatch,
        topics: I64,
        use_agents: bool,
    ) -> None:
        """The rows that left ``hold`` (the last ``len(batch)`` of its :attr:`~aion_cli.
        engine.heading_hold.HeadingHold.left`) to the Mapper, each graph waiting ``behind``
        them applied between the rows before it and those after it."""
        start, done = hold.left - len(batch), 0
        while behind and behind[0][0] <= hold.left:
            at, snapshot, later = behind.popleft()
            cut = at - start
            if cut > done:
                part = np.arange(done, cut)
                self._feed(mapper, batch.select(part), topics[part])
            self._take_graph(mapper, snapshot, use_agents, later)
            done = max(done, cut)
        if done == 0:
            self._feed(mapper, batch, topics)
        elif done < len(batch):
            part = np.arange(done, len(batch))
            self._feed(mapper, batch.select(part), topics[part])

    def _feed(self, mapper: Mapper, batch: DetectionBatch, topics: I64) -> None:
        """Detections to the Mapper; what it drops is counted per reason and per topic
        (``topics``: the topic index of each row)."""
        if len(batch) == 0:
            return
        first = self.report.first_detection_ns is None  # the batch holds the first detections
        if first:
            self.report.first_detection_ns = int(batch.t_ns.min())
        self._check_after_map(batch.t_ns, "detection", first, batch.xyz)
        self._sketch.add(batch.t_ns, batch.xyz)
        codes = np.empty(len(batch), np.int8)
        mapper.add_detections(batch, codes)
        self._check_clocks(mapper, batch.t_ns, codes)
        self._tally.add(topics, codes)

    def _check_clocks(self, mapper: Mapper, t_ns: I64, codes: np.ndarray) -> None:
        """Detections of several logs dropped as ``before_window`` because the logs' own log
        times are a simulation's clock from 0 while the stamps, which make the windows, are
        on the wall clock: the stream merges the logs by log times, which cannot tell the order
        of their stamps, so whole logs would be lost in silence.
        :func:`aion_cli.log_order.other_clock_error` instead, as the parallel build refuses
        them (before anything is written)."""
        open_window = mapper.state.open_window
        if len(self._logs) < 2 or open_window is None:
            return
        late = codes == DROP_REASONS.index("before_window")
        if not late.any():
            return
        from aion_cli.engine.windows import window_ns

        delta = window_ns(mapper.state.config.window_s)
        clocks = other_clock_error(
            self._log_names(), self._times.start_ns, open_window * delta, int(t_ns[late].min())
        )
        if clocks is not None:
            raise clocks

    def _check_after_map(
        self, t_ns: I64, what: str, first: bool = False, xyz: F64 | None = None
    ) -> None:
        """A continued map's closed windows take no data (:func:`aion_cli.log_order.
        check_after_open`; detections, ``xyz``, that repeat a recording the map holds are
        refused as such: :func:`aion_cli.recording_twins.check_batch`); the ``first``
        detections are checked for the map's data (:func:`aion_cli.log_order.overlap_note`;
        a parallel build's parent checks its shards'). Every build keeps the earliest time of
        each ``what`` (``report.data_starts``): a shard's fold checks it by the same rule."""
        if len(t_ns) == 0:
            return
        starts = self.report.data_starts  # a shard's, for its fold's check (shard_fold)
        starts[what] = min(starts.get(what, int(t_ns.min())), int(t_ns.min()))
        if self._map_open is None:
            return
        from aion_cli.engine.windows import window_ns

        delta = window_ns(self.previous.config.window_s) if self.previous else 1
        if xyz is not None and int(t_ns.min()) < self._map_open * delta:
            from aion_cli.recording_twins import check_batch

            name, whole = self._continued_name(), self._whole_times
            span = (whole.start_ns, whole.end_ns)
            check_batch(self.previous_manifest, name, self._log_names(), span, t_ns, xyz)
        inputs = self.previous_manifest.inputs if self.previous_manifest else ()
        check_after_open(
            t_ns,
            self._map_open * delta,
            what,
            [entry.name for entry in inputs],
            self._logs,
            self._continued_name(),
            self._times.start_ns,  # the logs' own clock (log times)
            self.previous.config.timezone if self.previous else "UTC",  # the hint's --tz
        )
        if first:
            self.note_overlap(int(t_ns.min()))

    def note_overlap(self, first_ns: int) -> None:
        """The note on logs whose first detection (``first_ns``) comes before the continued
        map's data ends (:func:`aion_cli.log_order.overlap_note`); none in a shard, whose
        parent makes it from its shards' first detections."""
        end = self.previous_manifest.end_ns if self.previous_manifest else None
        if self.shard or end is None:
            return
        note = overlap_note(first_ns, end, self._logs, self._continued_name())
        if note is not None:
            self.report.notes.append(note)

    def _continued_name(self) -> str:
        """The name of the map being continued (``--map``), which closed the windows; the
        output (``-o``) may be another file."""
        continued = self.opts.continue_from
        return continued.name if continued is not None else self.report.output.name

    def _take_graph(
        self, mapper: Mapper, snapshot: GraphSnapshot, use_agents: bool, later: bool = False
    ) -> None:
        """One scene graph of the stream (a message :func:`graph_schedule` kept, decoded or
        its last payload's graph reused, :meth:`aion_cli.graph_feed.GraphFeed.decode`;
        damaged ones were skipped, :meth:`aion_cli.graph_feed.GraphFeed.decode_or_skip`)
        applied to the map. ``later``: the first graph of a later log (or group of logs at
        once) than the graph before (:attr:`aion_cli.session_graphs.SessionGraphs.
        new_group`): when it holds the place ids of the map's graph at other places (another
        Hydra session, ``aion merge``'s lineage test), the map's node entries are released
        to hash cells first (:meth:`aion_cli.engine.mapper.Mapper.begin_session`), as the
        merge of the two sessions' maps releases them, rather than following the ids to the
        new session's unrelated places."""
        if later and mapper.state.graph is not None:
            from aion_cli.build_lineage import other_session

            if other_session(mapper.state.graph, snapshot, mapper.state.config.bind_radius):
                self._session_breaks.append(mapper.begin_session(snapshot.t_ns))
        if self._lineage_graph is not None and self.previous is not None:
            from aion_cli.build_lineage import check_log_graph

            before, self._lineage_graph = self._lineage_graph, None  # the first graph only
            check_log_graph(
                before, self._continued_name(), snapshot, self._log_names(),
                self.previous.config.bind_radius,
            )  # fmt: skip
        self._check_after_map(np.array([snapshot.t_ns], np.int64), "scene graph")
        mapper.add_graph(snapshot)
        if use_agents:
            self.graphs.add_agent_poses(mapper, snapshot.agents)
            self._agent_times = joined_times(self._agent_times, snapshot.agents)
        self.report.graph_messages += 1


def _superseded_mesh(behind: deque[tuple[int, GraphSnapshot, bool]]) -> None:
    """The newest graph waiting ``behind`` the heading hold without its mesh, as a later
    graph comes to wait behind it: that one is applied after it and replaces it as the map's
    graph, and only the map's last graph's mesh is kept (:mod:`aion_cli.engine.graph_arrays`;
    no step of the build reads a mesh). So the hold keeps one graph's mesh however many
    graphs wait: with ``--graph-period 0`` a 10 Hz stream waits ~50 graphs behind rows held
    5 s, and their 30,000-vertex meshes held 121 MB (the places, shared between snapshots
    where they did not change, held 4 MB for 3,000 places)."""
    if behind and behind[-1][1].mesh is not None:
        at, snapshot, later = behind[-1]
        behind[-1] = (at, dataclasses.replace(snapshot, mesh=None), later)
