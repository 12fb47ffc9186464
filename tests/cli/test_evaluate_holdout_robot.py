"""``aion evaluate holdout`` of test logs a moving robot recorded: the activity is scored only
in the windows the robot observed, and sums, per window, the map places within its sensor
range then (a window it did not cover is left out, with a note saying why)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.build_report import BuildReport
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.holdout import HoldoutResult, _activity
from aion_cli.evaluation.holdout_notes import held_out_notes
from aion_cli.held_out import HeldOut
from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.test_evaluate_holdout import MONDAY, S


def test_a_window_without_coverage_is_left_out_of_the_activity() -> None:
    batch = DetectionBatch.from_arrays([MONDAY + S], [[0.0, 0.0, 0.0]], [0.0], [1.0])
    window = np.array([MONDAY // (600 * S)])
    held = HeldOut(batch, window, np.array([False]), BuildReport(Path("x.aion")))  # no seen
    notes = held_out_notes(held, {}, 8.0)
    assert any("observed by a moving robot" in n and "(8 m)" in n for n in notes)
    result = HoldoutResult()
    _activity(result, object(), held)  # type: ignore[arg-type]  # never read: no window
    assert result.activity == []
    assert any("needs one" in n for n in result.notes)


def test_a_patrolling_robot_counts_the_places_in_its_range(tmp_path: Path) -> None:
    """Simulated office days (a robot patrolling, detections in its frame): the held-out day's
    windows are all robot-observed, and the activity sums, per window, the places within
    its sensor range then — all of them while it tours, fewer while it rests."""
    logs = []
    sessions = (("train", "2", "1", "2026-01-05"), ("test", "1", "2", "2026-01-07"))
    for name, days, seed, start in sessions:
        log = tmp_path / f"{name}.mcap"
        result = run("simulate", "-o", log, "--days", days, "--seed", seed, "--start", start)
        assert result.exit_code == 0, result.stderr
        logs.append(log)
    site = tmp_path / "office.aion"
    assert run("build", logs[0], "-o", site, "-q").exit_code == 0
    doc = run_json("evaluate", "holdout", site, logs[1], "--format", "json")
    test = doc["test"]
    assert test["robot_windows"] == test["windows"] == 144  # one day of 10-minute windows
    assert sum(doc["hourly_series"]["truth"]) == test["detections"]  # each in a window seen
    assert any("moving robot" in n for n in doc["notes"])
    activity = {a["model"]: a for a in doc["activity"]}
    assert activity["aion"]["poisson_deviance"] < activity["aion static"]["poisson_deviance"]

    from aion_cli.build_options import BuildOptions
    from aion_cli.held_out import read_held_out
    from aion_cli.mapquery import load_map

    state = load_map(site).state
    watch = state.entries.xyz[state.entries.canonical_order(), :2]
    held = read_held_out(BuildOptions(logs=(logs[1],)), state.config, watch=watch)
    sizes = {len(v) for v in held.seen.values()}
    assert max(sizes) == len(watch) > min(sizes) > 0  # touring sees all, resting a part

    # --base-frame reaches the reading (as aion build's does): a frame TF does not have
    # leaves no trajectory, so the same day is a fixed sensor's; an empty one is refused
    other = run_json("evaluate", "holdout", site, logs[1], "--base-frame", "nowhere",
                     "--format", "json")
    assert other["test"]["robot_windows"] == 0
    assert other["test"]["observation"].startswith("fixed sensor")
    empty = run("evaluate", "holdout", site, logs[1], "--base-frame", "")
    assert empty.exit_code == 2
    assert_one_line_error(empty.stderr, "--base-frame")
