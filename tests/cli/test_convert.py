"""``aion convert``: a canonical tracks CSV becomes a log that ``aion build`` learns from."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.logdata import T0, save_graph_file

S = 1_000_000_000


def write_tracks(path: Path) -> int:
    """Two people walking +x along y = 0 and y = 0.4 at 1 m/s, 1 Hz, for 60 s."""
    lines = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    for k in range(60):
        for track, y in ((1, 0.0), (2, 0.4)):
            lines.append(f"{T0 + k * S},{track},{0.1 + k * 0.1:.3f},{y},0.0,0.0,1.0")
    path.write_text("\n".join(lines) + "\n")
    return 120


def test_convert_then_build_and_predict(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    n = write_tracks(csv)
    log = tmp_path / "tracks.mcap"
    result = run("convert", csv, "-o", log)
    assert result.exit_code == 0, result.stderr
    assert f"{n} detections of 2 tracks" in result.stderr
    info = run_json("info", log, "--format", "json")
    assert info["will_use"]["detections"] == ["/people_tracker/tracked_persons"]
    report = run_json("build", log, "--derive-graph", "--format", "json")
    assert report["detections"]["used"] == n
    assert report["observation"] == "fixed sensor over the log's time span"
    assert report["nodes"] >= 1
    doc = run_json(
        "predict", tmp_path / "tracks.aion", "--historical", "--layer", "places", "--format", "json"
    )
    with_flow = [e for e in doc["entries"] if e["flow"]]
    assert len(with_flow) == report["nodes_with_flow"] >= 1
    for entry in with_flow:
        assert entry["direction_bin"] == 4, entry  # heading 0 rad: bin [0, 45) degrees
        assert entry["direction_deg"] == pytest.approx(22.5, abs=1.0)


def test_convert_with_graph_into_a_bag(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    graph = save_graph_file(tmp_path / "dsg.json")
    bag = tmp_path / "tracks.bag"
    result = run("convert", csv, "-o", bag, "--graph", graph)
    assert result.exit_code == 0, result.stderr
    report = run_json("build", bag, "--format", "json")
    assert report["graph"]["source"] == "log"
    assert report["nodes"] == 7


def test_bad_inputs(tmp_path: Path) -> None:
    result = run("convert", tmp_path / "none.csv", "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "none.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1,2,three,4,5,6,7\n")
    result = run("convert", bad, "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "bad.csv")
    good = tmp_path / "good.csv"
    write_tracks(good)
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"")
    result = run("convert", good, "-o", existing)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "exists")
    result = run("convert", good, "-o", tmp_path / "x.txt")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "x.txt")
