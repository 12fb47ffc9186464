"""``aion simulate --start`` outside 1970 .. 2261: the hint points the way back into range
(a 1960 start said "choose an earlier start")."""

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
