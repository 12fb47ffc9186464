"""Raw detection messages -> map-frame :class:`DetectionBatch` chunks for the Mapper.

Messages are decoded per topic (and encoding) with the adapter the build chose for it (a
built-in adapter reading the log's own definition, numpy fast path only where that definition
is the layout the fast decoder was written for, or the user's TOML mapping), moved into the
map frame with the TF buffer (rows without a transform are counted as ``no_transform`` and
dropped; a frame with no TF at all is an error naming ``--map-frame``), linked into short
tracks where nothing else can give a heading -- no track id, no velocity, no pose yaw (and a
topic whose orientations never vary has none) -- with one
:class:`~aion_cli.engine.tracking.TrackLinker` per topic, its state carried across chunks, so
such detections get headings from motion; sorted by time and given headings by
:class:`HeadingEstimator` s that keep their per-track state across chunks.
:class:`DetectionCounts` tallies what happened per topic and per heading source.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.errors import TransformError
from aion_cli.engine.types import DetectionBatch

if TYPE_CHECKING:
    from aion_cli.engine.tracking import LinkerConfig, TrackLinker
    from formats.detections import DetectionAdapter
    from formats.raw import RawMessage
    from formats.tf import TfBuffer

#: Heading sources counted by :class:`DetectionCounts` (the build summary's order).
HEADING_SOURCES: tuple[str, ...] = ("velocity", "track", "linked", "pose_yaw", "none")

_VARIES = float("nan")
_SAME_YAW = 1e-9  # rad: yaws closer than this are one orientation

#: Builds the adapter of one (topic, message type, encoding) the first time it is seen.
AdapterFactory = Callable[[str, str, str], "DetectionAdapter"]


@dataclass
class TopicCounts:
    """One detection topic: messages decoded, messages that could not be decoded, and the
    first decode failure (its message)."""

    messages: int = 0
    undecodable: int = 0
    first_error: str | None = None
    first_hint: str | None = None


@dataclass
class DetectionCounts:
    """Detections decoded (``read``), accepted by the Mapper (``used``), dropped by reason, how
    many had a zero header stamp and took their message's log time (``stamp_fallbacks``), how
    many came from header-less messages and took it by design (``log_times``), headings by
    source (:data:`HEADING_SOURCES`) and per-topic message counts."""

    read: int = 0
    used: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    stamp_fallbacks: int = 0
    log_times: int = 0
    headings: Counter[str] = field(default_factory=Counter)
    topics: dict[str, TopicCounts] = field(default_factory=dict)

    def topic(self, name: str) -> TopicCounts:
        got = self.topics.get(name)
        if got is None:
            got = self.topics[name] = TopicCounts()
        return got


def _default_factory(topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
    """The built-in adapter with aion's shipped definitions (no log at hand)."""
    from aion_cli.engine.errors import TopicNotFoundError
    from formats.detections import adapter_for

    adapter = adapter_for(msgtype)
    if adapter is None:
        raise TopicNotFoundError(f"no people-detection adapter for {msgtype} on {topic!r}")
    return adapter


class DetectionFeeder:
    """Decodes chunks of raw detection messages into map-frame DetectionBatches.

    ``adapters``: the adapter per ``(topic, msgtype, encoding)`` (from
    :func:`aion_cli.pipeline`'s topic choice); ``factory`` builds the missing ones on first
    sight (default: the built-in adapter with shipped definitions). ``linker``: the track
    linker's parameters for id-less detections, None to leave them unlinked."""

    def __init__(
        self,
        tf: TfBuffer | None,
        map_frame: str,
        counts: DetectionCounts,
        adapters: Mapping[tuple[str, str, str], DetectionAdapter] | None = None,
        factory: AdapterFactory | None = None,
        linker: LinkerConfig | bool | None = True,
    ) -> None:
        from aion_cli.engine.tracking import LinkerConfig
        from formats.detections import HeadingEstimator

        self.tf = tf
        self.map_frame = map_frame
        self.counts = counts
        self.adapters: dict[tuple[str, str, str], DetectionAdapter] = dict(adapters or {})
        self.factory = factory or _default_factory
        self.headings = HeadingEstimator()
        if linker is True:
            linker = LinkerConfig()
        self.linker_config: LinkerConfig | None = linker or None
        cfg = self.linker_config
        # Linked tracks are differenced like the linker's own rule: displacements of at least
        # min_step, looking back at most heading_span_s (ids of their own number space).
        self.linked_headings = HeadingEstimator(
            min_displacement=cfg.min_step if cfg else 0.3,
            max_gap_s=cfg.heading_span_s if cfg else 5.0,
        )
        self._linkers: dict[str, TrackLinker] = {}
        # per topic: the one yaw its messages have shown so far (float), or _VARIES
        self._yaw_seen: dict[str, float] = {}

    def adapter(self, topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
        """The adapter of ``topic`` (built on first use)."""
        key = (topic, msgtype, encoding)
        got = self.adapters.get(key)
        if got is None:
            got = self.adapters[key] = self.factory(topic, msgtype, encoding)
        return got

    def decode(self, messages: list[RawMessage]) -> DetectionBatch:
        """Decode, transform, link and give headings to ``messages`` (any detection topics)."""
        from formats.detections.frame import FrameDetections

        groups: dict[tuple[str, str, str], list[RawMessage]] = {}
        for msg in messages:
            groups.setdefault((msg.topic, msg.msgtype, msg.encoding), []).append(msg)
        parts = []
        linked = []
        for (topic, msgtype, encoding), msgs in groups.items():
            adapter = self.adapter(topic, msgtype, encoding)
            frames = adapter.decode(msgs, on_error="skip")  # damaged messages: counted
            self._count(topic, adapter, frames, len(msgs))
            frames = self._informative_yaws(topic, frames)
            frames = self._to_map_frame(frames)
            parts.append(frames)
            linked.append(self._link(topic, frames))
        if not parts:
            return DetectionBatch.empty()
        merged = parts[0] if len(parts) == 1 else FrameDetections.concat(parts)
        link_ids = linked[0] if len(linked) == 1 else np.concatenate(linked)
        t = merged.t_ns
        if t.size > 1 and not bool(np.all(t[1:] >= t[:-1])):  # usually in order already
            order = np.argsort(t, kind="stable")
            merged, link_ids = merged.select(order), link_ids[order]
        return self._headings(merged, link_ids)

    # --- internals ---------------------------------------------------------------------------
    def _count(self, topic: str, adapter: DetectionAdapter, frames: Any, n_messages: int) -> None:
        c = self.counts
        c.read += len(frames)
        if adapter.stamped:
            c.stamp_fallbacks += int(frames.stamp_fallbacks)
        else:
            c.log_times += int(frames.stamp_fallbacks)
        per_topic = c.topic(topic)
        per_topic.messages += n_messages
        for reason, n in frames.filtered.items():
            # damaged payloads are counted per message: their detections are unknown
            key = "undecodable_messages" if reason == "undecodable" else reason
            c.dropped[key] += n
            if reason == "undecodable":
                per_topic.undecodable += n
        error = adapter.first_error
        if error is not None and per_topic.first_error is None:
            per_topic.first_error, per_topic.first_hint = error.message, error.hint

    def _informative_yaws(self, topic: str, frames: Any) -> Any:
        """``frames`` with its yaws unset while its topic's orientations have never varied
        (checked in the message frame, before TF turns them with the robot): a publisher
        that leaves every orientation at zero or at identity says nothing about where people
        walk, and a yaw of 0 for everyone would pose as a heading."""
        y = frames.yaw
        finite = np.isfinite(y)
        if not finite.any():
            return frames
        seen = self._yaw_seen.get(topic)
        if seen is not None and np.isnan(seen):
            return frames  # the topic's orientations vary: they are real
        vals = y[finite]
        lo, hi = float(vals.min()), float(vals.max())
        if hi - lo > _SAME_YAW or (seen is not None and abs(seen - lo) > _SAME_YAW):
            self._yaw_seen[topic] = _VARIES
            return frames
        self._yaw_seen[topic] = lo
        return dataclasses.replace(frames, yaw=np.full(len(frames), np.nan))

    def _link(self, topic: str, frames: Any) -> np.ndarray:
        """Linked track ids (-1 elsewhere) of the rows that have no other heading source: no
        track id, no velocity, no (informative) pose yaw. One linker per topic, so that two
        sensors' detections are never joined into one track."""
        out = np.full(len(frames), -1, np.int64)
        if self.linker_config is None or len(frames) == 0:
            return out
        v = frames.velocity
        moving = np.isfinite(v[:, :2]).all(axis=1) & ((v[:, 0] != 0) | (v[:, 1] != 0))
        rows = np.flatnonzero((frames.track_id < 0) & ~moving & np.isnan(frames.yaw))
        if rows.size == 0:
            return out
        linker = self._linkers.get(topic)
        if linker is None:
            from aion_cli.engine.tracking import TrackLinker

            linker = self._linkers[topic] = TrackLinker(self.linker_config)
        ids = linker.link(frames.t_ns[rows], frames.xyz[rows, :2])
        # the linked tracks of every topic in one number space: id * 2**16 + topic index
        stride = 1 << 16
        index = list(self._linkers).index(topic)
        out[rows] = np.where(ids >= 0, ids * stride + index, -1)
        return out

    def _headings(self, merged: Any, link_ids: np.ndarray) -> DetectionBatch:
        """Headings of every row: the main estimator for rows with the source's ids (or none),
        the linked estimator for linked rows; both tallied by source."""
        from formats.detections.heading import SOURCES

        batch = self.headings.to_batch(merged)
        sources = self.headings.sources
        is_linked = link_ids >= 0
        if is_linked.any():
            rows = np.flatnonzero(is_linked)
            lb = self.linked_headings.estimate(
                merged.t_ns[rows], merged.xyz[rows], merged.velocity[rows], merged.yaw[rows],
                link_ids[rows],
            )
            batch.heading[rows], batch.speed[rows] = lb.heading, lb.speed
            lsrc = self.linked_headings.sources
            self._tally(lsrc, SOURCES, linked=True)
            sources = sources[~is_linked]
        self._tally(sources, SOURCES, linked=False)
        return batch

    def _tally(self, codes: np.ndarray, names: tuple[str, ...], linked: bool) -> None:
        tally = np.bincount(codes, minlength=len(names))
        for name, n in zip(names, tally.tolist(), strict=True):
            if n:
                key = "linked" if linked and name == "track" else name
                self.counts.headings[key] += int(n)

    def _to_map_frame(self, frames: Any) -> Any:
        """Rows moved into the map frame; rows without a transform are counted and dropped."""
        if len(frames) == 0:
            return frames
        target = self.map_frame
        if all(name in ("", target) for name in frames.frames):  # nothing to move
            if frames.frames == (target,):
                return frames
            return dataclasses.replace(
                frames, frame_id=np.zeros(len(frames), np.int64), frames=(target,)
            )
        xyz = frames.xyz.copy()
        vel = frames.velocity.copy()
        yaw = frames.yaw.copy()
        ok = np.ones(len(frames), dtype=bool)
        for index, name in enumerate(frames.frames):
            if name in ("", target):
                continue  # Hydra's ROS 1 sender leaves frame ids empty: taken as the map frame
            rows = np.flatnonzero(frames.frame_id == index)
            if len(rows) == 0:
                continue
            if self.tf is None:
                raise TransformError(
                    f"detections are in frame {name!r} but the log has no TF to {target!r}",
                    hint=f"if {name!r} is a fixed frame, build with --map-frame {name}",
                )
            R, t, good = self.tf.lookup(target, name, frames.t_ns[rows])
            xyz[rows] = np.einsum("nij,nj->ni", R, frames.xyz[rows]) + t
            vel[rows] = np.einsum("nij,nj->ni", R, frames.velocity[rows])
            yaw[rows] = yaw[rows] + np.arctan2(R[:, 1, 0], R[:, 0, 0])
            ok[rows] = good
        n_bad = int((~ok).sum())
        if n_bad:
            self.counts.dropped["no_transform"] += n_bad
        moved = dataclasses.replace(
            frames,
            xyz=xyz,
            velocity=vel,
            yaw=yaw,
            frame_id=np.zeros(len(frames), np.int64),
            frames=(target,),
        )
        return moved.select(ok) if n_bad else moved


MAX_CHUNK_BYTES = 32 * 1024**2
"""Payload bytes after which a chunk ends whatever its message count: with large messages
(many people each, or point clouds inside detections) ``size`` messages alone could hold
gigabytes, and the decoders copy the payloads once more."""


def chunks(
    messages: Iterator[RawMessage],
    graph_topics: set[str],
    size: int,
    max_bytes: int = MAX_CHUNK_BYTES,
) -> Iterator[tuple[list[RawMessage], RawMessage | None]]:
    """(detection chunk, graph message or None): chunks end at a graph message, at ``size``
    messages or at ``max_bytes`` of payload."""
    chunk: list[RawMessage] = []
    nbytes = 0
    for msg in messages:
        if msg.topic in graph_topics:
            yield chunk, msg
            chunk = []
            nbytes = 0
        else:
            chunk.append(msg)
            nbytes += len(msg.data)
            if len(chunk) >= size or nbytes >= max_bytes:
                yield chunk, None
                chunk = []
                nbytes = 0
    if chunk:
        yield chunk, None


def decoded_chunks(
    stream: Iterator[tuple[list[RawMessage], RawMessage | None]],
    feeder: DetectionFeeder,
    ahead: int = 2,
) -> Iterator[tuple[DetectionBatch | None, int, RawMessage | None]]:
    """(decoded batch or None, messages in it, graph message or None) for every item of
    ``stream`` (see :func:`chunks`), in order, decoding up to ``ahead`` chunks in a worker
    thread while the caller reads the next messages and feeds the Mapper.

    Decoding is numpy work that mostly releases the GIL, so on two cores reading and decoding
    overlap. One worker keeps the chunks' order (the heading estimator and the counters are
    stateful); an error in a chunk is raised here, when its turn comes."""
    from collections import deque
    from concurrent.futures import Future, ThreadPoolExecutor

    queue: deque[tuple[Future[DetectionBatch] | None, int, RawMessage | None]] = deque()
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="aion-decode") as pool:
        try:
            for chunk, graph_msg in stream:
                job = pool.submit(feeder.decode, chunk) if chunk else None
                queue.append((job, len(chunk), graph_msg))
                while len(queue) > ahead or (queue and queue[0][2] is not None):
                    # a graph message waits for the detections before it
                    yield _ready(queue.popleft())
            while queue:
                yield _ready(queue.popleft())
        finally:
            for job, _, _ in queue:
                if job is not None:
                    job.cancel()


def _ready(
    item: tuple[Any, int, RawMessage | None],
) -> tuple[DetectionBatch | None, int, RawMessage | None]:
    job, n, graph_msg = item
    return (None if job is None else job.result()), n, graph_msg


def log_adapters(
    logset: Any, topics: list[Any], mappings: Mapping[str, Any]
) -> tuple[dict[tuple[str, str, str], DetectionAdapter], AdapterFactory, list[str]]:
    """The adapters of a build's detection ``topics`` (TopicInfo) in ``logset``, built now so
    that a bad mapping or an unreadable definition stops the build before anything is read;
    a factory for the same topic in another encoding (logs of both ROS versions); and notes
    on topics whose log definition keeps them off the numpy fast path.

    Every adapter deserializes with a typestore built from the log's own definition of its
    topic's type; the fast decoder is kept only where that definition has the layout it was
    written for; a topic of ``mappings`` (topic -> TopicMapping) is read with its mapping,
    checked against the log's definition."""
    from aion_cli.engine.errors import TopicNotFoundError
    from formats.detections.registry import log_adapter

    def factory(topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
        store = logset.typestore(topic, msgtype, encoding)
        mapping = mappings.get(topic)
        if mapping is not None:
            adapter: DetectionAdapter = mapping.check(store).adapter(store)
            return adapter
        definition, idl = logset.definition(topic, msgtype, encoding)
        found = log_adapter(msgtype, encoding, definition, idl, store)
        if found is None:
            raise TopicNotFoundError(
                f"no people-detection adapter for {msgtype} on {topic!r}",
                hint="map it with --detections-mapping FILE",
            )
        return found

    adapters = {}
    notes = []
    for info in topics:
        key = (info.topic, info.msgtype, info.encoding)
        adapter = adapters[key] = factory(*key)
        if adapter.layout_differs:
            notes.append(
                f"{info.topic}: the log's definition of {info.msgtype} differs from the layout "
                "of aion's fast decoder; its messages are decoded with the log's own definition"
            )
    return adapters, factory, notes
