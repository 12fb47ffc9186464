"""rosbag2 storage files without metadata.yaml (indexed in memory, as ``ros2 bag reindex`` would)
and rosbag2 whole-file compression (``*.db3.zstd``, ``*.mcap.zstd``), by folder or by file.

Expected answers: the real bags' own metadata.yaml, their storage files read with Python's
``sqlite3`` and the ``mcap`` library, and bags written here with rosbags' writer.
"""

from __future__ import annotations

import shutil
import sqlite3
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from aion_cli.formats.rosbag2_reindex import reindex
from tests.cli.conftest import assert_one_line_error, run
from tests.formats.rosbag2_reference import bag_metadata, read_only, sqlite_messages
from tests.shared_data import SHARED_DATA, real, writable_copy

DATA = SHARED_DATA / "logs" / "rosbag2_tests"
NO_DATA = "the rosbag2 test bags of ../shared/data/logs are not available"
REINDEX = "rosbag2_py_sqlite3_reindex_test_bags_multiple_files"


def _real(*parts: str) -> Path:
    return real("logs", "rosbag2_tests", *parts)


def _got(logs: Any) -> list[tuple[str, int, bytes]]:
    return [(m.topic, m.log_time_ns, m.data) for m in logs.messages()]


def _zstd(src: Path, dst: Path, frame: int = 4096) -> Path:
    """``src`` compressed with zstd into ``dst`` as several frames (a streaming writer's
    output), which the reader must read across."""
    import zstandard

    data = src.read_bytes()
    frames = [data[k : k + frame] for k in range(0, len(data), frame)]
    dst.write_bytes(b"".join(zstandard.ZstdCompressor().compress(f) for f in frames))
    return dst


# --- storage files without metadata.yaml -----------------------------------------------------


def test_reindex_test_bag_folder_is_read_from_its_storage_files() -> None:
    folder = _real(REINDEX)
    files = sorted(folder.glob("*.db3"))
    assert len(files) == 3
    assert not (folder / "metadata.yaml").exists()
    expected = sqlite_messages(*files)
    assert len(expected) == 3177  # 1324 + 1324 + 529 on /chatter
    with open_logs([folder]) as logs:
        (f,) = logs.files
        assert (f.path, f.format, f.message_count) == (folder, "rosbag2-sqlite3", 3177)
        assert f.size_bytes == sum(p.stat().st_size for p in files)
        assert [(t.topic, t.msgtype, t.count) for t in logs.topics] == [
            ("/chatter", "std_msgs/msg/String", 3177)
        ]
        assert (logs.start_ns, logs.end_ns) == (expected[0][1], expected[-1][1])
        assert _got(logs) == expected  # across the three files, in time order
        first = next(iter(logs.messages()))
        size = int.from_bytes(first.data[4:8], "little")  # CDR string: length, text, NUL
        text = first.data[8 : 8 + size - 1].decode()
        assert logs.decode(first).data == text == "test"  # the shipped std_msgs definition
        times = np.array([t for _, t, _ in expected])
        for window in (1, 10**9, 600 * 10**9):
            assert np.array_equal(logs.recorded_windows(window), np.unique(times // window))
        assert logs.warnings == [
            f"{folder}: no metadata.yaml; indexed in memory from its 3 storage files, "
            "as `ros2 bag reindex` would; read as one recording, the time between its files "
            "included (give the files themselves if they are separate logs)"
        ]


@pytest.mark.parametrize(
    "parts",
    [(REINDEX, "multiple_files_1.db3"), ("rosbag2_cpp_bags", "topics_and_services.db3")],
    ids=["split-file", "cpp-bag"],
)
def test_one_storage_file_alone(parts: tuple[str, ...]) -> None:
    path = _real(*parts)
    expected = sqlite_messages(path)
    with open_logs([path]) as logs:
        (f,) = logs.files
        assert (f.path, f.format) == (path, "rosbag2-sqlite3")
        assert logs.total() == len(expected) > 0
        assert _got(logs) == expected
        assert logs.warnings == []


def test_reindex_writes_what_the_bags_own_metadata_says(tmp_path: Path) -> None:
    talker = _real("rosbag2_py_sqlite3_talker")
    wbag = _real("rosbag2_py_sqlite3_wbag")
    for bag in (talker, wbag):
        copy = tmp_path / bag.name
        copy.mkdir()
        for f in bag.glob("*.db3"):
            shutil.copy(f, copy / f.name)
        meta, built = bag_metadata(bag), reindex(copy)
        assert built["storage_identifier"] == meta["storage_identifier"] == "sqlite3"
        assert built["relative_file_paths"] == meta["relative_file_paths"]
        assert built["message_count"] == meta["message_count"]

        def topics(info: dict[str, Any]) -> dict[str, tuple[str, str, int]]:
            return {
                t["topic_metadata"]["name"]: (
                    t["topic_metadata"]["type"],
                    t["topic_metadata"]["serialization_format"],
                    t["message_count"],
                )
                for t in info["topics_with_message_count"]
            }

        assert topics(built) == topics(meta)
        expected = sqlite_messages(*sorted(copy.glob("*.db3")))
        assert built["starting_time"]["nanoseconds_since_epoch"] == expected[0][1]
        assert built["duration"]["nanoseconds"] == expected[-1][1] - expected[0][1]
        assert [f["message_count"] for f in built["files"]] == [
            len(sqlite_messages(copy / name)) for name in meta["relative_file_paths"]
        ]
        assert built["compression_mode"] == built["compression_format"] == ""
    # the talker's metadata.yaml has the right times (the wbag one states another bag's); the
    # QoS written is what the storage file keeps (it differs from the metadata.yaml's)
    built, meta = reindex(tmp_path / talker.name), bag_metadata(talker)
    assert built["starting_time"] == meta["starting_time"]
    assert built["duration"] == meta["duration"]
    with read_only(talker / "talker.db3") as db:
        qos = dict(db.execute("SELECT name, offered_qos_profiles FROM topics").fetchall())
    got = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
        for t in built["topics_with_message_count"]
    }
    assert got == qos
    assert "deadline:\n    sec: 2147483647" in qos["/topic"]


def test_mcap_storage_files_without_metadata(tmp_path: Path) -> None:
    bag = _real("rosbag2_py_mcap_wbag")
    copy = tmp_path / "wbag"
    copy.mkdir()
    for f in bag.glob("*.mcap"):
        shutil.copy(f, copy / f.name)
    meta = bag_metadata(bag)
    with open_logs([copy]) as logs:
        assert [f.path.name for f in logs.files] == meta["relative_file_paths"]
        assert {f.format for f in logs.files} == {"rosbag2-mcap"}
        assert logs.total() == meta["message_count"] == 6074
        assert len(list(logs.messages())) == 6074
        assert "no metadata.yaml; indexed in memory from its 5 storage files" in logs.warnings[-1]
    built = reindex(copy)
    assert built["storage_identifier"] == "mcap"
    assert {
        t["topic_metadata"]["name"]: t["message_count"] for t in built["topics_with_message_count"]
    } == {
        t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]
    }


def test_a_folder_of_storage_files_and_other_logs_is_refused(tmp_path: Path) -> None:
    """A folder without metadata.yaml is read as one bag's storage files: one that also holds
    a ROS 1 bag or a rosbag2 folder read its storage files alone and left the other logs out
    without a word (`aion build logs/` of a .mcap and a .bag learnt the .mcap only)."""
    folder = tmp_path / "logs"
    folder.mkdir()
    shutil.copy(_real("rosbag2_py_mcap_talker", "talker.mcap"), folder / "talker.mcap")
    with open_logs([folder]) as logs:  # storage files alone: one bag, as before
        assert logs.total() == 20
    shutil.copy(real("logs", "rosbagjs_fixtures", "example.bag"), folder / "example.bag")
    with pytest.raises(LogFormatError, match=r"holds other logs .*\(example\.bag\)"):
        open_logs([folder])
    (folder / "example.bag").unlink()
    shutil.copytree(_real("rosbag2_py_sqlite3_talker"), folder / "sqlite_talker")
    result = run("info", folder)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "holds other logs", "(sqlite_talker)")
    assert f"give the logs one by one ({folder}/*)" in result.stderr
    # a bag with its metadata.yaml is a bag: whatever else its folder holds stays unread
    bag = tmp_path / "bag"
    writable_copy(_real("rosbag2_py_mcap_talker"), bag)
    shutil.copy(real("logs", "rosbagjs_fixtures", "example.bag"), bag / "example.bag")
    with open_logs([bag]) as logs:
        assert logs.total() == 20


@pytest.mark.parametrize("name", ["example.bag.zst", "example.BAG.zstd"])
def test_a_compressed_ros1_bag_beside_storage_files_is_another_log(
    tmp_path: Path, name: str
) -> None:
    """A ROS 1 bag compressed whole, which aion reads given alone (``run.bag.zst``), is a log
    as ``run.bag`` is: a folder of storage files holding one is refused (its storage files
    were read alone and the bag left out without a word)."""
    folder = tmp_path / "logs"
    folder.mkdir()
    shutil.copy(_real("rosbag2_py_mcap_talker", "talker.mcap"), folder / "talker.mcap")
    packed = _zstd(real("logs", "rosbagjs_fixtures", "example.bag"), folder / name)
    with open_logs([packed]) as logs:  # read alone, it is a ROS 1 bag
        assert [f.format for f in logs.files] == ["bag"]
    result = run("info", folder)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "holds other logs", f"({name})")


def test_unusable_metadata_yaml_falls_back_to_the_storage_files(tmp_path: Path) -> None:
    talker = _real("rosbag2_py_sqlite3_talker")
    copy = writable_copy(talker, tmp_path / "talker")
    (copy / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 4}\n")
    with open_logs([copy]) as logs:
        assert logs.total() == 20
        assert _got(logs) == sqlite_messages(talker / "talker.db3")
        assert "metadata.yaml not used (" in logs.warnings[-1]
        assert "indexed in memory from its 1 storage file" in logs.warnings[-1]


def test_a_metadata_yaml_that_is_no_yaml_is_named_on_one_line(tmp_path: Path) -> None:
    """A metadata.yaml cut inside a list: the YAML parser's error spans four lines (the text
    it quotes and a caret under it), and the warning carried them as they were, which the
    console printed as ``\\n`` escapes inside one warning line. The reason is now one line,
    its parts joined as an error's are."""
    talker = _real("rosbag2_py_sqlite3_talker")
    copy = writable_copy(talker, tmp_path / "talker")
    (copy / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    with open_logs([copy]) as logs:
        assert logs.total() == 20
        warning = logs.warnings[-1]
    assert "metadata.yaml not used (" in warning
    assert "\n" not in warning
    assert "while parsing a flow node; expected the node content" in warning

# --- whole-file compression --------------------------------------------------------------------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_compressed_storage_file_by_file_or_folder(
    storage: str, tmp_path: Path, temp_root: Path
) -> None:
    bag = _real(f"rosbag2_py_{storage}_talker")
    (plain,) = bag.glob("talker.*[3p]")
    expected = sqlite_messages(bag / "talker.db3") if storage == "sqlite3" else None
    folder = tmp_path / "compressed"
    folder.mkdir()
    packed = _zstd(plain, folder / f"{plain.name}.zstd")
    with open_logs([bag]) as twin:
        reference = _got(twin)
    assert expected is None or expected == reference
    # the compressed file alone, then its folder (no metadata.yaml)
    for path, warned in ((packed, False), (folder, True)):
        with open_logs([path]) as logs:
            (f,) = logs.files
            assert f.format == f"rosbag2-{storage}"
            # a folder of sqlite3 files is one entry; mcap storage files are one entry each
            assert f.path == (folder if warned and storage == "sqlite3" else packed)
            assert f.size_bytes == packed.stat().st_size
            assert logs.total() == 20
            assert _got(logs) == reference
            assert len(list(temp_root.iterdir())) == 1  # the decompressed copy, while open
            assert bool(logs.warnings) == warned
        assert list(temp_root.iterdir()) == []  # removed on close
    # with a metadata.yaml saying compression_mode: file, by folder or by the storage file
    text = (bag / "metadata.yaml").read_text()
    text = (
        text.replace(f"- {plain.name}", f"- {packed.name}")
        .replace("compression_format: ''", "compression_format: zstd")
        .replace('compression_format: ""', "compression_format: zstd")
        .replace("compression_mode: ''", "compression_mode: file")
        .replace('compression_mode: ""', "compression_mode: file")
    )
    assert "compression_mode: file" in text
    assert packed.name in text
    (folder / "metadata.yaml").write_text(text)
    for path in (folder, packed):
        with open_logs([path]) as logs:
            # mcap storage files are read by aion's MCAP reader, one entry each (shown as
            # the compressed file), as in a folder of plain ones
            assert [f.path for f in logs.files] == [packed if storage == "mcap" else folder]
            assert logs.files[0].format == f"rosbag2-{storage}"
            assert _got(logs) == reference
            assert logs.warnings == []


def test_message_compressed_bag_with_and_without_metadata(tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from aion_cli.formats import msgdefs

    folder = tmp_path / "msgzstd"
    writer = Writer(folder, version=9, storage_plugin=StoragePlugin.SQLITE3)
    writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    writer.open()
    conn = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=msgdefs.typestore(2))
    payloads = [
        b"\x00\x01\x00\x00" + (len(t) + 1).to_bytes(4, "little") + t + b"\x00"
        for t in (b"one", b"two", b"three")
    ]
    for k, data in enumerate(payloads):
        writer.write(conn, 1000 + k, data)
    writer.close()
    (db3,) = folder.glob("*.db3")
    stored = sqlite_messages(db3)
    assert all(row[2][:4] == b"\x28\xb5\x2f\xfd" for row in stored)  # stored compressed
    with open_logs([folder]) as logs:
        assert [m.data for m in logs.messages()] == payloads
    (folder / "metadata.yaml").unlink()
    with open_logs([folder]) as logs:  # reindexed: recognised by the zstd magic bytes
        assert [m.data for m in logs.messages()] == payloads
        assert [logs.decode(m).data for m in logs.messages()] == ["one", "two", "three"]


# --- bad input -----------------------------------------------------------------------------------


def _sqlite_file(path: Path, sql: str) -> Path:
    with sqlite3.connect(path) as db:
        db.executescript(sql)
    return path


def test_bad_storage_files(
    tmp_path: Path, temp_root: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import zstandard

    talker = _real("rosbag2_py_sqlite3_talker", "talker.db3")
    packed = _zstd(talker, tmp_path / "talker.db3.zstd")
    cut = tmp_path / "cut" / "talker.db3.zstd"
    cut.parent.mkdir()
    cut.write_bytes(packed.read_bytes()[:-100])
    with pytest.raises(LogFormatError, match="not a readable zstd file"):
        open_logs([cut])
    text = tmp_path / "notes.txt.zst"
    text.write_bytes(zstandard.ZstdCompressor().compress(b"no log here\n" * 10))
    with pytest.raises(LogFormatError, match="zstd-compressed but holds no log"):
        open_logs([text])
    other = _sqlite_file(tmp_path / "other.db3", "CREATE TABLE t(x);")
    with pytest.raises(LogFormatError, match="not a readable rosbag2 sqlite3 storage file"):
        open_logs([other])
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / "bag_0.db3").write_text("not a database\n")
    with pytest.raises(LogFormatError, match="not a rosbag2 storage file"):
        open_logs([fake])
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    shutil.copy(talker, mixed / "a.db3")
    shutil.copy(_real("rosbag2_py_mcap_talker", "talker.mcap"), mixed / "b.mcap")
    with pytest.raises(LogFormatError, match="both sqlite3 and mcap storage files"):
        open_logs([mixed])
    with pytest.raises(LogFormatError, match="holds no rosbag2 storage files"):
        reindex(_empty(tmp_path))
    assert list(temp_root.iterdir()) == []  # nothing left behind by the failures
    # no room for the decompressed copy
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "missing" / "tmp"))
    with pytest.raises(LogFormatError, match="cannot decompress it into") as info:
        open_logs([packed])
    assert "TMPDIR" in (info.value.hint or "")


def _empty(tmp_path: Path) -> Path:
    folder = tmp_path / "empty"
    folder.mkdir()
    (folder / "readme.txt").write_text("hello\n")
    return folder


# --- from the command line -------------------------------------------------------------------


def test_aion_info_reads_them(tmp_path: Path) -> None:
    folder = _real(REINDEX)
    result = run("info", folder)
    assert result.exit_code == 0, result.stderr
    assert "format: rosbag2-sqlite3" in result.stdout
    assert "messages: 3,177" in result.stdout or "messages: 3177" in result.stdout
    assert "no metadata.yaml; indexed in memory" in result.stderr
    packed = _zstd(_real("rosbag2_py_mcap_talker", "talker.mcap"), tmp_path / "talker.mcap.zstd")
    result = run("info", packed)
    assert result.exit_code == 0, result.stderr
    assert "format: rosbag2-mcap" in result.stdout
    assert "messages: 20" in result.stdout
    broken = tmp_path / "broken.mcap.zstd"
    broken.write_bytes(packed.read_bytes()[: packed.stat().st_size // 2])
    result = run("info", broken)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not a readable zstd file")


def test_other_logs_compressed_whole(tmp_path: Path, temp_root: Path) -> None:
    # any log aion reads, compressed with zstd: told apart by its decompressed first bytes
    bag = DATA.parent / "rosbagjs_fixtures" / "example-lz4.bag"
    if not bag.is_file():
        pytest.skip(NO_DATA)
    packed = _zstd(bag, tmp_path / "example.bag.zst")
    with open_logs([bag]) as plain, open_logs([packed]) as logs:
        assert [(f.path, f.format) for f in logs.files] == [(packed, "bag")]
        assert logs.total() == plain.total() == 8647
        assert _got(logs) == _got(plain)
    assert list(temp_root.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "plain", "fmt", "said"),
    [
        ("z.bag.zst", b"hello\n", "bag", "is not a ROS 1 bag"),
        ("z.mcap.zstd", b"hello\n", "mcap", "is not an MCAP file"),
        ("d.db3.zstd", b"SQLite format 3\x00" + bytes(range(256)) * 8, None, "Cannot open"),
    ],
    ids=["bag", "mcap", "db3"],
)
def test_errors_on_a_compressed_file_name_it_not_its_temporary_copy(
    name: str, plain: bytes, fmt: str | None, said: str, tmp_path: Path, temp_root: Path
) -> None:
    """A compressed file that holds no log of the format it is read as: the error named the
    decompressed copy (/tmp/aion-unzstd-.../z.bag), removed before the user reads it."""
    import zstandard

    packed = tmp_path / "logs" / name
    packed.parent.mkdir()
    packed.write_bytes(zstandard.ZstdCompressor().compress(plain))
    result = run("info", packed, *(["--log-format", fmt] if fmt else []))
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, f"{packed} (decompressed)", said)
    assert str(temp_root) not in result.stderr
    assert list(temp_root.iterdir()) == []
