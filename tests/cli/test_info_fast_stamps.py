"""``aion info``'s table printed rates such as ``402402402.40`` Hz (rosbag2's wbag test bags: 804
messages stamped within 2 µs) and ``1111111111.11`` Hz (the MCAP conformance TenMessages: 10 in
9 ns): true as a quotient, unreadable, and no stream's rate. Above 100 kHz the table now gives
the count over the time it spans (``804 in 2 µs``); JSON keeps ``rate_hz`` a number."""

from __future__ import annotations

import json
import sqlite3

import pytest

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def _row(stdout: str, topic: str) -> list[str]:
    """The cells of ``topic``'s row in info's table."""
    for line in stdout.splitlines():
        cells = [c.strip() for c in line.strip("│ ").split("│")]
        if cells and cells[0] == topic:
            return cells
    raise AssertionError(f"no row {topic!r} in\n{stdout}")


def test_ten_messages_nanoseconds_apart() -> None:
    log = real("logs", "mcap_conformance", "TenMessages", "TenMessages.mcap")
    records = json.loads(log.with_suffix(".json").read_text())["records"]
    times = [int(dict(r["fields"])["log_time"]) for r in records if r["type"] == "Message"]
    span_ns = max(times) - min(times)
    assert 0 < span_ns < 1000
    result = run("info", log)
    assert result.exit_code == 0, result.stderr
    assert _row(result.stdout, "example")[3] == f"{len(times)} in {span_ns} ns"
    (topic,) = run_json("info", log, "--format", "json")["topics"]
    assert topic["rate_hz"] == pytest.approx(len(times) / (span_ns / 1e9), rel=1e-9)


def test_rosbag2_wbag_topics_microseconds_apart() -> None:
    """The wbag's topics as its SQLite storage files hold them (count, first and last stamp),
    read with sqlite3 alone."""
    folder = real("logs", "rosbag2_tests", "rosbag2_py_sqlite3_wbag")
    stamps: dict[str, list[int]] = {}
    for db in sorted(folder.glob("*.db3")):
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as con:
            rows = con.execute(
                "SELECT t.name, m.timestamp FROM messages m JOIN topics t ON t.id = m.topic_id"
            ).fetchall()
        for name, stamp in rows:
            stamps.setdefault(name, []).append(int(stamp))
    table = run("info", folder).stdout
    checked = 0
    for name, seen in stamps.items():
        span_ns = max(seen) - min(seen)
        if not 1000 <= span_ns < 10_000:
            continue
        assert _row(table, name)[3] == f"{len(seen)} in {round(span_ns / 1000)} µs", name
        checked += 1
    assert checked >= 8


@pytest.mark.parametrize(
    ("hz", "count", "shown"),
    [(2e5, 10, "10 in 50 µs"), (99_999.0, 10, "99999.00"), (2.5, 10, "2.50"),
     (1e6, 2_000_000, "2,000,000 in 2 s"), (4e5, 1_000, "1,000 in 2.5 ms")],
)  # fmt: skip
def test_a_rate_above_100_khz_reads_as_its_count_over_its_span(
    hz: float, count: int, shown: str
) -> None:
    from aion_cli.cli.info_table import rate_text

    assert rate_text(hz, count) == shown
