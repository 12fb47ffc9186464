"""The door check as `aion evaluate door` runs it, on the real signal."""

from __future__ import annotations

from pathlib import Path

from aion_cli.evaluation.door import run_door

DOOR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "fremen_door"


def test_door_check_finds_the_day_and_beats_the_static_mean() -> None:
    result = run_door(DOOR, weeks=range(1, 4))
    assert 24.0 in result["strongest_periods_h"][:3]
    assert result["fremen_wins"] == 3
    assert all(w["samples"] == 10081 for w in result["weeks"])
    assert result["chosen_order"] >= 1
