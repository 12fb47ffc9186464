"""``aion merge`` of maps of one local day (merge approximation 4, narrowed at stop 71): a later
map that ends on the day it starts joins the earlier map's part of that day as one day, so the
merged file is one build's and no note speaks of the day; a later map that goes on past the day
scored it already, and the note says the day counts as two."""

from __future__ import annotations

from pathlib import Path

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from aion_cli.merging import merge_map_files
from tests.engine.state_logs import HOUR, MORNING, W, fixed_sensor_log, run_steps
from tests.merging_logs import fixed_sensor_map


def test_a_morning_and_an_afternoon_map_merge_as_one_build_of_both(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), MORNING, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), MORNING + 5 * HOUR, seed=2)
    whole = run_steps(
        fixed_sensor_log(MORNING, seed=1) + fixed_sensor_log(MORNING + 5 * HOUR, seed=2)
    ).state
    report = merge_map_files([b, a], tmp_path / "ab.aion")
    assert not [n for n in report.notes if "approximation 4" in n], report.notes
    merged = load_map(tmp_path / "ab.aion", writable=True).state
    assert differences(whole, merged) == []


def test_a_later_map_going_on_past_the_day_gets_the_note(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), MORNING, seed=1)
    late = MORNING + 15 * HOUR + 3 * W  # 23:30: its six windows end after midnight
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), late, seed=2)
    report = merge_map_files([a, b], tmp_path / "ab.aion")
    days = [n for n in report.notes if "approximation 4" in n]
    assert len(days) == 1, report.notes
    assert "a.aion ends on the day b.aion starts, and b.aion goes on past that day" in days[0]
