"""``aion simulate --start`` at a wall-clock time of ``--tz`` that a clock change skips or
repeats: the scene started at another instant than the one typed, and nothing said so
(``predict --at`` and ``plan`` note it). Now a note says which instant it was read as."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import pytest

from tests.cli.conftest import run

S = 1_000_000_000


@pytest.mark.parametrize(
    ("start", "said", "utc"),
    [
        # Europe/London jumps 01:00 GMT -> 02:00 BST on 2026-03-29: 01:30 is read as 01:30 GMT
        ("2026-03-29T01:30", "does not exist in Europe/London", datetime(2026, 3, 29, 1, 30)),
        # and goes back 02:00 BST -> 01:00 GMT on 2026-10-25: the first 01:30 is BST (00:30 UTC)
        ("2026-10-25T01:30", "happens twice in Europe/London", datetime(2026, 10, 25, 0, 30)),
        ("2026-01-05T01:30", None, datetime(2026, 1, 5, 1, 30)),  # GMT all day: no note
    ],
)
def test_a_start_a_clock_change_skips_or_repeats_is_noted(
    tmp_path: Path, start: str, said: str | None, utc: datetime
) -> None:
    out = tmp_path / "s.mcap"
    args = ("--start", start, "--tz", "Europe/London", "--days", "0.01", "--robot", "fixed")
    result = run("simulate", "-o", out, *args)
    assert result.exit_code == 0, result.stderr
    truth = json.loads(out.with_name("s.mcap.truth.json").read_text())
    assert truth["start_ns"] == int(utc.replace(tzinfo=UTC).timestamp()) * S
    notes = [line for line in result.stderr.splitlines() if line.startswith("--start ")]
    if said is None:
        assert notes == []
    else:
        assert len(notes) == 1, result.stderr
        assert said in notes[0]
