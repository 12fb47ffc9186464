"""A recording whose clock stepped back (an NTP correction of ten minutes mid-log): its
log times go back between chunks, and the minutes it covers twice are read together in time
order, so the people seen then count twice. The build did that without a word; now the
log's reader warns (from the chunk indexes of an MCAP file and the MessageIndex records of its
chunks, the chunk infos of a ROS 1 bag, the ``timestamp`` column of a rosbag2 sqlite3 file in
the order its rows were written), in ``aion build`` and ``aion info``. A step inside one MCAP
chunk and rosbag2 ``.db3`` files were not checked before; nor a step inside one ROS 1 bag chunk,
nor an MCAP file without a summary (read linearly: no chunk index to look at)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.robustness.conftest import T0, Message, S, build_json, person, run

N = 1800  # one message a second: 15 minutes, then the clock goes back 10 minutes, 15 more
STEP_S = 600


CONTAINERS = pytest.mark.parametrize("container", ["mcap", "bag", "rosbag2-sqlite3"])
#: a chunk (64 MiB) that holds the whole log: a step can only be inside it
ONE_CHUNK = 64 * 2**20


def write_chunked(
    path: Path, messages: list[Message], container: str, chunk_size: int = 4096
) -> Path:
    """``messages`` in the given order, in small chunks (4 KiB: about 20 messages each; a
    rosbag2 sqlite3 file has none: its rows in that order)."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, container, chunk_size=chunk_size) as writer:
        for topic, msgtype, msg, t_ns in messages:
            writer.write(topic, msgtype, msg, t_ns)
    return path


def stepped(step_s: int) -> list[Message]:
    """The person messages with the clock stepped by ``step_s`` (negative: back) halfway."""
    return [
        person(T0 + (k + (step_s if k >= N // 2 else 0)) * S, (2.1, 0.1, 0.0)) for k in range(N)
    ]


def steps_back(warnings: list[str]) -> list[float]:
    """The minutes each 'log times go back' warning names."""
    return [
        float(m.group(1))
        for w in warnings
        if (m := re.search(r"its log times go back at least ([0-9.]+) min", w)) is not None
    ]


@CONTAINERS
def test_log_times_stepping_back_are_a_warning(tmp_path: Path, container: str) -> None:
    log = write_chunked(tmp_path / f"back.{container}", stepped(-STEP_S), container)
    report = build_json(log, "-o", tmp_path / "back.aion")
    (minutes,) = steps_back(report["warnings"])
    # the step is 10 min; chunk bounds can only make it look smaller, by a chunk's 20 s
    assert 10 - 0.5 <= minutes <= 10
    assert report["detections"]["used"] == N  # what the warning is about: all are used
    info = run("info", log)
    assert info.exit_code == 0
    assert len(steps_back(info.stderr.splitlines())) == 1


@CONTAINERS
def test_log_times_in_order_or_stepping_forward_are_no_warning(
    tmp_path: Path, container: str
) -> None:
    for name, messages in (("ordered", stepped(0)), ("forward", stepped(3600))):
        log = write_chunked(tmp_path / f"{name}.{container}", messages, container)
        report = build_json(log, "-o", tmp_path / f"{name}.aion")
        assert steps_back(report["warnings"]) == [], report["warnings"]


@CONTAINERS
def test_a_log_written_out_of_time_order_builds_the_ordered_map_and_says_both_causes(
    tmp_path: Path, container: str
) -> None:
    """Messages of one topic written in shuffled order look like clock steps from the chunks'
    time ranges, yet build the map of the same messages written in order: the warning names
    both causes, not only a clock that stepped back."""
    import random

    from tests.robustness.conftest import assert_same_arrays, map_arrays

    ordered = stepped(0)
    shuffled = list(ordered)
    random.Random(2).shuffle(shuffled)
    build_json(
        write_chunked(tmp_path / f"o.{container}", ordered, container), "-o", tmp_path / "o.aion"
    )
    report = build_json(
        write_chunked(tmp_path / f"s.{container}", shuffled, container), "-o", tmp_path / "s.aion"
    )
    (warning,) = [w for w in report["warnings"] if "its log times go back at least" in w]
    assert "or the messages were written out of time order" in warning
    assert_same_arrays(map_arrays(tmp_path / "s.aion"), map_arrays(tmp_path / "o.aion"))


@pytest.mark.parametrize("container", ["mcap", "mcap-ros1"])
def test_a_step_inside_one_mcap_chunk_is_a_warning(tmp_path: Path, container: str) -> None:
    """The whole log in one chunk: the chunk's time range says nothing of a step inside it;
    its MessageIndex records (the messages' log times in the order they are in the chunk)
    do. The step is exactly 10 min: message N/2 is logged 599 s before message N/2 - 1."""
    log = write_chunked(tmp_path / "one.mcap", stepped(-STEP_S), container, ONE_CHUNK)
    from mcap.reader import make_reader

    with log.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert len(summary.chunk_indexes) == 1
    report = build_json(log, "-o", tmp_path / "one.aion")
    (minutes,) = steps_back(report["warnings"])
    assert minutes == round((STEP_S - 1) / 60, 1)
    (warning,) = [w for w in report["warnings"] if "go back" in w]
    assert "a message logged" in warning  # inside a chunk, not between two
    info = run("info", log)
    assert len(steps_back(info.stderr.splitlines())) == 1
    ordered = write_chunked(tmp_path / "ordered.mcap", stepped(0), container, ONE_CHUNK)
    assert steps_back(build_json(ordered, "-o", tmp_path / "o.aion")["warnings"]) == []


def test_a_rosbag2_storage_file_alone_is_checked_too(tmp_path: Path) -> None:
    """A .db3 given without its metadata.yaml is indexed in memory (formats.rosbag2_reindex):
    the same check, named by the storage file."""
    folder = write_chunked(tmp_path / "back", stepped(-STEP_S), "rosbag2-sqlite3")
    (db3,) = folder.glob("*.db3")
    alone = tmp_path / "alone.db3"
    alone.write_bytes(db3.read_bytes())
    info = run("info", alone)
    assert info.exit_code == 0, info.stderr
    (minutes,) = steps_back(info.stderr.splitlines())
    assert minutes == round((STEP_S - 1) / 60, 1)
    assert "alone.db3: its log times go back" in info.stderr


def without_summary(log: Path, out: Path) -> Path:
    """``log`` (an MCAP file) cut where its summary section begins: its chunks and DataEnd
    record, no summary and no footer (a recorder stopped before it wrote them)."""
    data = log.read_bytes()
    # the footer: opcode, length, summary start, summary offset start, CRC; then the magic
    summary_start = int.from_bytes(data[-8 - 20 : -8 - 12], "little")
    assert 0 < summary_start < len(data)
    out.write_bytes(data[:summary_start])
    return out


@pytest.mark.parametrize("chunk_size", [4096, ONE_CHUNK])
@pytest.mark.parametrize("container", ["mcap", "mcap-ros1"])
def test_an_mcap_without_a_summary_is_checked_while_it_is_scanned(
    tmp_path: Path, container: str, chunk_size: int
) -> None:
    """An MCAP file without a summary is read linearly (no chunk index to look at): the
    opening scan checks its messages' log times per channel, between chunks (small chunks:
    the chunks' time ranges, as a summary's chunk indexes give them) and inside one (the
    whole log in one chunk: message N/2 is logged 599 s before message N/2 - 1)."""
    full = write_chunked(tmp_path / "full.mcap", stepped(-STEP_S), container, chunk_size)
    log = without_summary(full, tmp_path / "cut.mcap")
    report = build_json(log, "-o", tmp_path / "cut.aion")
    (minutes,) = steps_back(report["warnings"])
    # the same warning the file with its summary gets
    assert steps_back(build_json(full, "-o", tmp_path / "full.aion")["warnings"]) == [minutes]
    if chunk_size == ONE_CHUNK:
        assert minutes == round((STEP_S - 1) / 60, 1)
        (warning,) = [w for w in report["warnings"] if "go back" in w]
        assert "cut.mcap: its log times go back" in warning
        assert "a message logged" in warning  # inside a chunk, not between two
    else:
        assert 10 - 0.5 <= minutes <= 10
    info = run("info", log)
    assert len(steps_back(info.stderr.splitlines())) == 1
    ordered = write_chunked(tmp_path / "ordered.mcap", stepped(0), container, chunk_size)
    cut = without_summary(ordered, tmp_path / "ordered-cut.mcap")
    assert steps_back(build_json(cut, "-o", tmp_path / "o.aion")["warnings"]) == []


def test_a_step_inside_one_ros1_bag_chunk_is_a_warning(tmp_path: Path) -> None:
    """The whole bag in one chunk: its chunk info's time range says nothing of a step inside
    it; the index entries of the chunk (each message's log time and offset in the chunk: the
    order they were written) do. Message N/2 is logged 599 s before message N/2 - 1."""
    log = write_chunked(tmp_path / "one.bag", stepped(-STEP_S), "bag", ONE_CHUNK)
    from rosbags.rosbag1 import Reader

    with Reader(log) as reader:
        assert len(reader.chunk_infos) == 1
    report = build_json(log, "-o", tmp_path / "one.aion")
    (minutes,) = steps_back(report["warnings"])
    assert minutes == round((STEP_S - 1) / 60, 1)
    (warning,) = [w for w in report["warnings"] if "go back" in w]
    assert "one.bag: its log times go back" in warning
    assert "a message logged" in warning  # inside a chunk, not between two
    info = run("info", log)
    assert len(steps_back(info.stderr.splitlines())) == 1
    ordered = write_chunked(tmp_path / "ordered.bag", stepped(0), "bag", ONE_CHUNK)
    assert steps_back(build_json(ordered, "-o", tmp_path / "o.aion")["warnings"]) == []


def unchunked(log: Path, out: Path) -> Path:
    """``log`` (an MCAP file) written again by the mcap writer with chunking off: the same
    messages in the same file order as bare Message records, with a summary (statistics,
    schemas, channels) but no chunk, so no chunk index to look at."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with log.open("rb") as f, out.open("wb") as g:
        reader = make_reader(f)
        writer = Writer(g, use_chunking=False)
        writer.start(profile=reader.get_header().profile, library="test")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, msg in reader.iter_messages(log_time_order=False):
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            writer.add_message(
                channels[channel.id], msg.log_time, msg.data, msg.publish_time, msg.sequence
            )
        writer.finish()
    return out


@pytest.mark.parametrize("container", ["mcap", "mcap-ros1"])
def test_an_mcap_with_a_summary_but_no_chunk_is_checked_while_it_is_scanned(
    tmp_path: Path, container: str
) -> None:
    """Bare messages and a summary without chunk indexes (``Writer(use_chunking=False)``):
    the summary cannot say where the log times go, so the file is scanned and the scan checks
    its messages in file order (message N/2 is logged 599 s before message N/2 - 1), in build
    and info alike, as a file without a summary. Pins what the reader does; no code changed."""
    from mcap.reader import make_reader

    full = write_chunked(tmp_path / "full.mcap", stepped(-STEP_S), container)
    log = unchunked(full, tmp_path / "bare.mcap")
    with log.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert summary.statistics is not None
    assert summary.statistics.message_count == N
    assert summary.chunk_indexes == []
    report = build_json(log, "-o", tmp_path / "bare.aion")
    (minutes,) = steps_back(report["warnings"])
    assert minutes == round((STEP_S - 1) / 60, 1)  # message by message: the step exactly
    (warning,) = [w for w in report["warnings"] if "go back" in w]
    assert "bare.mcap: its log times go back" in warning
    assert report["detections"]["used"] == N
    info = run("info", log)
    assert len(steps_back(info.stderr.splitlines())) == 1
    ordered = unchunked(
        write_chunked(tmp_path / "ordered.mcap", stepped(0), container), tmp_path / "o-bare.mcap"
    )
    assert steps_back(build_json(ordered, "-o", tmp_path / "o.aion")["warnings"]) == []
