"""``aion info GRAPH_FILE`` and ``aion build --nav-layer`` on graphs written by spark_dsg itself
(Hydra 1.1.x: 96 2D places in ``MESH_PLACES`` = ``3[1]``) and the real legacy files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.formats import dsg_builders as b
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"
IGX = DATA / "apartment_igx_dsg.json"
S = 1_000_000_000
T0 = 1_795_420_800 * S  # Monday 2026-11-23 08:00 UTC


@pytest.fixture(scope="module")
def hydra_json(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return b.save(b.hydra_graph(), tmp_path_factory.mktemp("graphs") / "dsg.json")


def _table(stdout: str) -> dict[str, str]:
    """The rows of a two-column rich table."""
    return {
        cells[0]: cells[1]
        for line in stdout.splitlines()
        if len(cells := [c.strip() for c in line.strip("│ ").split("│")]) == 2
    }


def test_info_graph_file_table(hydra_json: Path) -> None:
    result = run("info", hydra_json)
    assert result.exit_code == 0, result.stderr
    lines = _table(result.stdout)
    assert lines["format"].startswith("spark_dsg JSON 1.1.3, ")
    assert lines["navigational layer"] == "MESH_PLACES (3[1])"
    assert lines["places"] == "96"
    assert lines["place edges"] == "172"
    assert lines["rooms"] == "2 (96 places in a room)"
    assert lines["buildings"] == "1"
    assert result.stderr == ""


def test_info_graph_file_json_and_nav_layer(hydra_json: Path, tmp_path: Path) -> None:
    report = run_json("info", hydra_json, "--format", "json")
    assert report["nav_layer"] == {"name": "MESH_PLACES", "key": "3[1]"}
    assert report["reader"] == "spark_dsg"
    assert report["version"] == "1.1.3"
    assert (report["places"], report["edges"], report["rooms"]) == (96, 172, 2)
    assert report["layers"] == [
        {"key": "2", "name": "OBJECTS", "nodes": 0},
        {"key": "3", "name": "PLACES", "nodes": 11},
        {"key": "3[1]", "name": "MESH_PLACES", "nodes": 96},
        {"key": "4", "name": "ROOMS", "nodes": 2},
        {"key": "5", "name": "BUILDINGS", "nodes": 1},
    ]
    assert report["notes"] == []
    places = run_json("info", hydra_json, "--nav-layer", "PLACES", "--format", "json")
    assert places["nav_layer"] == {"name": "PLACES", "key": "3"}
    assert (places["places"], places["edges"], places["frontiers_left_out"]) == (10, 9, 1)
    # the same graph saved in the binary format, and in the legacy layer 20
    binary = tmp_path / "dsg.sparkdsg"
    b.hydra_graph().save(str(binary), True)
    report = run_json("info", binary, "--format", "json")
    assert (report["format"], report["places"]) == ("spark_dsg binary 1.1.3", 96)
    legacy = b.save(b.legacy_mesh_graph(), tmp_path / "legacy.json")
    report = run_json("info", legacy, "--format", "json")
    assert report["nav_layer"] == {"name": "MESH_PLACES", "key": "20"}
    assert report["places"] == 96


@pytest.mark.skipif(not IGX.is_file(), reason=f"real data not present: {IGX}")
def test_info_real_file_spark_dsg_refuses() -> None:
    result = run("info", IGX)
    assert result.exit_code == 0, result.stderr
    lines = _table(result.stdout)
    assert lines["navigational layer"] == "PLACES (3)"
    assert lines["format"].startswith("spark_dsg JSON (legacy, no version header); read leniently")
    assert lines["places"] == "437"
    assert result.stderr.strip() == (
        "note: apartment_igx_dsg.json: spark_dsg refused it (failed to add O(23) → p(8928)); "
        "read leniently: 6 dangling edges skipped"
    )
    report = run_json("info", IGX, "--format", "json")
    assert report["reader"] == "lenient"
    assert report["skipped"] == {"dangling_edges": 6}
    assert (report["places"], report["rooms"]) == (437, 4)
    assert report["format"] == "spark_dsg JSON (legacy, no version header)"


def test_info_graph_errors_exit_2(hydra_json: Path, tmp_path: Path) -> None:
    broken = tmp_path / "broken.json"
    broken.write_text('{"nodes": [{"id": 1,')
    result = run("info", broken)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not valid JSON (Expecting", "broken.json")
    result = run("info", hydra_json, "--nav-layer", "20")
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr, "dsg.json: scene graph has no layer 20; its layers: 2 OBJECTS (0 nodes)"
    )
    result = run("info", hydra_json, "--nav-layer", "3[")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "bad navigational layer '3['")
    log = tmp_path / "x.mcap"
    log.write_bytes(b"")
    result = run("info", hydra_json, log)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not a mix")


# ----------------------------------------------------------------------------- build


def _write_log(path: Path, graph: bool = True) -> None:
    """20 minutes: the Hydra 1.1.x graph as DsgUpdate every minute (if ``graph``), two people
    standing at P(2) and P(28) every 10 s (spencer TrackedPersons in the map frame), no TF."""
    from aion_cli.formats.writers import LogWriter

    payload = np.frombuffer(b.hydra_graph().to_binary(False), dtype=np.uint8)
    with LogWriter(path, "mcap") as writer:
        for k in range(120):
            t = T0 + k * 10 * S
            stamp = {"sec": t // S, "nanosec": 0}
            if graph and k % 6 == 0:
                writer.write(
                    "/hydra/backend/dsg",
                    "hydra_msgs/msg/DsgUpdate",
                    {
                        "header": {"stamp": stamp, "frame_id": "map"},
                        "layer_contents": payload,
                        "full_update": True,
                    },
                    t,
                )
            tracks = [
                {
                    "track_id": track,
                    "is_matched": True,
                    "pose": {
                        "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"w": 1.0}}
                    },
                    "twist": {"twist": {"linear": {"x": 1.0, "y": 0.0, "z": 0.0}}},
                }
                for track, (x, y) in ((1, (2.1, 0.1)), (2, (4.1, 1.9)))
            ]
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                {"header": {"stamp": stamp, "frame_id": "map"}, "tracks": tracks},
                t + 5 * S,
            )


def test_build_from_dsg_update_payloads_with_mesh_places(tmp_path: Path) -> None:
    log = tmp_path / "hydra.mcap"
    _write_log(log)
    report = run_json("build", log, "-o", tmp_path / "a.aion", "--format", "json")
    assert report["graph"]["source"] == "log"
    assert report["graph"]["layer"] == "MESH_PLACES (3[1])"
    assert report["graph"]["messages"] == 20
    assert report["nodes"] == 96
    assert report["nodes_with_flow"] == 2
    predicted = run_json("predict", tmp_path / "a.aion", "--historical", "--format", "json")
    with_flow = {e["id"] for e in predicted["entries"] if e["flow"] > 0}
    assert with_flow == {"P2", "P28"}
    assert {e["layer"] for e in predicted["entries"]} == {"mesh_places"}

    report = run_json(
        "build", log, "-o", tmp_path / "b.aion", "--nav-layer", "PLACES", "--format", "json"
    )
    assert report["graph"]["layer"] == "PLACES (3)"
    assert report["nodes"] == 10

    result = run("build", log, "-o", tmp_path / "c.aion", "--nav-layer", "20")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "/hydra/backend/dsg: scene graph has no layer 20")
    assert not (tmp_path / "c.aion").exists()


def test_build_graph_file_with_nav_layer_and_without_graph(tmp_path: Path) -> None:
    log = tmp_path / "hydra.mcap"
    _write_log(log)
    graph = b.save(b.hydra_graph(), tmp_path / "dsg.json")
    report = run_json("build", log, "-o", tmp_path / "f.aion", "--graph", graph, "--format", "json")
    assert (report["graph"]["source"], report["graph"]["layer"]) == (
        "file dsg.json",
        "MESH_PLACES (3[1])",
    )
    assert report["nodes"] == 96
    assert "--graph given: scene graphs in the log are ignored" in report["notes"]
    report = run_json(
        "build",
        log,
        "-o",
        tmp_path / "g.aion",
        "--graph",
        graph,
        "--nav-layer",
        "3",
        "--format",
        "json",
    )
    assert report["graph"]["layer"] == "PLACES (3)"
    assert report["nodes"] == 10
    bare = tmp_path / "bare.mcap"
    _write_log(bare, graph=False)
    report = run_json(
        "build", bare, "-o", tmp_path / "h.aion", "--nav-layer", "3", "--format", "json"
    )
    assert report["graph"]["layer"] is None
    assert "--nav-layer ignored: no scene graph is read" in report["notes"]


def test_info_graph_file_with_two_robots_says_whose_poses_are_taken(tmp_path: Path) -> None:
    """Hydra-Multi graphs hold an agent partition per robot (``2[97]`` robot a, ``2[98]``
    robot b). aion takes robot a's poses; "agent poses 3" read as every robot's, so the row
    now names the robot taken and the poses left out, each count as spark_dsg holds it."""
    import datetime

    import spark_dsg

    G = b.hydra_graph()
    for robot, poses in (("b", 5), ("a", 3)):
        for k in range(poses):
            agent = spark_dsg.AgentNodeAttributes()
            agent.position = np.array([float(k), 1.0, 0.0])
            agent.timestamp = datetime.timedelta(seconds=k)
            G.add_node(2, spark_dsg.NodeSymbol(robot, k), agent, ord(robot))
    path = b.save(G, tmp_path / "two_robots.json")
    back = spark_dsg.DynamicSceneGraph.load(str(path))
    held = {v.partition: v.num_nodes() for v in back.layer_partitions if v.id == 2}
    assert held == {ord("a"): 3, ord("b"): 5}
    result = run("info", path)
    assert result.exit_code == 0, result.stderr
    row = _table(result.stdout)["agent poses"]
    assert row == f"{held[ord('a')]} (robot a, 2[97]; not used: 2[98] {held[ord('b')]})"
    assert run_json("info", path, "--format", "json")["agent_poses"] == held[ord("a")]
    one = b.save(b.hydra_graph(), tmp_path / "no_robot.json")
    assert _table(run("info", one).stdout)["agent poses"] == "0"
