"""``aion predict``: values checked against the office log's known people and directions."""

from __future__ import annotations

import cmath
import csv
import io
import json
import math
import zipfile
from pathlib import Path
from typing import Any

import pytest

from aion_cli.engine.temporal.direction_prior import FALLBACK
from tests.cli.conftest import Office, assert_one_line_error, run, run_json, run_process

AT = "2026-11-23 08:30"


def entries(office: Office, *args: str) -> dict[str, dict[str, Any]]:
    doc = run_json("predict", office.map, *args, "--format", "json")
    return {e["id"]: e for e in doc["entries"]}


WALKED = {4: 0.0, 2: -90.0, 0: 180.0}
"""The tracks' headings (tests/cli/logdata.py: velocities +x, -y, -x), by the bin each falls
in: the direction a bin's detections went, which the map keeps per bin."""


def _circular_mean_deg(hist: list[float], walked: dict[int, float] | None = None) -> float:
    """Circular mean of a B-bin histogram, bin b at ``walked[b]`` degrees where its
    detections' direction is known, else at its centre -180 + (b + 0.5)·360/B degrees."""
    b = len(hist)
    at = [(walked or {}).get(k, -180.0 + (k + 0.5) * 360.0 / b) for k in range(b)]
    z = sum(p * cmath.exp(1j * math.radians(a)) for p, a in zip(hist, at, strict=True))
    return math.degrees(cmath.phase(z))


def _same_angle(a: float, b: float, tol: float = 1e-9) -> bool:
    """Equal as directions (180 and -180 degrees are the same)."""
    return abs((a - b + 180.0) % 360.0 - 180.0) <= tol


def _static_histograms(kappa: float) -> dict[str, list[float]]:
    """The predicted (static family) histograms of p1, p3, p4, from the log's known counts and
    the documented prior: p_map = (N_map + 1) / (N_map + B) (Laplace), the room's
    p_g = (N_g + κ p_map) / (N_g + κ), the place's h = (N_e + κ p_g) / (N_e + κ)."""
    b = 8
    counts = {"p1": {4: 120}, "p4": {2: 120}, "p3": {0: 60}}  # tracks 1, 2, 3 (logdata.py)
    rooms = {"p1": ("p0", "p1"), "p3": ("p2", "p3", "p4"), "p4": ("p2", "p3", "p4")}

    def vec(place: str) -> list[float]:
        return [float(counts.get(place, {}).get(k, 0)) for k in range(b)]

    n_map = [sum(vec(p)[k] for p in counts) for k in range(b)]
    p_map = [(n + 1.0) / (sum(n_map) + b) for n in n_map]
    out = {}
    for place, room in rooms.items():
        n_g = [sum(vec(p)[k] for p in room) for k in range(b)]
        p_g = [(n + kappa * q) / (sum(n_g) + kappa) for n, q in zip(n_g, p_map, strict=True)]
        n_e = vec(place)
        out[place] = [(n + kappa * q) / (sum(n_e) + kappa) for n, q in zip(n_e, p_g, strict=True)]
    return out


def test_dominant_directions_are_the_walking_directions(office: Office) -> None:
    """The predicted histogram is the static posterior (one day: nothing scored yet, so every
    entry forecasts with ``static``), pulled toward the room's and the map's histograms by the
    Dirichlet prior of the map's ``direction_prior`` κ; its circular mean moves off the
    direction its detections went by that pull (p3 shares room R1 with p4, who walks at
    -90°; a bin the prior fills sits where the room's or the map's people walked, a bin
    nobody walked at its centre), but the dominant direction, the most frequent bin's, is the
    walking direction itself, predicted and historically (not the bin's centre)."""
    kappa = run_json("info", office.map, "--format", "json")["config"]["direction_prior"]
    if kappa == "auto":  # three people's places: too few to estimate κ (MIN_ENTRIES)
        kappa = FALLBACK
    rows = entries(office, "--time", AT)
    hist = _static_histograms(kappa)
    historical = entries(office, "--historical")
    # the walking directions (bin centres for B = 8 would be 22.5, -67.5 and -157.5 degrees)
    expected = {"p1": (4, 0.0), "p4": (2, -90.0), "p3": (0, 180.0)}
    for node, (bin_, angle) in expected.items():
        row = rows[node]
        assert row["kind"] == "node"
        assert row["direction_bin"] == bin_
        assert row["histogram"] == pytest.approx(hist[node], abs=1e-12)
        # the pull moves the circular mean (every bin someone walked at that walking
        # direction, the bins nobody walked at their centres), not the most frequent bin
        assert not _same_angle(_circular_mean_deg(hist[node], WALKED), angle)
        assert _same_angle(row["direction_deg"], angle)
        assert max(row["histogram"]) == row["histogram"][bin_] > 0.5
        assert sum(row["histogram"]) == pytest.approx(1.0)
        assert row["mean_speed"] == pytest.approx(1.0)
        assert row["flow"] > 0
        assert (row["family"], row["direction_family"]) == ("static", "static")
        past = historical[node]
        assert past["histogram"] == [1.0 if k == bin_ else 0.0 for k in range(8)]
        assert _same_angle(past["direction_deg"], angle)
    for node in ("p0", "p2", "p5", "p6"):  # nobody there
        assert rows[node]["flow"] == 0
        assert rows[node]["direction_deg"] is None
    assert (rows["p1"]["x"], rows["p1"]["y"]) == (2.0, 0.0)


def test_static_model_without_prior_predicts_what_was_observed(
    office: Office, tmp_path: Path
) -> None:
    """``families = ["static"]`` and ``direction_prior = 0``: the prediction at any time equals
    the historical table in flow and histogram (the walking directions' bins)."""
    from aion_cli.engine.config import ModelConfig

    config = tmp_path / "static.toml"
    config.write_text(ModelConfig(families=("static",), direction_prior=0.0).to_toml())
    out = tmp_path / "static.aion"
    run_json("build", office.log, "-o", out, "--config", config, "--format", "json")
    past = {
        e["id"]: e for e in run_json("predict", out, "--historical", "--format", "json")["entries"]
    }
    for at in (AT, "2026-11-28 03:10"):  # the log's morning; a Saturday night
        now = {
            e["id"]: e
            for e in run_json("predict", out, "--time", at, "--format", "json")["entries"]
        }
        assert set(now) == set(past)
        for node, row in now.items():
            assert row["flow"] == past[node]["flow"], node
            assert row["histogram"] == pytest.approx(past[node]["histogram"], abs=1e-12), node
    bins = {"p1": 4, "p4": 2, "p3": 0}
    for node, bin_ in bins.items():
        assert _same_angle(now[node]["direction_deg"], WALKED[bin_])
        assert (now[node]["family"], now[node]["direction_family"]) == ("static", "static")


def test_historical_counts_per_window(office: Office) -> None:
    doc = run_json("predict", office.map, "--historical", "--format", "json")
    assert doc["mode"] == "historical"
    assert doc["time"] is None
    rows = {e["id"]: e for e in doc["entries"]}
    # 120 detections over the two windows the robot watched (one closed, one open)
    assert rows["p1"]["flow"] == pytest.approx(60.0)
    assert rows["p4"]["flow"] == pytest.approx(60.0)
    # track 3 left after the first window; the open window counts as closing it now would
    # record it: the robot at (3, 0) watched p3 (3 m away, 8-m range) in both windows, so
    # 60 detections in two windows
    assert rows["p3"]["flow"] == pytest.approx(30.0)
    assert rows["p1"]["flow_per_hour"] == pytest.approx(360.0)
    assert rows["p1"]["histogram"][4] == pytest.approx(1.0)
    assert rows["p1"]["entropy"] == pytest.approx(0.0, abs=1e-9)


def test_historical_help_says_what_it_prints(office: Office) -> None:
    """``--historical`` printed detections per observed window (p1: 120 detections over two
    windows, 60) while its help said "cumulative counts" (120): the help says what it prints."""
    rows = {e["id"]: e for e in run_json("predict", office.map, "--historical", "--format",
                                           "json")["entries"]}
    assert rows["p1"]["flow"] == pytest.approx(120 / 2)
    text = " ".join(run("predict", "--help").output.split())
    said = text.split("--historical", 1)[1].split("--node", 1)[0]
    assert "per observed window" in said
    assert "cumulative" not in said


def test_a_layer_is_named_in_any_case(office: Office) -> None:
    """``--format JSON`` was accepted but ``--layer Rooms`` refused (exit 2, "'Rooms' is not
    one of ..."): it now answers as ``--layer rooms``."""
    rooms = entries(office, "--time", "2026-11-23T09:30:00+01:00", "--layer", "rooms")
    assert rooms
    assert entries(office, "--time", "2026-11-23T09:30:00+01:00", "--layer", "Rooms") == rooms
    assert entries(office, "--time", "2026-11-23T09:30:00+01:00", "--layer", "ROOMS") == rooms


def test_json_document_metadata_and_sorting(office: Office) -> None:
    doc = run_json("predict", office.map, "--time", "2026-11-23T09:30:00+01:00", "--format", "json")
    assert doc["mode"] == "predicted"
    assert doc["time_ns"] == 1795422600 * 1_000_000_000  # 08:30 UTC
    assert doc["bins"] == 8
    assert doc["bin_centres_deg"][4] == pytest.approx(22.5)
    flows = [e["flow"] for e in doc["entries"]]
    assert flows == sorted(flows, reverse=True)


def test_node_at_top_and_layer_selection(office: Office) -> None:
    (row,) = entries(office, "--time", AT, "--node", "p4").values()
    assert row["id"] == "p4"
    (row,) = entries(office, "--time", AT, "--layer", "rooms", "--node", "R1").values()
    assert row["kind"] == "room"
    # rooms and buildings asked for alone are answered on their layer without --layer
    assert entries(office, "--time", AT, "--node", "R1") == {"R1": row}
    (building,) = entries(office, "--time", AT, "--node", "B0").values()
    assert building["kind"] == "building"
    result = run("predict", office.map, "--time", AT, "--node", "R1", "--node", "p4")
    assert result.exit_code == 2  # a room beside a place: one table cannot hold both
    assert "asked for alone" in result.stderr
    (row,) = entries(office, "--time", AT, "--at", "5.8,0.3").values()
    assert row["id"] == "p3"
    top = entries(office, "--time", AT, "--top", "2")
    assert len(top) == 2
    assert set(top) <= {"p1", "p3", "p4"}
    rooms = entries(office, "--time", AT, "--layer", "rooms")
    assert set(rooms) == {"R0", "R1", "R2"}
    assert rooms["R1"]["flow"] > rooms["R0"]["flow"] > rooms["R2"]["flow"] == 0
    places = entries(office, "--time", AT, "--layer", "places")
    assert set(places) == {f"p{i}" for i in range(7)}
    buildings = entries(office, "--time", AT, "--layer", "buildings")
    assert set(buildings) == {"B0"}


def test_csv_has_flat_histogram_columns(office: Office) -> None:
    result = run("predict", office.map, "--time", AT, "--format", "csv", "--node", "p1")
    assert result.exit_code == 0, result.stderr
    (row,) = list(csv.DictReader(io.StringIO(result.stdout)))
    assert row["id"] == "p1"
    assert float(row["histogram_4"]) > 0.9
    assert "histogram_7" in row
    assert float(row["direction_deg"]) == pytest.approx(0.0, abs=1.0)  # along +x


def test_table_output_and_the_zone_on_stderr(office: Office) -> None:
    result = run("predict", office.map, "--time", AT, "--tz", "Europe/Berlin")
    assert result.exit_code == 0, result.stderr
    assert "p1" in result.stdout
    assert "time: 2026-11-23 08:30:00+01:00 (Europe/Berlin)" in result.stderr


def test_a_forecast_says_why_it_does_not_change_with_the_time(office: Office) -> None:
    """The office map holds 20 minutes: no day was scored, so every entry keeps its static
    rate, and a time two months before the log is named as such (stderr, beside the time)."""
    result = run("predict", office.map, "--time", "2026-09-20 08:30", "--top", "1")
    assert result.exit_code == 0, result.stderr
    assert "every entry forecasts its static rate, whatever the time" in result.stderr
    assert "this time is 9 weeks before the map's data (2026-11-23)" in result.stderr
    assert "static rate" not in result.stdout
    plan = run("plan", office.map, "--from", "p1", "--to", "p2", "--time", AT)
    assert "every entry forecasts its static rate" in plan.stderr
    assert "before the map's data" not in plan.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--time", "half past eight"], "half past eight"),
        (["--time", AT, "--tz", "Mars/Olympus"], "Mars/Olympus"),
        (["--node", "p99"], "p99"),
        (["--node", "kitchen"], "kitchen"),
        (["--at", "1,2,3,4"], "--at"),
        (["--at", "3900,1700"], "farther than the whole map spans"),  # millimetres?
        (["--at", "1e300,0"], "is 1e+300 m from the nearest entry"),  # not 301 digits
        (["--layer", "floors"], "floors"),
    ],
)
def test_bad_input_is_one_line_exit_2(office: Office, args: list[str], fragment: str) -> None:
    result = run("predict", office.map, *args)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)
    assert result.stdout == ""


def _rewrite_manifest(src: Path, dst: Path, **changes: Any) -> None:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "manifest.json":
                manifest = json.loads(data)
                manifest.update(changes)
                data = json.dumps(manifest).encode()
            zout.writestr(item, data)


def test_map_from_a_newer_version_and_broken_maps(office: Office, tmp_path: Path) -> None:
    newer = tmp_path / "newer.aion"
    _rewrite_manifest(office.map, newer, version="9.0")
    result = run("predict", newer, "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "9.0", "newer")
    junk = tmp_path / "junk.aion"
    junk.write_bytes(b"PK\x03\x04 garbage")
    result = run("predict", junk, "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)
    result = run("predict", tmp_path, "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "folder")


def test_subprocess_predict_json(office: Office) -> None:
    proc = run_process("predict", office.map, "--time", AT, "--node", "p1", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    (row,) = json.loads(proc.stdout)["entries"]
    assert row["direction_bin"] == 4
    assert "time: 2026-11-23 08:30:00+00:00" in proc.stderr


def test_the_map_zone_is_the_default_zone(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "berlin.aion"
    run_json("build", office.log, "-o", out, "--tz", "Europe/Berlin", "--format", "json")
    doc = run_json("predict", out, "--time", AT, "--format", "json")
    assert doc["zone"] == "Europe/Berlin"
    assert doc["time_ns"] == 1795419000 * 1_000_000_000  # 08:30 CET = 07:30 UTC
    doc = run_json("predict", out, "--time", AT, "--tz", "UTC", "--format", "json")
    assert doc["zone"] == "UTC"
    result = run("build", office.log, "-o", tmp_path / "x.aion", "--tz", "Atlantis/Capital")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "Atlantis/Capital")


def test_terminal_table_is_limited_but_json_is_not(
    office: Office, monkeypatch: pytest.MonkeyPatch
) -> None:
    import aion_cli.cli.predict as predict_module

    monkeypatch.setattr(predict_module, "TABLE_LIMIT", 2)
    result = run("predict", office.map, "--time", AT)
    assert result.exit_code == 0
    assert "showing the 2 busiest of 7 entries" in result.stderr
    assert "p0" not in result.stdout
    assert len(entries(office, "--time", AT)) == 7


def test_load_map_gives_state_graph_and_manifest(office: Office) -> None:
    from aion_cli.mapquery import load_map

    state, graph, manifest = load_map(office.map)
    assert graph is not None
    assert len(graph.places) == 7
    assert manifest["counts"]["used"] == 300
    assert state.config.bins == 8
    # a path given as a string, as a script writes it (it raised AttributeError)
    from aion_cli.mapquery import load_map_head

    again = load_map(str(office.map))
    assert again.manifest == manifest
    assert load_map_head(str(office.map)).manifest == manifest


def test_subprocess_bad_inputs_are_one_line_exit_2(office: Office, tmp_path: Path) -> None:
    """The installed script on a mistyped time and a map from a newer aion (the CliRunner
    tests above cover every other mistake; tests/robustness runs more through subprocesses)."""
    from concurrent.futures import ThreadPoolExecutor

    newer = tmp_path / "newer.aion"
    _rewrite_manifest(office.map, newer, version="3.0")  # this aion writes format 2.1
    cases = {
        "25:99": ["predict", office.map, "--time", "25:99"],
        "3.0": ["predict", newer],
    }
    with ThreadPoolExecutor(max_workers=2) as pool:
        procs = dict(zip(cases, pool.map(lambda a: run_process(*a), cases.values()), strict=True))
    for fragment, proc in procs.items():
        assert proc.returncode == 2, (fragment, proc.stderr)
        assert_one_line_error(proc.stderr, fragment)
        assert proc.stdout == ""


def test_a_map_of_format_1_must_be_rebuilt(office: Office, tmp_path: Path) -> None:
    """Format 1 held the old FreMEn state; this aion refuses it with a hint to rebuild."""
    older = tmp_path / "older.aion"
    _rewrite_manifest(office.map, older, version="1.0")
    for args in (["predict", older, "--time", AT], ["info", older]):
        result = run(*args)
        assert result.exit_code == 2
        assert_one_line_error(result.stderr, "1.0", "older")
        hints = [line for line in result.stderr.splitlines() if line.startswith("hint: ")]
        assert len(hints) == 1, result.stderr
        assert "rebuild" in hints[0], result.stderr
        assert result.stdout == ""
    proc = run_process("predict", older, "--time", AT)
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "older")
    assert "rebuild" in proc.stderr


def test_an_unknown_id_in_a_map_of_cells_points_to_at_and_top(tmp_path: Path) -> None:
    """A map without a scene graph holds hash cells only, whose ids are spatial-hash keys: a
    wrong id is told how to find a cell (by position, or from --top), not that the map is
    empty."""
    import numpy as np

    from aion_cli.engine.types import DetectionBatch
    from aion_cli.formats.tracks_log import tracks_to_log

    n = 60
    t = 1_762_070_400 * 10**9 + np.arange(n) * 10**9
    xyz = np.column_stack([np.linspace(0.0, 3.0, n), np.zeros(n), np.zeros(n)])
    log = tmp_path / "cells.mcap"
    tracks_to_log(DetectionBatch.from_arrays(t, xyz, np.zeros(n), np.ones(n), np.zeros(n)), log)
    out = tmp_path / "cells.aion"
    assert run("build", log, "-o", out, "-q").exit_code == 0
    cells = len(run_json("predict", out, "--historical", "--format", "json")["entries"])
    assert cells > 1
    result = run("predict", out, "--historical", "--node", "c123")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "c123")
    assert f"only {cells:,} hash cells" in result.stderr
    assert "--at X,Y" in result.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["predict", "MAP", "--time", AT, "--tz", ""], "empty time zone"),
        (["predict", "MAP", "--time", AT, "--tz", " "], "empty time zone"),
        (["predict", "MAP", "--node", "p4", "--from", AT, "--to", AT, "--step", ""],
         "cannot read the step"),
        (["plan", "MAP", "--from", "p1", "--to", "p2", "--leave", f"{AT}..+1h", "--step", ""],
         "cannot read the step"),
        (["export", "MAP", "--time", "", "-o", "OUT"], "empty time"),
    ],
)
def test_an_empty_value_is_an_error_not_the_default(
    office: Office, tmp_path: Path, args: list[str], fragment: str
) -> None:
    """An unset shell variable ("$TZ" empty) must not silently mean the machine's zone, the
    default step or now."""
    argv = [office.map if a == "MAP" else tmp_path / "out" if a == "OUT" else a for a in args]
    result = run(*argv)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, fragment)
    assert not (tmp_path / "out").exists()


def test_rooms_carry_the_names_the_graph_gives_them(office: Office) -> None:
    """The test office's graph names its rooms room0..room2 (Hydra-like labels): predict's
    rows say so in JSON, CSV and the table; places and cells have none."""
    rows = run_json("predict", office.map, "--time", AT, "--layer", "rooms", "--format",
                    "json")["entries"]
    names = {row["id"]: row["name"] for row in rows}
    assert names["R1"] == "room1"
    places = run_json("predict", office.map, "--time", AT, "--format", "json")["entries"]
    assert {row["name"] for row in places} == {None}
    csv_text = run("predict", office.map, "--time", AT, "--layer", "rooms", "--format",
                   "csv").stdout
    header, first = csv_text.splitlines()[:2]
    name = header.split(",").index("name")
    assert first.split(",")[name].startswith("room")
    table = run("predict", office.map, "--time", AT, "--layer", "rooms").stdout
    assert "room1" in table
