"""Steps 2 and 3 of a build (:mod:`aion_cli.pipeline`): what the stream is read against.

TF into its trees (:mod:`aion_cli.tf_trees`) and the log times of every topic the build uses,
with the time-sanity rules (:mod:`aion_cli.log_times`) over them; which windows the map
observed (:func:`aion_cli.build_observation.observe`); and the graph added once at the start
(``--graph FILE`` or ``--derive-graph``, :func:`aion_cli.graph_source.graph_source`), with the
model config they are read with.

:class:`ReadStep` holds these methods of :class:`aion_cli.pipeline._Build`, which inherits
them (and, through it, :class:`aion_cli.build_stream.StreamStep`'s); the build's state they
use beyond :class:`~aion_cli.build_stream.StreamStep`'s is declared here for the type checker.
"""

from __future__ import annotations

from itertools import takewhile
from typing import TYPE_CHECKING, Any

from aion_cli.build_observation import observe
from aion_cli.build_options import resolve_config
from aion_cli.build_stream import StreamStep
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.types import GraphSnapshot
from aion_cli.engine.windows import window_ns
from aion_cli.formats.log_overlaps import topics_at_once
from aion_cli.graph_owners import graph_groups, graph_streams_at_once
from aion_cli.graph_schedule import GraphTimes
from aion_cli.graph_source import graph_source
from aion_cli.log_observed import marker_times, observed_fill
from aion_cli.session_graphs import SessionGraphs
from aion_cli.tf_feed import (
    check_tf,
    check_times,
    check_unusable,
    read_tf_and_times,
    with_static_tf,
)
from aion_cli.tf_trees import TfTrees, own_tf_buffers

if TYPE_CHECKING:
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import I64
    from aion_cli.topics import TopicPlan


class ReadStep(StreamStep):
    """The reading steps' methods (module docstring); :class:`aion_cli.pipeline._Build` sets
    the attributes below."""

    deferred: bool
    start: MapState | None
    _use_index: bool
    _detection_windows: I64 | None

    def config(self) -> ModelConfig:
        """The model config (:func:`aion_cli.build_options.resolve_config`)."""
        return resolve_config(self.opts, self.previous.config if self.previous else None)

    def _read_times(self, logset: Any, plan: TopicPlan) -> TfTrees:
        """TF into its trees (:mod:`aion_cli.tf_trees`) and the log times of every topic the
        build uses, then the time-sanity rules (:mod:`aion_cli.log_times`) over them: their
        warnings go to the report, and :attr:`_times` filters the later reads. The build's
        time span comes from the detection, scene-graph and (dynamic) TF topics only:
        unrelated topics and container summaries have no say."""
        graphs = plan.names("graph") if self.opts.graph_file is None else set()
        timed = plan.names("detections") | graphs
        thinned = graphs if self.opts.graph_period_ns > 0 else set()
        own = own_tf_buffers(logset, plan)  # robots recording at once: a tree each
        tf, times, stats = read_tf_and_times(
            logset, plan, timed, self.progress, thinned, use_index=self._use_index, own=own
        )
        tf_topics = plan.names("tf") if plan.tf else set()
        self._times = self._whole_times = check_times(
            times, plan, timed, self.report, list(logset.recording_times().values())
        )
        self._marks = marker_times(self.opts.observed_marked, times, self._whole_times.strays)
        self._detection_windows = times.windows(
            plan.names("detections"), window_ns(self.config().window_s)
        )
        if self.time_part is not None:
            self._times = self._whole_times.limited(*self.time_part)
            self._part_total = times.count_inside(timed, *self.time_part)
        if isinstance(times, GraphTimes):
            delta = window_ns(self.config().window_s)
            self.graphs.schedule(times, self._times.strays, delta, self.time_part)
            start = self._times.start_ns
            if self.deferred and start is not None:  # a shard after others: its own poses
                self.graphs.agents_since(start // delta * delta)
        check_tf(stats, tf_topics, self.report)
        if self.at.first_part:  # (every part reads the whole logs' TF)
            check_unusable(tf, self.report)
        else:  # the whole logs' counts: the first part reports them
            self.report.time_dropped = {}
            self.report.tf_undecodable = 0
        # a shard: all logs' /tf_static, in every tree
        return TfTrees(with_static_tf(tf, self.at.static_tf), own).with_static()

    def _observation(self, mapper: Mapper, tf: TfTrees, plan: TopicPlan, logset: Any) -> None:
        """Which windows the map observed (:func:`aion_cli.build_observation.observe`); the first
        scene graph's agent layer is asked for only without a robot trajectory."""

        def graph_agents(between: tuple[int, int] | None) -> bool:
            if not plan.graph or self.opts.graph_file is not None:
                return False
            # the first graph of the logs, also in a time shard (every part observes alike);
            # with ``between``, the first in that span of log time (a later group of logs)
            messages = self._whole_times.filter(logset.messages(plan.names("graph"), between))
            if between is None:
                return self.graphs.first_has_agents(logset, iter(messages))
            lo, hi = between
            inside = (m for m in messages if m.log_time_ns >= lo)
            return self.graphs.has_agents(logset, takewhile(lambda m: m.log_time_ns < hi, inside))

        frames = (self.opts.map_frame, self.opts.base_frame)
        # the logs holding /tf: a short one's whole trajectory is its own, not strays
        dynamic = [t for t in plan.names("tf") if not t.endswith("_static")] if plan.tf else []
        observe(
            mapper, tf.shared, frames, graph_agents, logset, self._times, self.report,
            self.opts.observed, self._detection_windows,
            observed_fill(self.opts, self.previous_manifest, mapper.state.window_ns),
            self._marks,
            self._whole_times,
            self.at.opens_map and self.start is None,  # (learnt onto a map: it has started)
            self.shard and not self.at.opens_map and self.start is None,
            tuple(logset.recording_times(dynamic).values()),
            tf.poses(*frames),
        )

    def _fixed_graph(
        self, logset: Any, plan: TopicPlan, tf: TfTrees, config: ModelConfig
    ) -> GraphSnapshot | None:
        """The graph from ``--graph FILE`` or ``--derive-graph`` (added once, at the start;
        :func:`aion_cli.graph_source.graph_source`)."""
        start = self._times.start_ns
        if start is None:
            start = int(logset.start_ns)
        fixed = graph_source(
            self.report, plan, self.opts,
            continued_graph=self.previous is not None and self.previous.graph is not None,
            start=start,
            derive=lambda: self._derive(logset, plan, tf, config, start),
            graph_topics_at_once=lambda: topics_at_once(logset, plan.names("graph")),
            graph_streams_at_once=lambda: graph_streams_at_once(
                logset, plan.names("graph"), self.graphs.peek, config.bind_radius
            ),
        )
        if plan.graph:  # robots at once logging one session's graphs: their union, per group
            self.graphs.sessions = SessionGraphs(graph_groups(logset, plan.names("graph")))
        return fixed
