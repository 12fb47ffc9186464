"""A real THÖR run through the user's path: ``convert --start --tz`` -> ``info`` -> ``build``
-> ``predict --historical``, every answer checked against the CSV itself, read here with
numpy: the detections are conserved, the hours and times are Örebro's, and each busy place
holds the people nearest it, walking the way the file's own ``motion_angle_rad`` column says.
(``info`` gave the hours with messages in UTC, 11:00-12:00, where the map built from the same
log says 12:00-13:00 Europe/Stockholm.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def test_a_thor_run_keeps_its_people_hours_and_directions(tmp_path: Path) -> None:
    from datetime import datetime
    from zoneinfo import ZoneInfo

    csv = real("thor", "thor1-exp-1-run-2.csv")
    rows = np.loadtxt(csv, delimiter=",")  # time_s from 0, id, x, y, speed, motion angle
    start = datetime(2026, 1, 5, 12, 0, tzinfo=ZoneInfo("Europe/Stockholm"))  # a Monday
    log = tmp_path / "thor.mcap"
    converted = run("convert", csv, "--layout", "thor", "--start", "2026-01-05 12:00",
                    "--tz", "Europe/Stockholm", "-o", log, "-q")  # fmt: skip
    assert converted.exit_code == 0, converted.stderr

    info = run_json("info", log, "--format", "json")
    assert info["declared_zones"] == {str(log): "Europe/Stockholm"}
    hours = "weekdays 12:00-13:00; weekends none (Europe/Stockholm)"  # 4 minutes from 12:00
    assert info["fixed_sensor"]["hours_with_messages"] == hours

    built = tmp_path / "thor.aion"
    made = run("build", log, "--derive-graph", "--workers", "1", "-o", built, "-q")
    assert made.exit_code == 0, made.stderr
    described = run_json("info", built, "--format", "json")
    assert described["counts"]["used"] == len(rows)  # every row, none lost or doubled
    assert described["timezone"] == "Europe/Stockholm"
    first_ns = round((start.timestamp() + rows[:, 0].min()) * 1e9)
    assert abs(described["time_span"]["start_ns"] - first_ns) < 1_000  # to float rounding
    shown = " ".join(run("info", built).stdout.split())  # the zone named once, by the span
    assert hours.removesuffix(" (Europe/Stockholm)") in shown
    assert "Europe/Stockholm" in shown

    timed = run_json("predict", built, "--time", "2026-01-05 12:02", "--format", "json", "-q")
    assert (timed["zone"], timed["time"]) == ("Europe/Stockholm", "2026-01-05 12:02:00+01:00")
    doc = run_json("predict", built, "--historical", "--format", "json", "-q")
    nodes = [e for e in doc["entries"] if e["kind"] == "node"]
    xy = np.array([[e["x"], e["y"]] for e in nodes])
    nearest = np.hypot(rows[:, None, 2] - xy[None, :, 0], rows[:, None, 3] - xy[None, :, 1])
    owner = nearest.argmin(axis=1)
    counts = np.bincount(owner, minlength=len(nodes))
    busiest = np.argsort(-counts)[:5]
    flows = np.array([nodes[i]["flow"] for i in busiest])
    # one window's detections scaled by the share of it recorded: the same factor for all
    ratio = flows / counts[busiest]
    np.testing.assert_allclose(ratio, np.median(ratio), rtol=0.05)
    for i in busiest:
        walking = (owner == i) & (rows[:, 4] > 0)
        raw, _ = np.histogram(np.degrees(rows[walking, 5]), bins=8, range=(-180, 180))
        shown = np.asarray(nodes[i]["histogram"])
        assert int(np.argmax(shown)) == int(np.argmax(raw)), nodes[i]["id"]
        np.testing.assert_allclose(shown, raw / raw.sum(), atol=0.1)
