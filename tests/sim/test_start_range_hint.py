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


@pytest.mark.parametrize("container", ["bag", "mcap-ros1", "mcap"])
def test_a_start_past_2038_is_refused_in_every_container(tmp_path: Path, container: str) -> None:
    """The scene graphs, detections and TF carry header stamps whose seconds aion serializes
    signed (int32: to 2038-01-19 03:14:07 UTC) in every container. A 2099 start in a .bag or
    mcap-ros1 log was an internal error (struct.error, exit 1); an .mcap one hinted at a ROS 1
    log, which failed the same way. Each is refused before anything is written."""
    out = tmp_path / ("s.bag" if container == "bag" else "s.mcap")
    args = ("--start", "2099-01-01T08:00", "--days", "0.05", "--container", container)
    result = run("simulate", "-o", out, *args)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "reach beyond 2038-01-19 03:14:07 UTC")
    assert "ROS 1 log" not in result.stderr
    assert not out.exists()


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
