"""The detection stream cut into pieces and decode jobs (:class:`Chunk`, :func:`chunks`) and
decoded a few jobs ahead in one worker thread (:func:`decoded_chunks`), the graph messages
between the pieces handed on in order.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from aion_cli.engine.types import DetectionBatch

if TYPE_CHECKING:
    from aion_cli.detection_feed import DetectionFeeder
    from aion_cli.formats.raw import RawMessage

MAX_CHUNK_BYTES = 32 * 1024**2
"""Payload bytes after which a chunk ends whatever its message count: with large messages
(many people each, or point clouds inside detections) ``size`` messages alone could hold
gigabytes, and the decoders copy the payloads once more."""


class Chunk(list["RawMessage"]):
    """The detection messages of one item of :func:`chunks` (a list), and whether a decode
    job ends with it (``closes``): the messages since the last job reached the size or byte
    limit, or the stream ended. Items between two closing ones are decoded together."""

    closes: bool = True


def chunks(
    messages: Iterator[RawMessage],
    graph_topics: set[str],
    size: int,
    max_bytes: int = MAX_CHUNK_BYTES,
) -> Iterator[tuple[list[RawMessage], RawMessage | None]]:
    """(detection chunk, graph message or None): chunks end at a graph message, at ``size``
    messages or at ``max_bytes`` of payload -- the pieces the Mapper is fed, in order.

    Each chunk is a :class:`Chunk`; a *decode job* ends with the first chunk by which ``size``
    detection messages or ``max_bytes`` of payload (detections and graphs: a job holds both
    until it is fed) have come since the last job, wherever the graphs fall: a scene graph
    every few messages cuts the Mapper's pieces, not the decoding."""
    chunk = Chunk()
    append = chunk.append
    count = nbytes = 0  # the chunk's messages (len(chunk)) and payload bytes
    job_count = job_bytes = 0
    for msg in messages:  # per message: one len() and a few int operations
        length = len(msg.data)
        job_bytes += length
        if msg.topic in graph_topics:
            chunk.closes = job_count >= size or job_bytes >= max_bytes
            yield chunk, msg
        else:
            append(msg)
            count += 1
            nbytes += length
            job_count += 1
            if count < size and nbytes < max_bytes:
                continue
            yield chunk, None  # closes
        count = nbytes = 0
        if chunk.closes:
            job_count = job_bytes = 0
        chunk = Chunk()
        append = chunk.append
    if chunk:
        yield chunk, None


def decoded_chunks(
    stream: Iterator[tuple[list[RawMessage], RawMessage | None]],
    feeder: DetectionFeeder,
    ahead: int = 2,
) -> Iterator[tuple[DetectionBatch | None, int, RawMessage | None]]:
    """(decoded batch or None, messages in it, graph message or None) for every item of
    ``stream`` (see :func:`chunks`), in order, decoding up to ``ahead`` jobs in a worker
    thread while the caller reads the next messages and feeds the Mapper.

    A job is the items up to one whose chunk closes (:class:`Chunk`; a plain list closes):
    with ``decode_segments`` (:meth:`DetectionFeeder.decode_segments`) the feeder decodes them
    at once and splits the rows back per item, so a graph between two items costs no decode
    of its own; a feeder with only ``decode`` decodes the items one after the other in the
    same job. Either way the worker runs ahead across graph messages: the caller receives a
    graph only after the detections before it, and the detections after it only then.

    Decoding is numpy work that mostly releases the GIL, so on two cores reading and decoding
    overlap. One worker keeps the jobs' order (the heading estimator and the counters are
    stateful); an error in a job is raised here, when its first item's turn comes."""
    from collections import deque
    from concurrent.futures import Future, ThreadPoolExecutor

    decode_all = getattr(feeder, "decode_segments", None)

    def run(parts: list[list[RawMessage]]) -> list[DetectionBatch | None]:
        if len(parts) == 1 or decode_all is None:
            return [feeder.decode(p) if p else None for p in parts]
        result: list[DetectionBatch | None] = decode_all(parts)
        return result

    Job = tuple["Future[list[DetectionBatch | None]] | None", list[tuple[int, Any]]]
    queue: deque[Job] = deque()
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="aion-decode") as pool:
        try:
            parts: list[list[RawMessage]] = []
            items: list[tuple[int, Any]] = []

            def submit() -> None:
                job = pool.submit(run, parts) if any(parts) else None
                queue.append((job, items))

            for chunk, graph_msg in stream:
                parts.append(chunk)
                items.append((len(chunk), graph_msg))
                if getattr(chunk, "closes", True):
                    submit()
                    parts, items = [], []
                while len(queue) > ahead:
                    yield from _ready(queue.popleft())
            if items:
                submit()
            while queue:
                yield from _ready(queue.popleft())
        finally:
            for job, _ in queue:
                if job is not None:
                    job.cancel()


def _ready(
    item: tuple[Any, list[tuple[int, RawMessage | None]]],
) -> Iterator[tuple[DetectionBatch | None, int, RawMessage | None]]:
    job, items = item
    batches = [None] * len(items) if job is None else job.result()
    for batch, (n, graph_msg) in zip(batches, items, strict=True):
        yield batch, n, graph_msg
