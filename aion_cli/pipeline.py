"""The build orchestration: logs -> scene graphs, detections and TF -> Mapper -> map file.

No click here: the CLI hands over :class:`BuildOptions` and a
:class:`~aion_cli.build_report.ProgressSink`, and gets a :class:`~aion_cli.build_report.BuildReport`
back. This module holds the order of the steps and the state they share (:class:`_Build`); the
steps' parts live beside it, each with its own rules. Steps of :func:`build_map`:

1. open the logs (``formats.logs.open_logs``) and pick topics by type
   (:func:`aion_cli.build_options.build_topics`, :func:`aion_cli.topics.select_topics`):
   detection topics with a supported adapter (all of them, or those named), the scene-graph
   topic(s) (``hydra_msgs/DsgUpdate``), ``/tf`` and ``/tf_static``;
2. (:mod:`aion_cli.build_reading`, whose methods :class:`_Build` inherits, as step 3's)
   read TF first into a ``TfBuffer`` (and, for robots recording at once, a tree per log:
   :mod:`aion_cli.tf_trees`), and the log times of every topic the build uses (from
   the logs' indexes where they give exactly the stream's, else in the same pass;
   :mod:`aion_cli.tf_feed`, :mod:`formats.stream_times`); the time-sanity rules
   (:mod:`aion_cli.log_times`) drop messages with stray or unrepresentable log times
   (counted, warned) and give the build's time span (from the messages used, never from
   other topics or a summary); the observation mask comes from the robot trajectory
   ``map -> base_link``, else from the scene graph's agent layer, else the log is treated as
   a fixed sensor over the windows in which it recorded any message within that span (the
   report says which);
3. with ``--derive-graph`` and no scene graph, one extra pass counts where people walk and
   :mod:`aion_cli.derive_graph` turns that into a navigational graph;
4. stream detection and scene-graph messages in log-time order (:mod:`aion_cli.build_stream`,
   whose methods :class:`_Build` inherits): detection messages are
   collected into chunks of ``batch_size`` (flushed before every scene graph, so the Mapper sees
   everything in time order; decoded in jobs of ``batch_size`` messages however often the
   graphs come, :mod:`aion_cli.detection_feed`), decoded per topic and type with numpy,
   transformed to the map frame, given headings, and fed to the Mapper, which says per row
   what it dropped (so a topic that loses most of its detections is a warning,
   :mod:`aion_cli.build_report`); scene graphs are thinned by ``--graph-period``, decoded
   with the version and layer pinned and identical payloads reused (:mod:`aion_cli.graph_feed`);
   a continued map refuses data in the windows it has already closed (logs are added in time
   order);
5. write the map atomically (:mod:`aion_cli.build_output`, ``formats.mapfile.write_map``)
   with its typed manifest (:class:`aion_cli.manifest.Manifest`: the config, the inputs'
   provenance (path, size, sha256), the time span and the counts); a continued map's manifest
   is read the same way.

With ``--workers`` several groups of logs are learnt at once and joined into the same map
(:mod:`aion_cli.parallel_build`); with ``--part`` the closed days are held for ``aion merge``.

:func:`aion_cli.mapquery.load_map` reads a map back for ``predict``, ``plan`` and ``export``;
:mod:`aion_cli.topics` and :mod:`aion_cli.provenance` hold the remaining steps' parts, and
:mod:`aion_cli.continued_map` the rules for a continued map (``--map``) and ``--part``.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.build_options import (
    MAP_SUFFIX,
    BuildOptions,
    ShardStart,
    build_topics,
    check_not_an_input,
)
from aion_cli.build_output import write_build
from aion_cli.build_plausibility import held_ground, new_ground_warning
from aion_cli.build_reading import ReadStep
from aion_cli.build_report import BuildReport, NoProgress, ProgressSink
from aion_cli.continued_map import check_part, frame_warning, load_continued
from aion_cli.detection_adapters import log_adapters
from aion_cli.detection_counts import MapperTally
from aion_cli.detection_feed import DetectionCounts
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.graph_arrays import file_graph_time
from aion_cli.engine.windows import window_ns
from aion_cli.errors import InputError, StaleIndexError
from aion_cli.graph_feed import GraphFeed
from aion_cli.log_observed import NO_MARKS, with_logs_observed
from aion_cli.log_order import overlap_warnings
from aion_cli.log_times import TopicTimes
from aion_cli.log_twins import topic_twin_warnings
from aion_cli.manifest import InputLog, Manifest
from aion_cli.mapquery import LoadedMap
from aion_cli.provenance import DistinctLogs, distinct_logs
from aion_cli.recording_twins import check_continued
from aion_cli.stamp_warnings import sim_time_warning
from aion_cli.topic_mappable import no_detection_topic
from aion_cli.topics import TopicPlan

if TYPE_CHECKING:
    from aion_cli.build_plausibility import Ground
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import I64

__all__ = ["MAP_SUFFIX", "BuildOptions", "build_map"]


class _Build(ReadStep):
    """One run of ``aion build`` (state shared by the phases).

    ``shard``: a part of a parallel build (:mod:`aion_cli.parallel_build`): the logs are
    learnt into a map whose closed days are held for the join (``deferred``) or not (the first
    part), starting from ``start`` (a map in memory) if given, and nothing is hashed, checked
    for usable detections or written: :meth:`learn` returns the state. ``at``: where in one
    pass's stream the shard starts (:class:`~aion_cli.build_options.ShardStart`): a time shard
    learns only its part of log time, with the whole logs' time rules, TF and graph schedule."""

    #: what a start on a simulation's clock is said of, and whether to say at which times to
    #: query the map (a held-out reading: the test logs, judged at them)
    sim_clock_subject: tuple[str, bool] = ("the map's data", True)

    def __init__(
        self,
        opts: BuildOptions,
        progress: ProgressSink,
        shard: bool = False,
        deferred: bool = False,
        start: MapState | None = None,
        at: ShardStart | None = None,
    ) -> None:
        self.opts = opts
        self.progress = progress
        self.shard = shard
        self.deferred = deferred
        self.start = start
        self.at = at or ShardStart()
        self.time_part = self.at.part  # a time shard's [lo, hi) of log time
        self.counts = DetectionCounts()
        self.report = BuildReport(output=opts.output_path())
        self.previous: LoadedMap | None = None
        self.previous_manifest: Manifest | None = None  # the continued map's
        self.graphs = self._graph_feed()
        # log times from the logs' indexes (formats.stream_times) unless a read showed one
        # stale, or the Mapper starts from a state in memory that a second try cannot restore
        self._use_index = start is None
        self._adapters: dict[tuple[str, str, str], Any] = {}
        self._factory: Any = None
        self._logs: tuple[Path, ...] = tuple(opts.logs)  # the distinct logs (by sha256)
        self._times = TopicTimes(()).check(())
        self._whole_times = self._times  # without a time shard's limits
        # the windows holding a detection message (a robot's windows without one are noted)
        self._detection_windows: I64 | None = None
        self._marks = NO_MARKS  # the times of the messages that only mark spans
        self._part_total: int | None = None  # a time shard's messages to stream
        self._map_open: int | None = None  # a continued map's open window when loaded
        self._held: Ground | None = None  # its entries before (build_plausibility)
        self._tally = MapperTally(0)  # what the Mapper accepted and dropped, per topic

    def _graph_feed(self) -> GraphFeed:
        o = self.opts
        return GraphFeed(
            self.report,
            o.dsg_version,
            o.nav_layer,
            o.graph_period_ns,
            o.skip_identical_graphs,
            self.at.graph_pins,
            o.map_frame,
        )

    @property
    def logs(self) -> tuple[Path, ...]:
        """The distinct logs of this build (after hashing, :meth:`_inputs`)."""
        return self._logs

    def set_logs(self, logs: tuple[Path, ...]) -> None:
        """A part of a parallel build: the parent hashed and de-duplicated the logs."""
        self._logs = tuple(logs)

    def run(self) -> BuildReport:
        """The build, holding the output map's lock from start to end."""
        from aion_cli.formats.mapfile import (
            check_map_folder,
            check_map_suffix,
            check_map_target,
            map_lock,
            read_manifest,
        )

        out = self.report.output
        check_map_folder(out)
        check_not_an_input(out, self.opts.logs)
        if self.opts.continue_from is not None:  # the input first: without -o it is the
            read_manifest(self.opts.continue_from)  # output too, judged below as a target
        check_map_target(out)  # a device, FIFO or foreign file fails now, not after hashing
        check_map_suffix(out)  # -o map.png: a new map named as a picture
        # Held from reading a continued map to writing the result: two builds extending the
        # same map would otherwise both start from the old map, and the later write would
        # silently drop the other build's logs.
        with map_lock(out):
            return self._run()

    def _note_rooms_off_the_nav_layer(self, graph: Any) -> None:
        """A note when the map's graph has rooms but none holds a navigational place (rooms
        over 3D places, 2D places taken): ``predict --layer rooms`` would refuse the map."""
        from aion_cli.room_names import rooms_off_the_nav_layer

        off = None if graph is None else rooms_off_the_nav_layer(graph)
        if off is not None:
            self.report.notes.append(
                f"{off[0]}: the map answers per place, not per room; {off[1]}"
            )

    def _run(self) -> BuildReport:
        opts = self.opts
        if opts.continue_from is not None:
            self.previous = load_continued(opts.continue_from, opts, self.report.notes)
            self.previous_manifest = Manifest.from_dict(self.previous.manifest)
            self.report.continued = True
            self._map_open = self.previous.state.open_window
            self._held = held_ground(self.previous.state)
            warning = frame_warning(  # --map-frame said so
                opts.continue_from.name, self.previous_manifest.map_frame, opts.map_frame
            )
            if warning is not None:
                self.report.warnings.append(warning)
        elif opts.lineage != "auto":
            self.report.notes.append(f"--lineage {opts.lineage} ignored: no --map to continue")
        config = self.config()
        hashes = self._distinct_logs().start()
        try:
            state = self._learn_state(config)
        except BaseException:
            hashes.cancel()
            raise
        self._note_rooms_off_the_nav_layer(state.graph)
        self._write(state, config, self._inputs(hashes))
        return self.report

    def _learn_state(self, config: ModelConfig) -> MapState:
        """The map state of the logs: in this process, in workers, or a part map."""
        opts = self.opts
        out = self.report.output
        if out.exists() and self.previous is None:
            self.report.notes.append(
                f"{out.name} existed and is replaced (use --map {out.name} to extend a map)"
            )
        if opts.part:
            check_part(self.previous, opts, self.report.notes)
            state = self.learn(config).state
            self.report.notes.append(
                f"a part map: its {len(state.deferred.days) if state.deferred else 0} closed "
                "day(s) are held unscored for `aion merge` (it cannot forecast on its own)"
            )
            return state
        if opts.workers != 1 or opts.scheduler is not None:
            from aion_cli.parallel_build import ParallelBuild

            return ParallelBuild(self, config).run()
        return self.learn(config).state

    def learn(self, config: ModelConfig) -> Mapper:
        """Read the logs and learn them into a Mapper (steps 1-4 of the module docstring).
        Step 2 takes its log times from the logs' indexes where it can
        (:meth:`formats.logs.LogSet.index_times`); a chunk that then turns out unreadable
        (:class:`~aion_cli.errors.StaleIndexError`) makes it start over from the same report
        and map (a continued map loaded again), reading every message."""
        if not self._use_index:
            return self._learn(config)
        report = copy.deepcopy(self.report)
        try:
            return self._learn(config)
        except StaleIndexError:
            self._use_index = False
            vars(self.report).update(vars(report))  # the same object: others hold it
            self.graphs = self._graph_feed()
            self.counts = DetectionCounts()
            if self.previous is not None and self.opts.continue_from is not None:
                self.previous = load_continued(
                    self.opts.continue_from, self.opts, self.report.notes
                )
            return self._learn(config)

    def _learn(self, config: ModelConfig) -> Mapper:
        from aion_cli.formats.logs import open_logs

        opts = self.opts
        with open_logs(list(self._logs), opts.log_format) as logset:
            plan: TopicPlan = build_topics(logset, opts)
            if not plan.detections and not self.shard:  # a part of a build may have none
                raise no_detection_topic(logset, plan)
            self.report.detection_topics = sorted(plan.names("detections"))
            self.report.warnings.extend(getattr(logset, "warnings", []))  # lost or odd input
            self._adapters, self._factory, notes = log_adapters(
                logset, plan.detections, plan.mappings
            )
            adapter_of = lambda *key: self._adapters.get(key) or self._factory(*key)  # noqa: E731
            self.report.warnings.extend(  # logs of one time holding the same detections
                overlap_warnings(logset, plan.names("detections"), window_ns(config.window_s),
                                 adapter_of)
                + topic_twin_warnings(logset, self.report.detection_topics, adapter_of)
            )
            self.report.notes.extend(notes)
            self.continue_on_logs(logset, plan)  # the logs' graphs: the map's session?
            self.report.detection_decoding = {
                info.topic: {
                    "type": info.msgtype,
                    "why": plan.reasons.get(info.topic, ""),
                    "decoder": self._adapters[info.topic, info.msgtype, info.encoding].kind,
                }
                for info in plan.detections
            }
            mapper = self._mapper(config)
            tf = self._read_times(logset, plan)
            self._observation(mapper, tf, plan, logset)
            fixed_graph = self._fixed_graph(logset, plan, tf, config)
            if fixed_graph is not None:
                before = mapper.state.graph
                mapper.add_graph(fixed_graph)
                if self.opts.graph_file is not None:  # the file again: one pass added it once
                    mapper.state.graph = file_graph_time(mapper.state.graph, before)
            self._stream(logset, plan, tf, mapper)
            end = self._span()
            if end is not None:  # the last message aion uses (not a summary's), or a span's
                mapper.advance(end)  # declared after it (its last instant)
            # readers warn while streaming too (a corrupt chunk ends a file early): lost or
            # unusual input is a warning, shown with -q and under "warnings" in JSON
            self.report.warnings.extend(w for w in logset.warnings if w not in self.report.warnings)
        return mapper

    def _mapper(self, config: ModelConfig) -> Mapper:
        """The Mapper the logs go into: the continued map's, a shard's, or a new one."""
        from aion_cli.engine.mapper import Mapper
        from aion_cli.engine.state import MapState

        if self.start is not None:
            return Mapper(config, self.start)
        if self.deferred or (self.opts.part and self.previous is None):
            from aion_cli.engine.shards import start_shard

            return Mapper(config, start_shard(MapState.empty(config)))
        return Mapper(config, self.previous.state if self.previous else None)

    def _distinct_logs(self) -> DistinctLogs:
        """Which logs are distinct (:func:`aion_cli.provenance.distinct_logs`): they become
        :attr:`logs`; their hashes may still be under way (:meth:`_inputs` waits)."""
        previous = self.previous_manifest
        known = {i.sha256: i.size for i in previous.inputs} if previous else {}
        hashes = distinct_logs(self.opts.logs, self.progress, known)
        self._logs = hashes.logs
        self.report.notes.extend(hashes.notes)
        return hashes

    def _inputs(self, hashes: DistinctLogs) -> tuple[InputLog, ...]:
        """Provenance of the map's logs: the continued map's inputs first, then this build's
        (waiting for the hashes still under way)."""
        new = hashes.entries(self.progress)
        self.report.inputs = new
        previous = self.previous_manifest
        old = previous.inputs if previous is not None else ()
        return old + tuple(InputLog.from_dict(entry) for entry in new)

    def _span(self) -> int | None:
        """The map's time span: the first and last message the build used (detections, scene
        graphs, dynamic TF; strays and out-of-range times left out), joined with a continued
        map's; a span ``--observed`` declared before the first message starts it there, one
        after the last ends it there (``declared_span``). Returns this build's end."""
        from aion_cli.log_observed import declared_span

        start, end = declared_span(self._times.start_ns, self._times.end_ns, self.report)
        self.join_span(start, end)
        return end

    def join_span(self, start: int | None, end: int | None) -> None:
        """The report's span: ``start``..``end`` joined with the continued map's."""
        if self.previous_manifest is not None:
            start, end = self.previous_manifest.joined_span(start, end)
        self.report.start_ns, self.report.end_ns = start, end
        sim = sim_time_warning(start, *self.sim_clock_subject)
        if sim is not None and not self.shard:  # a parallel build's parent says it once
            self.report.warnings.append(sim)

    def _write(self, state: MapState, config: ModelConfig, inputs: tuple[InputLog, ...]) -> None:
        """The map file (:func:`aion_cli.build_output.write_build`; run() holds the lock),
        unless its logs are a recording the continued map holds already."""
        previous = self.previous_manifest
        recordings = previous.recordings if previous is not None else ()
        check_continued(recordings, self._continued_name(), self._log_names(), self.report.sketch)
        if self._held is not None and self.opts.continue_from is not None:
            name = self.opts.continue_from.name
            warning = new_ground_warning(state, self._held, name)  # another place's logs
            if warning is not None:
                self.report.warnings.append(warning)
        write_build(
            state, config, inputs, self.report, self.previous_manifest, self.opts.map_frame,
            self.opts.observed,
        )


def build_map(opts: BuildOptions, progress: ProgressSink | None = None) -> BuildReport:
    """Run a build (see the module docstring) and return its report."""
    if not opts.logs:
        raise InputError("no log given", hint="aion build LOG... -o MAP")
    if opts.batch_size < 1:
        raise InputError("batch size must be >= 1")
    opts, notes = with_logs_observed(opts)  # the spans aion convert --observed recorded
    report = _Build(opts, progress or NoProgress()).run()
    report.notes[:0] = notes
    return report
