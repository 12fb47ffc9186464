"""``aion simulate --start`` outside 1970 .. 2261: the hint points the way back into range
(a 1960 start said "choose an earlier start"); a start with an impossible field names it."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run


@pytest.mark.parametrize(
    ("start", "hint"),
    [("1960-01-01", "hint: choose a later start"), ("2260-12-30", "hint: choose an earlier start")],
)
def test_the_hint_of_a_start_out_of_range_points_back_into_it(
    tmp_path: Path, start: str, hint: str
) -> None:
    result = run("simulate", "-o", tmp_path / "s.mcap", "--start", start, "--days", "3")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "the simulated days must lie in 1970 .. 2261")
    assert hint in result.stderr


@pytest.mark.parametrize(
    ("start", "reason"),
    [("2026-02-29", "day is out of range for month"), ("2026-01-05T25:00", "hour must be in")],
)
def test_a_start_with_an_impossible_field_names_it(tmp_path: Path, start: str, reason: str) -> None:
    """2026 has no 29 February: the error said only "bad --start '2026-02-29'"."""
    result = run("simulate", "-o", tmp_path / "s.mcap", "--start", start)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, f"bad --start '{start}': {reason}")
    assert not (tmp_path / "s.mcap").exists()


def test_a_start_past_2038_is_refused_in_a_ros2_log_only(tmp_path: Path) -> None:
    """ROS 2 header stamps hold signed 32-bit seconds (to 2038-01-19 03:14:07 UTC): a 2099
    start in an .mcap log is refused before anything is written, the hint naming a ROS 1 log,
    whose ``time`` holds unsigned seconds (to 2106). In a .bag or mcap-ros1 log it was refused
    too (rosbags serialized ROS 1's Time with signed seconds; before that, an internal
    struct.error): now the log is written and builds a map of 2099 from its scene graphs."""
    import json

    from tests.cli.conftest import run_json

    args = ("--start", "2099-01-05T09:00", "--days", "0.02")
    out = tmp_path / "s.mcap"
    result = run("simulate", "-o", out, *args)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "reach beyond 2038-01-19 03:14:07 UTC")
    assert "hint: write a ROS 1 log" in result.stderr
    assert not out.exists()
    for container, name in (("bag", "s.bag"), ("mcap-ros1", "s1.mcap")):
        log = tmp_path / name
        result = run("simulate", "-o", log, *args, "--container", container, "-q")
        assert result.exit_code == 0, result.stderr
        start = json.loads((tmp_path / f"{name}.truth.json").read_text())["start_ns"]
        report = run_json("build", log, "-o", tmp_path / f"{name}.aion", "--format", "json")
        assert report["time_span"]["start_ns"] == start > (2**32 - 2**30) * 10**9
        assert report["graph"]["decoded"] > 0
        assert report["detections"]["used"] > 0
        assert report["detections"]["dropped"].get("no_transform", 0) == 0


def test_a_start_with_fractional_seconds_keeps_them(tmp_path: Path) -> None:
    """``--start 2026-01-05T08:00:00.700``: the scene started at 08:00:00.000, the 0.7 s
    dropped without a word. It starts at the instant typed (the truth's start and the log's
    first message)."""
    import json
    from datetime import UTC, datetime

    out = tmp_path / "s.mcap"
    args = ("--start", "2026-01-05T08:00:00.700", "--days", "0.01", "--robot", "fixed")
    result = run("simulate", "-o", out, *args)
    assert result.exit_code == 0, result.stderr
    when = datetime(2026, 1, 5, 8, 0, 0, 700_000, tzinfo=UTC)
    expected = int(when.timestamp()) * 10**9 + 700_000_000
    assert json.loads((tmp_path / "s.mcap.truth.json").read_text())["start_ns"] == expected
    from mcap.reader import make_reader

    with out.open("rb") as f:
        first = make_reader(f).get_summary().statistics.message_start_time
    assert first == expected
