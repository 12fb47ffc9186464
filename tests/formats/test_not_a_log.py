"""A file read as a log whose first bytes are not its container's magic: ``printf 'hello\\n' >
x.bag && aion info x.bag`` said "not a readable ROS 1 bag (File magic is invalid.)" with the
hint to try `rosbag reindex` (the advice for a damaged bag), and a rosbag2 folder whose .db3
is text said "Cannot open database ...: file is not a database" of the folder. Each reader
now says the file does not start with its magic and what the file looks like (text, CSV,
gzip, an older ROS bag format), one line and a hint, exit 2; a bag that starts right but is
damaged keeps the reindex advice."""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from tests.cli.conftest import assert_one_line_error, run
from tests.formats.log_builders import _write

TEXT = b"hello\n"
CSV = b"a,b,c\n1,2,3\n"


@pytest.mark.parametrize(
    ("name", "data", "fmt", "expected"),
    [
        ("x.bag", TEXT, None, "x.bag is not a ROS 1 bag (it does not start with '#ROSBAG V2.0'): "
                              "it looks like text starting 'hello'"),
        ("x.txt", TEXT, "bag", "x.txt is not a ROS 1 bag (it does not start with '#ROSBAG "
                               "V2.0'): it looks like text starting 'hello'"),
        ("old.bag", b"#ROSBAG V1.2\n" + bytes(64), None,
         "it looks like a ROS bag of format '1.2' (aion reads format 2.0)"),
        ("x.mcap", CSV, None, "x.mcap is not an MCAP file (it does not start with the MCAP magic "
                              "bytes): it looks like CSV text starting 'a,b,c'"),
        ("x.txt", TEXT, "mcap", "x.txt is not an MCAP file"),
        ("x.db3", TEXT, None, "x.db3 is not a rosbag2 storage file (it does not start with the "
                              "SQLite or MCAP magic bytes): it looks like text starting 'hello'"),
        ("x.txt", gzip.compress(TEXT), "rosbag2", "it looks like gzip-compressed data"),
    ],
    ids=["text-bag", "text-as-bag", "old-bag", "csv-mcap", "text-as-mcap", "text-db3",
         "gzip-as-rosbag2"],
)
def test_a_file_without_its_container_magic_says_what_it_looks_like(
    tmp_path: Path, name: str, data: bytes, fmt: str | None, expected: str
) -> None:
    path = tmp_path / name
    path.write_bytes(data)
    given = ["--log-format", fmt] if fmt else []
    for args in (["info", path], ["build", path, "-o", tmp_path / "m.aion"]):
        result = run(*args, *given)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, expected)
        assert "reindex" not in result.stderr
        assert "File magic" not in result.stderr
    assert not (tmp_path / "m.aion").exists()


def test_a_rosbag2_folder_with_a_text_storage_file_names_that_file(tmp_path: Path) -> None:
    folder = _write(tmp_path / "bag", "rosbag2-sqlite3")
    (storage,) = folder.glob("*.db3")
    with open_logs([folder]) as logs:  # the bag as written reads
        assert logs.total(["/people"]) == 4
    storage.write_bytes(CSV)
    with pytest.raises(LogFormatError) as info:
        open_logs([folder])
    assert info.value.message == (
        f"{storage} is not a rosbag2 storage file (it does not start with the SQLite or MCAP "
        "magic bytes): it looks like CSV text starting 'a,b,c'"
    )
    result = run("info", folder)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "is not a rosbag2 storage file")


def test_a_damaged_bag_that_starts_as_a_bag_keeps_the_reindex_advice(tmp_path: Path) -> None:
    bag = _write(tmp_path / "a.bag", "bag")
    cut = tmp_path / "cut.bag"
    shutil.copyfile(bag, cut)
    with cut.open("r+b") as f:
        f.truncate(20)  # the magic, then half a header
    with pytest.raises(LogFormatError, match="not a readable ROS 1 bag") as info:
        open_logs([cut])
    assert "reindex" in (info.value.hint or "")
