"""``aion build`` with its first pass through the logs' indexes (issue 15): the log times come
from the containers' indexes (``LogSet.index_times``) instead of a read of every message, and the
map and the report are those of reading every message (``index_times`` patched to say "no
index"): every container, several logs at once, a continued map, a compressed log, graph
thinning with a stray graph, stray and out-of-range detections. A log whose index is damaged
falls back to reading every message and builds the map of the undamaged log; a chunk that fails
its CRC (which no index shows) makes the build start over reading every message, with the same
result as a build that never used the index."""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.compare import differences
from aion_cli.engine.mapper import MAX_TIME_NS
from aion_cli.formats.logs import LogSet, open_logs
from aion_cli.formats.writers import LogWriter
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, _Build, build_map
from tests.cli.logdata import write_office_log
from tests.graph_stream_logs import write_stream_log
from tests.robustness.conftest import (
    T0,
    S,
    graph_payload,
    person,
    robot_tf,
    scene_graph,
    walk,
)

DAY = 86_400 * S
SUFFIX = {"mcap": ".mcap", "mcap-ros1": ".mcap", "bag": ".bag"}

Built = tuple[dict[str, Any], Any]  # the report (as JSON) and the map state


@dataclasses.dataclass
class Builds:
    """The same build through the index (``fast``) and reading every message (``full``), and
    what ``LogSet.index_times`` answered during the first (True: times from the index)."""

    fast: Built
    full: Built
    indexed: list[bool]
    tries: int  # _Build._learn calls of the fast build (2: it started over)

    def assert_same(self) -> None:
        (fast_report, fast_state), (full_report, full_state) = self.fast, self.full
        assert differences(fast_state, full_state) == []
        assert _comparable(fast_report) == _comparable(full_report)


def _comparable(report: dict[str, Any]) -> dict[str, Any]:
    """The report without what names the output file or the copy of the continued map."""
    out = {k: v for k, v in report.items() if k not in ("map", "map_bytes")}
    out["notes"] = [
        n.replace("fast_start.aion", "START").replace("full_start.aion", "START")
        for n in report.get("notes", [])
    ]
    return out


def _build(logs: list[Path], out: Path, **options: Any) -> Built:
    report = build_map(BuildOptions(logs=tuple(logs), output=out, **options))
    return report.to_dict(), load_map(out).state


@pytest.fixture
def both(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Callable[..., Builds]:
    """Build ``logs`` through the index and reading every message (``continue_from``: a map
    copied for each, so both continue the same map)."""

    def run(logs: list[Path], continue_from: Path | None = None, **options: Any) -> Builds:
        indexed: list[bool] = []
        tries = [0]
        real_index, real_learn = LogSet.index_times, _Build._learn

        def spy(self: LogSet, topics: Any) -> Any:
            found = real_index(self, topics)
            indexed.append(found is not None)
            return found

        def learn(self: _Build, config: Any) -> Any:
            tries[0] += 1
            return real_learn(self, config)

        built = {}
        for name in ("fast", "full"):
            extra = dict(options)
            if continue_from is not None:
                extra["continue_from"] = tmp_path / f"{name}_start.aion"
                extra["continue_from"].write_bytes(continue_from.read_bytes())
            with monkeypatch.context() as m:
                m.setattr(_Build, "_learn", learn)
                m.setattr(LogSet, "index_times", spy if name == "fast" else _no_index)
                built[name] = _build(logs, tmp_path / f"{name}.aion", **extra)
            if name == "fast":
                fast_tries = tries[0]
        return Builds(built["fast"], built["full"], indexed, fast_tries)

    return run


def _no_index(self: LogSet, topics: Any) -> None:
    return None


def office(tmp_path: Path, container: str, name: str = "office", **kw: Any) -> Path:
    path = tmp_path / f"{name}{SUFFIX.get(container, '')}"
    write_office_log(path, container, **kw)
    return path


@pytest.mark.parametrize(
    "container", ["mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap"]
)
def test_every_container_builds_the_same_map_through_its_index(
    container: str, tmp_path: Path, both: Callable[..., Builds]
) -> None:
    builds = both([office(tmp_path, container)])
    assert builds.indexed == [True]
    assert builds.tries == 1
    builds.assert_same()
    assert builds.fast[0]["observation"].startswith("tf")


def test_several_logs_and_a_continued_map_build_the_same_map(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    a = office(tmp_path, "mcap", "a")
    b = office(tmp_path, "bag", "b", shift_s=900)  # overlapping in time, another container
    c = office(tmp_path, "rosbag2-sqlite3", "c", shift_s=3000, second_topic="/tracks_b")
    together = both([a, b, c])
    assert together.indexed == [True]
    together.assert_same()
    first = tmp_path / "first.aion"
    build_map(BuildOptions(logs=(a,), output=first))
    continued = both([b, c], continue_from=first)
    assert continued.indexed == [True]
    continued.assert_same()


def test_a_compressed_log_builds_the_same_map(tmp_path: Path, both: Callable[..., Builds]) -> None:
    import zstandard

    plain = office(tmp_path, "mcap")
    packed = tmp_path / "office.mcap.zstd"
    packed.write_bytes(zstandard.ZstdCompressor().compress(plain.read_bytes()))
    builds = both([packed])
    assert builds.indexed == [True]
    builds.assert_same()


def test_graph_thinning_with_a_stray_graph_is_the_same(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    log = write_stream_log(tmp_path / "stream.mcap", stray_graph=True)
    builds = both([log], graph_period_ns=5 * S)
    assert builds.indexed == [True]
    builds.assert_same()
    report = builds.fast[0]
    assert report["graph"]["skipped_period"] > 0
    assert report["log_times_dropped"]["/hydra/backend/dsg"]["stray"] == 1


def _timed_log(path: Path, container: str = "mcap", chunk: int | None = 600) -> Path:
    """People every second for 200 s with TF and a graph every 20 s, a stray person three days
    later and one out of range (MCAP), written out of order (chunks overlap)."""
    payload = graph_payload()
    events = walk(200)
    events += [robot_tf(T0 + k * S) for k in range(0, 200, 5)]
    events += [scene_graph(T0 + k * S, payload) for k in range(0, 200, 20)]
    events.append(person(T0 + 3 * DAY, (2.1, 0.1, 0.0), header_ns=T0))
    if container.startswith("mcap"):
        events.append(person(MAX_TIME_NS + S, (2.1, 0.1, 0.0), header_ns=T0))
    events = events[::3] + events[1::3] + events[2::3]
    target = path.with_suffix(SUFFIX.get(container, ""))
    with LogWriter(target, container, chunk_size=chunk) as writer:
        for topic, msgtype, msg, t in events:
            writer.write(topic, msgtype, msg, t)
    return target


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_stray_and_out_of_range_detections_are_dropped_alike(
    container: str, tmp_path: Path, both: Callable[..., Builds]
) -> None:
    builds = both([_timed_log(tmp_path / "timed", container)], graph_period_ns=0)
    assert builds.indexed == [True]
    builds.assert_same()
    dropped = builds.fast[0]["log_times_dropped"]["/tracks"]
    assert dropped == {"out_of_range": int(container == "mcap"), "stray": 1}


# -- damaged indexes, damaged chunks ---------------------------------------------------------


def _chunks(path: Path) -> list[Any]:
    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


def test_a_damaged_message_index_falls_back_and_builds_the_undamaged_logs_map(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    log = _timed_log(tmp_path / "timed")
    good = _build([log], tmp_path / "good.aion", graph_period_ns=0)
    chunk = _chunks(log)[1]
    entry = min(chunk.message_index_offsets.values()) + 15  # first entry's log time
    data = bytearray(log.read_bytes())
    data[entry : entry + 8] = struct.pack("<Q", chunk.message_end_time + 10 * S)
    log.write_bytes(bytes(data))
    builds = both([log], graph_period_ns=0)
    assert builds.indexed == [False]  # the index says a time outside its chunk
    builds.assert_same()
    assert differences(builds.fast[1], good[1]) == []
    assert _comparable(builds.fast[0])["time_span"] == good[0]["time_span"]


def _flip_in_chunk(data: bytearray, offset: int, length: int) -> None:
    """Flip one bit in the last quarter of the bytes at ``offset .. offset + length``."""
    data[offset + length - max(length // 4, 2)] ^= 0x10


def test_a_chunk_failing_its_crc_makes_the_build_start_over_with_the_same_result(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    log = _timed_log(tmp_path / "timed")
    # a chunk without TF: the first pass takes its times from the index; the stream finds
    # it damaged and the build starts over
    victim = next(c for c in _chunks(log)[2:] if len(c.message_index_offsets) == 1)
    data = bytearray(log.read_bytes())
    _flip_in_chunk(data, victim.chunk_start_offset, victim.chunk_length)
    log.write_bytes(bytes(data))
    builds = both([log], graph_period_ns=0)
    assert builds.indexed == [True]
    assert builds.tries == 2
    builds.assert_same()
    notes = builds.fast[0]["notes"] + builds.fast[0].get("warnings", [])
    assert any(f"corrupt chunk at byte {victim.chunk_start_offset} skipped" in n for n in notes)


def _bag_chunk_positions(path: Path) -> Iterator[tuple[int, int, int]]:
    """``(chunk data position, first /tracks message offset in it, connection id)``."""
    from aion_cli.formats.bag_reader import BagReader
    from aion_cli.formats.limits import ReadLimits

    reader = BagReader(path, ReadLimits())
    reader.open()
    try:
        tracks = next(c.id for c in reader.connections if c.topic == "/tracks")
        firsts: dict[int, int] = {}
        for entry in reader.indexes[tracks]:
            firsts.setdefault(entry.chunk_pos, entry.offset)
        for pos, offset in sorted(firsts.items()):
            yield reader.chunks[pos].datapos, offset, tracks
    finally:
        reader.close()


def test_a_failing_chunk_at_the_end_of_a_fixed_sensors_log_starts_over_too(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    """No TF: the observed windows and the span come from the log times; the last chunk's
    times must not count once it turns out unreadable (the build that did not start over
    would end the span, and observe windows, past the last message it used)."""
    log = tmp_path / "fixed.mcap"
    with LogWriter(log, "mcap", chunk_size=800) as writer:
        for k in range(240):
            writer.write(*person(T0 + k * 30 * S, (2.1, 0.1, 0.0))[:3], T0 + k * 30 * S)
    victim = _chunks(log)[-1]
    data = bytearray(log.read_bytes())
    _flip_in_chunk(data, victim.chunk_start_offset, victim.chunk_length)
    log.write_bytes(bytes(data))
    builds = both([log])
    assert builds.indexed == [True]
    assert builds.tries == 2
    builds.assert_same()
    assert builds.fast[0]["time_span"]["end_ns"] < victim.message_start_time


def test_a_bag_chunk_that_does_not_parse_makes_the_build_start_over(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    log = _timed_log(tmp_path / "timed", "bag", chunk=2000)
    datapos, offset, _ = list(_bag_chunk_positions(log))[2]
    data = bytearray(log.read_bytes())
    data[datapos + offset : datapos + offset + 4] = struct.pack("<I", 0x7FFFFFF0)  # header length
    log.write_bytes(bytes(data))
    builds = both([log], graph_period_ns=0)
    assert builds.indexed == [True]
    assert builds.tries == 2
    builds.assert_same()
    assert builds.fast[0]["detections"]["read"] < 200


def test_fast_and_full_first_pass_agree_on_the_robot_trajectory(tmp_path: Path) -> None:
    """TF is read message by message either way: the trajectory is the same arrays."""
    from aion_cli.build_report import NoProgress
    from aion_cli.formats.logs import open_logs
    from aion_cli.tf_feed import read_tf_and_times
    from aion_cli.topics import select_topics

    log = _timed_log(tmp_path / "timed")
    out = []
    for use_index in (True, False):
        with open_logs([log]) as logset:
            plan = select_topics(logset.topics, (), None, {})
            timed = plan.names("detections") | plan.names("graph")
            tf, _, _ = read_tf_and_times(logset, plan, timed, NoProgress(), use_index=use_index)
        assert tf is not None
        out.append(tf.trajectory("map", "base_link"))
    np.testing.assert_array_equal(out[0].t_ns, out[1].t_ns)
    np.testing.assert_array_equal(out[0].xyz, out[1].xyz)


def test_a_build_that_starts_over_keeps_the_note_on_a_log_overlapping_the_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A continued map whose data ends 49 s into its open window, and a log from that
    window's start: when the stream finds a stale index after its first detections and the
    build starts over, the note that the log overlaps the map's data is made again (the
    second pass took it as made, and the report it starts from had lost it)."""
    from aion_cli.build_stream import StreamStep
    from aion_cli.errors import StaleIndexError

    base = tmp_path / "base.mcap"
    with LogWriter(base, "mcap") as writer:
        for topic, msgtype, msg, t in walk(100, start_s=-50):
            writer.write(topic, msgtype, msg, t)
    first = tmp_path / "first.aion"
    build_map(BuildOptions(logs=(base,), output=first))
    log = _timed_log(tmp_path / "timed")
    fed, real = [0], StreamStep._feed

    def feed(self: StreamStep, *args: Any) -> None:
        fed[0] += 1
        if fed[0] == 3:  # after the first detections: as a damaged chunk found by the stream
            raise StaleIndexError("a chunk the index vouched for does not read")
        real(self, *args)

    monkeypatch.setattr(StreamStep, "_feed", feed)
    report = build_map(BuildOptions(
        logs=(log,), output=tmp_path / "out.aion", continue_from=first, graph_period_ns=0,
        batch_size=5,
    ))
    assert fed[0] > 3
    assert sum("before first.aion's data ends" in n for n in report.notes) == 1, report.notes


def _set_log_time_in_chunk(path: Path, topic: str, value: int) -> int:
    """Set the log time of the first message on ``topic`` inside an uncompressed chunk of the
    MCAP file ``path`` to ``value`` (uint64), the chunk's CRC made right; its index and the
    summary are left as they were. Returns the chunk's offset."""
    import zlib

    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    (cid,) = [c.id for c in summary.channels.values() if c.topic == topic]
    data = bytearray(path.read_bytes())
    for chunk in _chunks(path):
        body = chunk.chunk_start_offset + 9
        comp_len = struct.unpack_from("<I", data, body + 28)[0]
        assert data[body + 32 : body + 32 + comp_len] == b""  # uncompressed
        records = body + 32 + comp_len + 8
        end = records + struct.unpack_from("<Q", data, records - 8)[0]
        at = records
        while at < end:
            op, length = data[at], struct.unpack_from("<Q", data, at + 1)[0]
            if op == 0x05 and struct.unpack_from("<H", data, at + 9)[0] == cid:
                struct.pack_into("<Q", data, at + 15, value)
                if struct.unpack_from("<I", data, body + 24)[0]:  # a CRC to keep right
                    struct.pack_into("<I", data, body + 24, zlib.crc32(data[records:end]))
                path.write_bytes(bytes(data))
                return chunk.chunk_start_offset
            at += 9 + length
    raise AssertionError(f"no message on {topic}")


def test_a_message_time_beyond_int64_inside_a_chunk_makes_the_build_start_over(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    """A person's log time inside a chunk set to 2^64 - 1 ns (the long fuzz run of stop 66,
    target log_fields, on a rosbag2 bag with mcap storage: uncompressed chunks): its index
    still gives the old time, which the first pass took, and the stream yielded a time no
    int64 holds (``internal error: OverflowError``, exit 1). Now the chunk's times outside its
    index make the build start over reading every message, which drops that one as out of
    range, as a build that never used the index does."""
    log = office(tmp_path, "rosbag2-mcap")  # no stray time: nothing for the stream to drop
    (storage,) = log.glob("*.mcap")
    with open_logs([log]) as logs:
        (topic,) = [t.topic for t in logs.topics if "TrackedPersons" in t.msgtype]
    _set_log_time_in_chunk(storage, topic, 2**64 - 1)
    builds = both([log])
    assert builds.indexed == [True]
    assert builds.tries == 2
    builds.assert_same()
    assert builds.fast[0]["log_times_dropped"][topic] == {"out_of_range": 1, "stray": 0}


def test_a_time_beyond_int64_in_an_mcap_read_without_its_summary_is_dropped(
    tmp_path: Path, both: Callable[..., Builds]
) -> None:
    """The same time in a zstd chunk, recompressed: the summary's offsets no longer hold, the
    file is scanned, and its span ended at 2^64 - 1 ns, which the stray rule's recording spans
    could not hold in int64 (``internal error: OverflowError``). The span ends at 2^63 - 1 ns
    now; the message is dropped as out of range, the stray kept out: the full read's map."""
    import random

    from tests.robustness.fuzz_fields import Field, mutate_mcap_chunk

    log = _timed_log(tmp_path / "timed")
    victim = next(c for c in _chunks(log)[2:] if len(c.message_index_offsets) == 1)

    class Victim(random.Random):  # that chunk, its first message's log time, 2^64 - 1
        def choice(self, seq: Any) -> Any:
            if isinstance(seq[0], tuple):
                return next(c for c in seq if c[0] == victim.chunk_start_offset)
            if isinstance(seq[0], Field):
                return next(f for f in seq if f.kind == "time")
            return 2**64 - 1

    mutant = mutate_mcap_chunk(log.read_bytes(), Victim(1))
    assert mutant is not None
    assert len(mutant) != log.stat().st_size
    log.write_bytes(mutant)
    builds = both([log], graph_period_ns=0)
    # the map of the full read (the warnings name another message "first": the stream's order)
    assert differences(builds.fast[1], builds.full[1]) == []
    # the out-of-range person _timed_log writes, and this one
    for report in (builds.fast[0], builds.full[0]):
        assert report["log_times_dropped"]["/tracks"] == {"out_of_range": 2, "stray": 1}
