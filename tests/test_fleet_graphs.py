"""Robots recording at the same time, each with its own Hydra scene graph on the same topic
(``aion build robot1.mcap robot2.mcap``): merged by time into one stream, each robot's graph
replaced the other's at every message (every graph decoded anew, the map's places those of
whichever robot's graph came last, the other robot's flows bound to them). The build now
refuses such logs (:mod:`aion_cli.graph_owners`), with a hint whose commands (each robot's
map, then ``aion merge``) give the fleet's map; one robot's log split into files one after
the other in time is still one stream, whose later graph replaces its earlier one.

The logs: an office whose robot 1 maps places p0..p6 (``tests.cli.logdata.PLACES``) and whose
robot 2, in a Hydra session of its own, maps the same building with other positions for the
same node ids; each robot sees a person of its own, standing at a place of its own graph."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.errors import InputError
from aion_cli.formats.writers import LogWriter
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import EDGES, PLACES, ROOMS, T0, S, _stamp, graph_payload, sym
from tests.graph_stream_logs import assert_same_map

TOPIC = "/hydra/backend/dsg"
DURATION_S = 1200  # two 10-minute windows
GRAPH_PERIOD_S = 60
#: robot 2's session: the same node ids at other positions (another Hydra session)
PLACES2 = {k: (x + 0.7, y + 3.0, z) for k, (x, y, z) in PLACES.items()}


def write_robot(
    path: Path,
    places: dict[int, tuple[float, float, float]],
    person: tuple[float, float],
    track: int,
    offset_s: int = 0,
    seconds: range = range(DURATION_S),
    moved: int | None = None,
    quiet: range = range(0),
    others: dict[int, tuple[float, float]] | None = None,
    offsets: tuple[int, ...] = (),
) -> Path:
    """A robot's log over ``seconds`` of the recording: its graph of ``places`` every minute,
    ``offset_s`` after the whole minute (robots' graphs interleave); the person ``track``
    standing at ``person`` (map frame) every second; the robot at rest at p0 on ``/tf``
    every 5 s. ``moved``: from that second on the graphs hold p1 moved 1 m along y (a later
    graph of the same session); ``quiet``: seconds without the person (a pause a parallel
    build may cut the log at); ``others``: more people standing (track: position) beside the
    person; ``offsets``: more seconds after the minute with a graph (one log with the graphs
    of several robots' times)."""
    first, second = sorted(places)[:2]  # p0, p1
    later = dict(places)
    x, y, z = later[second]
    later[second] = (x, y + 1.0, z)
    payloads = [np.frombuffer(graph_payload(p), np.uint8) for p in (places, later)]
    with LogWriter(path, "mcap") as writer:
        for s in seconds:
            t = T0 + s * S
            if s % GRAPH_PERIOD_S in (offset_s, *offsets):
                payload = payloads[int(moved is not None and s >= moved)]
                writer.write(
                    TOPIC,
                    "hydra_msgs/msg/DsgUpdate",
                    {
                        "header": {"stamp": _stamp(t), "frame_id": "map"},
                        "layer_contents": payload,
                        "full_update": True,
                    },
                    t,
                )
            if s % 5 == 0:
                x0, y0, z0 = places[first]
                writer.write(
                    "/tf",
                    "tf2_msgs/msg/TFMessage",
                    {
                        "transforms": [{
                            "header": {"stamp": _stamp(t), "frame_id": "map"},
                            "child_frame_id": "base_link",
                            "transform": {
                                "translation": {"x": x0, "y": y0, "z": z0},
                                "rotation": {"w": 1.0},
                            },
                        }]
                    },
                    t,
                )
            if s in quiet:
                continue
            half = t + S // 2
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                {
                    "header": {"stamp": _stamp(half), "frame_id": "map"},
                    "tracks": [{
                        "track_id": k,
                        "is_matched": True,
                        "pose": {"pose": {"position": {"x": xy[0], "y": xy[1]},
                                          "orientation": {"w": 1.0}}},
                    } for k, xy in {track: person, **(others or {})}.items()],
                },
                half,
            )
    return path


def _robots(folder: Path) -> tuple[Path, Path]:
    """Robot 1's and robot 2's logs of the same 20 minutes, graphs 30 s apart."""
    one = write_robot(folder / "robot1.mcap", PLACES, PLACES[1][:2], track=1)
    two = write_robot(folder / "robot2.mcap", PLACES2, PLACES2[4][:2], track=1, offset_s=30)
    return one, two


def test_two_robots_graphs_at_once_are_refused(tmp_path: Path) -> None:
    """Before: the build decoded all 40 graphs (each one another session's than the graph
    before: p0..p6 3 m away and back at every message) and kept robot 2's, whose graphs
    come 30 s after robot 1's. Either order of the logs, either build (a parallel build puts
    overlapping logs in one shard) refuses them, and writes nothing."""
    one, two = _robots(tmp_path)
    out = tmp_path / "fleet.aion"
    for logs, workers in (((one, two), 1), ((two, one), 1), ((one, two), 2)):
        with pytest.raises(InputError) as exc:
            build_map(BuildOptions(logs=logs, output=out, workers=workers))
        assert f"2 logs carry scene graphs on {TOPIC} at the same time" in exc.value.message
        assert str(one) in exc.value.message
        assert str(two) in exc.value.message
        assert "aion merge" in (exc.value.hint or "")
        assert not out.exists()


def test_a_session_without_a_shared_place_id_is_refused_too(tmp_path: Path) -> None:
    """Robot 2's session numbering its places from p10: no place id in common, so nothing
    says the graphs are one session (``aion merge`` calls such maps different too)."""
    one = write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[1][:2], track=1)
    renumbered = {k + 10: xyz for k, xyz in PLACES.items()}
    two = write_robot(tmp_path / "robot2.mcap", renumbered, PLACES[4][:2], track=2,
                      offset_s=30)
    with pytest.raises(InputError, match="at the same time"):
        build_map(BuildOptions(logs=(one, two), output=tmp_path / "m.aion", workers=1))


def test_robots_sharing_one_session_build_as_one_stream(tmp_path: Path) -> None:
    """Robots whose graphs are one session's (a multi-robot graph both log, or one recording
    twice): the graphs agree where they share place ids, so the logs build together as
    before, one stream of that session's graphs (identical here: decoded once)."""
    one = write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[1][:2], track=1)
    two = write_robot(tmp_path / "robot2.mcap", PLACES, PLACES[4][:2], track=2, offset_s=30)
    report = build_map(BuildOptions(logs=(one, two), output=tmp_path / "m.aion", workers=1))
    assert report.graph_source == "log"
    assert report.graph_messages == 2 * DURATION_S // GRAPH_PERIOD_S
    assert report.graph_decoded == 1
    assert report.detections_used == 2 * DURATION_S


def test_the_hints_builds_and_merge_give_the_fleet_map(tmp_path: Path) -> None:
    """The route the refusal's hint gives: each robot's map on its own graph, then ``aion
    merge``. The two sessions are told apart (another lineage: no node id of one graph lies
    near the same id of the other), so the merged map binds both robots' flows to the newer
    map's graph: robot 2's person to its p4, robot 1's person (at robot 1's p1, more than 3 m
    from every place of robot 2's graph) stays a hash cell; each holds its 1,200
    detections."""
    from aion_cli.merging import merge_map_files

    one, two = _robots(tmp_path)
    maps = []
    for log in (one, two):
        maps.append(tmp_path / f"{log.stem}.aion")
        report = build_map(BuildOptions(logs=(log,), output=maps[-1], workers=1))
        assert report.graph_decoded == 1  # one session, its graph repeated unchanged
    merged = merge_map_files(maps, tmp_path / "fleet.aion")
    assert merged.lineage == "different"
    state = load_map(tmp_path / "fleet.aion").state
    entries = state.entries
    rows = entries.live_rows()
    total = entries.counts[rows].sum(axis=1) + entries.nodir[rows]
    held = total > 0
    assert total[held].tolist() == [DURATION_S, DURATION_S]
    nodes = entries.node_id[rows][held & (entries.node_id[rows] > 0)]
    assert state.graph is not None  # robot 2's: its p4 where robot 2's graphs have it
    (p4,) = np.flatnonzero(np.asarray(state.graph.places.ids) == sym("p", 4))
    np.testing.assert_allclose(np.asarray(state.graph.places.xyz)[p4], PLACES2[4])
    assert nodes.tolist() == [sym("p", 4)]
    cells = entries.xyz[rows][held & (entries.node_id[rows] == 0), :2]
    assert len(cells) == 1
    assert np.linalg.norm(cells[0] - np.array(PLACES[1][:2])) < 0.5


def test_one_robots_log_split_in_time_is_one_stream(tmp_path: Path) -> None:
    """``rosbag record --split``: one robot's recording in two files, one after the other.
    Its graphs are one stream: the second file's graphs (p1 moved) replace the first's as in
    the unsplit log, and the map equals the unsplit log's."""
    whole = write_robot(tmp_path / "whole.mcap", PLACES, PLACES[1][:2], track=1, moved=900)
    first = write_robot(tmp_path / "run_0.mcap", PLACES, PLACES[1][:2], track=1,
                        seconds=range(600), moved=900)
    second = write_robot(tmp_path / "run_1.mcap", PLACES, PLACES[1][:2], track=1,
                         seconds=range(600, DURATION_S), moved=900)
    build_map(BuildOptions(logs=(whole,), output=tmp_path / "whole.aion", workers=1))
    report = build_map(BuildOptions(logs=(first, second), output=tmp_path / "split.aion",
                                    workers=1))
    assert report.graph_decoded == 2  # the first graph, then the moved one
    assert_same_map(tmp_path / "whole.aion", tmp_path / "split.aion")
    graph = load_map(tmp_path / "split.aion").state.graph
    assert graph is not None
    (p1,) = np.flatnonzero(np.asarray(graph.places.ids) == sym("p", 1))
    np.testing.assert_allclose(np.asarray(graph.places.xyz)[p1, :2],
                               (PLACES[1][0], PLACES[1][1] + 1.0))  # the second file's


def test_a_second_robot_without_graphs_builds_with_the_first_ones(tmp_path: Path) -> None:
    """One graph stream at a time is no clash: a robot (or a recording split by topic)
    without scene graphs beside one with them builds as before, on that robot's graph."""
    one = write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[1][:2], track=1)
    bare = tmp_path / "robot2.mcap"
    with LogWriter(bare, "mcap") as writer:
        for s in range(DURATION_S):
            t = T0 + s * S + S // 2
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                {
                    "header": {"stamp": _stamp(t), "frame_id": "map"},
                    "tracks": [{"track_id": 7, "is_matched": True,
                                "pose": {"pose": {"position": {"x": PLACES[4][0],
                                                               "y": PLACES[4][1]},
                                                  "orientation": {"w": 1.0}}}}],
                },
                t,
            )
    report = build_map(BuildOptions(logs=(one, bare), output=tmp_path / "m.aion", workers=1))
    assert report.graph_source == "log"
    assert report.graph_messages == DURATION_S // GRAPH_PERIOD_S


def test_one_graph_for_the_fleet_with_graph_file(tmp_path: Path) -> None:
    """``--graph FILE``: the logs' graphs are ignored, so robots recording at once build
    together on that one graph."""
    from tests.cli.logdata import build_graph

    one, two = _robots(tmp_path)
    graph_file = tmp_path / "office.json"
    build_graph(PLACES, EDGES, ROOMS).save(str(graph_file))
    report = build_map(BuildOptions(logs=(one, two), output=tmp_path / "m.aion", workers=1,
                                    graph_file=graph_file))
    assert report.graph_source == "file office.json"
    assert report.detections_used == 2 * DURATION_S


def test_the_cli_refuses_in_one_line_with_the_hint(tmp_path: Path) -> None:
    from tests.cli.conftest import run

    one, two = _robots(tmp_path)
    done = run("build", one, two, "-o", tmp_path / "fleet.aion")
    assert done.exit_code == 2
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1
    assert "at the same time" in errors[0]
    assert "Traceback" not in done.stderr
    assert f"aion build {one} -o robot1.aion; aion build {two} -o robot2.aion" in done.stderr
    assert "aion merge robot1.aion robot2.aion -o fleet.aion" in done.stderr
