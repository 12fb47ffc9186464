"""``aion predict``: the temporal model's fields (families, predictive intervals) in its
table, CSV and JSON rows, on the office log's maps."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from tests.cli.conftest import Office, build_office_days, run, run_json
from tests.cli.test_predict import entries

AT = "2026-11-23 08:30"


def test_rows_name_their_families_and_a_predictive_interval(office: Office) -> None:
    """One day of log: nothing scored yet, so every entry forecasts with ``static`` and the
    dispersion is 1: the interval is the Poisson one around the flow (p1 and p4 at 120
    detections in 2 windows: Poisson(60); p3 at 60 in 2: Poisson(30)); p0 and p2, which the
    robot watched empty, at 0."""
    from scipy import stats

    rows = entries(office, "--time", AT)
    for node, flow in (("p1", 60.0), ("p4", 60.0), ("p3", 30.0)):
        row = rows[node]
        assert row["flow"] == pytest.approx(flow)
        assert row["family"] == "static"
        assert row["direction_family"] == "static"
        assert row["flow_p10"] == stats.poisson.ppf(0.1, flow)
        assert row["flow_p90"] == stats.poisson.ppf(0.9, flow)
        assert row["flow_p10"] <= row["flow"] <= row["flow_p90"]
    for node in ("p0", "p2"):  # watched by the robot, nobody there: static, 0 per window
        row = rows[node]
        assert row["flow"] == 0.0
        assert (row["family"], row["direction_family"]) == ("static", "static")
        assert row["flow_p10"] == row["flow_p90"] == 0.0
    for node in ("p5", "p6"):  # 17 m from the robot: never observed, no entry
        row = rows[node]
        assert (row["family"], row["direction_family"]) == ("none", "none")
        assert row["flow_p10"] == row["flow_p90"] == 0.0
    for row in rows.values():
        assert row["flow_p10"] <= row["flow_p90"]
        assert float(row["flow_p10"]).is_integer()
        assert float(row["flow_p90"]).is_integer()
    past = entries(office, "--historical")
    for row in past.values():
        assert row["flow_p10"] is None
        assert row["flow_p90"] is None
    for node in ("p1", "p3", "p4"):
        assert (past[node]["family"], past[node]["direction_family"]) == (
            "historical",
            "historical",
        )
    rooms = entries(office, "--time", AT, "--layer", "rooms")
    assert rooms["R1"]["family"] == "aggregate"


def test_csv_carries_the_new_columns(office: Office) -> None:
    result = run("predict", office.map, "--time", AT, "--format", "csv", "--node", "p3")
    assert result.exit_code == 0, result.stderr
    (row,) = list(csv.DictReader(io.StringIO(result.stdout)))
    assert (row["family"], row["direction_family"]) == ("static", "static")
    assert float(row["flow_p10"]) <= float(row["flow"]) <= float(row["flow_p90"])


def test_a_scored_day_keeps_rows_consistent(tmp_path: Path) -> None:
    """Three days of the office log: the middle day is scored against the first (the last
    stays pending), so the dispersion is estimated; intervals stay ordered around the flow and
    the families are the documented names."""
    out = build_office_days(tmp_path)
    flow_names = {"static", "shape", "profile", *(f"fremen{m}" for m in range(1, 5))}
    direction_names = flow_names - {"shape"}
    doc = run_json("predict", out, "--time", "2026-11-26 08:05", "--format", "json")
    rows = {e["id"]: e for e in doc["entries"]}
    for node in ("p1", "p3", "p4"):
        row = rows[node]
        assert row["family"] in flow_names
        assert row["direction_family"] in direction_names
        assert row["flow_p10"] <= row["flow"] <= row["flow_p90"]
