"""rosbag2 sqlite3 storage files with bytes inserted inside (found by the long fuzz run of stop
66, target ``logs``): every page after the insertion is shifted, so SQLite finds damaged pages
where the messages' b-tree points, and rows that read by their rowid alone but not whole.

``formats.sqlite_salvage`` looked for where SQLite reads again by reading rowids only, while
the copy reads whole rows: a row whose rowid read and whose columns did not made it step one
rowid at a time from -2^63 (``aion info`` and ``aion build`` hung). Expected answers: the
storage file aion's writer made, read whole with Python's ``sqlite3`` before it was damaged,
and the rowids of its intact leaf pages parsed from their bytes.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from tests.cli.conftest import assert_one_line_error
from tests.formats.rosbag2_reference import read_only
from tests.formats.test_sqlite_salvage import _leaf_rowids
from tests.robustness.conftest import (
    T0,
    S,
    graph_payload,
    robot_tf,
    run,
    scene_graph,
    walk,
    write_log,
)

PAGE = 4096


def _storage(tmp_path: Path) -> tuple[Path, bytes]:
    """A rosbag2 sqlite3 log (people, TF, one scene graph: the fuzz run's seed) and the bytes
    of its storage file."""
    msgs = sorted(
        [*walk(40), *[robot_tf(T0 + 5 * k * S) for k in range(8)],
         scene_graph(T0 + 1, graph_payload())],
        key=lambda m: m[3],
    )
    folder = write_log(tmp_path / "seed", msgs, "rosbag2-sqlite3")
    (db,) = folder.glob("*.db3")
    return db, db.read_bytes()


def _rows(db: Path) -> dict[int, tuple[int, bytes]]:
    with read_only(db) as con:
        return {i: (t, d) for i, t, d in con.execute("SELECT id, timestamp, data FROM messages")}


def _message_leaves(db: Path, data: bytes) -> list[int]:
    """The numbers (from 1) of the leaf pages of the messages table: the table leaves after
    its root page (an interior page: aion's writer makes the small tables first)."""
    with read_only(db) as con:
        query = "SELECT rootpage FROM sqlite_master WHERE name = 'messages'"
        (root,) = con.execute(query).fetchone()
    assert data[(root - 1) * PAGE] == 5  # an interior page: its leaves come after it
    return [p for p in range(root + 1, len(data) // PAGE + 1) if data[(p - 1) * PAGE] == 13]


def _shifted(data: bytes, page: int, at: int) -> bytes:
    """One zero byte inserted at byte ``at`` of page ``page``: it and every later page move."""
    k = (page - 1) * PAGE + at
    return data[:k] + b"\0" + data[k:]


def test_a_byte_inserted_in_a_leaf_loses_the_messages_from_its_first_id_on(
    tmp_path: Path,
) -> None:
    """The byte inside a leaf page of messages: the messages of the pages before it are read,
    byte for byte, and the warning says none can be read from that page's first id on (it said
    "not in its messages: all N of them are read", or counted five single ids lost)."""
    db, data = _storage(tmp_path)
    rows = _rows(db)
    leaves = _message_leaves(db, data)
    assert len(leaves) >= 3
    page = leaves[len(leaves) // 2]
    first = min(_leaf_rowids(data[(page - 1) * PAGE : page * PAGE]))
    damaged = tmp_path / db.name
    damaged.write_bytes(_shifted(data, page, 100))
    with open_logs([damaged]) as logs:
        got = sorted((m.log_time_ns, m.data) for m in logs.messages())
        (warning,) = logs.warnings
    assert got == sorted(v for i, v in rows.items() if i < first)
    assert warning.startswith(f"{db.name}: the sqlite3 storage file is damaged inside")
    assert warning.endswith(
        f"{first - 1:,} messages are read, none from id {first:,} on can be read: they are lost"
    )


def test_a_byte_inserted_in_any_leaf_is_read_or_refused_never_a_hang(tmp_path: Path) -> None:
    """One byte inserted into each leaf page of the messages, read and given to ``aion info``:
    messages byte for byte the file's own and exit 0, or one error line that SQLite reads
    none of them, exit 2. In the first leaf it was a hang (the fuzz run's case)."""
    db, data = _storage(tmp_path)
    original = set(_rows(db).values())
    leaves = _message_leaves(db, data)
    assert len(leaves) >= 3
    refused = 0
    for page in leaves:
        damaged = tmp_path / f"p{page}" / db.name
        damaged.parent.mkdir()
        damaged.write_bytes(_shifted(data, page, 100))
        got: list[tuple[int, bytes]] | None = None
        why = ""
        try:
            with open_logs([damaged]) as logs:
                got = [(m.log_time_ns, m.data) for m in logs.messages()]
        except LogFormatError as exc:
            why = exc.message
        assert got is not None or "SQLite reads none of its messages" in why
        assert got is None or set(got) <= original
        result = run("info", damaged)
        assert result.exit_code == (2 if got is None else 0), result.stderr
        if got is None:
            refused += 1
            assert_one_line_error(result.stderr, "SQLite reads none of its messages")
    assert refused < len(leaves)


def test_a_row_read_whole_that_cannot_be_kept_is_stepped_over(tmp_path: Path) -> None:
    """The copy reads a row whose NOT NULL column came out NULL (a damaged cell), the first
    of the table: it steps over that rowid and reads on (it stepped one rowid at a time from
    -2^63, where the read began: a hang)."""
    from aion_cli.formats import sqlite_salvage

    db = tmp_path / "x.db3"
    con = sqlite3.connect(db)
    con.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, data BLOB)")
    con.executemany("INSERT INTO messages VALUES (?, ?, ?)",
                    [(1, None, b"a"), (2, 1, b"b"), (3, 1, b"c")])
    con.commit()
    con.close()
    cut = sqlite3.connect(db)
    copy = sqlite3.connect(tmp_path / "copy.db3", isolation_level=None)
    copy.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
                 "data BLOB)")
    copy.execute("BEGIN")
    copied, why, gaps = sqlite_salvage._copy_table(cut, copy, "messages", skip=True)
    copy.execute("COMMIT")
    assert (copied, gaps) == (2, [(1, 1)])
    assert "NOT NULL constraint failed" in why
    assert copy.execute("SELECT id, data FROM messages").fetchall() == [(2, b"b"), (3, b"c")]
