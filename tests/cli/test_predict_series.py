"""``aion predict --from --to --step`` (aion_cli/prediction_series.py): every value is what
``predict --time`` says at that time, and a rhythm the map learnt shows in the series."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.api import Map
from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor

AT = "2026-11-23 08:30"
DAYS = 14
T_DAY = MONDAY + DAYS * DAY  # the Monday after two weeks of data


def _rush(day: int, hour: int) -> float:
    """People at 08-10 h (40 an hour), a few by day, nobody at night."""
    if 8 <= hour < 10:
        return 40.0
    return 4.0 if 6 <= hour < 20 else 0.0


@pytest.fixture(scope="module")
def rhythm(tmp_path_factory: pytest.TempPathFactory) -> Path:
    mapper = corridor(DAYS, _rush, cells=(4.0, 1.0))
    path = tmp_path_factory.mktemp("series") / "rush.aion"
    Map.from_state(mapper.state, timezone="UTC").save(path)
    return path


def _iso(t_ns: int) -> str:
    return str(t_ns // 10**9)  # UNIX seconds: an aion time form


def test_each_value_is_predict_at_that_time(rhythm: Path) -> None:
    start, end = T_DAY, T_DAY + 21 * HOUR
    doc = run_json(
        "predict", rhythm, "--from", _iso(start), "--to", _iso(end), "--step", "3h",
        "--format", "json",
    )
    assert doc["mode"] == "series"
    assert doc["times_ns"] == [start + k * 3 * HOUR for k in range(8)]
    assert len(doc["times"]) == 8
    assert doc["entries"]
    for j, t in enumerate(doc["times_ns"]):
        single = run_json("predict", rhythm, "--time", _iso(t), "--format", "json")
        by_id = {row["id"]: row for row in single["entries"]}
        assert len(by_id) == len(doc["entries"])  # every entry: no --top
        for entry in doc["entries"]:
            row = by_id[entry["id"]]
            assert entry["flow"][j] == row["flow"]
            assert entry["flow_per_hour"][j] == row["flow_per_hour"]
            assert (entry["x"], entry["y"], entry["kind"]) == (row["x"], row["y"], row["kind"])


def test_the_learnt_rush_shows_and_orders_the_entries(rhythm: Path) -> None:
    doc = run_json(
        "predict", rhythm, "--from", _iso(T_DAY), "--to", _iso(T_DAY + 23 * HOUR),
        "--format", "json",
    )
    means = [sum(f for f in e["flow"] if f is not None) / 24 for e in doc["entries"]]
    assert means == sorted(means, reverse=True)  # busiest over the series first
    busiest = doc["entries"][0]["flow"]
    assert busiest[9] > 5 * busiest[3]  # 09:00 against 03:00: the rush, not the night
    top = run_json(
        "predict", rhythm, "--from", _iso(T_DAY), "--to", _iso(T_DAY + 23 * HOUR), "--top", "2",
        "--format", "json",
    )
    assert top["entries"] == doc["entries"][:2]


def test_csv_and_table_forms(rhythm: Path) -> None:
    args = ("predict", rhythm, "--from", _iso(T_DAY + 6 * HOUR), "--to", _iso(T_DAY + 9 * HOUR))
    csv = run(*args, "--top", "3", "--format", "csv")
    assert csv.exit_code == 0, csv.stderr
    lines = csv.stdout.strip().splitlines()
    assert lines[0] == "time,time_ns,id,name,kind,layer,x,y,z,flow,flow_per_hour,hour_observed"
    assert len(lines) == 1 + 4 * 3  # 06:00 .. 09:00 hourly, three entries each
    table = run(*args, "--top", "3")
    assert table.exit_code == 0, table.stderr
    for label in ("06:00", "07:00", "08:00", "09:00"):
        assert label in table.stdout
    assert "from: " in table.stderr


def test_the_api_series_equals_the_cli(rhythm: Path) -> None:
    m = aion.Map.load(rhythm)
    series = m.predict_series(T_DAY, T_DAY + 5 * HOUR, "1h", top=4)
    doc = run_json(
        "predict", rhythm, "--from", _iso(T_DAY), "--to", _iso(T_DAY + 5 * HOUR), "--top", "4",
        "--format", "json",
    )
    assert series.records() == doc["entries"]
    assert series.times_ns == doc["times_ns"]
    assert series.flow.shape == (4, 6)
    seconds = m.predict_series(T_DAY, T_DAY + 5 * HOUR, 3600.0, top=4)
    assert seconds.records() == series.records()
    with pytest.raises(aion.InputError, match="step"):
        m.predict_series(T_DAY, T_DAY + HOUR, 0.5)


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--from", "2026-01-01"], "needs both --from and --to"),
        (["--to", "2026-01-01"], "needs both --from and --to"),
        (["--step", "1h"], "--step needs --from and --to"),
        (["--from", "2026-01-02", "--to", "2026-01-01"], "--to is before --from"),
        (["--from", "2026-01-01", "--to", "2026-01-02", "--historical"], "--historical"),
        (["--from", "2026-01-01", "--to", "2026-01-02", "--time", "now"], "--time or --from"),
        (["--historical", "--time", "now"], "it takes no --time"),
        (["--from", "2026-01-01", "--to", "2026-01-02", "--step", "0"], "at least 1 s"),
        (["--from", "2026-01-01", "--to", "2026-01-02", "--step", "fast"], "cannot read the step"),
        (["--from", "2026-01-01", "--to", "2026-03-01", "--step", "1m"], "at most 1,000"),
    ],
)
def test_bad_series_options(rhythm: Path, extra: list[str], fragment: str) -> None:
    result = run("predict", rhythm, *extra)
    assert result.exit_code == 2
    assert result.stdout == ""
    assert_one_line_error(result.stderr, fragment)


def test_a_step_longer_than_the_span_is_one_time(rhythm: Path) -> None:
    doc = run_json(
        "predict", rhythm, "--from", _iso(T_DAY), "--to", _iso(T_DAY + HOUR), "--step", "1d",
        "--top", "1", "--format", "json",
    )
    assert doc["times_ns"] == [T_DAY]
    assert math.isfinite(doc["entries"][0]["flow"][0])


def test_a_series_to_now_ends_now(rhythm: Path) -> None:
    """``--to now`` is the current time, not the series' start: from two days ago, daily,
    it holds three times (it had been the start alone, without a word), each one day after
    the one before; ``--to +2d`` from the same start counts from the start, as before."""
    import time

    before = time.time_ns()
    doc = run_json(
        "predict", rhythm, "--from", "-2d", "--to", "now", "--step", "1d", "--top", "1",
        "--tz", "UTC", "--format", "json",
    )
    times = doc["times_ns"]
    assert len(times) == 3
    assert [times[1] - times[0], times[2] - times[1]] == [DAY, DAY]
    assert before - 2 * DAY <= times[0] <= time.time_ns() - 2 * DAY
    relative = run_json(
        "predict", rhythm, "--from", _iso(T_DAY), "--to", "+2d", "--step", "1d", "--top", "1",
        "--format", "json",
    )
    assert relative["times_ns"] == [T_DAY, T_DAY + DAY, T_DAY + 2 * DAY]


def test_places_without_data_and_every_layer_agree_with_predict(office: Office) -> None:
    """The office graph has places no detection reached (flow 0 in predict's table): the
    series says the same for them, and for cells, rooms and buildings, at each time."""
    times = ["2026-11-23 07:00", "2026-11-23 08:30", "2026-11-23 12:00"]
    for layer in ("all", "places", "cells", "rooms", "buildings"):
        doc = run_json(
            "predict", office.map, "--layer", layer, "--tz", "UTC", "--from", times[0],
            "--to", times[-1], "--step", "90m", "--format", "json",
        )
        for j, t_text in enumerate(["2026-11-23 07:00", "2026-11-23 08:30", "2026-11-23 10:00"]):
            single = run_json("predict", office.map, "--layer", layer, "--tz", "UTC", "--time",
                              t_text, "--format", "json")
            flows = {row["id"]: (row["flow"], row["flow_per_hour"]) for row in single["entries"]}
            assert {e["id"] for e in doc["entries"]} == set(flows)
            for entry in doc["entries"]:
                assert (entry["flow"][j], entry["flow_per_hour"][j]) == flows[entry["id"]]
    places = run_json("predict", office.map, "--layer", "places", "--tz", "UTC", "--time",
                      times[0], "--format", "json")["entries"]
    assert any(row["flow"] == 0 for row in places)  # the case under test


def test_a_node_asked_for_twice_is_one_entry(office: Office) -> None:
    """Repeated ``--node`` ids (or a room by name and by id) are taken once: the rows of p4
    and p1, busiest first as always, not p4, p1, p4 (each was printed as often as given)."""
    def ids(*args: str) -> list[str]:
        doc = run_json("predict", office.map, *args, "--format", "json")
        return [e["id"] for e in doc["entries"]]

    assert ids("--time", AT, "--node", "p4", "--node", "p4") == ["p4"]
    both = ids("--time", AT, "--node", "p4", "--node", "p1")
    assert sorted(both) == ["p1", "p4"]
    assert ids("--time", AT, "--node", "p4", "--node", "p1", "--node", "p4") == both
    assert ids("--time", AT, "--node", "room1", "--node", "R1") == ["R1"]
    series = ids("--from", AT, "--to", "2026-11-23 10:30", "--node", "p4", "--node", "p4")
    assert series == ["p4"]
    m = aion.Map.load(office.map)
    assert [r["id"] for r in m.predict(AT, nodes=["p1", "p4", "p1"]).entries] == both
    table = m.predict_series(AT, "2026-11-23 10:30", nodes=["p1", "p1"])
    assert table.flow.shape == (1, 3)


def test_a_series_names_the_rooms_as_predict_does(sample_map: Path) -> None:
    """The sample's rooms carry names (samples/README.md): a series of rooms gives each entry
    the name ``predict --time --layer rooms`` gives it, in JSON, CSV and the table's headers."""
    span = ("--from", "2026-01-12 08:00", "--to", "2026-01-12 09:00", "--tz", "UTC")
    series = run_json("predict", sample_map, "--layer", "rooms", *span, "--format", "json")
    single = run_json(
        "predict", sample_map, "--layer", "rooms", "--time", "2026-01-12 08:00", "--tz", "UTC",
        "--format", "json",
    )
    named = {e["id"]: e["name"] for e in single["entries"]}
    assert named["R2"] == "kitchen"
    assert {e["id"]: e["name"] for e in series["entries"]} == named
    csv = run("predict", sample_map, "--layer", "rooms", *span, "--format", "csv")
    assert ",R2,kitchen,room,rooms," in csv.stdout
    table = run("predict", sample_map, "--layer", "rooms", *span)
    assert "kitchen (R2)" in table.stdout
    places = run_json("predict", sample_map, *span, "--top", "2", "--format", "json")
    assert [e["name"] for e in places["entries"]] == [None, None]  # places have no names
