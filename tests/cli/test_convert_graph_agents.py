"""``aion convert --graph`` with a graph Hydra saved: its agent layer (the robot trajectory of
the graph's own recording) must not become the dataset's observation. A dataset has no robot:
the build of the converted log is a fixed sensor over its messages and ``--observed`` spans."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def _tracks(path: Path) -> Path:
    """Two people walking for two minutes, canonical columns, from 2026-01-05 10:00 UTC."""
    t0 = 1_767_607_200 * 10**9
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    for i in range(120):
        rows.append(f"{t0 + i * 10**9},1,{i * 0.05:.2f},0.0,0.0,0.0,1.0")
        rows.append(f"{t0 + i * 10**9},2,{6 - i * 0.05:.2f},1.0,0.0,3.14159,1.0")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_graph_agent_layer_is_left_out_of_a_converted_dataset(tmp_path: Path) -> None:
    graph = real("dsg", "apartment_dsg.json")  # a Hydra graph with 102 agent poses
    log = tmp_path / "tracks.mcap"
    result = run(
        "convert", _tracks(tmp_path / "tracks.csv"), "-o", log, "--graph", graph,
        "--observed", "2026-01-05 09:00..2026-01-05 12:00",
    )
    assert result.exit_code == 0, result.stderr
    assert "its agent layer (102 robot poses" in result.stderr
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--format", "json", "-q")
    # before: "scene-graph agent layer" (the apartment robot's poses of another time) and
    # the declared three hours ignored
    assert report["observation"].startswith("fixed sensor over the 18 windows"), report


def test_graph_read_leniently_is_said(tmp_path: Path) -> None:
    """A graph file spark_dsg refuses is read leniently by convert as by build and info, and
    convert says what it skipped (it said nothing: the log's graph silently lacked them)."""
    import json

    doc = json.loads(real("dsg", "apartment_dsg.json").read_text())
    info = {"type": "EdgeAttributes", "weight": 1.0, "weighted": True}
    doc["edges"].append(  # to a place the file does not hold
        {"source": (ord("p") << 56) | 99_999, "target": doc["nodes"][0]["id"], "info": info}
    )
    graph = tmp_path / "dangling.json"
    graph.write_text(json.dumps(doc))
    result = run(
        "convert", _tracks(tmp_path / "tracks.csv"), "-o", tmp_path / "tracks.mcap",
        "--graph", graph,
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert "dangling.json: spark_dsg refused it (failed to add p(99999)" in result.stderr
    assert "read leniently: 1 dangling edge skipped" in result.stderr
    assert "its agent layer (102 robot poses" in result.stderr
