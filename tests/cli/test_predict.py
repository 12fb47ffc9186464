"""``aion predict``: values checked against the office log's known people and directions."""

from __future__ import annotations

import csv
import io
import json
import zipfile
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json, run_process

AT = "2026-11-23 08:30"


def entries(office: Office, *args: str) -> dict[str, dict[str, Any]]:
    doc = run_json("predict", office.map, *args, "--format", "json")
    return {e["id"]: e for e in doc["entries"]}


def test_dominant_directions_are_the_walking_directions(office: Office) -> None:
    rows = entries(office, "--time", AT)
    # bin centres for B = 8: -157.5, -112.5, ..., 157.5 degrees
    expected = {"p1": (4, 22.5), "p4": (2, -67.5), "p3": (0, -157.5)}
    for node, (bin_, angle) in expected.items():
        row = rows[node]
        assert row["kind"] == "node"
        assert row["direction_bin"] == bin_
        assert row["direction_deg"] == pytest.approx(angle, abs=1.0)
        assert row["histogram"][bin_] > 0.9
        assert sum(row["histogram"]) == pytest.approx(1.0)
        assert row["mean_speed"] == pytest.approx(1.0)
        assert row["flow"] > 0
    for node in ("p0", "p2", "p5", "p6"):  # nobody there
        assert rows[node]["flow"] == 0
        assert rows[node]["direction_deg"] is None
    assert (rows["p1"]["x"], rows["p1"]["y"]) == (2.0, 0.0)


def test_historical_counts_per_window(office: Office) -> None:
    doc = run_json("predict", office.map, "--historical", "--format", "json")
    assert doc["mode"] == "historical"
    assert doc["time"] is None
    rows = {e["id"]: e for e in doc["entries"]}
    # 120 detections over the two windows the robot watched (one closed, one open)
    assert rows["p1"]["flow"] == pytest.approx(60.0)
    assert rows["p4"]["flow"] == pytest.approx(60.0)
    # track 3 left after the first window; the open window is not closed yet, so it counts
    # as observed only where it has detections: 60 detections in one window
    assert rows["p3"]["flow"] == pytest.approx(60.0)
    assert rows["p1"]["flow_per_hour"] == pytest.approx(360.0)
    assert rows["p1"]["histogram"][4] == pytest.approx(1.0)
    assert rows["p1"]["entropy"] == pytest.approx(0.0, abs=1e-9)


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
    result = run("predict", office.map, "--time", AT, "--node", "R1")
    assert result.exit_code == 2
    assert "--layer rooms" in result.stderr
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
    assert float(row["direction_deg"]) == pytest.approx(22.5, abs=1.0)


def test_table_output_and_the_zone_on_stderr(office: Office) -> None:
    result = run("predict", office.map, "--time", AT, "--tz", "Europe/Berlin")
    assert result.exit_code == 0, result.stderr
    assert "p1" in result.stdout
    assert "time: 2026-11-23 08:30:00+01:00 (Europe/Berlin)" in result.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--time", "half past eight"], "half past eight"),
        (["--time", AT, "--tz", "Mars/Olympus"], "Mars/Olympus"),
        (["--node", "p99"], "p99"),
        (["--node", "kitchen"], "kitchen"),
        (["--at", "1,2,3,4"], "--at"),
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
    from aion_cli.pipeline import load_map

    state, graph, manifest = load_map(office.map)
    assert graph is not None
    assert len(graph.places) == 7
    assert manifest["counts"]["used"] == 300
    assert state.config.bins == 8


def test_subprocess_bad_inputs_are_one_line_exit_2(office: Office, tmp_path: Path) -> None:
    """The installed script on a mistyped time and a map from a newer aion (the CliRunner
    tests above cover every other mistake; tests/robustness runs more through subprocesses)."""
    from concurrent.futures import ThreadPoolExecutor

    newer = tmp_path / "newer.aion"
    _rewrite_manifest(office.map, newer, version="2.0")
    cases = {
        "25:99": ["predict", office.map, "--time", "25:99"],
        "2.0": ["predict", newer],
    }
    with ThreadPoolExecutor(max_workers=2) as pool:
        procs = dict(zip(cases, pool.map(lambda a: run_process(*a), cases.values()), strict=True))
    for fragment, proc in procs.items():
        assert proc.returncode == 2, (fragment, proc.stderr)
        assert_one_line_error(proc.stderr, fragment)
        assert proc.stdout == ""
