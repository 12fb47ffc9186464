"""``aion plan``: paths, costs, snapping and failures on the office map."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json, run_process
from tests.cli.logdata import save_graph_file, write_office_log

AT = "2026-11-23 08:30"


def test_path_length_and_costs(office: Office) -> None:
    doc = run_json(
        "plan", office.map, "--from", "p0", "--to", "p3", "--time", AT, "--format", "json"
    )
    temporal, shortest = doc["temporal"], doc["distance_only"]
    assert shortest["path"] == ["p0", "p1", "p2", "p3"]
    assert shortest["length_m"] == pytest.approx(6.0)
    assert temporal["path"] == shortest["path"]  # the only way
    assert temporal["length_m"] == pytest.approx(6.0)
    assert shortest["duration_s"] == pytest.approx(6.0 / doc["speed_mps"])
    # people stand at p1 and p3: walking through them costs more than the distance
    assert temporal["cost"] > temporal["length_m"]
    assert temporal["cost"] == pytest.approx(shortest["cost"])
    assert doc["depart"] == "2026-11-23 08:30:00+00:00"
    assert len(temporal["arrival"]) == 4
    assert temporal["arrival"][0] == "2026-11-23 08:30:00.000+00:00"  # the departure
    # to the nanosecond: the steps are 2 m each (p0..p3 on a line), walked at speed_mps
    step_ns = 2.0 / doc["speed_mps"] * 1e9
    expected = [doc["depart_ns"] + round(k * step_ns) for k in range(4)]
    assert temporal["arrival_ns"] == pytest.approx(expected, abs=2)


def test_arrival_times_keep_the_fraction_of_a_second(office: Office) -> None:
    """2 m steps (p0..p3 on a line) at 0.75 m/s: one every 2.667 s. ``arrival`` said
    08:30:02, 08:30:05 (the fraction cut off: 5.333 s read as 5); now to the millisecond."""
    doc = run_json(
        "plan", office.map, "--from", "p0", "--to", "p3", "--time", AT, "--speed", "0.75",
        "--format", "json",
    )
    assert doc["temporal"]["arrival"] == [
        "2026-11-23 08:30:00.000+00:00",
        "2026-11-23 08:30:02.667+00:00",
        "2026-11-23 08:30:05.333+00:00",
        "2026-11-23 08:30:08.000+00:00",
    ]


def test_coordinates_snap_to_the_nearest_node_and_speed(office: Office) -> None:
    doc = run_json(
        "plan",
        office.map,
        "--from",
        "0.2,-0.1",
        "--to",
        "3.9,1.7",
        "--time",
        AT,
        "--speed",
        "0.5",
        "--format",
        "json",
    )
    assert doc["from"] == "p0"
    assert doc["to"] == "p4"
    assert doc["distance_only"]["path"] == ["p0", "p1", "p2", "p4"]
    assert doc["distance_only"]["duration_s"] == pytest.approx(6.0 / 0.5)
    assert [s["node"] for s in doc["snapped"]] == ["p0", "p4"]


def test_the_snapped_note_says_the_point_as_it_was_typed(office: Office) -> None:
    """The note said ``--from [0.2, -0.1] snapped to p0``, a Python list; it says the point
    as typed (x,y or x,y,z). Distances by hand: (0.2, -0.1) is sqrt(0.05) = 0.22 m from p0
    (0, 0); (3.9, 1.7, 0.25) is sqrt(0.1625) = 0.40 m from p4 (4, 2, 0)."""
    result = run(
        "plan", office.map, "--from", "0.2,-0.1", "--to", "3.9,1.7,0.25", "--time", AT
    )
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert "--from 0.2,-0.1 snapped to p0 (0.22 m away)" in said, said
    assert "--to 3.9,1.7,0.25 snapped to p4 (0.40 m away)" in said, said
    assert "[" not in said, said


def test_temporal_path_avoids_the_crowd(tmp_path: Path) -> None:
    """A square A-B-C / A-D-C: B (on the short way) is where a person stands."""
    log = tmp_path / "square.mcap"
    write_office_log(log, graph=False)
    places = {0: (0.0, 0.0, 0.0), 1: (2.0, 0.0, 0.0), 2: (4.0, 0.0, 0.0), 3: (2.0, -2.0, 0.0)}
    graph = save_graph_file(tmp_path / "square.json", places, [(0, 1), (1, 2), (0, 3), (3, 2)])
    out = tmp_path / "square.aion"
    run_json("build", log, "--graph", graph, "-o", out, "--format", "json")
    doc = run_json("plan", out, "--from", "p0", "--to", "p2", "--time", AT, "--format", "json")
    assert doc["distance_only"]["path"] == ["p0", "p1", "p2"]
    assert doc["distance_only"]["length_m"] == pytest.approx(4.0)
    assert doc["temporal"]["path"] == ["p0", "p3", "p2"]
    assert doc["temporal"]["length_m"] == pytest.approx(2 * 8**0.5)
    assert doc["temporal"]["cost"] < doc["distance_only"]["cost"]
    # to the nanosecond on steps of sqrt(8) m too (counted from model seconds, where a float's
    # step is 30 ns in 2026, the last arrival was 15 ns off)
    step_ns = 8**0.5 / doc["speed_mps"] * 1e9
    expected = [doc["depart_ns"] + round(k * step_ns) for k in range(3)]
    assert doc["temporal"]["arrival_ns"] == pytest.approx(expected, abs=1)
    table = run("plan", out, "--from", "p0", "--to", "p2", "--time", AT)
    assert table.exit_code == 0, table.stderr
    assert "p0 > p3 > p2" in table.stdout
    assert "p0 > p1 > p2" in table.stdout


def test_no_path_names_the_disconnected_parts(office: Office) -> None:
    result = run("plan", office.map, "--from", "p0", "--to", "p6", "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no path", "p0", "p6", "component")


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--from", "p42", "--to", "p1"], "p42"),
        (["--from", "lobby", "--to", "p1"], "lobby"),
        (["--from", "p0", "--to", "p1", "--time", "yesterday-ish"], "yesterday-ish"),
        (["--from", "p0", "--to", "p1", "--speed", "-1"], "--speed"),
        # millimetres, or another frame: far beyond the graph, not snapped to its edge
        (["--from", "p0", "--to", "3900,1700"], "farther than the whole map spans"),
        (["--from", "1e300,0", "--to", "p0"], "is 1e+300 m from the nearest place"),  # no overflow
        # raw integer ids: past uint64, or a digit int() does not read (internal errors before)
        (["--from", "9" * 30, "--to", "p0"], "9" * 30),
        (["--from", "p0", "--to", "\u00b2"], "not a node id"),
    ],
)
def test_bad_input_is_one_line_exit_2(office: Office, args: list[str], fragment: str) -> None:
    result = run("plan", office.map, *args)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)


def test_plan_on_a_map_without_graph(tmp_path: Path) -> None:
    log = tmp_path / "cells.mcap"
    write_office_log(log, graph=False, tf=False)
    out = tmp_path / "cells.aion"
    run_json("build", log, "-o", out, "--format", "json")
    result = run("plan", out, "--from", "p0", "--to", "p1")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no navigational graph")


def test_subprocess_plan_with_export(office: Office, tmp_path: Path) -> None:
    ply = tmp_path / "route.ply"
    proc = run_process(
        "plan",
        office.map,
        "--from",
        "p0",
        "--to",
        "p4",
        "--time",
        AT,
        "--export",
        ply,
        "--format",
        "json",
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["temporal"]["path"] == ["p0", "p1", "p2", "p4"]
    assert ply.read_bytes().startswith(b"ply\n")
    assert b"element vertex" in ply.read_bytes()[:400]


def test_rooms_and_buildings_are_endpoints(office: Office) -> None:
    """A room plans from its place nearest the room's centre, a building likewise (checked by
    hand on the office graph: R1 holds p2 (4,0), p3 (6,0), p4 (4,2), centre (4.67, 0.67), so
    p2 at 0.94 m; B0 stands at (10, 0, 3), 5 m from p3 (6, 0, 0))."""
    doc = run_json(
        "plan", office.map, "--from", "R1", "--to", "B0", "--time", AT, "--format", "json"
    )
    start, goal = doc["snapped"]
    assert (start["option"], start["room"], start["node"]) == ("--from", "R1", "p2")
    assert start["distance_m"] == pytest.approx(2**0.5 * 2 / 3)
    assert start["point"] == pytest.approx([14 / 3, 2 / 3, 0.0])
    assert (goal["option"], goal["building"], goal["node"]) == ("--to", "B0", "p3")
    assert goal["distance_m"] == pytest.approx(5.0)
    assert doc["distance_only"]["path"] == ["p2", "p3"]
    table = run("plan", office.map, "--from", "R1", "--to", "p0", "--time", AT)
    assert table.exit_code == 0, table.stderr
    assert "--from room1 (R1): its place nearest the room's centre, p2" in table.stderr
    assert "room1 (p2) -> p0" in table.stdout  # the graph names its rooms
    missing = run("plan", office.map, "--from", "R9", "--to", "p0", "--time", AT)
    assert missing.exit_code == 2
    assert_one_line_error(missing.stderr, "R9")


def test_rooms_by_their_names(office: Office) -> None:
    """The office graph names its rooms room0 .. room2 (Hydra's room labels): a name, in any
    case, stands for the room, in plan and predict alike; an unknown one lists the names."""
    by_id = run_json("plan", office.map, "--from", "R1", "--to", "p0", "--time", AT,
                     "--format", "json")
    by_name = run_json("plan", office.map, "--from", "ROOM1", "--to", "p0", "--time", AT,
                       "--format", "json")
    assert by_name["temporal"] == by_id["temporal"]
    assert by_name["snapped"][0]["name"] == "room1"
    assert by_name["snapped"][0]["room"] == "R1"
    table = run("plan", office.map, "--from", "room1", "--to", "p0", "--time", AT)
    assert "--from room1 (R1): its place nearest the room's centre, p2" in table.stderr
    unknown = run("plan", office.map, "--from", "pantry", "--to", "p0", "--time", AT)
    assert unknown.exit_code == 2
    assert_one_line_error(unknown.stderr, "not a node id or room name: 'pantry'")
    assert "room0, room1, room2" in unknown.stderr
    rooms = run_json("predict", office.map, "--time", AT, "--layer", "rooms", "--node", "Room2",
                     "--format", "json")
    assert [r["id"] for r in rooms["entries"]] == ["R2"]


def test_an_unknown_name_lists_the_names_in_predict_and_export_as_in_plan(
    office: Office, tmp_path: Path
) -> None:
    """``predict --node pantry`` said only "not a node id: 'pantry'" with the hint that ids
    look like "p12", where plan (and export's path ends) list the graph's room names."""
    for args in (
        ["predict", office.map, "--time", AT, "--node", "pantry"],
        ["predict", office.map, "--from", AT, "--to", "2026-11-23 09:30", "--node", "pantry"],
        ["predict", office.map, "--time", AT, "--node", "p0", "--node", "pantry"],
        ["export", office.map, "--time", AT, "--path-from", "pantry", "--path-to", "p0",
         "-o", tmp_path / "out"],
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stdout
        assert_one_line_error(result.stderr, "not a node id or room name: 'pantry'")
        assert "room0, room1, room2" in result.stderr
    # ids and hash cells are no names: answered, or "not in the map", as before
    result = run("predict", office.map, "--time", AT, "--node", "p999")
    assert_one_line_error(result.stderr, "node p999 is not in the map")
    result = run("predict", office.map, "--time", AT, "--node", "c123")
    assert_one_line_error(result.stderr, "node c123 is not in the map")


def test_a_point_without_a_height_snaps_horizontally(office: Office) -> None:
    """``--from x,y`` names a spot on the floor plan: the place above or below it is
    0 m away (it was measured from height 0, so a place 1 m up on a real map was 1 m
    further, and another place could win). ``x,y,z`` is measured in 3-D (p1 at (2, 0, 0))."""
    import math

    from aion_cli.engine.nearest import distances_from
    from aion_cli.engine.node_ids import parse_point, shown_point

    flat = run_json("plan", office.map, "--from", "2,0", "--to", "p3", "--time", AT,
                    "--format", "json")["snapped"][0]
    assert (flat["node"], flat["distance_m"], flat["point"]) == ("p1", 0.0, [2.0, 0.0])
    high = run_json("plan", office.map, "--from", "2,0,5", "--to", "p3", "--time", AT,
                    "--format", "json")["snapped"][0]
    assert (high["node"], high["distance_m"], high["point"]) == ("p1", 5.0, [2.0, 0.0, 5.0])
    point = parse_point("3,4")
    assert point is not None
    assert math.isnan(point[2])
    assert shown_point(point) == [3.0, 4.0]
    assert distances_from([[0.0, 0.0, 12.0]], point).tolist() == [5.0]
    assert distances_from([[0.0, 0.0, 12.0]], (3.0, 4.0, 0.0)).tolist() == [13.0]


def test_the_temporal_plan_never_costs_more_than_the_distance_only_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """S(0) - X(2) directly (10 m) or by M(1) (10.2 m), then X - G(3) (10 m). S is busy, so
    reaching X by M is cheaper and the search keeps only that arrival at X; but G turns busy
    at 600 s, which the 0.2 m longer walk reaches G after and the direct one before. The
    search's path costs 27.7, the distance-only path 25.0: the plan is the cheaper one (it
    was the search's, dearer than the path printed beside it)."""
    from types import SimpleNamespace

    from aion_cli import mapquery
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.nav_graph import NavGraph
    from aion_cli.engine.planning import NodeCosts
    from aion_cli.engine.windows import EPOCH_NS
    from aion_cli.routes import plan_departures, plan_routes

    p = ord("p") << 56
    xyz = np.array([[0, 0, 0], [5, 1, 0], [10, 0, 0], [20, 0, 0]], dtype=float)
    nav = NavGraph.build(np.arange(4, dtype=np.uint64) + p, xyz, [(0, 2), (0, 1), (1, 2), (2, 3)])

    def node_cost(t_s: float) -> NodeCosts:
        flow = np.array([20.0, 0.0, 0.0, 20.0 if t_s >= 600.0 else 0.0])
        return NodeCosts(np.where(flow > 0, 0.0, np.nan), flow, np.full(4, np.nan), np.zeros(4))

    monkeypatch.setattr(mapquery, "node_cost_fn", lambda loaded, ids: node_cost)
    monkeypatch.setattr(mapquery, "planning_config", lambda loaded: ModelConfig())
    loaded: Any = SimpleNamespace(manifest={})  # lists no observed hours
    depart_ns = EPOCH_NS + round((600 - 20.1) * 1e9)
    routes = plan_routes(loaded, p, p + 3, depart_ns, 1.0, nav)
    assert list(routes.distance_only.node_ids) == [p, p + 2, p + 3]
    assert routes.distance_only.cost == pytest.approx(25.0)
    assert routes.temporal.node_ids == routes.distance_only.node_ids
    assert routes.temporal.cost == routes.distance_only.cost
    plans, best = plan_departures(loaded, p, p + 3, [depart_ns], 1.0, nav)
    assert plans[best].temporal.cost == pytest.approx(25.0)


def test_unknown_room_hint_lists_every_room(sample_map: Path) -> None:
    # the sample's graph has six rooms, R0 .. R5: the hint named the first five as "its
    # rooms", as if office 2 (R5) were not one of them
    result = run("plan", sample_map, "--from", "R9", "--to", "p2", "--time", AT)
    assert_one_line_error(result.stderr, "room R9 is not in the map")
    assert "hint: its rooms: R0, R1, R2, R3, R4, R5\n" in result.stderr
    assert run("plan", sample_map, "--from", "R5", "--to", "p2", "--time", AT).exit_code == 0


def test_a_node_id_in_the_other_case_is_pointed_to_its_spelling(office: Office) -> None:
    """``P1`` where the map has ``p1`` (ids keep their category letter's case, room names do
    not): plan and predict ask "did you mean p1?"; an id absent in both cases keeps listing
    the map's ids."""
    for args in (["plan", office.map, "--from", "P1", "--to", "p3"],
                 ["predict", office.map, "--node", "P1"]):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, "P1 is not in the")
        assert "hint: did you mean p1? (node ids are case-sensitive)" in result.stderr
    absent = run("predict", office.map, "--node", "P99999")
    assert "did you mean" not in absent.stderr
    assert "ids include p" in absent.stderr


def test_a_room_id_in_lower_case_is_pointed_to_the_room(office: Office) -> None:
    """``r1`` where the office has room ``R1`` (named room1): the hint listed the places
    (``nodes include p0, p1, ...``, ``ids include p0, ...``), as though the map had no
    such room; plan, export and predict now name the room and its name (predict said only
    that room ids are upper case). A room id absent in both cases keeps the places' hint
    (predict: that room ids are upper case)."""
    for args in (
        ["plan", office.map, "--from", "r1", "--to", "p3", "--time", AT],
        ["export", office.map, "--time", AT, "-o", office.map.parent / "r1.png",
         "--path-from", "r1", "--path-to", "p3"],
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, "node r1 is not in the navigational graph")
        assert "hint: did you mean R1 (room1)? (ids are case-sensitive" in result.stderr
    assert not (office.map.parent / "r1.png").exists()
    for args in (["--node", "r1"], ["--node", "r1", "--layer", "rooms"]):
        predicted = run("predict", office.map, *args)
        assert predicted.exit_code == 2, predicted.stderr
        assert_one_line_error(predicted.stderr, "node r1 is not in the map")
        assert "hint: did you mean R1 (room1)? (ids are case-sensitive" in predicted.stderr
    absent = run("plan", office.map, "--from", "r9", "--to", "p3", "--time", AT)
    assert "did you mean" not in absent.stderr
    assert "nodes include p0" in absent.stderr
    absent = run("predict", office.map, "--node", "r9")
    assert "did you mean" not in absent.stderr
    assert "room and building ids are upper case (R1, B0)" in absent.stderr


def test_the_plan_picture_names_the_rooms_asked_for(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--from room0 --to R1``: the table's title reads "room0 (p0) -> room1 (p2)", the
    picture's title and markers read "p0 to p2", "start p0", "goal p2", naming neither room.
    Both now name them as the table does (a place asked for by id stays its id)."""
    import aion_cli.pictures.plan as plan_picture

    drawn: list[dict[str, Any]] = []
    real = plan_picture.plan_figure

    def spy(*args: Any, **kwargs: Any) -> Any:
        drawn.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(plan_picture, "plan_figure", spy)
    for ends in (("room0", "R1"), ("p0", "p4")):
        png = tmp_path / f"{ends[0]}.png"
        args = ("plan", office.map, "--from", ends[0], "--to", ends[1], "--time", AT)
        doc = run_json(*args, "--png", png, "--format", "json")
        assert png.stat().st_size > 0
        table = run(*args, "-q").stdout
        snapped = {s["option"]: s for s in doc["snapped"]}
        if ends[0] == "room0":
            start = f"room0 ({snapped['--from']['node']})"
            goal = f"room1 ({snapped['--to']['node']})"
        else:
            start, goal = "p0", "p4"
        assert (drawn[-1]["start_label"], drawn[-1]["goal_label"]) == (start, goal)
        assert drawn[-1]["title"] == f"{start} to {goal}, departing Mon 2026-11-23 08:30 UTC"
        assert f"{start} -> {goal}, departing" in table


@pytest.mark.parametrize(
    ("where", "said"),
    [
        ("1,2,3,4", "(4 numbers)"),  # one coordinate too many
        ("(0.2,-0.1)", "without brackets"),
        ("[0.2, -0.1]", "without brackets"),  # a point as plan's JSON prints it
        ("0.2 -0.1", "joined by commas"),
        ("0.2;-0.1", "joined by commas"),
    ],
)
def test_a_mistyped_point_is_refused_as_a_point(office: Office, where: str, said: str) -> None:
    """Before: "not a node id: '1,2,3,4'" with a hint about node ids only, for what was
    meant as coordinates (plan, export --path-from/--path-to and Map.plan alike)."""
    result = run("plan", office.map, "--from", where, "--to", "p3", "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not a point x,y or x,y,z", repr(where))
    assert said in result.stderr
    assert "not a node id" not in result.stderr
    # the two forms it is told from still read as before: a point, and a place id
    doc = run_json("plan", office.map, "--from", "0.2,-0.1", "--to", "p3", "--time", AT,
                   "--format", "json")
    assert doc["from"] == "p0"


def test_a_room_whose_centre_place_is_isolated_is_reached_by_its_other_places(
    tmp_path: Path,
) -> None:
    """Hydra leaves a few places without edges. Room R1 holds p2 (4,0), p5 (5,0.1) - isolated -
    and p6 (6.5,0): its centre (31/6, 1/30) is nearest p5 (0.17 m), so "plan to R1" said "no
    path from p0 to p5" though p2 and p6 of R1 are joined to p0. Now R1 stands for its place
    nearest the centre of those joined to the other end: p2 (1.17 m), by hand."""
    import aion_cli as aion
    from tests.cli.logdata import build_graph

    log = tmp_path / "rooms.mcap"
    write_office_log(log, graph=False)
    places = {0: (0.0, 0.0, 0.0), 1: (2.0, 0.0, 0.0), 2: (4.0, 0.0, 0.0),
              5: (5.0, 0.1, 0.0), 6: (6.5, 0.0, 0.0)}
    graph = tmp_path / "rooms.json"
    build_graph(places, [(0, 1), (1, 2), (2, 6)], {0: (0, 1), 1: (2, 5, 6)}).save(
        str(graph), include_mesh=False
    )
    out = tmp_path / "rooms.aion"
    run_json("build", log, "--graph", graph, "-o", out, "--format", "json")
    centre = (31 / 6, 1 / 30)
    doc = run_json("plan", out, "--from", "p0", "--to", "R1", "--time", AT, "--format", "json")
    (goal,) = doc["snapped"]
    assert (goal["room"], goal["node"], goal["reachable_only"]) == ("R1", "p2", True)
    assert goal["distance_m"] == pytest.approx(float(np.hypot(4 - centre[0], centre[1])))
    assert doc["distance_only"]["path"] == ["p0", "p1", "p2"]
    assert doc["distance_only"]["length_m"] == pytest.approx(4.0)
    back = run("plan", out, "--from", "room1", "--to", "p0", "--time", AT)
    assert back.exit_code == 0, back.stderr
    assert "its place nearest the room's centre of those joined to the goal, p2" in " ".join(
        back.stderr.split()
    )
    assert aion.Map.load(out).plan("p0", "R1", time=AT).nodes == ["p0", "p1", "p2"]
    # a room whose centre place is joined keeps it, without the flag
    near = run_json("plan", out, "--from", "p2", "--to", "R0", "--time", AT, "--format", "json")
    assert near["snapped"][0]["node"] in ("p0", "p1")  # centre (1, 0): 1 m from both
    assert "reachable_only" not in near["snapped"][0]
    # a point is the place nearest it, joined or not: the error says which place it became
    # (it named p5, which nobody typed, and the note saying so is printed on success only)
    lost = run("plan", out, "--from", "0.1,0", "--to", "5,0.3", "--time", AT)
    assert lost.exit_code == 2
    assert_one_line_error(
        lost.stderr, "no path from p0 to p5", "the start 0.1,0 snapped to p0 (0.10 m away)",
        "the goal 5,0.3 snapped to p5 (0.20 m away)",
    )


def test_the_api_documents_the_snapped_records_keys(sample_map: Path) -> None:
    """docs/API.md listed ``Plan.snapped`` by name only, and a script found records keyed
    ``option`` with the command's "--from" / "--to" in them, undocumented. Every key a room's
    and a point's record has is documented in its bullet, and so are the option values."""
    import re

    import aion_cli as aion

    doc = (Path(__file__).resolve().parents[2] / "docs" / "API.md").read_text()
    bullet = re.search(r"^- `snapped`: (.*?)^- ", doc, re.M | re.S)
    assert bullet is not None, "docs/API.md documents Plan.snapped's records"
    named = set(re.findall(r"`([a-z_]+)`", bullet.group(1)))
    plan = aion.Map.load(sample_map).plan("kitchen", (3.0, 4.0), time=AT, tz="UTC")
    assert [s["option"] for s in plan.snapped] == ["--from", "--to"]
    assert all(f'"{s["option"]}"' in bullet.group(1) for s in plan.snapped)
    for record in plan.snapped:
        assert set(record) <= named, set(record) - named
