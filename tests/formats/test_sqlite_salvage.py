"""rosbag2 sqlite3 storage files cut short (``formats.sqlite_salvage``): SQLite refuses such a
file whole ("database disk image is malformed"); what it can still read of it is read, with a
warning naming how much is missing, and a file of which it reads no message is refused as cut
short.

Expected answers: rosbag2's own test bags under ``../shared/data/logs/rosbag2_tests`` read
whole with Python's ``sqlite3`` (the messages of a cut file are the whole file's first ones,
byte for byte), and their metadata.yaml.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from tests.cli.conftest import assert_one_line_error, run
from tests.formats.rosbag2_reference import bag_metadata, read_only, sqlite_messages
from tests.shared_data import real

FILE = ("logs", "rosbag2_tests", "rosbag2_py_sqlite3_reindex_test_bags_multiple_files",
        "multiple_files_0.db3")
WBAG = ("logs", "rosbag2_tests", "rosbag2_py_sqlite3_wbag")


def _got(logs: Any) -> list[tuple[str, int, bytes]]:
    return [(m.topic, m.log_time_ns, m.data) for m in logs.messages()]


def _first(path: Path, n: int) -> list[tuple[str, int, bytes]]:
    """(topic, time, data) of the first ``n`` messages of a whole sqlite3 file by id (the
    order they were written in), sorted."""
    with read_only(path) as db:
        rows = db.execute(
            "SELECT topics.name, timestamp, data FROM messages "
            "JOIN topics ON messages.topic_id = topics.id ORDER BY messages.id LIMIT ?",
            (n,),
        ).fetchall()
    return sorted(rows)


def _cut(src: Path, dst: Path, size: int) -> Path:
    with src.open("rb") as f:
        dst.write_bytes(f.read(size))
    return dst


@pytest.mark.parametrize("size", [60_000, 45_056])  # inside a page; at a page's end
def test_a_cut_storage_file_is_read_as_far_as_sqlite_reads_it(size: int, tmp_path: Path) -> None:
    """The file was refused ("not a readable rosbag2 sqlite3 storage file ... malformed");
    now its first messages are read, the same bytes as the whole file's, and a warning says
    how much of the file is missing and how many messages were read."""
    whole = real(*FILE)
    expected = sqlite_messages(whole)
    assert len(expected) == 1324
    cut = _cut(whole, tmp_path / whole.name, size)
    with open_logs([cut]) as logs:
        got = _got(logs)
        warnings = logs.warnings
    assert 0 < len(got) < len(expected)
    assert sorted(got) == _first(whole, len(got))  # none altered, none from the missing pages
    # at least the share of messages the pages kept (the file's first 5 pages are its schema)
    assert len(got) >= len(expected) * (size // 4096 - 5) / 22
    assert warnings == [
        f"{whole.name}: the sqlite3 storage file is cut short, {size:,} of its 90,112 bytes "
        f"({size // 4096} of 22 pages of 4,096 bytes): its first {len(got):,} messages are "
        "read, those after them are lost (SQLite: database disk image is malformed)"
    ]


def test_a_bag_folder_with_a_cut_storage_file_reads_its_files(tmp_path: Path) -> None:
    """rosbag2's five-file test bag with its last file cut short: the four whole files and
    what SQLite reads of the fifth, and the count metadata.yaml gives to compare with."""
    folder = tmp_path / "wbag"
    shutil.copytree(real(*WBAG), folder)
    files = sorted(folder.glob("*.db3"))
    assert len(files) == 5
    whole = sqlite_messages(*files)
    last = len(sqlite_messages(files[-1]))
    before = sqlite_messages(*files[:-1])
    stated = bag_metadata(folder)["message_count"]
    assert stated == len(whole) == 6074
    files[-1].chmod(0o644)
    _cut(real(*WBAG, files[-1].name), files[-1], 40_000)
    last_whole = real(*WBAG, files[-1].name)
    with open_logs([folder]) as logs:
        got = _got(logs)
        warnings = logs.warnings
    read = len(got) - len(before)
    assert 0 < read < last
    assert sorted(got) == sorted(before + _first(last_whole, read))
    assert warnings[-1] == (
        f"{folder}: metadata.yaml not used (wbag_4.db3 cut short); indexed in memory from its "
        f"5 storage files: {len(got):,} of the 6,074 messages metadata.yaml counts"
    )


def test_a_file_sqlite_reads_no_message_of_is_refused_as_cut_short(tmp_path: Path) -> None:
    """The refusal said "not a readable ... (database disk image is malformed)" with a hint
    to check metadata.yaml; it now says the file is cut short and how much of it is there."""
    cut = _cut(real(*FILE), tmp_path / "multiple_files_0.db3", 5_000)
    with pytest.raises(LogFormatError) as caught:
        open_logs([cut]).close()
    assert "the sqlite3 storage file is cut short, 5,000 of its 90,112 bytes" in (
        caught.value.message
    )
    result = run("info", cut)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "cut short", "SQLite reads none of its messages")
    assert list(tmp_path.iterdir()) == [cut]  # no copy, journal or lock left beside it


def _leaf_rowids(page: bytes) -> list[int]:
    """The rowids of a table b-tree leaf page (type 13), parsed from its bytes: cell count at
    offset 3, cell pointers from offset 8, each cell a payload-size varint then the rowid's."""

    def varint(at: int) -> tuple[int, int]:
        value = 0
        for k in range(9):
            byte = page[at + k]
            if k == 8:
                return (value << 8) | byte, at + 9
            value = (value << 7) | (byte & 0x7F)
            if byte < 0x80:
                return value, at + k + 1
        raise AssertionError("unreachable")

    assert page[0] == 13, "not a table leaf page"
    cells = int.from_bytes(page[3:5], "big")
    out = []
    for k in range(cells):
        at = int.from_bytes(page[8 + 2 * k : 10 + 2 * k], "big")
        _, at = varint(at)
        out.append(varint(at)[0])
    return out


@pytest.mark.parametrize("pages", [(11,), (5,), (11, 19)])  # mid-file; the first; two runs
def test_a_storage_file_damaged_inside_is_read_past_the_damage(
    pages: tuple[int, ...], tmp_path: Path
) -> None:
    """Leaf pages of the messages table overwritten with noise: SQLite refuses the file at
    open ("database disk image is malformed") and it was refused whole. Now every message
    outside those pages is read, byte for byte the whole file's, and a warning counts the
    ones lost with their ids (the rowids the pages held, parsed from the intact pages)."""
    import random

    whole = real(*FILE)
    data = bytearray(whole.read_bytes())
    lost: list[int] = []
    rng = random.Random(7)
    for page in pages:
        at = (page - 1) * 4096
        lost += _leaf_rowids(bytes(data[at : at + 4096]))
        data[at : at + 4096] = bytes(rng.randrange(256) for _ in range(4096))
    damaged = tmp_path / whole.name
    damaged.write_bytes(bytes(data))
    with read_only(whole) as db:
        rows = db.execute(
            "SELECT messages.id, topics.name, timestamp, data FROM messages "
            "JOIN topics ON messages.topic_id = topics.id"
        ).fetchall()
    expected = sorted((t, ts, d) for i, t, ts, d in rows if i not in set(lost))
    assert 0 < len(lost) < len(rows)
    with open_logs([damaged]) as logs:
        got = _got(logs)
        (warning,) = logs.warnings
    assert sorted(got) == expected
    assert warning.startswith(f"{whole.name}: the sqlite3 storage file is damaged inside")
    assert f"{len(expected):,} messages are read, {len(lost):,} cannot be (ids " in warning
    result = run("info", damaged)
    assert result.exit_code == 0, result.stderr
    assert f"{len(lost):,} cannot be" in " ".join(result.stderr.split())


def test_a_storage_file_whose_messages_root_page_is_damaged_is_refused(tmp_path: Path) -> None:
    """The messages table's root page (3) overwritten: no row can be reached; a one-line error
    that says SQLite reads none of its messages past the damage, no copy left behind."""
    data = bytearray(real(*FILE).read_bytes())
    data[2 * 4096 : 3 * 4096] = bytes(4096)
    damaged = tmp_path / "multiple_files_0.db3"
    damaged.write_bytes(bytes(data))
    result = run("info", damaged)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "SQLite reads none of its messages past the damage")
    assert list(tmp_path.iterdir()) == [damaged]
