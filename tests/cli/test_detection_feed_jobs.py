"""Decoding many scene-graph intervals at once (issue 15): ``chunks`` cuts the Mapper's pieces
as before and groups them into decode jobs wherever the graphs fall; ``decode_segments``
decodes a job in one go and gives every piece exactly the batch that decoding the pieces one
after the other gives (headings, links, the judgement of a topic's orientations, the order of
rows, the counts), for id-carrying and id-less detections, stamps out of order across graph
boundaries, two encodings on one topic and several topics."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from aion_cli.detection_feed import (
    Chunk,
    DetectionCounts,
    DetectionFeeder,
    TopicFeeders,
    chunks,
    decoded_chunks,
)
from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import header, pose, raw

S = 1_000_000_000
T0 = 1_700_000_000 * S
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"


def _graph(t: int) -> RawMessage:
    return RawMessage("/dsg", "hydra_msgs/msg/DsgUpdate", t, b"g" * 100, "cdr")  # type: ignore[arg-type]


def _old_chunks(
    messages: list[RawMessage], graph_topics: set[str], size: int, max_bytes: int
) -> list[tuple[list[RawMessage], RawMessage | None]]:
    """The cutting rule before issue 15 (the reference for the Mapper's pieces)."""
    out: list[tuple[list[RawMessage], RawMessage | None]] = []
    chunk: list[RawMessage] = []
    nbytes = 0
    for msg in messages:
        if msg.topic in graph_topics:
            out.append((chunk, msg))
            chunk, nbytes = [], 0
        else:
            chunk.append(msg)
            nbytes += len(msg.data)
            if len(chunk) >= size or nbytes >= max_bytes:
                out.append((chunk, None))
                chunk, nbytes = [], 0
    if chunk:
        out.append((chunk, None))
    return out


@pytest.mark.parametrize("seed", range(6))
def test_pieces_are_cut_as_before_and_jobs_span_graphs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    stream: list[RawMessage] = []
    for i in range(600):
        if rng.random() < 0.15:
            stream.append(_graph(i))
        else:
            stream.append(RawMessage("/p", POSE_ARRAY, i, b"x" * int(rng.integers(1, 60)), "cdr"))  # type: ignore[arg-type]
    size, max_bytes = int(rng.integers(1, 40)), int(rng.integers(50, 3000))
    got = list(chunks(iter(stream), {"/dsg"}, size, max_bytes))
    want = _old_chunks(stream, {"/dsg"}, size, max_bytes)
    assert [(list(c), g) for c, g in got] == want
    assert all(isinstance(c, Chunk) for c, _ in got)
    # a job closes once size detection messages or max_bytes (graphs included) have come
    count = nbytes = 0
    for c, g in got:
        count += len(c)
        nbytes += sum(len(m.data) for m in c) + (len(g.data) if g is not None else 0)
        assert c.closes == (g is None or count >= size or nbytes >= max_bytes)
        if c.closes:
            count = nbytes = 0
    assert got[-1][0].closes


class RecordingFeeder(DetectionFeeder):
    """One detection per message at its log time; records the jobs it decoded."""

    def __init__(self) -> None:
        super().__init__(None, "map", DetectionCounts())
        self.jobs: list[list[int]] = []

    def decode_rows(
        self, messages: list[RawMessage], segment: Any = None
    ) -> tuple[DetectionBatch, Any]:
        self.jobs.append([m.log_time_ns for m in messages])
        t = np.array([m.log_time_ns for m in messages], np.int64)
        n = len(t)
        seg = np.zeros(n, np.int64) if segment is None else segment
        nan = np.full(n, np.nan)
        return DetectionBatch(t, np.zeros((n, 3)), nan, nan, np.full(n, -1, np.int64)), seg


def test_a_job_of_many_pieces_is_decoded_once_and_fed_in_order() -> None:
    stream = [
        RawMessage("/p", POSE_ARRAY, t, b"x", "cdr") if t % 4 else _graph(t)  # type: ignore[arg-type]
        for t in range(1, 41)
    ]
    feeder = RecordingFeeder()
    events = []
    for batch, n, graph in decoded_chunks(chunks(iter(stream), {"/dsg"}, 12), feeder, ahead=1):
        if batch is not None:
            assert n == len(batch)
            events += batch.t_ns.tolist()
        if graph is not None:
            events.append(graph.log_time_ns)
    assert events == list(range(1, 41))  # every graph after the detections before it
    # 30 detection messages, jobs of at least 12: three decodes, not one per graph
    assert [len(j) for j in feeder.jobs] == [12, 12, 6]


# --- real messages: decode_segments equals decoding the pieces one by one ----------------------


def _walk(rng: np.random.Generator, n_msgs: int, per: int, jitter: bool) -> Iterator[Any]:
    """(i, stamp, positions, track ids) of ``per`` people walking or standing, 10 Hz."""
    start = rng.uniform(0, 20, (per, 2))
    heading = rng.uniform(-math.pi, math.pi, per)
    speed = rng.choice([0.0, 0.02, 1.0], per)
    for i in range(n_msgs):
        t = T0 + i * S // 10
        if jitter and rng.random() < 0.3:
            t -= int(rng.integers(1, 8)) * S // 10  # stamped before earlier messages
        d = speed * i / 10
        xy = start + np.stack([d * np.cos(heading), d * np.sin(heading)], 1)
        xy = xy + rng.normal(0, 0.01, xy.shape)
        seen = rng.random(per) < 0.85
        yield i, t, xy[seen], np.flatnonzero(seen) + 1000 * (i // 60)


def _pose_arrays(rng: np.random.Generator, n: int, jitter: bool, ros: int, topic: str = "/legs",
                 yaw_from: int = 10**9) -> list[RawMessage]:
    out = []
    for i, t, xy, _ in _walk(rng, n, 4, jitter):
        a = 0.0 if i < yaw_from else float(rng.uniform(-3, 3))
        q = (0.0, 0.0, 0.0, 0.0) if i < yaw_from // 2 else (0.0, 0.0, math.sin(a / 2),
                                                              math.cos(a / 2))
        poses = [pose(float(x), float(y), 0.0, q) for x, y in xy]
        msg = {"header": header(t // S, t % S, "map"), "poses": poses}
        r = ros if ros in (1, 2) else int(rng.choice([1, 2]))
        out.append(raw(POSE_ARRAY, msg, r, log_time_ns=T0 + i * S // 10, topic=topic))
    return out


def _tracked(rng: np.random.Generator, n: int, jitter: bool, topic: str = "/tracks"
             ) -> list[RawMessage]:
    out = []
    for i, t, xy, ids in _walk(rng, n, 5, jitter):
        tracks = []
        for (x, y), k in zip(xy.tolist(), ids.tolist(), strict=True):
            tcov = np.zeros(36)
            if rng.random() < 0.5:
                tcov[[0, 7, 14]] = 1e6  # no velocity: headings by differencing
            tracks.append({
                "track_id": k,
                "pose": {"pose": pose(x, y, 0.0, (0.0, 0.0, 0.0, 1.0)), "covariance": np.zeros(36)},
                "twist": {"twist": {"linear": {"x": 0.3, "y": -0.2}}, "covariance": tcov},
            })
        msg = {"header": header(t // S, t % S, "map"), "tracks": tracks}
        out.append(raw(TRACKED, msg, 2, log_time_ns=T0 + i * S // 10, topic=topic))
    return out


def _pieces(rng: np.random.Generator, msgs: list[RawMessage]) -> list[list[RawMessage]]:
    """``msgs`` cut at random (graph) positions, with some empty pieces."""
    cuts = np.sort(rng.integers(0, len(msgs) + 1, int(rng.integers(1, 25))))
    bounds = [0, *cuts.tolist(), len(msgs)]
    return [msgs[a:b] for a, b in itertools.pairwise(bounds)]


def _same_batch(a: DetectionBatch | None, b: DetectionBatch | None) -> None:
    assert (a is None) == (b is None)
    if a is None or b is None:
        return
    for name in ("t_ns", "xyz", "heading", "speed", "track_id"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def _one_by_one(feeder: Any, pieces: list[list[RawMessage]]) -> list[DetectionBatch | None]:
    return [feeder.decode(p) if p else None for p in pieces]


CASES = ["tracked", "tracked-jitter", "legs", "legs-jitter", "legs-yaws", "legs-mixed-ros"]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("seed", range(3))
def test_decode_segments_equals_decoding_the_pieces_one_by_one(case: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    jitter = case.endswith("jitter")
    if case.startswith("tracked"):
        msgs = _tracked(rng, 240, jitter)
    else:
        ros = 0 if case == "legs-mixed-ros" else 2
        msgs = _pose_arrays(rng, 240, jitter, ros, yaw_from=120 if case == "legs-yaws" else 10**9)
    pieces = _pieces(rng, msgs)
    ca, cb = DetectionCounts(), DetectionCounts()
    fa, fb = DetectionFeeder(None, "map", ca), DetectionFeeder(None, "map", cb)
    got = fa.decode_segments(pieces)
    want = _one_by_one(fb, pieces)
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        _same_batch(g, w)
    assert ca == cb
    assert sum(ca.headings.values()) == ca.read > 0
    if case == "legs-yaws":
        assert ca.headings["pose_yaw"] > 0
        assert ca.headings["linked"] > 0


@pytest.mark.parametrize("seed", range(3))
def test_topic_feeders_merge_topics_per_piece_as_before(seed: int) -> None:
    rng = np.random.default_rng(seed)
    msgs = sorted(
        [*_tracked(rng, 150, True, "/a"), *_pose_arrays(rng, 150, True, 2, "/b"),
         *_tracked(rng, 150, False, "/c")],
        key=lambda m: (m.log_time_ns, m.topic),
    )
    pieces = _pieces(rng, msgs)

    def make(topic: str, counts: DetectionCounts) -> DetectionFeeder:
        return DetectionFeeder(None, "map", counts)

    ta, tb = TopicFeeders(make, ["/a", "/b", "/c"]), TopicFeeders(make, ["/a", "/b", "/c"])
    got = ta.decode_segments(pieces)
    want = _one_by_one(tb, pieces)
    for g, w in zip(got, want, strict=True):
        _same_batch(g, w)
        if g is not None and w is not None:
            np.testing.assert_array_equal(ta.topics_of(g), tb.topics_of(w))
    assert ta.total() == tb.total()
    assert not ta._labels
    assert not tb._labels


def test_an_empty_piece_has_no_topics_to_label() -> None:
    """A piece no topic decoded anything from (no detection message in it) gives an empty
    batch whose topic labels are empty — the build feeds it without a KeyError (the office
    scene's first chunk is such a piece)."""

    def make(topic: str, counts: DetectionCounts) -> DetectionFeeder:
        return DetectionFeeder(None, "map", counts)

    feeders = TopicFeeders(make, ["/a"])
    empty = feeders.decode([])
    assert len(empty) == 0
    assert feeders.topics_of(empty).tolist() == []
    (none,) = feeders.decode_segments([[]])
    assert none is None
    with pytest.raises(KeyError):
        feeders.topics_of(DetectionBatch.from_arrays(t_ns=[1], xyz=[[0.0, 0.0, 0.0]]))
