"""Recovery over trust (issue 14, point 5): damaged chunks are skipped one by one, indexes and
statistics that disagree with the data are checked against it, impossible rosbag2 metadata is
said and ignored; and special files are refused before anything reads them (point 6).

Every MCAP and ROS 1 bag here is assembled record by record (``tests/formats/craft.py``) from
messages a LogWriter wrote, so the messages each test must get back are known exactly: those of
the chunks left intact, in log-time order.
"""

from __future__ import annotations

import os
import re
import signal
import stat
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import LogFormatError, MapFileError
from aion_cli.formats.logs import open_logs
from aion_cli.formats.raw import check_regular_input
from tests.formats.craft import McapFile, McapParts, Summary, mcap_parts, records_chunk
from tests.formats.craft_bag import bag_topic, craft_bag
from tests.robustness.conftest import (
    T0,
    S,
    assert_one_error,
    build_json,
    robot_tf,
    run,
    walk,
    write_log,
)

PER_CHUNK = 50  # messages per crafted chunk
N_CHUNKS = 6


@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> McapParts:
    """150 person messages on /tracks and 150 TF messages on /tf, one of each per second
    (TF half a second later), as a LogWriter MCAP holds them."""
    folder = tmp_path_factory.mktemp("craft")
    tf = [robot_tf(T0 + k * S + S // 2) for k in range(150)]
    source = write_log(folder / "source.mcap", [*walk(150), *tf])
    found = mcap_parts(source)
    found.messages.sort(key=lambda m: m.log_time)
    return found


def chunked(parts: McapParts, **per_chunk: dict[str, Any]) -> tuple[McapFile, list[list[Any]]]:
    """The messages in ``N_CHUNKS`` chunks of ``PER_CHUNK`` (schemas and channels in the
    first); ``per_chunk["3"] = {...}`` passes keywords to chunk 3's :func:`records_chunk`."""
    f = McapFile(parts)
    groups = [parts.messages[k : k + PER_CHUNK] for k in range(0, len(parts.messages), PER_CHUNK)]
    assert len(groups) == N_CHUNKS
    for k, group in enumerate(groups):
        head = [*parts.schemas, *parts.channels] if k == 0 else []
        f.chunk(records_chunk([*head, *group], **per_chunk.get(str(k), {})))
    return f, groups


def times(groups: list[list[Any]], skip: set[int] = frozenset()) -> list[int]:  # type: ignore[assignment]
    return sorted(m.log_time for k, g in enumerate(groups) if k not in skip for m in g)


def read_all(path: Path) -> tuple[list[int], list[str], Any]:
    """Log times of every message, the warnings, and the LogSet's file entry."""
    with open_logs([path]) as logs:
        got = [m.log_time_ns for m in logs.messages()]
        return got, logs.warnings, logs.files[0]


def lost_line(warnings: list[str], offset: int) -> str:
    (line,) = [w for w in warnings if f"at byte {offset} skipped" in w]
    return line


# -- damaged chunks are skipped one by one -------------------------------------------------------


@pytest.mark.parametrize("summary", [True, False], ids=["indexed", "linear"])
def test_chunks_failing_their_crc_are_skipped_one_by_one(
    summary: bool, parts: McapParts, tmp_path: Path
) -> None:
    """Chunks 1 and 3 fail their CRC: chunks 0, 2, 4 and 5 are read (the first failing chunk
    used to end the read: 50 of 300 messages), each skipped chunk named with what it held."""
    f, groups = chunked(parts, **{"1": {"crc": 12345}, "3": {"crc": 678}})
    path = f.write(tmp_path / "crc.mcap", with_summary=summary)
    got, warnings, _ = read_all(path)
    assert got == times(groups, {1, 3})
    for k in (1, 3):
        line = lost_line(warnings, f.chunk_offsets[k])
        assert line.startswith("crc.mcap: corrupt chunk at byte")
        assert "its records fail their CRC-32 check; 50 messages lost (/tf 25, /tracks 25)" in line
    assert len(warnings) == 2


@pytest.mark.parametrize("summary", [True, False], ids=["indexed", "linear"])
def test_an_unknown_chunk_compression_is_skipped_with_a_warning(
    summary: bool, parts: McapParts, tmp_path: Path
) -> None:
    """A chunk labelled ``brotli`` (its records stored as they are): neither silently read as
    if uncompressed (what the linear read did) nor the end of the file (the indexed read)."""
    f, groups = chunked(parts, **{"2": {"compression": "brotli"}})
    path = f.write(tmp_path / "brotli.mcap", with_summary=summary)
    got, warnings, _ = read_all(path)
    assert got == times(groups, {2})
    line = lost_line(warnings, f.chunk_offsets[2])
    assert "chunk at byte" in line
    assert "corrupt" not in line
    assert "unknown compression 'brotli'; 50 messages lost (/tf 25, /tracks 25)" in line


@pytest.mark.parametrize("crc_too", [False, True], ids=["length", "length-and-crc"])
def test_a_chunk_whose_record_length_is_broken_is_found_through_the_index(
    crc_too: bool, parts: McapParts, tmp_path: Path
) -> None:
    """The length field of chunk 2's record is overwritten (2**62): a walk over the records
    cannot step over it, but the chunk indexes say where it ends and where chunks 3 to 5 start.
    With its data intact the chunk is read with its index's length (and the damage said);
    with its data damaged too, it alone is skipped (the read used to end there: 100 of 300)."""
    f, groups = chunked(parts, **({"2": {"crc": 99}} if crc_too else {}))
    data = bytearray(f.bytes())
    at = f.chunk_offsets[2]
    data[at + 1 : at + 9] = (2**62).to_bytes(8, "little")
    path = tmp_path / "broken.mcap"
    path.write_bytes(bytes(data))
    got, warnings, _ = read_all(path)
    assert got == times(groups, {2} if crc_too else set())
    assert warnings[0] == (
        f"broken.mcap: the record of the chunk at byte {at} states a wrong length (its record "
        "claims 4,611,686,018,427,387,904 bytes, past the end of the file); it is read with "
        "the length its chunk index gives"
    )
    if crc_too:
        assert "CRC-32 check; 50 messages lost (/tf 25, /tracks 25)" in lost_line(warnings, at)
    assert len(warnings) == 1 + crc_too


def test_damaged_bag_chunks_are_skipped_one_by_one(tmp_path: Path) -> None:
    """A ROS 1 bag of four bz2 chunks, the second's compressed data damaged and the third in
    an unknown compression: the first and the last are read (the bag used to be refused at
    open for the compression, and its read ended at the damage)."""
    source = write_log(tmp_path / "source.bag", walk(40), "bag")
    topic, msgs = bag_topic(source, "/tracks")
    chunks = [msgs[k : k + 10] for k in range(0, 40, 10)]
    good = craft_bag(topic, chunks, "bz2")
    start = good.index(b"BZh", good.index(b"BZh") + 1)  # the second chunk's bz2 stream
    data = bytearray(good)
    data[start + 40 : start + 60] = bytes(20)
    path = tmp_path / "damaged.bag"
    path.write_bytes(bytes(data))
    got, warnings, _f = read_all(path)
    assert got == [t for t, _ in chunks[0] + chunks[2] + chunks[3]]
    (line,) = warnings
    assert "damaged.bag: chunk at byte" in line
    assert "cannot decompress its bz2 data" in line
    assert line.endswith("; 10 messages lost (/tracks 10)")

    odd = craft_bag(topic, chunks, "bz2").replace(b"compression=bz2", b"compression=br0", 3)
    odd = odd.replace(b"compression=br0", b"compression=bz2", 2)  # only the third is "br0"
    path = tmp_path / "odd.bag"
    path.write_bytes(odd)
    with open_logs([path]) as logs:
        assert logs.total() == 30  # counted without the refused chunk
        assert [m.log_time_ns for m in logs.messages()] == [
            t for t, _ in chunks[0] + chunks[1] + chunks[3]
        ]
        (line,) = logs.warnings
        assert "unknown compression 'br0'; 10 messages lost (/tracks 10)" in line


def test_a_damaged_bag_chunk_is_one_warning_whatever_the_topics_read(tmp_path: Path) -> None:
    """rosbag.js's example-bz2.bag keeps its 8,647 messages on nine topics in one bz2 chunk.
    Damaged, it is skipped; a build reads it twice (TF, then people) and used to warn twice,
    each line counting only the topics of its pass ("1,344 messages lost (/turtle1/pose
    1,344)" beside "4,033 messages lost (/tf ...)"). One line now counts the whole chunk."""
    from tests.shared_data import real

    data = bytearray(real("logs", "rosbagjs_fixtures", "example-bz2.bag").read_bytes())
    data[data.index(b"BZh") + 5000] ^= 0xFF
    path = tmp_path / "damaged.bag"
    path.write_bytes(bytes(data))
    with open_logs([path]) as logs:
        counts = {t.topic: t.count for t in logs.topics}
        assert sum(counts.values()) == 8647
        assert not list(logs.messages({"/turtle1/pose"}))
        assert not list(logs.messages({"/tf", "/turtle1/pose"}))
        (line,) = logs.warnings
    per = ", ".join(f"{topic} {n:,}" for topic, n in sorted(counts.items()))
    assert line.startswith("damaged.bag: chunk at byte ")
    assert line.endswith(f"; 8,647 messages lost ({per})")


# -- indexes and statistics are checked against the data ------------------------------------------


def edited(parts: McapParts, tmp_path: Path, edit: Callable[[Summary], None]) -> Path:
    f, _ = chunked(parts)
    return f.write(tmp_path / "edited.mcap", edit)


def test_a_chunk_index_that_omits_a_channel_loses_nothing(
    parts: McapParts, tmp_path: Path
) -> None:
    """The chunk indexes of chunks 1 to 5 leave out /tf: reading /tf through them used to
    skip those chunks (25 of 150 TF messages read, 83 % lost)."""
    tf_id = next(c.id for c in parts.channels if c.topic == "/tf")

    def omit(summary: Summary) -> None:
        for index in summary.chunk_indexes[1:]:
            del index.message_index_offsets[tf_id]

    path = edited(parts, tmp_path, omit)
    with open_logs([path]) as logs:
        assert [m.log_time_ns for m in logs.messages(["/tf"])] == [
            m.log_time for m in parts.on("/tf")
        ]
        (line,) = logs.warnings
    assert line.startswith("edited.mcap: its summary disagrees with the data: the chunk index ")
    assert f"leaves out channel {tf_id} (/tf), which has 25 message(s) there (and 4 more)" in line
    assert line.endswith("aion read the chunks themselves instead (linear scan): 300 messages")


def test_statistics_that_count_no_message_do_not_hide_a_full_file(
    parts: McapParts, tmp_path: Path
) -> None:
    def nothing(summary: Summary) -> None:
        summary.statistics.message_count = 0
        summary.statistics.channel_message_counts = {}

    path = edited(parts, tmp_path, nothing)  # aion refused it: "no messages"
    with open_logs([path]) as logs:
        assert logs.total() == 300
        assert {t.topic: t.count for t in logs.topics} == {"/tf": 150, "/tracks": 150}
        assert len(list(logs.messages())) == 300
        (line,) = logs.warnings
        assert "its statistics count 0 messages, its message indexes 300" in line


def test_a_summary_end_time_that_lies_is_replaced_by_the_data(
    parts: McapParts, tmp_path: Path
) -> None:
    last = parts.messages[-1].log_time
    lie = 2_147_483_647 * S  # 2038-01-19

    def far(summary: Summary) -> None:
        summary.statistics.message_end_time = lie

    path = edited(parts, tmp_path, far)
    with open_logs([path]) as logs:
        assert (logs.start_ns, logs.end_ns) == (parts.messages[0].log_time, last)
        (line,) = logs.warnings
        assert "its statistics say the messages end at 2038-01-19T03:14:07.000000Z" in line

    def index_lies(summary: Summary) -> None:  # the chunk index alone
        summary.chunk_indexes[-1].message_end_time = lie
        summary.statistics.message_end_time = lie

    with open_logs([edited(parts, tmp_path, index_lies)]) as logs:
        assert logs.end_ns == last
        assert "disagrees with the chunk record (end time)" in logs.warnings[0]
        assert logs.recorded_windows(600 * S).max() == last // (600 * S)


def test_chunks_the_summary_does_not_index_are_read(parts: McapParts, tmp_path: Path) -> None:
    def forget(summary: Summary) -> None:
        summary.chunk_indexes = summary.chunk_indexes[:2]

    path = edited(parts, tmp_path, forget)
    got, warnings, f = read_all(path)
    assert len(got) == f.message_count == 300
    (line,) = warnings
    assert "4 chunk(s) are not in its chunk indexes" in line


def test_an_honest_summary_is_used_without_a_warning(parts: McapParts, tmp_path: Path) -> None:
    """The checks cost no false alarm: the crafted file as written, and LogWriter's."""
    f, groups = chunked(parts)
    got, warnings, _ = read_all(f.write(tmp_path / "honest.mcap"))
    assert got == times(groups)
    assert warnings == []


# -- rosbag2 metadata ----------------------------------------------------------------------------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_impossible_rosbag2_metadata_is_ignored_with_a_warning(
    storage: str, tmp_path: Path
) -> None:
    bag = write_log(tmp_path / "bag", walk(20), f"rosbag2-{storage}")
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    text = re.sub(r"(\n  starting_time:\n    nanoseconds_since_epoch: )\d+", r"\g<1>-5", text)
    text = re.sub(r"(\n  message_count: )20", r"\g<1>999", text)
    meta.write_text(text)
    with open_logs([bag]) as logs:
        assert (logs.start_ns, logs.end_ns) == (T0, T0 + 19 * S)  # from the storage files
        assert logs.total() == 20
        (line,) = logs.warnings
    assert line.startswith("bag: metadata.yaml disagrees with its storage files, which aion ")
    assert "starting_time -5 ns (impossible: before 1970; the files start at 2026-" in line
    assert "message_count 999 (the files: 20)" in line


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_type_metadata_yaml_names_wrongly_is_read_as_the_storage_keeps_it(
    storage: str, tmp_path: Path
) -> None:
    """metadata.yaml naming a type nothing defines for the people topic (an edited or
    mismatched file): a sqlite3 bag was refused as "no messages (... 20 messages on /tracks
    (the files: 0))" although its storage file holds the 20 messages with their real type;
    now they are read as the storage keeps them, with a warning naming both types."""
    bag = write_log(tmp_path / "bag", walk(20), f"rosbag2-{storage}")
    meta = bag / "metadata.yaml"
    real_type = "spencer_tracking_msgs/msg/TrackedPersons"
    assert real_type in meta.read_text()
    meta.write_text(meta.read_text().replace(real_type, "foo_msgs/msg/NotAType"))
    report = build_json(bag, "-o", tmp_path / "m.aion")
    assert report["detections"]["read"] == 20
    assert any(
        "metadata.yaml disagrees" in w
        and f"/tracks is of type foo_msgs/msg/NotAType (the files: {real_type})" in w
        for w in report["warnings"]
    ), report["warnings"]


# -- special files ---------------------------------------------------------------------------------


@pytest.fixture
def no_hang() -> Iterator[None]:
    """Fail instead of hanging when something opens a FIFO that has no writer."""

    def expired(signum: int, frame: Any) -> None:
        raise AssertionError("a FIFO was opened: the check must come before any read")

    old = signal.signal(signal.SIGALRM, expired)
    signal.alarm(10)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def test_special_files_are_refused_before_any_read(tmp_path: Path, no_hang: None) -> None:
    fifo = tmp_path / "run.mcap"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "a FIFO (named pipe)"), (Path("/dev/zero"), "a character device")):
        for fmt in (None, "mcap", "bag", "rosbag2"):
            with pytest.raises(LogFormatError) as err:
                open_logs([path], fmt)
            assert err.value.message == (
                f"{path} is {kind}, not a regular file: aion does not read a log from it"
            )
    link = tmp_path / "link.bag"
    link.symlink_to(fifo)  # followed
    with pytest.raises(LogFormatError, match="is a FIFO"):
        open_logs([link])


def test_a_rosbag2_folder_holding_a_fifo_is_refused(tmp_path: Path) -> None:
    """A storage file that is a FIFO: SQLite would block reading it (in C, where no signal
    reaches Python), so the read runs in a child process with a timeout."""
    bag = write_log(tmp_path / "bag", walk(5), "rosbag2-sqlite3")
    (db,) = bag.glob("*.db3")
    db.unlink()
    os.mkfifo(db)
    code = (
        "import sys\n"
        "from formats.logs import open_logs\n"
        "try:\n"
        "    open_logs([sys.argv[1]])\n"
        "except Exception as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(bag)], capture_output=True, text=True, timeout=60
    )
    assert done.stdout.strip() == (
        f"LogFormatError {db} is a FIFO (named pipe), not a regular file: aion does not read a "
        "log from it"
    ), done.stderr


def test_special_inputs_through_the_cli_are_one_error_line(tmp_path: Path, no_hang: None) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    result = run("info", fifo)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "is a FIFO (named pipe), not a regular file")
    result = run("info", "/dev/zero")  # was: "/dev/zero is empty (0 bytes)"
    assert result.exit_code == 2
    assert_one_error(result.stderr, "/dev/zero is a character device, not a regular file")


def test_check_regular_input_is_the_helper_for_every_input(tmp_path: Path, no_hang: None) -> None:
    """The helper the map loader and the build's hashing call: regular files, folders and
    missing paths pass (the caller words those), special files raise the error asked for."""
    fifo = tmp_path / "m.aion"
    os.mkfifo(fifo)
    (tmp_path / "plain.aion").write_bytes(b"x")
    check_regular_input(tmp_path / "plain.aion", "map", MapFileError)
    check_regular_input(tmp_path, "map", MapFileError)
    check_regular_input(tmp_path / "missing.aion", "map", MapFileError)
    with pytest.raises(MapFileError) as err:
        check_regular_input(fifo, "map", MapFileError, hint="pass an .aion map file")
    assert err.value.message == f"{fifo} is a FIFO (named pipe), not a regular file: aion does " \
        "not read a map from it"
    assert err.value.hint == "pass an .aion map file"
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)  # untouched
