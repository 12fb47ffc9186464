"""``aion build`` with scene graphs: a graph file, a derived graph or none, a graph in another
frame than the detections, the spark_dsg version pin, a navigational layer without places --
checked against what the generated office log is known to hold.

Split from tests/cli/test_build.py (counts, provenance, topics, observation, config and
continuation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import PLACES, save_graph_file, write_office_log
from tests.cli.test_build import FIXED_TWO_WINDOWS


def test_graph_file_and_derived_graph_without_tf(tmp_path: Path) -> None:
    log = tmp_path / "bare.mcap"
    write_office_log(log, graph=False, tf=False)
    graph = save_graph_file(tmp_path / "dsg.json")
    report = run_json("build", log, "--graph", graph, "--format", "json")
    assert report["graph"]["source"] == "file dsg.json"
    assert report["nodes"] == len(PLACES)
    # no robot trajectory: observed in the 600-s windows holding a message, two for the
    # 20-minute log from an aligned T0 (2 x 600 s = 0.33 h, both windows of the span)
    assert report["observation"] == FIXED_TWO_WINDOWS
    assert any("fixed sensor" in note for note in report["notes"])

    out = tmp_path / "derived.aion"
    report = run_json("build", log, "--derive-graph", "-o", out, "--format", "json")
    assert report["graph"]["source"] == "derived from walking people"
    # three standing people -> three occupied 1.5-m grid cells -> three derived places
    assert report["nodes"] == 3
    assert report["detections"]["used"] == 300
    sequence = [n for n in report["notes"] if "--derive-graph needs every log at once" in n]
    assert sequence == []  # --workers not given: one process is no news
    asked = run_json(
        "build", log, "--derive-graph", "-o", out, "--workers", "2", "--format", "json"
    )
    assert [n for n in asked["notes"] if "--derive-graph needs every log at once" in n]
    # a derived graph has places only: rooms are refused, not answered with an empty table
    for layer in ("rooms", "buildings"):
        refused = run("predict", out, "--layer", layer, "--format", "json")
        assert refused.exit_code == 2
        assert refused.stdout == ""
        assert_one_line_error(refused.stderr, f"has no {layer}")
    assert len(run_json("predict", out, "--layer", "places", "--format", "json")["entries"]) == 3

    report = run_json("build", log, "-o", tmp_path / "cells.aion", "--format", "json")
    assert report["graph"]["source"] == "none"
    assert report["nodes"] == 0
    assert report["cells"] == 3


def test_a_graph_in_another_frame_is_warned_about(tmp_path: Path) -> None:
    """The office graph file moved 500 m away: every detection stays on hash cells, away
    from every place, and the build asks whether the two share a frame; the same graph in
    place binds the detections and says nothing."""
    log = tmp_path / "bare.mcap"
    write_office_log(log, graph=False, tf=False)
    far = {k: (x + 500.0, y, z) for k, (x, y, z) in PLACES.items()}
    moved = save_graph_file(tmp_path / "moved.json", far)
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--graph", moved, "--format", "json")
    (warning,) = [w for w in report["warnings"] if "away from every place" in w]
    assert warning.startswith(f"{report['detections']['used']:,} of the ")
    assert f"0 of its {len(PLACES)} places hold any" in warning
    here = save_graph_file(tmp_path / "here.json")
    report = run_json("build", log, "-o", tmp_path / "h.aion", "--graph", here, "--format", "json")
    assert not [w for w in report["warnings"] if "away from every place" in w]


def test_a_far_graph_warning_needs_nearly_every_detection_off_the_places() -> None:
    from aion_cli.build_plausibility import far_from_graph_warning

    assert far_from_graph_warning(94.0, 6.0, 10, 3) is None  # 94 %: a graph of part of a site
    assert far_from_graph_warning(95.0, 5.0, 10, 1) is not None
    assert far_from_graph_warning(100.0, 0.0, 0, 0) is None  # no graph: hash cells only
    assert far_from_graph_warning(0.0, 0.0, 10, 0) is None  # no detection


def test_dsg_version_pin(office: Office, tmp_path: Path) -> None:
    from aion_cli.formats.dsg import installed_version

    version = installed_version()
    report = run_json(
        "build", office.log, "--dsg-version", version, "-o", tmp_path / "v.aion", "--format", "json"
    )
    assert report["graph"]["dsg_version"] == version
    result = run("build", office.log, "--dsg-version", "0.0.1", "-o", tmp_path / "w.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)


def test_a_navigational_layer_without_places_is_a_warning(tmp_path: Path) -> None:
    """--nav-layer naming a layer with no places (the sample graph's objects, layer 2) built a
    map of 0 nodes without a word."""
    sample = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"
    report = run_json("build", sample, "-o", tmp_path / "m.aion", "--nav-layer", "2",
                      "--format", "json")
    assert report["nodes"] == 0
    assert any("navigational layer has no places" in w for w in report["warnings"])
    plain = run_json("build", sample, "-o", tmp_path / "p.aion", "--format", "json")
    assert plain["nodes"] > 0
    assert not any("navigational layer has no places" in w for w in plain["warnings"])


#: Hydra's frontend graph: the places it still holds (p0..p3), in the odom frame 1.5 m off
FRONTEND = {k: (x + 1.5, y, z) for k, (x, y, z) in PLACES.items() if k < 4}


def test_hydra_frontend_graph_beside_the_backend_is_left_out(tmp_path: Path) -> None:
    """Hydra publishes its frontend graph beside the backend's by default. Both streams were
    used, their graphs taking turns as the map's graph: the map kept the last one, the
    frontend's 4 places in the odom frame, instead of the backend's 7. Now the backend's is
    used and a note says the frontend's was left out."""
    from aion_cli.formats.mapfile import read_map

    log = tmp_path / "hydra.mcap"
    write_office_log(log, second_graph=("/hydra/frontend/dsg", FRONTEND))
    out = tmp_path / "hydra.aion"
    report = run_json("build", log, "-o", out, "--format", "json")
    assert report["graph"]["topics"] == ["/hydra/backend/dsg"]
    assert report["nodes"] == len(PLACES)
    assert any(n.startswith("/hydra/frontend/dsg left out: Hydra's frontend") for n in
               report["notes"]), report["notes"]
    arrays, _ = read_map(out)
    xyz = np.asarray(arrays["graph_places_xyz"])
    np.testing.assert_allclose(np.sort(xyz[:, 0]), sorted(p[0] for p in PLACES.values()))


def test_a_scene_graph_in_another_frame_than_the_map_is_warned_of(tmp_path: Path) -> None:
    """A DsgUpdate names its graph's frame in its header (Hydra's frontend graph: ``odom``;
    the backend's: ``map``; Hydra's ROS 1 sender leaves it empty). aion takes a graph's
    positions as the map frame's and read the frontend's 1.5 m off without a word; a graph
    in another frame than the map's is now a warning naming both frames."""
    from aion_cli.graph_notes import other_frame_warning

    log = tmp_path / "hydra.mcap"
    write_office_log(log, second_graph=("/hydra/frontend/dsg", FRONTEND))
    front = run_json(
        "build", log, "-o", tmp_path / "front.aion", "--graph-topic", "/hydra/frontend/dsg",
        "--format", "json",
    )  # fmt: skip
    assert front["nodes"] == len(FRONTEND)
    warning = other_frame_warning("/hydra/frontend/dsg", "odom", "map")
    assert warning in front["warnings"], front["warnings"]
    assert warning.startswith(
        "the scene graphs on /hydra/frontend/dsg are in frame 'odom', not the map frame 'map'"
    )
    back = run_json("build", log, "-o", tmp_path / "back.aion", "--format", "json")
    assert back["graph"]["topics"] == ["/hydra/backend/dsg"]  # its graphs are in 'map'
    assert not [w for w in back["warnings"] if "are in frame" in w], back["warnings"]


def test_two_scene_graph_streams_need_graph_topic(tmp_path: Path) -> None:
    """Two robots' backend graphs (each numbering its places from p0) took turns as the map's
    graph; now the build is refused until --graph-topic names one."""
    log = tmp_path / "fleet.mcap"
    write_office_log(log, second_graph=("/robot2/hydra/backend/dsg", FRONTEND))
    out = tmp_path / "fleet.aion"
    result = run("build", log, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(
        result.stderr,
        "the logs carry 2 scene-graph topics at the same time (/hydra/backend/dsg, "
        "/robot2/hydra/backend/dsg)",
    )
    assert "hint: name the one to build on with --graph-topic" in result.stderr
    assert not out.exists()
    report = run_json(
        "build", log, "-o", out, "--graph-topic", "/robot2/hydra/backend/dsg", "--format", "json"
    )
    assert report["nodes"] == len(FRONTEND)


def test_one_stream_under_a_ros1_and_a_ros2_name_in_logs_of_other_days_is_one_stream(
    tmp_path: Path,
) -> None:
    """A ROS 2 MCAP and a ROS 1 bag of the same robot on two days (aion simulate names Hydra's
    topic /hydra/backend/dsg in one, /hydra_ros_node/backend/dsg in the other; README's
    `aion build run1.mcap run2.bag`) were refused as two graph streams; they are one stream
    read in time order, every graph of both logs used. The same two names at the same time
    are two streams, refused."""
    logs = {}
    for name, fmt, day in (("run1.mcap", "mcap", "05"), ("run2.bag", "bag", "06"),
                           ("run3.bag", "bag", "05")):
        logs[name] = tmp_path / name
        made = run("simulate", "-o", logs[name], "--format", fmt, "--days", "0.1", "--start",
                   f"2026-01-{day}T09:00", "-q")
        assert made.exit_code == 0, made.stderr
    graphs = {
        name: sum(t["count"] for t in run_json("info", log, "--format", "json")["topics"]
                  if t["type"].endswith("DsgUpdate"))
        for name, log in logs.items()
    }
    report = run_json("build", logs["run1.mcap"], logs["run2.bag"], "-o", tmp_path / "a.aion",
                      "--format", "json", "--workers", "1")
    assert report["graph"]["topics"] == ["/hydra/backend/dsg", "/hydra_ros_node/backend/dsg"]
    assert report["graph"]["messages"] == graphs["run1.mcap"] + graphs["run2.bag"] > 0
    at_once = run("build", logs["run1.mcap"], logs["run3.bag"], "-o", tmp_path / "b.aion")
    assert at_once.exit_code == 2, at_once.stderr
    assert_one_line_error(at_once.stderr, "the logs carry 2 scene-graph topics at the same time")


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_partial_scene_graph_updates_are_skipped(tmp_path: Path, container: str) -> None:
    """A DsgUpdate with full_update false holds the nodes that changed, not the graph. It was
    applied as a whole graph: every node it did not repeat left the map (the office log with a
    partial update of p0 and p1 30 s after each full graph ended as a map of 2 places, their
    flows released to hash cells). Now partial updates are skipped and noted: the map is the
    map of the same log without them (up to the last bits of sums, which the skipped messages
    still cut into other pieces). Where the topic's first message has the flag false too,
    the writer does not set it, and the graphs are read whole."""
    from aion_cli.formats.mapfile import read_map

    suffix = ".mcap" if container == "mcap" else ".bag"
    partial = {k: PLACES[k] for k in (0, 1)}
    log = tmp_path / f"partial{suffix}"
    write_office_log(log, container, partial_places=partial)
    plain = tmp_path / f"plain{suffix}"
    write_office_log(plain, container)
    args = ("--graph-period", "0", "--format", "json")
    report = run_json("build", log, "-o", tmp_path / "partial.aion", *args)
    run_json("build", plain, "-o", tmp_path / "plain.aion", *args)
    assert report["nodes"] == len(PLACES)
    assert any(n.startswith("20 partial scene-graph update(s) (full_update false) skipped")
               for n in report["notes"]), report["notes"]
    got, _ = read_map(tmp_path / "partial.aion")
    want, _ = read_map(tmp_path / "plain.aion")
    assert sorted(got) == sorted(want)
    for name in want:
        np.testing.assert_allclose(got[name], want[name], rtol=1e-12, atol=1e-20, err_msg=name)

    # a writer that never sets the flag (the topic's first message has it false too): its
    # graphs are read whole, as before
    unset = tmp_path / f"unset{suffix}"
    write_office_log(unset, container, graph=False, partial_places=partial)
    report = run_json("build", unset, "-o", tmp_path / "unset.aion", *args)
    assert report["nodes"] == len(partial)
    assert not any("partial scene-graph" in n for n in report["notes"]), report["notes"]


def test_partial_update_chosen_for_its_period_gives_way_to_a_whole_graph(tmp_path: Path) -> None:
    """--graph-period decides on log times alone, so it may choose a partial update (which
    the stream skips) for a period whose whole graph it passed over: the period was left
    without a graph. The office log has whole graphs at every minute (t % 60 == 0, 20 of
    them) and partial updates at t % 60 == 30; with 45 s periods (600-s windows) the schedule
    uses 0, 30P, 90P, 120, 180, 210P, 270P, 300, ... — 13 whole graphs, and the whole graphs
    at 60, 240, 420, 780, 960 and 1140 s are passed over for the partials at 30, 210, 390,
    750, 930 and 1110 s. Now the next whole graph of a used partial's window stands in for it:
    19 applied (600 s opens another window than 570 s's partial; 1170 s's has none after it).
    One pass and two workers choose alike and write the same map."""
    from aion_cli.formats.mapfile import read_map

    log = tmp_path / "partial.mcap"
    write_office_log(log, "mcap", partial_places={k: PLACES[k] for k in (0, 1)})
    maps = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}.aion"
        report = run_json(
            "build", log, "-o", out, "--graph-period", "45s", "--workers", workers,
            "--format", "json",
        )
        assert report["graph"]["messages"] == 19, (workers, report["graph"])
        assert report["nodes"] == len(PLACES)
        maps.append(read_map(out)[0])
    assert sorted(maps[0]) == sorted(maps[1])
    for name in maps[0]:
        np.testing.assert_array_equal(maps[0][name], maps[1][name], err_msg=name)


def test_a_map_or_a_log_given_as_the_graph_file_is_told_where_its_graph_comes_from(
    office: Office, tmp_path: Path
) -> None:
    """``--graph office.aion`` was refused with "Hydra saves graphs as dsg.json ..." alone:
    the hint now gives the export that writes the map's graph, which the build then takes
    (the map's places, every one); a log given so is told the build reads its graphs."""
    import shlex

    refused = run("build", office.log, "--graph", office.map, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "unsupported scene-graph file extension '.aion'")
    (command,) = [line for line in refused.stderr.splitlines() if line.startswith("hint:")]
    words = shlex.split(command.split("`")[1])
    assert words[:2] == ["aion", "export"]
    graph = tmp_path / "graph.json"
    exported = run(*[str(graph) if w == "graph.json" else w for w in words[1:]])
    assert exported.exit_code == 0, exported.stderr
    built = run_json("build", office.log, "--graph", graph, "-o", tmp_path / "y.aion",
                     "--format", "json")  # fmt: skip
    assert built["graph"]["source"] == "file graph.json"
    assert built["nodes"] == office.build["nodes"] == len(PLACES)
    as_log = run("build", office.log, "--graph", office.log, "-o", tmp_path / "z.aion")
    assert as_log.exit_code == 2
    assert f"{office.log.name} is a log: aion build reads the scene graphs" in as_log.stderr
