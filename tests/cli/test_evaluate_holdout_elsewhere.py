"""``aion evaluate holdout`` of an office map on a log simulated in another scene (the real
apartment scene graph): the robot never had a map place within its sensor range, so every
activity forecast is zero and the three activity rows are one and the same."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.evaluation.holdout import _no_place_observed
from tests.cli.conftest import run, run_json
from tests.shared_data import real


def test_an_activity_forecast_of_no_place_in_range_says_why_the_rows_are_alike(
    tmp_path: Path,
) -> None:
    """Before: three identical activity rows (Spearman -) and a warning about headings only.
    Now a warning says no map place lay within the robot's range in any test window, every
    model forecasts 0, and names the test detections the rows are judged on."""
    office, apartment = tmp_path / "office.mcap", tmp_path / "apt.mcap"
    assert run("simulate", "-o", office, "--days", "1", "-q").exit_code == 0
    made = run("simulate", "-o", apartment, "--days", "1", "--start", "2026-01-12", "-q",
               "--environment", real("dsg", "apartment_dsg.json"))  # fmt: skip
    assert made.exit_code == 0, made.stderr
    site = tmp_path / "office.aion"
    assert run("build", office, "-o", site, "-q").exit_code == 0
    doc = run_json("evaluate", "holdout", site, apartment, "--format", "json")
    series, test = doc["hourly_series"], doc["test"]
    truth = int(sum(series["truth"]))
    assert truth == test["detections"] > 0  # every detection in a robot window
    for model in ("aion", "aion static", "hour-of-day profile"):
        assert not any(series[model]), model  # nothing forecast anywhere
    said = [w for w in doc["warnings"] if w.startswith("no place of the map")]
    assert said == [
        "no place of the map lay within the robot's sensor range (8 m) in any of the "
        f"{test['robot_windows']:,} test windows it observed: every model forecasts 0 "
        f"detections per hour, so the hourly activity rows are alike (the {truth:,} test "
        "detections in those windows against nothing) and rank nothing; the test logs are "
        "of another place or frame than the map"
    ]
    shown = run("evaluate", "holdout", site, apartment, "-q")
    assert shown.exit_code == 0, shown.stderr
    assert "warning: no place of the map lay within the robot's sensor range" in shown.stderr


def test_a_place_observed_once_is_no_warning() -> None:
    fixed = np.array([False, False])
    assert _no_place_observed(np.array([3]), fixed, 5, 8.0) is None
    said = _no_place_observed(np.zeros(0, np.int64), np.array([True, False]), 5, 8.0)
    assert said is not None
    assert said.startswith(
        "no place of the map was observed in any of the 2"
    )
