"""``aion plan``'s endpoints: rooms and buildings by id or name, a room whose centre place is
isolated, and what a name or id the map does not hold is told (its other spelling, the rooms
it has), in plan, predict and export alike."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log
from tests.cli.test_plan import AT


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


def test_a_name_on_a_map_without_rooms_says_it_has_none(tmp_path: Path) -> None:
    """``predict --node kitchen`` / ``plan --to kitchen`` on a map without rooms said "not a
    node id: 'kitchen'" (a hint about ids only), where ``--layer rooms`` says clearly that
    the map has no rooms: a word that is no id says the map has no rooms to name, and where
    names come from; ids keep their own errors."""
    from tests.robustness.conftest import T0, S, build_json, person, write_log

    walk = [person(T0 + k * S, (0.1 * (k % 100), 0.0, 0.0)) for k in range(300)]
    log = write_log(tmp_path / "walk.mcap", walk)
    derived, bare = tmp_path / "derived.aion", tmp_path / "bare.aion"
    assert build_json(log, "--derive-graph", "-o", derived)["nodes"] > 0
    build_json(log, "-o", bare)
    time = str(T0 // S)
    for args, why in (
        (["predict", derived, "--time", time, "--node", "kitchen"], "scene graph has no rooms"),
        (["plan", derived, "--time", time, "--from", "0,0", "--to", "kitchen"],
         "scene graph has no rooms"),
        (["predict", bare, "--time", time, "--node", "kitchen"], "no scene graph, so no rooms"),
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stdout
        assert_one_line_error(result.stderr, "not a node id or room name: 'kitchen'", why)
        assert "room labels of a Hydra scene graph" in result.stderr
    # an id's form keeps its error, and a place id is answered
    too_large = run("predict", derived, "--time", time, "--node", "p99999999999999999999")
    assert_one_line_error(too_large.stderr, "node index too large")
    assert run("predict", derived, "--time", time, "--node", "p0").exit_code == 0


def test_a_point_may_lie_as_far_as_the_map_spans_with_its_hash_cells(tmp_path: Path) -> None:
    """A scene graph of one place (0,0) and detections along x up to 39.6 m (hash cells): a
    point 30 m from the place lies inside the map, whose cells span 40 m, and snaps to it
    (plan, export's path ends and Map.plan alike), as ``predict --at`` takes it; it was
    refused as "farther than 10 m, more than the whole map spans (0 m)", the span of the
    graph alone. A point farther than the cells span is refused naming that span."""
    import aion_cli as aion
    from aion_cli.errors import InputError
    from tests.cli.logdata import save_graph_file
    from tests.robustness.conftest import T0, S, build_json, person, write_log

    walk = [person(T0 + k * S, (0.4 * (k % 100), 0.0, 0.0)) for k in range(300)]
    log = write_log(tmp_path / "walk.mcap", walk)
    graph = save_graph_file(tmp_path / "one.json", {0: (0.0, 0.0, 0.0)}, [])
    out = tmp_path / "one.aion"
    report = build_json(log, "--graph", graph, "-o", out)
    assert report["nodes"] == 1
    assert report["cells"] > 0
    time = str(T0 // S)
    doc = run_json("plan", out, "--time", time, "--from", "30,0", "--to", "p0",
                   "--format", "json")
    (start,) = doc["snapped"]
    assert start["node"] == "p0"
    assert start["distance_m"] == pytest.approx(30.0)
    exported = run("export", out, "--time", time, "--path-from", "30,0", "--path-to", "p0",
                   "-o", tmp_path / "scene")
    assert exported.exit_code == 0, exported.stderr
    assert aion.Map.load(out).plan("30,0", "p0", time=int(T0)).snapped[0]["node"] == "p0"
    far = run("plan", out, "--time", time, "--from", "80,0", "--to", "p0")
    assert_one_line_error(far.stderr, "80 m from the nearest place (p0)",
                          "farther than the whole map spans (40 m)")
    with pytest.raises(InputError, match="the whole map spans"):
        aion.Map.load(out).plan("80,0", "p0", time=int(T0))
