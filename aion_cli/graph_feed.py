"""The scene-graph feed of a build: which ``hydra_msgs/DsgUpdate`` messages it uses
(``--graph-period``; :mod:`aion_cli.graph_schedule` decides), how each is decoded (the
spark_dsg version and the navigational layer pinned by the first graph that worked, a payload
identical to the last one reused instead of decoded again) and what damaged ones do (skipped
and counted; the first failure is the build's error when no graph at all could be decoded).
Where a map's graph comes from when not from the stream (``--graph FILE``, the continued map,
``--derive-graph``) is :mod:`aion_cli.graph_source`.

Why a module of its own, beside :mod:`aion_cli.detection_feed` and :mod:`aion_cli.tf_feed`:
the graph stream carries state across the whole log (the pinned version and layer, the last
payload, the robot poses already fed from the agent layer) that the build orchestration
(:mod:`aion_cli.pipeline`) should not have to know about; it only asks :class:`GraphFeed` for
the next snapshot.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import I64, GraphSnapshot, Trajectory
from aion_cli.errors import InputError, MessageDecodeError, PartialGraphError
from aion_cli.formats.dsg_delta import GraphReader
from aion_cli.graph_notes import (
    DAMAGED_GRAPHS_NOTE,
    PARTIAL_GRAPHS_NOTE,
    graph_counts_note,
    other_frame_warning,
)
from aion_cli.graph_schedule import graph_schedule
from aion_cli.session_graphs import SessionGraphs

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.engine.mapper import Mapper
    from aion_cli.formats.raw import RawMessage, UnreadHint
    from aion_cli.graph_schedule import GraphTimes

__all__ = ["GraphFeed"]


class GraphFeed:
    """The scene graphs of one build's stream, with the state they carry across the log.

    ``dsg_version`` (``--dsg-version``, None: the version of the first graph that decodes)
    and ``nav_layer`` (``--nav-layer``, None: the layer the first graph with places chose)
    are pinned for the rest of the log; ``skip_identical``: a payload byte-identical to the
    last one decoded reuses its snapshot. What happens to the graphs is counted in
    ``report`` (``graph_decoded``, ``graph_skipped``, ``graphs_skipped_identical``,
    ``graphs_skipped_period``, ``dsg_version``, ``graph_layer``, the notes)."""

    def __init__(
        self,
        report: BuildReport,
        dsg_version: str | None,
        nav_layer: str | None,
        period_ns: int,
        skip_identical: bool = True,
        pins: tuple[str | None, str | None] = (None, None),
        map_frame: str = "map",
    ) -> None:
        self.report = report
        self.map_frame = map_frame
        # robots at once logging one session's graphs: the map's graph is their union
        self.sessions = SessionGraphs()
        # per topic, the frame its graphs name when that is not the map frame (None: it is)
        self._frames: dict[str, str | None] = {}
        if dsg_version is not None:  # --dsg-version: failures stop the build
            from aion_cli.formats.dsg_payload import pinned_version

            dsg_version = pinned_version(dsg_version)
        self.pinned_version = dsg_version is not None
        self.dsg_version = dsg_version
        self.nav_layer = nav_layer
        self.period_ns = period_ns
        self.skip_identical = skip_identical
        self.used: npt.NDArray[np.bool_] | None = None  # graph_schedule (None: all)
        self.window_ns = 0  # the schedule's window (a partial's stand-in stays in it)
        # log times at which the schedule uses no graph: the reader may leave those unread
        self.unread_times: I64 = np.zeros(0, np.int64)
        self._nav_pin: str | None = None  # the layer key the log's first graph chose
        if pins[0] is not None and dsg_version is None:  # a stream continued (``pins``)
            self.dsg_version = pins[0]
        if pins[1] is not None and nav_layer is None:
            self._nav_pin = pins[1]
        self._agents_until = np.iinfo(np.int64).min
        self._first_error: MessageDecodeError | None = None
        self.partial = 0  # partial updates skipped (full_update false)
        self._last: tuple[memoryview, GraphSnapshot] | None = None  # payload, snapshot
        self._first: tuple[str, int, GraphSnapshot] | None = None  # decoded early
        self._fast_layout: dict[tuple[str, str, str], bool] = {}  # (topic, type, encoding)
        self._flag_used: dict[str, bool] = {}  # per topic: full_update is set (_uses_flag)
        self._reader = GraphReader()  # re-reads only the node records a payload changed

    @property
    def pins(self) -> tuple[str | None, str | None]:
        """What the graphs so far pinned for the rest of the stream: the spark_dsg version
        and the navigational layer's key (None where not yet, or given by an option)."""
        return (
            None if self.pinned_version else self.dsg_version,
            None if self.nav_layer is not None else self._nav_pin,
        )

    def schedule(
        self,
        times: GraphTimes,
        strays: dict[str, I64],
        window_ns: int,
        limits: tuple[int, int] | None = None,
    ) -> None:
        """Decide which graphs the stream uses (:func:`graph_schedule` over the graph log
        times read before the stream, without the ``strays`` the time check drops).

        ``limits``: a time shard of a parallel build streams only the part ``[lo, hi)`` of
        the log; it uses the graphs the whole log's schedule uses there, and feeds agent
        poses from ``lo`` on (:meth:`agents_since`)."""
        t = times.stream_times(strays)
        used = graph_schedule(t, self.period_ns, window_ns)
        if limits is not None:
            lo, hi = limits
            part = (t >= lo) & (t < hi)
            t, used = t[part], used[part]
            self.agents_since(lo)
        self.used = used
        self.window_ns = window_ns
        self.unread_times = np.setdiff1d(t[~used], t[used])

    def unread_hint(self, graph_topics: set[str]) -> UnreadHint | None:
        """The scene graphs :meth:`thin` will drop, for the reader: those logged at a time at
        which the schedule uses no graph (None before a schedule). A reader may yield them
        unread (:data:`formats.raw.UNREAD`): an MCAP chunk whose tail they are is then
        decompressed only up to them. The graphs it reads may come as read-only views
        (``views``: the stream reads, compares and decodes them as memoryviews, and keeps
        them no longer than it would keep their bytes)."""
        if self.used is None:
            return None
        from aion_cli.formats.raw import UnreadHint

        return UnreadHint(frozenset(graph_topics), self.unread_times, views=True)

    def agents_since(self, t_ns: int) -> None:
        """Feed no agent pose logged before ``t_ns``. A shard of a parallel build starts
        there (a window start): every Hydra snapshot repeats the session's trajectory, and one
        pass fed the earlier poses with the earlier graphs, before those windows closed."""
        self._agents_until = max(self._agents_until, int(t_ns) - 1)

    def thin(
        self,
        messages: Iterator[RawMessage],
        graph_topics: set[str],
        progress: ProgressSink,
        logset: Any = None,
    ) -> Iterator[RawMessage]:
        """The stream without the scene graphs the schedule leaves out
        (:func:`aion_cli.graph_thin.thin_graphs`; with ``logset`` a used partial update's
        period gets the next whole graph of its window)."""
        from aion_cli.graph_thin import thin_graphs

        return thin_graphs(self, messages, graph_topics, progress, logset)

    def is_whole(self, logset: Any, msg: RawMessage) -> tuple[bool, RawMessage]:
        """Whether the stream applies ``msg`` as a whole graph: not a partial update
        (:meth:`payload`); a message that cannot be read answers True (the stream counts it).
        With ``msg`` as the stream is to pass it on: with the fields read of it
        (:class:`~formats.dsg_update_fast.FieldsRead`), so that its decoding reads none again."""
        from aion_cli.formats.dsg_update_fast import FieldsRead, update_fields

        try:
            msg = FieldsRead.of(msg, update_fields(logset, msg, self._fast_layout))
            self.payload(logset, msg)
        except PartialGraphError:
            return False, msg
        except Exception:
            return True, msg
        return True, msg

    def has_agents(self, logset: Any, messages: Iterable[RawMessage]) -> bool:
        """Whether the first of the scene graphs ``messages`` that decodes carries robot
        poses, decoded apart from the stream (no version or layer pinned, nothing kept): the
        observation of a later group of logs (:func:`aion_cli.fixed_sensor.
        unposed_log_windows`). A damaged graph is passed over, as the stream skips it; none
        that decodes carries none."""
        for msg in messages:
            snapshot = self._apart(logset, msg, None)
            if snapshot is not None:
                return _posed(snapshot)
        return False

    def peek(self, logset: Any, msg: RawMessage) -> GraphSnapshot | None:
        """The scene graph ``msg`` decoded apart from the stream (no version or layer pinned,
        nothing counted or kept; ``--nav-layer`` and ``--dsg-version`` as given); None when
        it cannot be read or decoded, or is a partial update (the stream skips those)."""
        return self._apart(logset, msg, self.nav_layer)

    def _apart(self, logset: Any, msg: RawMessage, layer: str | None) -> GraphSnapshot | None:
        from aion_cli.formats.dsg import decode_dsg

        try:  # a partial update or a message that does not read: skipped by the stream too
            payload, t_ns = self.payload(logset, msg)
            return decode_dsg(payload, t_ns, self.dsg_version, layer).snapshot
        except InputError:
            return None

    def first_has_agents(self, logset: Any, messages: Iterator[RawMessage]) -> bool:
        """Whether the log's first scene graph that decodes carries robot poses (its agent
        layer); ``messages``: the graph messages the stream reads, in its order. The first
        one's snapshot is kept for the stream, which then does not decode it again. A damaged
        first graph is skipped, as the stream skips it (which counts it), and the next graphs
        answer (:meth:`has_agents`); with ``--dsg-version`` its failure stops the build, as it
        stops the stream. (A damaged first graph used to stop a build without TF.)"""
        first = next(messages, None)
        if first is None:
            return False
        try:
            snapshot = self.decode(logset, first)
        except PartialGraphError:  # skipped by the stream too
            return self.has_agents(logset, messages)
        except MessageDecodeError:
            if self.pinned_version:
                raise
            return self.has_agents(logset, messages)
        self._first = (first.topic, first.log_time_ns, snapshot)
        return _posed(snapshot)

    def add_agent_poses(self, mapper: Mapper, agents: Trajectory | None) -> None:
        """Feed the robot poses of a snapshot's agent layer that are newer than those fed
        before (every Hydra snapshot repeats the whole trajectory)."""
        if agents is None or len(agents) == 0:
            return
        t = np.asarray(agents.t_ns, dtype=np.int64)
        new = t > self._agents_until
        if new.any():
            mapper.add_trajectory(Trajectory(t[new], np.asarray(agents.xyz)[new]))
            self._agents_until = int(t[new].max())

    def decode_or_skip(self, logset: Any, msg: RawMessage) -> GraphSnapshot | None:
        """A damaged scene-graph message is skipped and counted (the graph stays as it was
        until the next full graph, which Hydra repeats every few seconds); with the version
        pinned by ``--dsg-version`` a failure is the user's to fix and stops the build."""
        try:
            return self.decode(logset, msg)
        except PartialGraphError:
            self.partial += 1
            return None
        except MessageDecodeError as exc:
            if self.pinned_version:
                raise
            self.report.graph_skipped += 1
            if self._first_error is None:
                self._first_error = exc
            return None

    def check_skips(self, stop_if_none: bool = True) -> None:
        """Skipped graphs are a note; when no scene graph at all could be decoded the first
        failure is the build's error (a map without the log's graph would mislead; a shard of
        a parallel build leaves that to the parent, ``stop_if_none=False``: another shard may
        have decoded some). Graphs left out by ``--graph-period`` or reused unchanged are a
        note with the counts (:func:`graph_counts_note`)."""
        r = self.report
        seen = r.graph_messages + r.graph_skipped + r.graphs_skipped_period
        if seen:
            r.graph_period_ns = self.period_ns
        note = graph_counts_note(r)
        if note is not None:
            r.notes.append(note)
        if self.partial:
            r.notes.append(f"{self.partial:,} {PARTIAL_GRAPHS_NOTE}")
        for topic, frame in sorted(self._frames.items()):
            if frame is not None:
                warning = other_frame_warning(topic, frame, self.map_frame)
                if warning not in r.warnings:
                    r.warnings.append(warning)
        if r.graph_skipped == 0 or self._first_error is None:
            return
        if r.graph_messages == 0 and stop_if_none:
            raise self._first_error
        r.notes.append(
            f"{r.graph_skipped:,} {DAMAGED_GRAPHS_NOTE} (first: "
            f"{self._first_error.message})"
        )

    def decode(self, logset: Any, msg: RawMessage) -> GraphSnapshot:
        """One DsgUpdate message as a snapshot, through the loader every command uses.

        The navigational layer is ``--nav-layer``, else the one the first graph with places
        chose by name, kept for the rest of the log (an early graph that has 3D places but no
        2D places yet must not make the map switch layers later); when a later graph lacks
        that layer it is chosen again.

        Decoding is skipped twice: the log's first graph when :meth:`first_has_agents`
        decoded it already, and a payload byte-identical to the last one decoded (a fixed
        sensor's static map, Hydra repeating an unchanged graph): its snapshot is reused with
        the message's own time (counted as ``skipped_identical``). The payload is compared
        byte for byte with the last one (:func:`_same_bytes`, a view of that message kept):
        exact, where a digest could collide, and cheaper (0.4-0.6 ms at most for a 1.9 MB,
        5,000-place payload, usually less: it stops at the first differing block; blake2b
        takes 3.4 ms).
        """
        from aion_cli.formats.dsg import GraphLayerError, decode_dsg

        first = self._first
        if first is not None and first[:2] == (msg.topic, msg.log_time_ns):
            self._first = None  # decoded already, for the observation
            return first[2]
        payload, t_ns = self.payload(logset, msg)
        if self.skip_identical:
            last = self._last
            if last is not None and _same_bytes(last[0], payload):
                # The same bytes decode to the same graph with the same pinned version and
                # layer: only its time differs. It is still applied (add_graph closes windows
                # and checks binds at its time), so the map equals decoding it again.
                self.report.graphs_skipped_identical += 1
                return last[1].restamped(t_ns)
        layer = self.nav_layer or self._nav_pin
        try:
            result = decode_dsg(payload, t_ns, self.dsg_version, layer, reader=self._reader)
        except GraphLayerError as exc:
            if self.nav_layer is not None or self._nav_pin is None:
                raise GraphLayerError(f"{msg.topic}: {exc.message}", hint=exc.hint) from exc
            result = decode_dsg(payload, t_ns, self.dsg_version, reader=self._reader)
        if self.dsg_version is None:  # pin the version that worked for the rest of the log
            self.dsg_version = result.version
        if self.nav_layer is None and self._nav_pin is None and len(result.snapshot.places):
            self._nav_pin = result.layer.key
        self.report.dsg_version = result.version
        self.report.graph_layer = str(result.layer)
        self.report.graph_decoded += 1
        self.report.graphs_read_by_changes = self._reader.delta_reads
        if self.skip_identical:
            self._last = (payload, result.snapshot)
        return result.snapshot

    def payload(self, logset: Any, msg: RawMessage) -> tuple[memoryview, int]:
        """A DsgUpdate's payload (a view of the message's own bytes) and its time: the
        header stamp, the log time where the stamp is zero.

        Read straight from the serialized message (:mod:`formats.dsg_update_fast`) where the
        log defines the type in the layout that reader knows (checked once per topic); the
        generic decoder reads the other messages, and those the fast reader declines.
        :class:`~aion_cli.errors.PartialGraphError` for a partial update (``full_update``
        false: the nodes that changed, not the graph; Hydra's own receivers refuse them),
        which read as a whole graph would take every node it does not repeat out of the map;
        unless the topic's first message has the flag false too (:meth:`_uses_flag`)."""
        from aion_cli.formats.dsg_update_fast import update_fields

        fields = update_fields(logset, msg, self._fast_layout)
        if msg.topic not in self._frames:  # the first graph's frame speaks for its topic
            from aion_cli.formats.raw import normalize_frame

            frame = normalize_frame(fields.frame_id)  # empty: Hydra's ROS 1 sender
            self._frames[msg.topic] = frame if frame not in ("", self.map_frame) else None
        t_ns = int(fields.sec) * 1_000_000_000 + int(fields.nanosec) or msg.log_time_ns
        if not fields.full_update and self._uses_flag(logset, msg.topic):
            raise PartialGraphError(
                f"{msg.topic}: a partial scene-graph update (full_update false) at {t_ns} ns"
            )
        return fields.payload, t_ns

    def _uses_flag(self, logset: Any, topic: str) -> bool:
        """Whether ``topic``'s writer sets ``full_update``: its first message (in the logs
        read) has it true. A stream cannot begin with a partial update (Hydra's receivers read
        the first message as the whole graph), so a topic whose first message has the flag
        false comes from a writer that leaves it unset, and its graphs are read whole."""
        from aion_cli.formats.dsg_update_fast import update_fields

        if topic not in self._flag_used:
            first = next(iter(logset.messages({topic})), None)
            self._flag_used[topic] = first is not None and bool(
                update_fields(logset, first, self._fast_layout).full_update
            )
        return self._flag_used[topic]


def _posed(snapshot: GraphSnapshot) -> bool:
    """Whether a snapshot's agent layer holds robot poses."""
    agents = snapshot.agents
    return agents is not None and len(agents) > 0


def _same_bytes(a: memoryview, b: memoryview, block: int = 1 << 16) -> bool:
    """Whether two payloads are byte-identical, compared block by block (a payload that
    differs is usually told apart in its first block). Each block is copied out of both
    views and compared as ``bytes`` (one ``memcmp``): half the time of numpy's elementwise
    comparison for a 63 KB payload, which a build compares at every scene graph (issue 15:
    14 against 28 µs), and about as fast for a 1.9 MB one (0.4-0.6 ms)."""
    x, y = a.cast("B"), b.cast("B")
    if x.nbytes != y.nbytes:
        return False
    return all(
        x[i : i + block].tobytes() == y[i : i + block].tobytes()
        for i in range(0, x.nbytes, block)
    )
