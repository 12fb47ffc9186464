"""LogSet.recorded_windows: the epoch-aligned time windows in which a log recorded at least one
message — never the gap between two recordings, inside one file or between files — read from the
containers' indexes (MCAP chunk and message indexes, the ROS 1 bag index, rosbag2 sqlite3), and
equal to the windows of every message the generic reader yields, on synthetic and real logs."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt
import pytest

import aion_cli.formats.mcap_linear
import aion_cli.formats.mcap_source
from aion_cli.errors import ConfigError
from aion_cli.formats.logs import LogSet, open_logs
from aion_cli.formats.writers import CONTAINERS, LogWriter, stamp
from tests.shared_data import SHARED_DATA, real

DATA = SHARED_DATA / "logs"
NO_DATA = "the real logs of ../shared/data/logs are not available"

S = 1_000_000_000
WINDOW = 600 * S  # the default window of aion build
W0 = 2_833_334  # a window of November 2023
SESSION_A = [W0 * WINDOW + k * 60 * S for k in range(30)]  # windows W0 .. W0+2
SESSION_B = [(W0 + 8) * WINDOW + 30 * S + k * 60 * S for k in range(15)]  # W0+8, W0+9
SESSIONS = [W0, W0 + 1, W0 + 2, W0 + 8, W0 + 9]
FILE_NAMES = {"mcap": "log.mcap", "mcap-ros1": "log.mcap", "bag": "log.bag"}


def _people(t: int) -> dict[str, Any]:
    return {
        "header": {"stamp": stamp(t), "frame_id": "odom"},
        "people": [{"name": "p0", "position": {"x": 1.0}}],
    }


def _write_sessions(path: Path, container: str, times: list[int]) -> Path:
    """People messages at ``times``, a TF message beside every 5th (two topics)."""
    with LogWriter(path, container) as w:
        for k, t in enumerate(times):
            w.write("/people", "people_msgs/People", _people(t), t)
            if k % 5 == 0:
                tf = {"transforms": [{"header": {"stamp": stamp(t), "frame_id": "map"}}]}
                w.write("/tf", "tf2_msgs/TFMessage", tf, t + 1)
    return path


def _log_path(tmp_path: Path, container: str, name: str = "log") -> Path:
    return tmp_path / FILE_NAMES.get(container, name).replace("log", name)


def _message_windows(logs: LogSet, window_ns: int) -> npt.NDArray[np.int64]:
    """The independent answer: windows of every message the generic reader yields."""
    times = np.fromiter((m.log_time_ns for m in logs.messages()), dtype=np.int64)
    return np.unique(times // window_ns)


def _boom(*args: Any, **kwargs: Any) -> NoReturn:
    raise AssertionError("recorded_windows must not read message payloads here")


# --- synthetic logs written with LogWriter ------------------------------------------------------


@pytest.mark.parametrize("container", CONTAINERS)
def test_two_sessions_in_one_file_give_their_windows_not_the_gap(
    container: str, tmp_path: Path
) -> None:
    path = _write_sessions(_log_path(tmp_path, container), container, SESSION_A + SESSION_B)
    with open_logs([path]) as logs:
        got = logs.recorded_windows(WINDOW)
        assert got.dtype == np.int64
        assert got.tolist() == SESSIONS
        assert np.array_equal(got, _message_windows(logs, WINDOW))
        ((f, per_file),) = logs.recorded_windows_by_file(WINDOW)
        assert f == logs.files[0]
        assert per_file.tolist() == SESSIONS
        assert logs.warnings == []


@pytest.mark.parametrize("container", ["mcap", "mcap-ros1", "rosbag2-mcap"])
def test_mcap_chunk_spanning_the_gap_is_answered_from_its_message_index(
    container: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.reader import make_reader

    path = _write_sessions(_log_path(tmp_path, container), container, SESSION_A + SESSION_B)
    (storage,) = [path] if path.is_file() else list(path.glob("*.mcap"))
    with storage.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    (chunk,) = summary.chunk_indexes  # one chunk holds both sessions and the gap between them
    assert chunk.message_index_offsets
    # no chunk is decompressed
    monkeypatch.setattr(aion_cli.formats.mcap_linear, "_decompress", _boom)
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS


def test_bag_windows_come_from_the_index_loaded_at_open(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rosbags.rosbag1 import Reader

    path = _write_sessions(tmp_path / "log.bag", "bag", SESSION_A + SESSION_B)
    with open_logs([path]) as logs:
        monkeypatch.setattr(Reader, "messages", _boom)
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS


def test_sqlite3_windows_come_from_sql_not_from_the_rows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rosbags.rosbag2.reader import DirectoryReader
    from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

    path = _write_sessions(tmp_path / "bag2", "rosbag2-sqlite3", SESSION_A + SESSION_B)
    with open_logs([path]) as logs:
        monkeypatch.setattr(Sqlite3Reader, "messages", _boom)
        monkeypatch.setattr(DirectoryReader, "messages", _boom)
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS


def test_windows_of_small_sizes_match_every_message_time(tmp_path: Path) -> None:
    path = _write_sessions(tmp_path / "log.mcap", "mcap", SESSION_A + SESSION_B)
    with open_logs([path]) as logs:
        for window in (1, 7, S, 60 * S, 3600 * S, 86_400 * S):
            assert np.array_equal(logs.recorded_windows(window), _message_windows(logs, window))
        one_ns = logs.recorded_windows(1)
        assert len(one_ns) == 45 + 9  # every people message and the 9 TF messages (t + 1)


def test_a_message_on_a_window_boundary_belongs_to_the_window_it_opens(tmp_path: Path) -> None:
    times = [5 * WINDOW - 1, 5 * WINDOW, 9 * WINDOW]
    path = _write_sessions(tmp_path / "log.mcap", "mcap", times)
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == [4, 5, 9]


def test_two_files_with_a_gap_between_them(tmp_path: Path) -> None:
    a = _write_sessions(tmp_path / "a.mcap", "mcap", SESSION_A)
    b = _write_sessions(tmp_path / "b.bag", "bag", SESSION_B)
    c = _write_sessions(tmp_path / "c", "rosbag2-sqlite3", [(W0 + 20) * WINDOW + 5 * S])
    with open_logs([a, b, c]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == [*SESSIONS, W0 + 20]
        per_file = logs.recorded_windows_by_file(WINDOW)
        assert [f.path for f, _ in per_file] == [a, b, c]
        assert [w.tolist() for _, w in per_file] == [SESSIONS[:3], SESSIONS[3:], [W0 + 20]]


def test_a_file_without_messages_records_no_window(tmp_path: Path) -> None:
    empty = tmp_path / "empty.bag"
    LogWriter(empty, "bag").close()
    full = _write_sessions(tmp_path / "full.mcap", "mcap", SESSION_B)
    with open_logs([empty, full]) as logs:
        (_, none), (_, some) = logs.recorded_windows_by_file(WINDOW)
        assert none.dtype == np.int64
        assert none.tolist() == []
        assert some.tolist() == SESSIONS[3:]
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS[3:]


@pytest.mark.parametrize("window", [0, -600, 2**63, 1.5, "600"])
def test_bad_window_is_a_config_error(window: Any, tmp_path: Path) -> None:
    path = _write_sessions(tmp_path / "log.mcap", "mcap", SESSION_A)
    with open_logs([path]) as logs, pytest.raises(ConfigError) as info:
        logs.recorded_windows(window)
    assert info.value.hint


def test_numpy_integer_window_and_closed_set(tmp_path: Path) -> None:
    path = _write_sessions(tmp_path / "log.mcap", "mcap", SESSION_A)
    logs = open_logs([path])
    assert logs.recorded_windows(np.int64(WINDOW)).tolist() == SESSIONS[:3]  # type: ignore[arg-type]
    logs.close()
    with pytest.raises(ValueError, match="closed"):
        logs.recorded_windows(WINDOW)


# --- MCAP variants written with the mcap library ------------------------------------------------


def _write_mcap(path: Path, times: list[int], **writer_options: Any) -> Path:
    """One channel of empty ROS 2 messages (100-byte payloads) at ``times``."""
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f, **writer_options)
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        channel = w.register_channel("/e", "cdr", schema)
        for t in times:
            w.add_message(channel, t, b"\x00\x01\x00\x00" + bytes(96), t)
        w.finish()
    return path


def test_narrow_chunks_need_no_message_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # about one message per chunk: every chunk lies inside one window
    path = _write_mcap(tmp_path / "small.mcap", SESSION_A + SESSION_B, chunk_size=64)

    def no_reads(self: Any, stream: Any, index: Any) -> NoReturn:
        raise AssertionError("a chunk inside two windows needs no message time")

    monkeypatch.setattr(aion_cli.formats.mcap_source._McapSource, "_chunk_times", no_reads)
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS


def test_chunks_without_message_indexes_are_decompressed(tmp_path: Path) -> None:
    from mcap.writer import CompressionType, IndexType

    for compression in (CompressionType.NONE, CompressionType.ZSTD, CompressionType.LZ4):
        path = _write_mcap(
            tmp_path / f"noidx-{compression.name}.mcap",
            SESSION_A + SESSION_B,
            index_types=IndexType.CHUNK,
            compression=compression,
        )
        with open_logs([path]) as logs:
            assert logs.recorded_windows(WINDOW).tolist() == SESSIONS
            assert logs.warnings == []


def test_unordered_and_overlapping_chunks(tmp_path: Path) -> None:
    times = [SESSION_B[0], SESSION_A[0], SESSION_B[-1], SESSION_A[-1], SESSION_A[10]]
    path = _write_mcap(tmp_path / "overlap.mcap", times, chunk_size=64)
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS
        assert np.array_equal(logs.recorded_windows(7), _message_windows(logs, 7))


def test_mcap_without_summary_uses_the_scan_done_at_open(tmp_path: Path) -> None:
    path = _write_mcap(
        tmp_path / "plain.mcap",
        SESSION_A + SESSION_B,
        use_chunking=False,
        use_statistics=False,
        use_summary_offsets=False,
    )
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS


def test_truncated_mcap_records_the_windows_up_to_the_break(tmp_path: Path) -> None:
    full = _write_mcap(tmp_path / "full.mcap", SESSION_A + SESSION_B, chunk_size=512)
    whole = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) // 2])
    with open_logs([cut]) as logs:
        assert "truncated or corrupt MCAP" in logs.warnings[0]
        got = logs.recorded_windows(WINDOW)
        assert np.array_equal(got, _message_windows(logs, WINDOW))
        assert 0 < logs.total() < 45
        assert 0 < len(got) < len(SESSIONS)  # the end of session B is cut off
        assert set(got.tolist()) <= set(SESSIONS)
        assert np.array_equal(logs.recorded_windows(S), _message_windows(logs, S))


def test_damaged_message_index_falls_back_to_the_chunk(tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap.writer import CompressionType

    path = _write_mcap(tmp_path / "c.mcap", SESSION_A + SESSION_B, compression=CompressionType.NONE)
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    (chunk,) = summary.chunk_indexes
    (offset,) = chunk.message_index_offsets.values()
    data = bytearray(path.read_bytes())
    data[offset] = 0x00  # no longer a MessageIndex opcode
    path.write_bytes(bytes(data))
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS
        assert logs.warnings == []
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0xFF  # and a damaged chunk
    path.write_bytes(bytes(data))
    with open_logs([path]) as logs:
        assert logs.recorded_windows(WINDOW).tolist() == []
        assert "corrupt chunk" in logs.warnings[-1]
        assert list(logs.messages()) == []  # the reader stops at the same chunk


# --- compressed rosbag2 (written with rosbags directly: LogWriter does not compress) -----------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("mode", ["file", "message"])
def test_compressed_rosbag2(storage: str, mode: str, tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from aion_cli.formats import msgdefs

    serializer = LogWriter(tmp_path / "unused.mcap", "mcap")
    data = serializer.serialize("people_msgs/People", _people(0))
    serializer.close()
    folder = tmp_path / "compressed"
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    writer = Writer(folder, version=9, storage_plugin=plugin)
    compression = CompressionMode.FILE if mode == "file" else CompressionMode.MESSAGE
    writer.set_compression(compression, CompressionFormat.ZSTD)
    writer.open()
    conn = writer.add_connection(
        "/people", "people_msgs/msg/People", typestore=msgdefs.typestore(2)
    )
    for t in SESSION_A + SESSION_B:
        writer.write(conn, t, data)
    writer.close()
    with open_logs([folder]) as logs:
        assert logs.files[0].format == f"rosbag2-{storage}"
        assert logs.recorded_windows(WINDOW).tolist() == SESSIONS
        assert np.array_equal(logs.recorded_windows(S), _message_windows(logs, S))


# --- real logs -----------------------------------------------------------------------------------

WINDOWS = (1, 7, 1_000, 1_000_000, S, WINDOW)


def _real(*parts: str) -> Path:
    return real("logs", *parts)



ROSBAG_JS = ["example-bz2.bag", "example.bag", "example-lz4.bag", "example-unsorted-chunks.bag"]
LEG_TRACKER = [
    "demo_stationary_simple_environment.bag",
    "positive_1_extracted.bag",
    "positive_2_extracted.bag",
]
ROSBAG2 = [
    "rosbag2_py_mcap_talker",
    "rosbag2_py_sqlite3_talker",
    "rosbag2_py_mcap_wbag",  # split over five storage files
    "rosbag2_py_sqlite3_wbag",
    "rosbag2_tests_mcap_bag_with_topics_and_service_events",
    "rosbag2_tests_mcap_cdr_test",
    "rosbag2_tests_sqlite3_bag_with_topics_and_service_events",
    "rosbag2_tests_sqlite3_cdr_test",
    "rosbag2_cpp_bags/only_services.mcap",
    "rosbag2_cpp_bags/only_topics.mcap",
    "rosbag2_cpp_bags/topics_and_services.mcap",
]


def _real_logs() -> Iterator[tuple[str, ...]]:
    yield from (("rosbagjs_fixtures", name) for name in ROSBAG_JS)
    yield from (("leg_tracker", name) for name in LEG_TRACKER)
    yield from (("rosbag2_tests", *name.split("/")) for name in ROSBAG2)


@pytest.mark.parametrize("parts", list(_real_logs()), ids="/".join)
def test_real_logs_match_the_windows_of_every_message(parts: tuple[str, ...]) -> None:
    with open_logs([_real(*parts)]) as logs:
        assert logs.total() > 0
        for window in WINDOWS:
            got = logs.recorded_windows(window)
            assert np.array_equal(got, _message_windows(logs, window)), window
        # the wbag bags' metadata.yaml states other times than their files: said, not used
        assert [w for w in logs.warnings if "metadata.yaml disagrees" not in w] == []
        assert len(logs.warnings) == parts[-1].endswith("_wbag")


def test_real_empty_bags_record_no_window() -> None:
    empty1 = _real("rosbagjs_fixtures", "no-messages.bag")
    empty2 = _real("rosbag2_tests", "ros2bag_empty_bag")
    full = _real("rosbagjs_fixtures", "example-unsorted-chunks.bag")
    with open_logs([empty1, empty2, full]) as logs:
        windows = [w.tolist() for _, w in logs.recorded_windows_by_file(S)]
        assert windows == [[], [], [1, 2, 3]]


def test_real_sqlite3_talker_equals_its_mcap_twin() -> None:
    # The same recording in both storages (the QoS of the sqlite3 one's metadata.yaml and of its
    # topics table differ: rosbags' own matching would find no message; aion matches by topic
    # and type, tests/formats/test_real_containers.py): the windows equal the mcap twin's.
    sqlite3 = _real("rosbag2_tests", "rosbag2_py_sqlite3_talker")
    mcap = _real("rosbag2_tests", "rosbag2_py_mcap_talker")
    with open_logs([sqlite3]) as a, open_logs([mcap]) as b:
        for window in WINDOWS:
            assert np.array_equal(a.recorded_windows(window), b.recorded_windows(window))
        assert len(a.recorded_windows(1)) == 20


def _conformance_cases() -> list[str]:
    folder = DATA / "mcap_conformance"
    # every variant of the files with messages: chunked or not, message indexes or not,
    # padding, statistics, summary offsets, repeated schemas and channels
    return sorted(str(p.relative_to(folder)) for p in folder.glob("*Message*/*.mcap"))


@pytest.mark.skipif(not (DATA / "mcap_conformance").is_dir(), reason=NO_DATA)
@pytest.mark.parametrize("name", _conformance_cases() or ["none"])
def test_mcap_conformance_files_match_their_expected_records(name: str) -> None:
    path = DATA / "mcap_conformance" / name
    records = json.loads(path.with_suffix(".json").read_text())["records"]
    times = np.array(
        [int(dict(r["fields"])["log_time"]) for r in records if r["type"] == "Message"], np.int64
    )
    with open_logs([path]) as logs:  # their topics are not ROS: messages() skips them
        for window in (1, 2, 3, 5, S):
            assert np.array_equal(logs.recorded_windows(window), np.unique(times // window))


def test_the_logs_own_time_counts_each_file_once_and_no_gap_between_files() -> None:
    """``fixed_sensor.recording_window_count``: a file read in two time shards is one span from its
    first window to its last; overlapping files count a window once; the time between files
    counts not at all. Checked against the union of the windows spelled out."""
    from hypothesis import given
    from hypothesis import strategies as st

    from aion_cli.fixed_sensor import recording_window_count

    assert recording_window_count([]) == 0
    # a.mcap cut in two parts (windows 0-3 and 10-12): 0..12; b.mcap 20-24; c.mcap 22-30
    spans = [("a.mcap", 0, 3), ("a.mcap", 10, 12), ("b.mcap", 20, 24), ("c.mcap", 22, 30)]
    assert recording_window_count(spans) == 13 + 11

    span = st.tuples(st.sampled_from("abcd"), st.integers(0, 60), st.integers(0, 20))

    @given(st.lists(span, max_size=8))
    def matches_the_spelled_out_union(parts: list[tuple[str, int, int]]) -> None:
        spans = [(name, first, first + length) for name, first, length in parts]
        reach: dict[str, tuple[int, int]] = {}
        for name, first, last in spans:
            lo, hi = reach.get(name, (first, last))
            reach[name] = (min(lo, first), max(hi, last))
        windows = {w for lo, hi in reach.values() for w in range(lo, hi + 1)}
        assert recording_window_count(spans) == len(windows)

    matches_the_spelled_out_union()
