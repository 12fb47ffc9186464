"""detection_feed.decoded_chunks: decoding one chunk ahead keeps every order and every error."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import numpy as np
import pytest

from aion_cli.detection_feed import DetectionCounts, DetectionFeeder, decoded_chunks
from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import TransformError
from aion_cli.formats.raw import RawMessage


class FakeFeeder(DetectionFeeder):
    """Decodes a chunk into one detection per message whose time is the message's log time;
    records the thread and the order of its calls; fails on a message topic "bad"."""

    def __init__(self) -> None:
        super().__init__(None, "map", DetectionCounts())
        self.calls: list[list[int]] = []
        self.threads: set[str] = set()

    def decode(self, messages: list[RawMessage]) -> DetectionBatch:
        self.threads.add(threading.current_thread().name)
        self.calls.append([m.log_time_ns for m in messages])
        if any(m.topic == "bad" for m in messages):
            raise TransformError("no transform for frame 'laser'")
        t = np.array([m.log_time_ns for m in messages], np.int64)
        n = len(t)
        return DetectionBatch(
            t, np.zeros((n, 3)), np.full(n, np.nan), np.full(n, np.nan), np.full(n, -1, np.int64)
        )


def _msg(t: int, topic: str = "people") -> RawMessage:
    return RawMessage(topic, "geometry_msgs/msg/PoseArray", t, b"", "cdr")  # type: ignore[arg-type]


def _stream(
    items: list[tuple[list[int], int | None]],
) -> Iterator[tuple[list[RawMessage], RawMessage | None]]:
    for times, graph_t in items:
        yield [_msg(t) for t in times], None if graph_t is None else _msg(graph_t, "dsg")


def test_batches_and_graph_messages_come_out_in_stream_order() -> None:
    items: list[tuple[list[int], int | None]] = [
        ([1, 2], None),
        ([3], 4),
        ([], 5),
        ([6, 7, 8], None),
        ([9], None),
        ([], 10),
        ([11], None),
    ]
    feeder = FakeFeeder()
    events = []
    for batch, n, graph in decoded_chunks(_stream(items), feeder, ahead=2):
        if batch is not None:
            assert n == len(batch.t_ns)
            events += batch.t_ns.tolist()
        if graph is not None:
            events.append(graph.log_time_ns)
    assert events == list(range(1, 12))  # detections before the graph that followed them
    assert feeder.calls == [[1, 2], [3], [6, 7, 8], [9], [11]]
    assert all(name.startswith("aion-decode") for name in feeder.threads)


def test_a_decode_error_is_raised_in_turn_after_the_earlier_batches() -> None:
    def stream() -> Iterator[tuple[list[RawMessage], RawMessage | None]]:
        yield [_msg(1)], None
        yield [_msg(2, "bad")], None
        yield [_msg(3)], None

    seen: list[int] = []

    def consume() -> None:
        for batch, _, _ in decoded_chunks(stream(), FakeFeeder(), ahead=1):
            assert batch is not None
            seen.extend(batch.t_ns.tolist())

    with pytest.raises(TransformError, match="laser"):
        consume()
    assert seen == [1]
