"""open_logs / LogSet given bad input: each kind of path or file it refuses (missing, empty, not
a log, no messages, a corrupted bag, an unknown format), and damaged logs it reads what it can
of with a warning (a truncated MCAP, a corrupt chunk, a truncated rosbag2 storage file, a
garbage payload). Reading well-formed logs: ``test_logs.py``."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from aion_cli.errors import LogFormatError, MessageDecodeError
from aion_cli.formats.logs import open_logs
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.writers import LogWriter
from tests.formats.log_builders import T0, _write, _write_plain_mcap


def test_decode_reports_garbage_payloads(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.mcap", "mcap", n=1)
    with open_logs([path]) as logs:
        (msg,) = logs.messages(["/people"])
        broken = RawMessage(msg.topic, msg.msgtype, msg.log_time_ns, msg.data[:9], msg.encoding)
        with pytest.raises(MessageDecodeError, match="cannot decode a people_msgs/msg/People"):
            logs.decode(broken)


def test_truncated_mcap_keeps_the_readable_part_and_warns(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "full.mcap"
    with path.open("wb") as f:
        w = Writer(f, chunk_size=4096)
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        channel = w.register_channel("/e", "cdr", schema)
        for k in range(40):
            payload = b"\x00\x01\x00\x00" + k.to_bytes(4, "little") * 256
            w.add_message(channel, T0 + k, payload, T0 + k)
        w.finish()
    whole = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) // 2])
    with open_logs([cut]) as logs:
        (warning,) = logs.warnings
        assert "truncated or corrupt MCAP" in warning
        assert "cut.mcap" in warning
        assert "read stopped at byte" in warning
        n = logs.total()
        assert 0 < n < 40
        assert f"after {n} messages" in warning
        msgs = list(logs.messages())
        assert [m.log_time_ns - T0 for m in msgs] == list(range(n))
        assert all(m.data[4:8] == k.to_bytes(4, "little") for k, m in enumerate(msgs))


def test_missing_path(tmp_path: Path) -> None:
    with pytest.raises(LogFormatError, match="no such file or folder") as info:
        open_logs([tmp_path / "nothing.mcap"])
    assert info.value.hint


def test_folder_that_is_not_a_bag(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(LogFormatError, match="not a rosbag2 bag") as info:
        open_logs([tmp_path])
    assert "notes.txt" in (info.value.hint or "")


@pytest.mark.parametrize("name", ["empty.mcap", "empty.bag", "empty"])
def test_empty_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(b"")
    with pytest.raises(LogFormatError, match=r"is empty \(0 bytes\)"):
        open_logs([path])


def test_non_log_files(tmp_path: Path) -> None:
    text = tmp_path / "readme.txt"
    text.write_text("not a log\n" * 10)
    with pytest.raises(LogFormatError, match="cannot tell the log format") as info:
        open_logs([text])
    assert "--log-format" in (info.value.hint or "")
    fake = tmp_path / "fake.mcap"
    fake.write_text("not a log either\n")
    with pytest.raises(LogFormatError, match="not an MCAP file"):
        open_logs([fake])


def test_other_aion_inputs_given_as_a_log_are_named(tmp_path: Path) -> None:
    """A map, a scene-graph file or a tracks CSV where a log belongs: the hint says what the
    file is and where it goes."""
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState

    made = tmp_path / "week.aion"
    Map.from_state(MapState.empty(ModelConfig())).save(made)
    graph = tmp_path / "dsg.json"
    graph.write_text('{"directed": false, "nodes": [], "edges": [], "layer_ids": [2, 3, 4, 5]}')
    tracks = tmp_path / "run.csv"
    tracks.write_text("0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n")
    for path, hint in (
        (made, "week.aion is an aion map, not a log: extend it with `aion build LOG --map"),
        (graph, "dsg.json looks like a scene-graph file: give it to `aion build` with --graph"),
        (tracks, f"`aion convert {shlex.quote(str(tracks))} --layout thor -o run.mcap`"),
    ):
        with pytest.raises(LogFormatError, match="cannot tell the log format") as info:
            open_logs([path])
        assert hint in (info.value.hint or ""), info.value.hint


def test_the_ground_truth_simulate_writes_given_as_a_log_is_named(tmp_path: Path) -> None:
    """``aion build day1*`` picks up ``day1.mcap.truth.json`` and ``.truth.npz`` beside the
    simulated log: the JSON was called "a scene-graph file: give it to aion build with
    --graph" (its config holds an "edges" key), the npz got the hint to try --log-format.
    Both are now named as the truth of their log."""
    from tests.robustness.conftest import run

    log = tmp_path / "day1.mcap"
    assert run("simulate", "-o", log, "--days", "0.01", "-q").exit_code == 0
    for suffix in ("json", "npz"):
        truth = tmp_path / f"day1.mcap.truth.{suffix}"
        with pytest.raises(LogFormatError, match="cannot tell the log format") as info:
            open_logs([truth])
        hint = info.value.hint or ""
        assert f"day1.mcap.truth.{suffix} is the ground truth `aion simulate` wrote" in hint
        assert "beside the log day1.mcap: build from the log alone" in hint
        assert "--graph" not in hint
        assert "--log-format" not in hint

def test_log_without_messages(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "nomsg.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        w.register_channel("/x", "cdr", w.register_schema("std_msgs/msg/Empty", "ros2msg", b""))
        w.finish()
    with pytest.raises(LogFormatError, match="no messages"):
        open_logs([path])
    bag = tmp_path / "nomsg.bag"
    with LogWriter(bag, "bag"):
        pass
    with pytest.raises(LogFormatError, match="no messages"):
        open_logs([bag])


def test_empty_file_among_good_ones_is_a_warning(tmp_path: Path) -> None:
    good = _write(tmp_path / "a.mcap", "mcap")
    empty = tmp_path / "b.bag"
    with LogWriter(empty, "bag"):
        pass
    with open_logs([good, empty]) as logs:
        assert logs.total() == 7
        assert logs.warnings == [f"{empty}: no messages"]


def test_corrupted_bag(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.bag", "bag")
    data = bytearray(path.read_bytes())
    truncated = tmp_path / "truncated.bag"
    truncated.write_bytes(bytes(data[: len(data) // 2]))
    with pytest.raises(LogFormatError, match="not a readable ROS 1 bag") as info:
        open_logs([truncated])
    assert "reindex" in (info.value.hint or "")
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(LogFormatError, match="not a readable ROS 1 bag"):
        open_logs([garbage])


def test_a_log_format_that_names_another_container_says_which_one_it_is(tmp_path: Path) -> None:
    """--log-format bag on an MCAP, a rosbag2 folder or its .db3 (which it opened as the
    folder: "Is a directory"), --log-format mcap on a bag or a .db3, --log-format rosbag2 on a
    bag (its hint said to pass .db3 / .mcap files): the error says what the file is and which
    --log-format reads it, not that a bag may be corrupt."""
    mcap = _write(tmp_path / "a.mcap", "mcap")
    bag = _write(tmp_path / "b.bag", "bag")
    folder = _write(tmp_path / "c", "rosbag2-sqlite3")
    (db3,) = folder.glob("*.db3")
    cases = [
        (mcap, "bag", f"{mcap}: not a readable ROS 1 bag (it is an MCAP file)", "mcap"),
        (db3, "bag", f"{db3}: not a readable ROS 1 bag (it is an SQLite database", "rosbag2"),
        (folder, "bag", f"{folder}: not a readable ROS 1 bag (it is a rosbag2 bag", "rosbag2"),
        (bag, "mcap", f"{bag} is not an MCAP file (it is a ROS 1 bag)", "bag"),
        (db3, "mcap", f"{db3} is not an MCAP file (it is an SQLite database", "rosbag2"),
        (bag, "rosbag2", f"{bag} is not a rosbag2 storage file (neither SQLite nor MCAP): it "
         "is a ROS 1 bag", "bag"),
    ]
    for path, fmt, message, right in cases:
        with pytest.raises(LogFormatError) as info:
            open_logs([path], fmt=fmt)
        assert info.value.message.startswith(message), (fmt, info.value.message)
        assert info.value.hint == f"read it with --log-format {right}"
        with open_logs([path], fmt=right) as logs:
            assert logs.total(["/people"]) == 4
    renamed = tmp_path / "renamed.bag"  # no --log-format: the suffix said bag
    renamed.write_bytes(mcap.read_bytes())
    with pytest.raises(LogFormatError, match=r"\(it is an MCAP file\)"):
        open_logs([renamed])
    with pytest.raises(LogFormatError, match=r"holds 0 \.mcap files") as info:
        open_logs([folder], fmt="mcap")
    assert "--log-format rosbag2" in (info.value.hint or "")


def test_unknown_format_value(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.mcap", "mcap")
    with pytest.raises(LogFormatError, match="unknown log format 'ros3'") as info:
        open_logs([path], fmt="ros3")
    assert "mcap, bag, rosbag2" in (info.value.hint or "")


def test_no_paths() -> None:
    with pytest.raises(LogFormatError, match="no log given"):
        open_logs([])


def test_corrupt_chunk_in_an_indexed_mcap_is_skipped_alone_with_a_warning(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    path = tmp_path / "c.mcap"
    _write_plain_mcap(path, "NONE")
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 3
    bad = chunks[1]
    data = bytearray(path.read_bytes())
    # overwrite the records inside the second chunk: the record lengths become nonsense
    start = bad.chunk_start_offset + bad.chunk_length - bad.compressed_size
    data[start : start + bad.compressed_size] = b"\xff" * bad.compressed_size
    path.write_bytes(bytes(data))
    lost = set(range(bad.message_start_time - T0, bad.message_end_time - T0 + 1))
    with open_logs([path]) as logs:
        msgs = list(logs.messages())
        # every chunk but the damaged one (issue 14: it no longer stops the read)
        assert [m.log_time_ns - T0 for m in msgs] == [k for k in range(30) if k not in lost]
        (warning,) = logs.warnings
        assert f"corrupt chunk at byte {bad.chunk_start_offset} skipped" in warning
        assert f"{len(lost)} messages lost" in warning


def test_rosbag2_mcap_folder_is_read_with_the_mcap_reader_even_when_truncated(
    tmp_path: Path,
) -> None:
    folder = _write(tmp_path / "rec", "rosbag2-mcap")
    with open_logs([folder]) as logs:
        (f,) = logs.files
        assert f.format == "rosbag2-mcap"
        assert f.path == folder / "rec.mcap"
        assert logs.total() == 7
    # a recording killed mid-way: the storage file lacks its end; rosbags refuses it
    (storage,) = folder.glob("*.mcap")
    _write_plain_mcap(storage.with_name("full.mcap"), "ZSTD", n=40, chunk_size=512)
    whole = storage.with_name("full.mcap").read_bytes()
    storage.with_name("full.mcap").unlink()
    storage.write_bytes(whole[: len(whole) // 2])
    with open_logs([folder]) as logs:
        assert logs.files[0].format == "rosbag2-mcap"
        n = logs.total()
        assert 0 < n < 40
        assert "truncated or corrupt MCAP" in logs.warnings[0]
        assert [m.log_time_ns - T0 for m in logs.messages()] == list(range(n))


def test_a_file_of_no_format_read_with_log_format_says_why_that_reader_cannot(
    tmp_path: Path,
) -> None:
    """A text file read with --log-format X was refused as 'cannot tell the log format' with
    the hint 'use --log-format mcap|bag|rosbag2': the option the user had just given. Now the
    reader named says why the file is not its format; a file that is another input aion
    reads (a tracks CSV here) keeps the hint that says what to do with it."""
    notes = tmp_path / "notes.txt"
    notes.write_text("the robot ran from 9 to 5\n")
    with pytest.raises(LogFormatError, match="cannot tell the log format"):
        open_logs([notes])
    expected = {
        "mcap": "is not an MCAP file (it does not start with the MCAP magic bytes)",
        "bag": "is not a ROS 1 bag (it does not start with '#ROSBAG V2.0')",
        "rosbag2": "is not a rosbag2 storage file (it does not start with the SQLite or MCAP",
    }
    for fmt, message in expected.items():
        with pytest.raises(LogFormatError) as info:
            open_logs([notes], fmt=fmt)
        assert message in info.value.message, (fmt, info.value.message)
        assert "--log-format mcap|bag|rosbag2" not in (info.value.hint or "")
    tracks = tmp_path / "tracks.csv"
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1000,1,0,0,0,0,1\n")
    with pytest.raises(LogFormatError, match="cannot tell the log format") as info:
        open_logs([tracks], fmt="mcap")
    assert f"aion convert {shlex.quote(str(tracks))}" in (info.value.hint or "")
