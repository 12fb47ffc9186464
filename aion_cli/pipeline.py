"""The build orchestration: logs -> scene graphs, detections and TF -> Mapper -> map file.

No click here: the CLI hands over :class:`BuildOptions` and a :class:`ProgressSink`, and gets a
:class:`BuildReport` back. Steps of :func:`build_map`:

1. open the logs (``formats.logs.open_logs``) and pick topics by type (:func:`select_topics`):
   detection topics with a supported adapter (all of them, or those named), the scene-graph
   topic(s) (``hydra_msgs/DsgUpdate``), ``/tf`` and ``/tf_static``;
2. read TF first (small) into a ``TfBuffer``; the observation mask comes from the robot
   trajectory ``map -> base_link``, else from the scene graph's agent layer, else the log is
   treated as a fixed sensor over the windows in which it recorded any message (the report
   says which);
3. with ``--derive-graph`` and no scene graph, one extra pass counts where people walk and
   :mod:`aion_cli.derive_graph` turns that into a navigational graph;
4. stream detection and scene-graph messages in log-time order: detection messages are
   collected into chunks of ``batch_size`` (flushed before every scene graph, so the Mapper sees
   everything in time order), decoded per type with numpy, transformed to the map frame,
   given headings, and fed to the Mapper;
5. write the map atomically (``formats.mapfile.write_map``) with a manifest recording the
   config, the inputs' provenance (path, size, sha256), the time span and the counts.

:func:`load_map` (from :mod:`aion_cli.mapquery`) reads a map back for ``predict``, ``plan``
and ``export``; :mod:`aion_cli.topics`, :mod:`aion_cli.detection_feed` and
:mod:`aion_cli.provenance` hold the steps' parts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from aion_cli.detection_feed import (
    HEADING_SOURCES,
    DetectionCounts,
    DetectionFeeder,
    chunks,
    decoded_chunks,
    log_adapters,
)
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.errors import (
    ConfigError,
    InputError,
    MessageDecodeError,
    TopicNotFoundError,
    TransformError,
)
from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Trajectory
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
    graph_messages: int = 0
    graph_skipped: int = 0
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
                "dsg_version": self.dsg_version,
                "topics": self.graph_topics,
            },
            "detection_topics": self.detection_topics,
            "detection_decoding": self.detection_decoding,
            "headings": {k: int(self.headings.get(k, 0)) for k in HEADING_SOURCES},
            "inputs": self.inputs,
            "notes": self.notes,
            "warnings": self.warnings,
        }


# -- the build ---------------------------------------------------------------------------------
def _load_tf(logset: Any, plan: TopicPlan, progress: ProgressSink) -> TfBuffer | None:
    """All TF into one buffer. Messages are decoded with numpy 4096 at a time
    (:mod:`formats.tf_fast`, ~50x faster than rosbags) where the log's definition of the TF
    type is the layout that decoder reads (:func:`formats.tf_fast.layout_matches`); messages
    of other topics, and a chunk the fast decoder rejects (e.g. big-endian CDR, a corrupt
    payload), are decoded message by message with the log's own definitions, which reports a
    corrupt payload as before."""
    import logging

    from formats.tf import TfBuffer
    from formats.tf_fast import decode_tf_messages, layout_matches

    if not plan.tf:
        return None
    topics = plan.names("tf")
    progress.start("reading TF", logset.total(topics))
    buffer = TfBuffer()
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
        static = np.fromiter((m.topic.endswith("_static") for m in chunk), bool, len(chunk))
        try:
            if not all(map(fast, chunk)):
                raise MessageDecodeError("the log defines TF in another layout")
            arrays = decode_tf_messages(chunk)
        except MessageDecodeError:
            generic += 1
            for m, st in zip(chunk, static.tolist(), strict=True):
                buffer.add_message(logset.decode(m), static=st)
        else:
            rows_static = static[arrays.msg_index]
            for flag in (True, False):  # like TfBuffer's own batches: static rows first
                for parent, child, rows in arrays.select(
                    arrays.usable() & (rows_static == flag)
                ).by_edge():
                    buffer.add_transforms(
                        parent, child, rows.t_ns, rows.translation, rows.quat_xyzw, flag
                    )
        progress.advance(len(chunk))

    chunk: list[RawMessage] = []
    for msg in logset.messages(topics):
        chunk.append(msg)
        if len(chunk) == 4096:
            add(chunk)
            chunk = []
    if chunk:
        add(chunk)
    if generic:
        logging.getLogger(__name__).info("TF: %d chunk(s) read by the generic decoder", generic)
    return buffer


def _robot_trajectory(tf: TfBuffer | None, opts: BuildOptions) -> Trajectory | None:
    if tf is None:
        return None
    try:
        traj = tf.trajectory(opts.map_frame, opts.base_frame)
    except TransformError:
        return None
    return traj if len(traj) else None


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
        self._adapters: dict[tuple[str, str, str], Any] = {}
        self._factory: Any = None

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
        from formats.mapfile import MapWriteError, map_lock

        out = self.report.output
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise MapWriteError(
                f"cannot write map {out}: folder {folder} does not exist",
                hint="create the folder first or choose another output path",
            )
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
        config = self.config()
        inputs = self._inputs()
        out = self.report.output
        if out.exists() and self.previous is None:
            self.report.notes.append(
                f"{out.name} existed and is replaced (use --map {out.name} to extend a map)"
            )
        mappings = _load_mappings(opts.detections_mapping)
        with open_logs(list(opts.logs), opts.log_format) as logset:
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
            tf = _load_tf(logset, plan, self.progress)
            self._observation(mapper, tf, plan, logset)
            fixed_graph = self._fixed_graph(logset, plan, tf, config)
            if fixed_graph is not None:
                mapper.add_graph(fixed_graph)
            self._stream(logset, plan, tf, mapper, fixed_graph is not None)
            mapper.advance(int(logset.end_ns))
            self._span(logset)
            # readers also warn while streaming (a corrupt chunk ends a file early)
            self.report.notes.extend(w for w in logset.warnings if w not in self.report.notes)
        self._write(mapper, config, inputs)
        return self.report

    def _inputs(self) -> list[dict[str, Any]]:
        for path in self.opts.logs:
            if not path.exists():
                raise InputError(f"log not found: {path}", hint="check the path")
        out = self.report.output.resolve()
        if any(out == p.resolve() for p in self.opts.logs):
            raise InputError(
                f"the map would overwrite the log {self.report.output}",
                hint="choose another output with -o (maps end in .aion)",
            )
        sizes = [provenance_size(p) for p in self.opts.logs]
        self.progress.start("hashing logs", max(sum(sizes) >> 20, 1), "MiB")
        new = []
        for path, size in zip(self.opts.logs, sizes, strict=True):
            new.append(provenance(path))
            self.progress.advance(size >> 20)
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
        traj = _robot_trajectory(tf, self.opts)
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
            self.report.observation = _fixed_sensor_windows(mapper, logset)
            self.report.notes.append(
                "no robot trajectory (TF map->base_link or scene-graph agents): the log is "
                "treated as a fixed sensor that saw everything in the windows in which it "
                "recorded any message"
            )

    def _graph_has_agents(self, logset: Any, plan: TopicPlan) -> bool:
        """Whether the first scene graph of the log carries robot poses (its agent layer)."""
        first = next(iter(logset.messages(plan.names("graph"))), None)
        if first is None:
            return False
        agents = self._decode_graph(logset, first).agents
        return agents is not None and len(agents) > 0

    def _fixed_graph(
        self, logset: Any, plan: TopicPlan, tf: TfBuffer | None, config: ModelConfig
    ) -> GraphSnapshot | None:
        """The graph from ``--graph FILE`` or ``--derive-graph`` (added once, at the start)."""
        opts = self.opts
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
        for chunk, _ in chunks(logset.messages(topics), set(), self.opts.batch_size):
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
        feeder = self._feeder(tf, self.counts)
        graph_topics = plan.names("graph")
        topics = plan.names("detections") | graph_topics
        self.progress.start("building map", logset.total(topics))
        use_agents = self.report.observation.startswith("scene-graph")
        stream = chunks(logset.messages(topics), graph_topics, self.opts.batch_size)
        for batch, n_messages, graph_msg in decoded_chunks(stream, feeder):
            if batch is not None:
                self._feed(mapper, batch)
                self.progress.advance(n_messages)
            if graph_msg is not None:
                snapshot = self._decode_graph_or_skip(logset, graph_msg)
                self.progress.advance(1)
                if snapshot is None:
                    continue
                mapper.add_graph(snapshot)
                if use_agents:
                    self._add_agent_poses(mapper, snapshot.agents)
                self.report.graph_messages += 1
        self._check_graph_skips()
        c = self.counts
        self.report.detections_read = c.read
        self.report.detections_used = c.used
        self.report.dropped = dict(c.dropped)
        self.report.headings = dict(c.headings)
        self._check_decoding(plan)
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
            self.report.observation = _fixed_sensor_windows(mapper, logset)

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
        """A map without a single usable detection is an error, never a success: it names
        what became of the detections read. A continued map that holds detections already
        may take logs of which none could be used (a warning), or in which nobody was seen
        (a note: their observed windows are real zeros)."""
        c = self.counts
        if c.used > 0:
            return
        drops = ", ".join(f"{k} {v:,}" for k, v in sorted(c.dropped.items()) if v)
        messages = sum(t.messages for t in c.topics.values())
        before = self.previous.manifest.get("counts", {}) if self.previous is not None else {}
        if int(before.get("used", 0)) > 0:
            if c.read == 0 and not drops:
                self.report.notes.append(
                    f"no person in the {messages:,} detection messages: only observed-empty "
                    "windows were added to the map"
                )
            else:
                self.report.warnings.append(
                    f"none of the {c.read:,} people detections of these logs could be used "
                    f"(dropped: {drops or 'none'}); the map keeps what it had"
                )
            return
        if c.read == 0:
            raise InputError(
                f"no people detection in the {messages:,} messages of "
                f"{', '.join(self.report.detection_topics)}"
                + (f" (dropped: {drops})" if drops else ""),
                hint="the topics carry no detections (check the class filter of vision_msgs, "
                "or choose other topics with --detections-topic); no map was written",
            )
        hint = "no map was written"
        if c.dropped.get("no_transform"):
            hint = "check --map-frame and the log's TF; no map was written"
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

    def _feed(self, mapper: Mapper, batch: DetectionBatch) -> None:
        if len(batch) == 0:
            return
        drops = mapper.add_detections(batch)
        dropped = sum(int(v) for v in drops.values())
        for reason, n in drops.items():
            if n:
                self.counts.dropped[reason] += int(n)
        self.counts.used += len(batch) - dropped

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
        failure is the build's error (a map without the log's graph would mislead)."""
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
        """
        from formats.dsg import GraphLayerError, decode_dsg

        decoded = logset.decode(msg)
        payload = np.asarray(decoded.layer_contents, dtype=np.uint8)
        stamp = decoded.header.stamp
        t_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) or msg.log_time_ns
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
        return result.snapshot

    def _span(self, logset: Any) -> None:
        start, end = int(logset.start_ns), int(logset.end_ns)
        if self.previous is not None:
            old = self.previous.manifest.get("time_span", {})
            start = min(start, int(old.get("start_ns", start)))
            end = max(end, int(old.get("end_ns", end)))
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


def _fixed_sensor_windows(mapper: Mapper, logset: Any) -> str:
    """A fixed sensor observes exactly the windows in which the logs recorded something (any
    message on any topic) — never the time between two recordings, within one file or across
    files — so ``build A B`` records the same empty windows as ``build A`` then ``--map B``.
    Returns the report's description of the observation."""
    from aion_cli.engine.windows import window_ns

    delta = window_ns(mapper.state.config.window_s)
    windows = logset.recorded_windows(delta)
    mapper.set_fixed_windows(windows)
    if len(windows) == 0:
        return "fixed sensor (no message recorded)"
    span = int(windows[-1] - windows[0] + 1)
    return (
        f"fixed sensor over the {len(windows):,} windows with messages "
        f"({len(windows) * delta / 3.6e12:.1f} h of a {span * delta / 3.6e12:.1f} h span)"
    )
