"""``aion predict`` at hours no log observed (issue 12): the forecast there is each entry's
static rate — its detections over all its observed windows — which, where one hour of the day
held most detections, lies above every quiet hour's own rate. Checked against a rate counted by
hand, and the output must say which rows are extrapolated and what their number is."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.cli.conftest import run, run_json
from tests.engine.temporal_data import DAY, HOUR, MONDAY

DAYS = 4
WINDOW = 600 * 10**9
QUIET, BUSY = 2, 60
"""Detections per 10-minute window at the one place: QUIET at 09:00-16:00, BUSY at 16:00-17:00
(a crowd at the end of the day), nothing recorded outside 09:00-17:00."""
STATIC = (7 * 6 * QUIET + 6 * BUSY) / (8 * 6)
"""By hand: per day 7 quiet hours of 6 windows and one busy hour, over the 8 x 6 windows
observed (the same every day): (84 + 360) / 48 = 9.25 per window."""


@pytest.fixture(scope="module")
def office_hours(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    mapper = Mapper(ModelConfig())
    mapper.set_fixed_windows(np.concatenate([
        np.arange((MONDAY + d * DAY + 9 * HOUR) // WINDOW, (MONDAY + d * DAY + 17 * HOUR) // WINDOW)
        for d in range(DAYS)
    ]))
    for d in range(DAYS):
        for h in range(9, 17):
            per = BUSY if h == 16 else QUIET
            mids = MONDAY + d * DAY + h * HOUR + np.arange(6) * WINDOW + WINDOW // 2
            t = np.repeat(mids, per)
            n = t.size
            xyz = np.tile([0.3, 0.3, 0.0], (n, 1))  # one spot: one entry
            mapper.add_detections(DetectionBatch.from_arrays(t, xyz, np.zeros(n), np.ones(n)))
    mapper.advance(MONDAY + DAYS * DAY)
    path = tmp_path_factory.mktemp("unobserved") / "office_hours.aion"
    Map.from_state(mapper.state, timezone="UTC").save(path)
    return path


SERIES = ("--from", "2026-11-09 07:00", "--to", "2026-11-09 20:00", "--step", "1h", "--tz", "UTC")
"""The Monday a week after the data, 07:00-20:00: 07:00, 08:00, 17:00-20:00 unobserved."""


def test_an_unobserved_hour_forecasts_the_mean_per_observed_window(office_hours: Path) -> None:
    doc = run_json("predict", office_hours, *SERIES, "--format", "json")
    (entry,) = doc["entries"]
    flow = dict(zip([t[11:16] for t in doc["times"]], entry["flow"], strict=True))
    unobserved = ["07:00", "08:00", "17:00", "18:00", "19:00", "20:00"]
    assert [k for k, seen in zip(flow, doc["hour_observed"], strict=True) if not seen] == unobserved
    for hour in unobserved:
        assert flow[hour] == pytest.approx(STATIC, rel=1e-9)
    # the mean of the hours observed: above every quiet hour's own rate, below the busy one's
    for hour in ("09:00", "10:00", "12:00", "15:00"):
        assert flow[hour] < STATIC
    assert flow["16:00"] > STATIC


def test_the_table_marks_extrapolated_rows_and_says_what_they_are(office_hours: Path) -> None:
    """Before: the table showed 9.25 at 08:00 beside 2.0 at 10:00 with nothing on the row,
    and the note only said 'extrapolated from the hours observed' — read as a place busiest
    at hours it never observed. Now each such row says ``extrapolated`` and the note says the
    number is the static rate, a mean over all the hours observed."""
    out = run("predict", office_hours, *SERIES)
    rows = {line.split("│")[1].split()[0]: line for line in out.stdout.splitlines()
            if line.count("│") >= 2}
    for hour in ("07:00", "08:00", "17:00", "20:00"):
        assert "extrapolated" in rows[hour]
    for hour in ("09:00", "10:00", "16:00"):
        assert "extrapolated" not in rows[hour]
    note = " ".join(out.stderr.split())
    assert (
        "6 of the 14 times fall in hours no log observed on any day (07:00-09:00, 17:00-21:00 "
        "UTC; the map observed 09:00-17:00): their forecast is extrapolated from the hours "
        "observed, not measured: every entry at its static rate, its mean per window over all "
        "the hours observed"
    ) in note
    single = run("predict", office_hours, "--time", "2026-11-09 08:00", "--tz", "UTC")
    assert "not measured: every entry at its static rate" in " ".join(single.stderr.split())


def test_a_single_time_table_says_its_hour_is_extrapolated(office_hours: Path) -> None:
    """Before: ``predict --time 08:00`` titled its table "predicted flows at ..." as at 10:00;
    only the stderr note flagged the hour, and stdout kept in a file lost it. Now the title
    says it (as a series marks the row), for every form of the table; not at an observed hour,
    nor with --historical (what was observed has no hour)."""
    one = ("--tz", "UTC")
    for extra in ((), ("--top", "1"), ("--at", "0.3,0.3"), ("--node", "c4611688217451692032")):
        out = run("predict", office_hours, "--time", "2026-11-09 08:00", *one, *extra)
        assert out.exit_code == 0, out.stderr
        assert "(extrapolated: an hour no log observed)" in " ".join(out.stdout.split()), extra
    observed = run("predict", office_hours, "--time", "2026-11-09 10:00", *one)
    assert observed.exit_code == 0
    assert "extrapolated" not in observed.stdout
    assert "extrapolated" not in run("predict", office_hours, "--historical").stdout


@pytest.mark.parametrize("layer", ["rooms", "buildings", "places"])
def test_rooms_and_buildings_say_it_too(office: Any, layer: str) -> None:
    """The office log observed 08:00-08:20 (UTC) only: rooms and buildings, sums of their
    places' extrapolated forecasts at 07:00, say so in the title and the JSON."""
    at = ("--time", "2026-11-30 07:00", "--tz", "UTC", "--layer", layer)
    out = run("predict", office.map, *at)
    assert out.exit_code == 0, out.stderr
    assert "(extrapolated: an hour no log observed)" in " ".join(out.stdout.split())
    assert run_json("predict", office.map, *at, "--format", "json")["hour_observed"] is False
    seen = ("--time", "2026-11-30 08:10", "--tz", "UTC", "--layer", layer)
    assert "extrapolated" not in run("predict", office.map, *seen).stdout
    assert run_json("predict", office.map, *seen, "--format", "json")["hour_observed"] is True


def test_a_series_csv_says_which_rows_are_extrapolated(office_hours: Path) -> None:
    """Before: the series CSV (one row per time and entry) had no hour_observed, so 9.25 at
    08:00 read as measured beside 2.0 at 10:00 once stdout was a file; the JSON had the flags.
    Now each row carries its time's flag, the JSON's (lowercase, as JSON writes it)."""
    import csv
    import io

    out = run("predict", office_hours, *SERIES, "--format", "csv")
    assert out.exit_code == 0, out.stderr
    rows = list(csv.DictReader(io.StringIO(out.stdout)))
    doc = run_json("predict", office_hours, *SERIES, "--format", "json")
    assert [r["time"] for r in rows] == doc["times"]  # one entry: a row per time
    assert [r["hour_observed"] for r in rows] == [
        "true" if seen else "false" for seen in doc["hour_observed"]
    ]
    flags = {r["time"][11:16]: r["hour_observed"] for r in rows}
    assert (flags["08:00"], flags["09:00"], flags["16:00"], flags["17:00"]) == (
        "false", "true", "true", "false")


SELECTIONS = ((), ("--top", "1"), ("--at", "0.3,0.3"), ("--node", "c4611688217451692032"),
              ("--layer", "cells"))
"""Every way ``predict`` chooses its entries: all, the busiest, the one nearest a point, one
by id, a layer."""


@pytest.mark.parametrize("extra", SELECTIONS)
def test_a_single_time_csv_and_json_say_whether_the_hour_was_observed(
    office_hours: Path, extra: tuple[str, ...]
) -> None:
    """Before: ``predict --time T --format csv`` had no hour_observed column, so 9.25 at 08:00
    (the static rate, extrapolated) read as measured once stdout was a file, while the series
    CSV had the column. Now every row carries the time's flag, as the series CSV writes it and
    the JSON says it, whatever the selection; historically it is empty (no hour to speak of)
    and the JSON has no key."""
    import csv
    import io

    one = ("--tz", "UTC", *extra)
    for when, seen in (("2026-11-09 08:00", False), ("2026-11-09 10:00", True)):
        out = run("predict", office_hours, "--time", when, *one, "--format", "csv")
        assert out.exit_code == 0, out.stderr
        rows = list(csv.DictReader(io.StringIO(out.stdout)))
        assert len(rows) == 1  # the one entry
        assert out.stdout.splitlines()[0].endswith(",name,hour_observed")
        assert rows[0]["hour_observed"] == ("true" if seen else "false")
        flow = float(rows[0]["flow"])
        if seen:  # a quiet hour, measured: below the mean of the hours observed
            assert flow < STATIC
        else:  # the static rate, counted by hand
            assert flow == pytest.approx(STATIC, rel=1e-9)
        doc = run_json("predict", office_hours, "--time", when, *one, "--format", "json")
        assert doc["hour_observed"] is seen
        (entry,) = doc["entries"]
        assert entry["flow"] == pytest.approx(flow, abs=1e-9)  # the CSV has 9 decimals
    past = run("predict", office_hours, "--historical", *extra, "--format", "csv")
    assert [r["hour_observed"] for r in csv.DictReader(io.StringIO(past.stdout))] == [""]
    doc = run_json("predict", office_hours, "--historical", *extra, "--format", "json")
    assert "hour_observed" not in doc
