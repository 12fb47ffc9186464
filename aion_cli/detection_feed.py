"""Raw detection messages -> map-frame :class:`DetectionBatch` chunks for the Mapper.

Messages are decoded per type with the numpy adapters of ``formats.detections``, moved into the
map frame with the TF buffer (rows without a transform are counted as ``no_transform`` and
dropped; a frame with no TF at all is an error naming ``--map-frame``), sorted by time and given
headings by one ``HeadingEstimator`` that keeps its per-track state across chunks.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.errors import TransformError
from aion_cli.engine.types import DetectionBatch

if TYPE_CHECKING:
    from formats.raw import RawMessage
    from formats.tf import TfBuffer


@dataclass
class DetectionCounts:
    """Detections decoded (``read``), accepted by the Mapper (``used``), dropped by reason, and
    how many had a zero header stamp and took their message's log time (``stamp_fallbacks``)."""

    read: int = 0
    used: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    stamp_fallbacks: int = 0


class DetectionFeeder:
    """Decodes chunks of raw detection messages into map-frame DetectionBatches."""

    def __init__(self, tf: TfBuffer | None, map_frame: str, counts: DetectionCounts) -> None:
        from formats.detections import HeadingEstimator, adapter_for

        self._adapter_for = adapter_for
        self.tf = tf
        self.map_frame = map_frame
        self.counts = counts
        self.headings = HeadingEstimator()

    def decode(self, messages: list[RawMessage]) -> DetectionBatch:
        """Decode, transform and give headings to ``messages`` (any detection types)."""
        from formats.detections.frame import FrameDetections

        by_type: dict[str, list[RawMessage]] = {}
        for msg in messages:
            by_type.setdefault(msg.msgtype, []).append(msg)
        parts = []
        for msgtype, msgs in by_type.items():
            adapter = self._adapter_for(msgtype)
            assert adapter is not None  # topics were selected by adapter
            frames = adapter.decode(msgs, on_error="skip")  # damaged messages: counted
            self.counts.read += len(frames)
            self.counts.stamp_fallbacks += int(frames.stamp_fallbacks)
            for reason, n in frames.filtered.items():
                # damaged payloads are counted per message: their detections are unknown
                key = "undecodable_messages" if reason == "undecodable" else reason
                self.counts.dropped[key] += n
            parts.append(self._to_map_frame(frames))
        if not parts:
            return DetectionBatch.empty()
        merged = parts[0] if len(parts) == 1 else FrameDetections.concat(parts)
        t = merged.t_ns
        if t.size > 1 and not bool(np.all(t[1:] >= t[:-1])):  # usually in order already
            merged = merged.select(np.argsort(t, kind="stable"))
        return self.headings.to_batch(merged)

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
