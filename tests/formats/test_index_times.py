"""LogSet.index_times (issue 15, the build's first pass at the speed of reading): the log times a
build's stream will yield, read from the containers' indexes, are exactly the times of the
messages the stream yields, in the same order (per topic and across topics, files and ties),
and the first pass that uses them (``tf_feed.read_tf_and_times``) records what reading every
message records: the same per-topic times, out-of-range counts and first such times, strays,
graph times in stream order and TF. An index that cannot say that exactly gives None (the
build reads the messages, as before)."""

from __future__ import annotations

import struct
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.build_report import NoProgress
from aion_cli.engine.mapper import MAX_TIME_NS
from aion_cli.formats.logs import LogSet, open_logs
from aion_cli.formats.writers import LogWriter
from aion_cli.graph_schedule import GraphTimes
from aion_cli.log_times import TopicTimes
from aion_cli.tf_feed import read_tf_and_times
from aion_cli.topics import select_topics
from tests.robustness.conftest import DSG, TRACKED, person, robot_tf, stamp

S = 1_000_000_000
T0 = 1_700_006_400 * S
DAY = 86_400 * S
OUT = MAX_TIME_NS + S  # a log time the build drops as out of range (int64 still holds it)
TOPICS = ("/tracks", "/tracks2", "/dsg", "/dsg2", "/tf", "/tf_static")
SUFFIX = {"mcap": ".mcap", "mcap-ros1": ".mcap", "bag": ".bag"}
#: (container, bytes per chunk): many small chunks, a few, one
CONTAINERS = [
    ("mcap", 96),
    ("mcap", 1500),
    ("mcap", None),
    ("mcap-ros1", 400),
    ("bag", 300),
    ("bag", None),
    ("rosbag2-sqlite3", None),
]

Event = tuple[str, int]


def _message(topic: str, t: int) -> tuple[str, str, dict[str, Any]]:
    """A message of ``topic`` at ``t`` (graph payloads are a few bytes: not decoded here)."""
    if topic.startswith("/tracks"):
        _, msgtype, msg, _ = person(t, (1.0, 2.0, 0.0), header_ns=t % DAY)
        return topic, msgtype, msg
    if topic.startswith("/dsg"):
        graph = {"header": {"stamp": stamp(t % DAY), "frame_id": "map"}, "layer_contents": b"g"}
        return topic, DSG, graph
    _, msgtype, msg, _ = robot_tf(t % (2**32 * S))
    return topic, msgtype, msg


def write(path: Path, container: str, chunk: int | None, events: list[Event]) -> Path:
    """The events in the order given (containers keep what they are given: MCAP chunks that
    overlap in time, messages out of order in a chunk)."""
    target = path.with_suffix(SUFFIX.get(container, ""))
    with LogWriter(target, container, chunk_size=chunk) as writer:
        for topic, t in events:
            writer.write(*_message(topic, t), t)
    return target


def _time(code: int) -> int:
    """Mostly close times (ties on purpose), some a stray three days later, some out of range."""
    if code < 85:
        return T0 + (code % 30) * S // 4
    if code < 92:
        return T0 + 3 * DAY + (code % 3) * S
    return OUT + (code % 2) * S


@st.composite
def logs(draw: Any) -> list[tuple[str, int | None, list[Event]]]:
    """One or two logs: a bulk of /tracks messages (so a few far ones are strays) and events on
    every topic, any order."""
    out = []
    for _ in range(draw(st.integers(1, 2))):
        container, chunk = draw(st.sampled_from(CONTAINERS))
        bulk = [("/tracks", T0 + k * S // 2) for k in range(draw(st.integers(0, 25)))]
        codes = draw(st.lists(st.integers(0, 99), max_size=40))
        topics = draw(st.lists(st.sampled_from(TOPICS), min_size=len(codes), max_size=len(codes)))
        events = [(topic, _time(code)) for topic, code in zip(topics, codes, strict=True)]
        if container == "bag":  # ROS 1 times end in 2106: no time out of range
            events = [(topic, min(t, T0 + 5 * DAY)) for topic, t in events]
        events = draw(st.permutations(bulk + events)) or [("/tracks", T0)]
        out.append((container, chunk, list(events)))
    return out


def first_pass(paths: list[Path], use_index: bool) -> tuple[Any, GraphTimes | TopicTimes, Any]:
    """``read_tf_and_times`` as a build calls it, every graph topic thinned."""
    with open_logs(paths) as logset:
        plan = select_topics(logset.topics, (), None, {})
        graphs = plan.names("graph")
        timed = plan.names("detections") | graphs
        return read_tf_and_times(
            logset, plan, timed, NoProgress(), graphs or None, use_index=use_index
        )


def assert_same_first_pass(paths: list[Path]) -> None:
    """The first pass through the index records what reading every message records."""
    tf_a, a, stats_a = first_pass(paths, True)
    tf_b, b, stats_b = first_pass(paths, False)
    assert a.topics == b.topics
    span = a.topics - {"/tf_static"}
    ca, cb = a.check(span), b.check(span)
    assert ca.out_of_range == cb.out_of_range
    assert ca.first_out_of_range == cb.first_out_of_range
    assert ca.kept == cb.kept
    assert sorted(ca.strays) == sorted(cb.strays)
    for topic in ca.strays:
        np.testing.assert_array_equal(ca.strays[topic], cb.strays[topic])
    for name in ("run_first", "run_last"):
        np.testing.assert_array_equal(getattr(ca, name), getattr(cb, name))
    np.testing.assert_array_equal(np.sort(ca.span_times), np.sort(cb.span_times))
    assert isinstance(a, GraphTimes) == isinstance(b, GraphTimes)
    if isinstance(a, GraphTimes) and isinstance(b, GraphTimes):
        assert a.graph_topics == b.graph_topics
        np.testing.assert_array_equal(a.stream_times(ca.strays), b.stream_times(cb.strays))
        assert list(a.graph_topic) == list(b.graph_topic)
    assert (stats_a.messages, stats_a.undecodable) == (stats_b.messages, stats_b.undecodable)
    assert (tf_a is None) == (tf_b is None)
    if tf_a is not None and tf_b is not None:
        assert tf_a.frames == tf_b.frames


def assert_index_is_the_stream(logs: LogSet, topics: set[str]) -> None:
    """index_times gives the stream's (topic, log time) sequence exactly."""
    found = logs.index_times(topics)
    assert found is not None
    stream = [(m.topic, m.log_time_ns) for m in logs.messages(topics)]
    assert [(found.topics[c], int(t)) for c, t in zip(found.code, found.t, strict=True)] == stream


def assert_between_only_skips(logs: LogSet, topics: set[str], lo: int, hi: int) -> None:
    """``messages(topics, between=(lo, hi))`` yields every message of ``[lo, hi)`` that
    ``messages(topics)`` yields, in the same order (a hint: it may skip what lies outside)."""

    def inside(between: tuple[int, int] | None) -> list[tuple[str, int, bytes]]:
        return [
            (m.topic, m.log_time_ns, bytes(m.data))
            for m in logs.messages(topics, between)
            if lo <= m.log_time_ns < hi
        ]

    assert inside((lo, hi)) == inside(None)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(spec=logs(), bounds=st.tuples(st.integers(-4, 40), st.integers(0, 40)))
def test_index_times_are_the_streams_times_and_the_first_pass_is_the_same(
    spec: Any, bounds: tuple[int, int]
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        paths = [
            write(Path(tmp) / f"log{k}", container, chunk, events)
            for k, (container, chunk, events) in enumerate(spec)
        ]
        with open_logs(paths) as logs:
            assert_index_is_the_stream(logs, {"/tracks", "/tracks2", "/dsg", "/dsg2"})
            assert_index_is_the_stream(logs, {"/dsg2", "/tf"})
            lo = T0 + bounds[0] * S // 4
            assert_between_only_skips(logs, {"/tracks", "/dsg", "/tf"}, lo, lo + bounds[1] * S)
        assert_same_first_pass(paths)


def test_an_indexed_mcap_skips_the_chunks_outside_a_time_range(tmp_path: Path) -> None:
    # 200 messages a second apart in chunks of a few messages: a 10-s range reads the chunks
    # that overlap it only, and yields every message inside it
    path = _raw_mcap(tmp_path / "long.mcap", [(1, T0 + k * S) for k in range(200)])
    with open_logs([path]) as logs:
        got = [m.log_time_ns for m in logs.messages({"/a"}, (T0 + 50 * S, T0 + 60 * S))]
    inside = [t for t in got if T0 + 50 * S <= t < T0 + 60 * S]
    assert inside == [T0 + k * S for k in range(50, 60)]
    assert len(got) < 30  # the other chunks were not read


# -- MCAP specifics: huge times, a file read linearly, damaged indexes -----------------------


def _raw_mcap(path: Path, times: list[tuple[int, int]], chunk_size: int = 200) -> Path:
    """An MCAP of raw TrackedPersons-typed channels 1 and 2 (payloads not decoded here) with
    messages ``(channel, log time)``, any uint64 time, in the order given."""
    from mcap.writer import CompressionType, Writer

    with path.open("wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        w.start(profile="ros2")
        schema = w.register_schema(TRACKED, "ros2msg", b"")
        ids = {k: w.register_channel(name, "cdr", schema) for k, name in ((1, "/a"), (2, "/b"))}
        for channel, t in times:
            w.add_message(ids[channel], t, b"\x00\x01\x00\x00" + bytes(20), t)
        w.finish()
    return path


HUGE = [(1, T0), (2, 2**63 + 5), (1, 2**64 - 1), (2, T0), (1, 2**63 - 1), (2, T0 + S)] * 8


def test_huge_mcap_times_come_in_stream_order_and_count_out_of_range(tmp_path: Path) -> None:
    path = _raw_mcap(tmp_path / "huge.mcap", HUGE)
    with open_logs([path]) as logs:
        assert_index_is_the_stream(logs, {"/a", "/b"})
        found = logs.index_times({"/a", "/b"})
        assert found is not None
        indexed, read = TopicTimes({"/a", "/b"}), TopicTimes({"/a", "/b"})
        indexed.add_stream(found)
        for m in logs.messages({"/a", "/b"}):
            read.add(m.topic, m.log_time_ns)
    assert indexed.out_of_range == read.out_of_range == {"/a": 16, "/b": 8}
    assert indexed.first_out_of_range == read.first_out_of_range
    ca, cb = indexed.check({"/a", "/b"}), read.check({"/a", "/b"})
    assert ca.kept == cb.kept
    np.testing.assert_array_equal(ca.span_times, cb.span_times)


def test_an_mcap_without_summary_gives_its_times_from_the_opening_scan(tmp_path: Path) -> None:
    """Read linearly (messages out of order in the file: the reader's heap sorts them)."""
    from mcap.reader import make_reader

    shuffled = [(1 + k % 2, T0 + (k * 7919) % 50 * S) for k in range(80)]
    full = _raw_mcap(tmp_path / "full.mcap", shuffled)
    with full.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    last = max(c.chunk_start_offset + c.chunk_length for c in summary.chunk_indexes)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[: last + 5])  # inside the index records after it
    with open_logs([cut]) as logs:
        # read linearly; the shuffled chunks' overlap (up to 49 s back) is a warning of its own
        # (formats/clock_steps.py), as it is for the whole file read by its summary
        assert any("truncated or corrupt MCAP" in w for w in logs.warnings), logs.warnings
        assert_index_is_the_stream(logs, {"/a", "/b"})
        assert_index_is_the_stream(logs, {"/b"})


def _first_index_entry(path: Path) -> tuple[int, int]:
    """Byte positions of the first entry (log time, then offset) of the first chunk's first
    MessageIndex record."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunk = min(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    record = min(chunk.message_index_offsets.values())
    entry = record + 1 + 8 + 2 + 4  # opcode, length, channel id, entries length
    return entry, entry + 8


@pytest.mark.parametrize("damage", ["time", "offset", "opcode"])
def test_a_damaged_message_index_gives_no_times(damage: str, tmp_path: Path) -> None:
    """A time outside its chunk, an offset past its records, a record that is no
    MessageIndex: the index cannot be trusted (the build reads every message instead)."""
    path = _raw_mcap(tmp_path / "log.mcap", [(1 + k % 2, T0 + k * S) for k in range(40)])
    data = bytearray(path.read_bytes())
    time_at, offset_at = _first_index_entry(path)
    if damage == "time":
        data[time_at : time_at + 8] = struct.pack("<Q", T0 + 10_000 * S)
    elif damage == "offset":
        data[offset_at : offset_at + 8] = struct.pack("<Q", 10**9)
    else:
        data[time_at - 15] = 0x42
    path.write_bytes(bytes(data))
    with open_logs([path]) as logs:
        assert logs.index_times({"/a", "/b"}) is None
        assert len(list(logs.messages({"/a", "/b"}))) == 40  # the messages are all there


def test_the_index_is_not_used_where_a_message_may_be_over_the_cap(tmp_path: Path) -> None:
    from aion_cli.formats.limits import ReadLimits

    path = _raw_mcap(tmp_path / "log.mcap", [(1, T0 + k * S) for k in range(40)])
    tight = ReadLimits(max_chunk_bytes=1 << 20, max_message_bytes=64)
    with open_logs([path], limits=tight) as logs:
        assert logs.index_times({"/a"}) is None
    with open_logs([path]) as logs:
        assert logs.index_times({"/a"}) is not None


def test_a_ros1_bag_reads_only_the_messages_of_a_time_range(tmp_path: Path) -> None:
    # the bag's index gives every message's time: a 10-s range yields exactly its messages,
    # reading only the chunks that hold them, and says it can (LogSet.skips_by_time)
    path = write(tmp_path / "long", "bag", 300, [("/tracks", T0 + k * S) for k in range(200)])
    with open_logs([path]) as logs:
        assert logs.skips_by_time()
        got = [m.log_time_ns for m in logs.messages({"/tracks"}, (T0 + 50 * S, T0 + 60 * S))]
    assert got == [T0 + k * S for k in range(50, 60)]
