"""Every real container in ../shared/data/logs opens with the right counts, times and payloads.

The expected answers come from outside aion's readers: the ROS 1 bags (cruise-automation's
rosbag.js fixtures) from a small independent parser of the bag format below (its IndexData
records, and the chunks decompressed with bz2 / lz4); the rosbag2 test bags (ros2/rosbag2) from
their own ``metadata.yaml`` and from their storage files read with Python's ``sqlite3`` and the
``mcap`` library's reader.
"""

from __future__ import annotations

import bz2
import struct
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from tests.formats.rosbag2_reference import bag_metadata, mcap_messages, sqlite_messages
from tests.shared_data import SHARED_DATA, real

DATA = SHARED_DATA / "logs"
NO_DATA = "the real logs of ../shared/data/logs are not available"


def _real(*parts: str) -> Path:
    """The real log: ../shared/data's copy, else the repository's fixture (tests/data), else
    the test skips."""
    return real("logs", *parts)


# --- an independent ROS 1 bag (format 2.0) parser -------------------------------------------------


def _fields(block: bytes) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    pos = 0
    while pos < len(block):
        (n,) = struct.unpack_from("<I", block, pos)
        name, value = block[pos + 4 : pos + 4 + n].split(b"=", 1)
        out[name.decode()] = value
        pos += 4 + n
    return out


def _bag_records(buf: bytes, pos: int = 0) -> list[tuple[dict[str, bytes], bytes]]:
    """``(header fields, data)`` of every record from ``pos``: header length, header, data
    length, data."""
    out = []
    while pos < len(buf):
        (header_len,) = struct.unpack_from("<I", buf, pos)
        header = _fields(buf[pos + 4 : pos + 4 + header_len])
        pos += 4 + header_len
        (data_len,) = struct.unpack_from("<I", buf, pos)
        out.append((header, buf[pos + 4 : pos + 4 + data_len]))
        pos += 4 + data_len
    return out


def _ros_time(value: bytes) -> int:
    sec, nsec = struct.unpack("<II", value)
    return sec * 1_000_000_000 + nsec


def _u32(value: bytes) -> int:
    return int(struct.unpack("<I", value)[0])


def read_bag(
    path: Path,
) -> tuple[list[tuple[str, int]], list[tuple[str, int, bytes]], dict[str, str]]:
    """The bag's index ``(topic, time)`` of every message (from its IndexData records), its
    messages ``(topic, time, data)`` from the (decompressed) chunks, and ``topic -> type``."""
    buf = path.read_bytes()
    assert buf.startswith(b"#ROSBAG V2.0\n")
    topics: dict[int, str] = {}
    types: dict[str, str] = {}
    index: list[tuple[int, int]] = []
    messages: list[tuple[int, int, bytes]] = []
    for header, data in _bag_records(buf, 13):
        op = header["op"][0]
        if op == 0x07:  # connection
            topic = header["topic"].decode()
            topics[_u32(header["conn"])] = topic
            types[topic] = _fields(data)["type"].decode()
        elif op == 0x04:  # index data: count x (time, offset)
            conn, count = _u32(header["conn"]), _u32(header["count"])
            index.extend((conn, _ros_time(data[12 * k : 12 * k + 8])) for k in range(count))
        elif op == 0x05:  # chunk
            compression = header["compression"].decode()
            if compression == "bz2":
                data = bz2.decompress(data)
            elif compression == "lz4":
                import lz4.frame  # type: ignore[import-untyped]

                data = lz4.frame.decompress(data)
            for inner, payload in _bag_records(data):
                if inner["op"][0] == 0x02:  # message data
                    messages.append((_u32(inner["conn"]), _ros_time(inner["time"]), payload))
    return (
        [(topics[c], t) for c, t in index],
        [(topics[c], t, d) for c, t, d in messages],
        types,
    )


ROSBAG_JS = ["example.bag", "example-bz2.bag", "example-lz4.bag", "example-unsorted-chunks.bag"]


@pytest.mark.parametrize("name", ROSBAG_JS)
def test_rosbag_js_fixtures(name: str) -> None:
    path = _real("rosbagjs_fixtures", name)
    index, chunks, types = read_bag(path)
    assert sorted((topic, t) for topic, t, _ in chunks) == sorted(index)  # the parser agrees
    counts = Counter(topic for topic, _ in index)
    times = [t for _, t in index]
    with open_logs([path]) as logs:
        assert [f.format for f in logs.files] == ["bag"]
        assert logs.total() == len(index)
        assert {t.topic: t.count for t in logs.topics} == dict(counts)
        assert {t.topic: t.msgtype for t in logs.topics} == {
            topic: kind.replace("/", "/msg/") for topic, kind in types.items()
        }
        assert (logs.start_ns, logs.end_ns) == (min(times), max(times))
        got = [(m.topic, m.log_time_ns, m.data) for m in logs.messages()]
        assert [t for _, t, _ in got] == sorted(times)  # log-time order, unsorted chunks too
        assert sorted(got) == sorted(chunks)
        assert logs.warnings == []


def test_rosbag_js_fixture_counts_as_published() -> None:
    # rosbag.js' own tests: example.bag holds 8647 messages, the unsorted one 3 at 1, 2, 3 s
    with open_logs([_real("rosbagjs_fixtures", "example.bag")]) as logs:
        assert logs.total() == 8647
    with open_logs([_real("rosbagjs_fixtures", "example-unsorted-chunks.bag")]) as logs:
        assert [m.log_time_ns for m in logs.messages()] == [10**9, 2 * 10**9, 3 * 10**9]


def test_rosbag_js_bag_without_messages_is_refused() -> None:
    path = _real("rosbagjs_fixtures", "no-messages.bag")
    index, chunks, _ = read_bag(path)
    assert index == []
    assert chunks == []
    with pytest.raises(LogFormatError, match="no messages"):
        open_logs([path])


# --- rosbag2 test bags: metadata.yaml and the storage files read directly ---------------------


def _storage_messages(folder: Path) -> list[tuple[str, int, bytes]]:
    db3 = sorted(folder.glob("*.db3"))
    return sqlite_messages(*db3) if db3 else mcap_messages(*sorted(folder.glob("*.mcap")))


ROSBAG2 = [
    "rosbag2_py_mcap_talker",
    "rosbag2_py_mcap_wbag",
    "rosbag2_py_sqlite3_talker",
    "rosbag2_py_sqlite3_wbag",
    "rosbag2_tests_mcap_bag_with_topics_and_service_events",
    "rosbag2_tests_mcap_cdr_test",
    "rosbag2_tests_sqlite3_bag_with_topics_and_service_events",
    "rosbag2_tests_sqlite3_cdr_test",
]


def _check_messages(logs: Any, expected: list[tuple[str, int, bytes]]) -> None:
    got = [(m.topic, m.log_time_ns, m.data) for m in logs.messages()]
    assert [t for _, t, _ in got] == sorted(t for _, t, _ in expected)
    assert sorted(got) == sorted(expected)
    if expected:
        assert (logs.start_ns, logs.end_ns) == (expected[0][1], max(t for _, t, _ in expected))


@pytest.mark.parametrize("name", ROSBAG2)
def test_rosbag2_test_bags(name: str) -> None:
    folder = _real("rosbag2_tests", name)
    meta = bag_metadata(folder)
    counts = {
        t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]
    }
    expected = _storage_messages(folder)
    assert Counter(topic for topic, _, _ in expected) == +Counter(counts)  # the bag is whole
    with open_logs([folder]) as logs:
        assert {f.format for f in logs.files} == {f"rosbag2-{meta['storage_identifier']}"}
        assert logs.total() == meta["message_count"] == len(expected)
        assert {t.topic: t.count for t in logs.topics} == counts
        types = {
            t["topic_metadata"]["name"]: t["topic_metadata"]["type"]
            for t in meta["topics_with_message_count"]
        }
        assert {t.topic: t.msgtype for t in logs.topics} == types
        _check_messages(logs, expected)
        if name.endswith("_wbag"):  # their metadata.yaml states other times: said, not used
            (warning,) = logs.warnings
            assert "metadata.yaml disagrees with its storage files" in warning
            assert f"starting_time {meta['starting_time']['nanoseconds_since_epoch']} ns" in warning
        else:
            assert logs.warnings == []
        if not name.endswith("_wbag"):
            start = meta["starting_time"]["nanoseconds_since_epoch"]
            assert (logs.start_ns, logs.end_ns) == (start, start + meta["duration"]["nanoseconds"])


def test_sqlite3_talker_yields_its_20_messages_like_its_mcap_twin() -> None:
    # metadata.yaml and the topics table disagree on the QoS profiles (deadline 0 s against
    # 2147483647 s): rosbags' folder reader matches connections by QoS too and yielded nothing
    sqlite = _real("rosbag2_tests", "rosbag2_py_sqlite3_talker")
    mcap = _real("rosbag2_tests", "rosbag2_py_mcap_talker")
    with open_logs([sqlite]) as a, open_logs([mcap]) as b:
        got = [(m.topic, m.msgtype, m.log_time_ns, m.data) for m in a.messages()]
        assert len(got) == 20
        assert got == [(m.topic, m.msgtype, m.log_time_ns, m.data) for m in b.messages()]
        assert [m.topic for m in a.messages(["/topic"])] == ["/topic"] * 10
        hello = [a.decode(m).data for m in a.messages(["/topic"])]
        assert hello == [f"Hello, world! {k}" for k in range(10)]


def test_empty_rosbag2_bag_is_refused() -> None:
    folder = _real("rosbag2_tests", "ros2bag_empty_bag")
    assert bag_metadata(folder)["message_count"] == 0
    with pytest.raises(LogFormatError, match="no messages"):
        open_logs([folder])


@pytest.mark.parametrize(
    "name", ["only_services.mcap", "only_topics.mcap", "topics_and_services.mcap"]
)
def test_rosbag2_cpp_storage_files_alone(name: str) -> None:
    path = _real("rosbag2_tests", "rosbag2_cpp_bags", name)
    expected = mcap_messages(path)
    with open_logs([path]) as logs:
        assert logs.total() == len(expected) > 0
        _check_messages(logs, expected)
        assert logs.warnings == []
