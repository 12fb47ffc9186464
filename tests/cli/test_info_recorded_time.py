"""``aion info LOG1 LOG2`` of two one-hour logs a week apart said "duration: 608,395.0 s = 7.0
days": the span from the first message to the last, the week between them included, under a
name that reads as how much was recorded. The header now says what the logs recorded (each
log's span, overlaps once) and their span apart, and the JSON has ``recorded_s``,
``recordings`` and ``span_s`` (``duration_s`` stays the span for scripts that read it)."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

from tests.cli.conftest import run, run_json
from tests.cli.logdata import write_office_log

WEEK_S = 7 * 86_400


def _times(path: Path) -> tuple[int, int]:
    """The first and last message log time, read with the mcap library itself."""
    with path.open("rb") as f:
        times = [m.log_time for _, _, m in make_reader(f).iter_messages()]
    return min(times), max(times)


def test_two_logs_a_week_apart_recorded_two_hours(tmp_path: Path) -> None:
    first, later = tmp_path / "monday.mcap", tmp_path / "next-monday.mcap"
    write_office_log(first, duration_s=3600)
    write_office_log(later, duration_s=3600, shift_s=WEEK_S)
    (a0, a1), (b0, b1) = _times(first), _times(later)
    doc = run_json("info", first, later, "--format", "json")
    assert doc["recorded_s"] == ((a1 - a0) + (b1 - b0)) / 1e9  # about two hours
    assert doc["recorded_s"] < 2 * 3600
    assert doc["span_s"] == doc["duration_s"] == (b1 - a0) / 1e9  # the week between included
    assert doc["recordings"] == 2
    header = " ".join(run("info", first, later).stdout.split())
    assert f"recorded: {doc['recorded_s']:,.1f} s = 1h59m50s in 2 logs" in header, header
    assert f"span: {doc['span_s']:,.1f} s = 7.0 days" in header, header
    assert "duration:" not in header


def test_overlapping_logs_count_their_shared_time_once(tmp_path: Path) -> None:
    first, overlapping = tmp_path / "a.mcap", tmp_path / "b.mcap"
    write_office_log(first, duration_s=3600)
    write_office_log(overlapping, duration_s=3600, shift_s=1800)
    (a0, a1), (b0, b1) = _times(first), _times(overlapping)
    assert b0 < a1  # they overlap
    doc = run_json("info", first, overlapping, "--format", "json")
    assert doc["recorded_s"] == (max(a1, b1) - min(a0, b0)) / 1e9 == doc["span_s"]
    header = " ".join(run("info", first, overlapping).stdout.split())
    assert "duration: " in header  # nothing between them: one time says it
    assert "recorded:" not in header


def test_one_log_recorded_its_span(tmp_path: Path) -> None:
    log = tmp_path / "one.mcap"
    write_office_log(log, duration_s=600)
    lo, hi = _times(log)
    doc = run_json("info", log, "--format", "json")
    assert doc["recorded_s"] == doc["span_s"] == (hi - lo) / 1e9
    assert doc["recordings"] == 1
