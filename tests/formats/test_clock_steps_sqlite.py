"""The clock-step check of a rosbag2 sqlite3 storage file (formats.clock_steps): the per-topic
window query cost about 1 s of CPU per million messages at every open of a .db3. It now runs
only when the timestamps of all topics together, read in one plain pass in blocks, go back
more than a step; the warnings stay those of the query, checked here against a step found by
hand (a per-topic running maximum in plain Python) on logs with steps and without."""

from __future__ import annotations

import random
import sqlite3
from pathlib import Path

import pytest

from aion_cli.formats import clock_steps
from aion_cli.formats.clock_steps import BACK_STEP_MAX_NS, BACK_STEP_NS, sqlite_step_warning

S = 1_000_000_000
T0 = 1_767_225_600 * S  # 2026-01-01


def _db(path: Path, rows: list[tuple[int, int]]) -> sqlite3.Connection:
    """A messages table as rosbag2 writes it: ``rows`` of (topic id, timestamp) in id order."""
    db = sqlite3.connect(path)
    db.execute(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL)"
    )
    db.execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC)")
    db.executemany(
        "INSERT INTO messages VALUES (?, ?, ?, x'00')",
        [(k + 1, topic, t) for k, (topic, t) in enumerate(rows)],
    )
    db.commit()
    return db


def _by_hand(rows: list[tuple[int, int]]) -> int | None:
    """The largest step back of one topic within the bounds, from its latest time before."""
    latest: dict[int, int] = {}
    best = None
    for topic, t in rows:
        if topic in latest:
            back = latest[topic] - t
            if BACK_STEP_NS < back <= BACK_STEP_MAX_NS and (best is None or back > best):
                best = back
        latest[topic] = max(latest.get(topic, t), t)
    return best


def _minutes(warning: str | None) -> str | None:
    if warning is None:
        return None
    return warning.split("go back at least ")[1].split(" min")[0]


def _rows(seed: int, n: int) -> list[tuple[int, int]]:
    """``n`` messages of 3 topics at 10 Hz, with (by the seed) a clock step back of one topic
    or of all, a topic's messages written late, a stray message days away, or none."""
    rnd = random.Random(seed)
    rows = [(rnd.randrange(3), T0 + k * S // 10) for k in range(n)]
    kind = seed % 5
    at = rnd.randrange(1, n)
    if kind == 1:  # the clock steps back for every topic
        back = rnd.randrange(5, 900) * S
        rows = [(c, t - back if k >= at else t) for k, (c, t) in enumerate(rows)]
    elif kind == 2:  # for one topic only
        back = rnd.randrange(5, 900) * S
        rows = [(c, t - back if k >= at and c == 0 else t) for k, (c, t) in enumerate(rows)]
    elif kind == 3:  # one topic written 30 s late: every topic in order, all together not
        rows = [(c, t - 30 * S if c == 1 else t) for c, t in rows]
    elif kind == 4:  # a stray, days before
        rows[at] = (rows[at][0], rows[at][1] - 3 * 86_400 * S)
    return rows


@pytest.mark.parametrize("seed", range(20))
def test_the_warning_names_the_step_found_by_hand(tmp_path: Path, seed: int) -> None:
    rows = _rows(seed, 2000 + seed * 37)
    db = _db(tmp_path / "bag.db3", rows)
    expected = _by_hand(rows)
    got = sqlite_step_warning("bag.db3", db)
    assert (got is None) == (expected is None), (seed, got, expected)
    if expected is not None:
        assert _minutes(got) == f"{expected / 6e10:.1f}"


def test_steps_across_the_blocks_are_found(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The pass reads the table in blocks: a step between two blocks is still a step."""
    monkeypatch.setattr(clock_steps, "_BLOCK", 7)
    for at in (7, 8, 13, 14):
        rows = [(0, T0 + k * S - (600 * S if k >= at else 0)) for k in range(30)]
        db = _db(tmp_path / f"b{at}.db3", rows)
        assert _minutes(sqlite_step_warning("b.db3", db)) == f"{_by_hand(rows) / 6e10:.1f}"


def test_a_file_in_order_is_not_asked_the_window_query(tmp_path: Path) -> None:
    """What made the check cost about 1 s per million messages: the window query (a sort of
    every row by topic); a file whose messages keep their order is now read once, plainly."""
    ordered = [(k % 3, T0 + k * S // 10) for k in range(3000)]
    stepped = [(c, t - 600 * S if k >= 1500 else t) for k, (c, t) in enumerate(ordered)]
    for name, rows, expected in (("in order", ordered, None), ("stepped", stepped, "10.0")):
        db = _db(tmp_path / f"{name}.db3", rows)
        statements: list[str] = []
        db.set_trace_callback(statements.append)
        assert _minutes(sqlite_step_warning("x.db3", db)) == expected
        windowed = [s for s in statements if " OVER (" in s]
        assert len(windowed) == (0 if expected is None else 1), (name, statements)
