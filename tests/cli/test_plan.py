"""``aion plan``: paths, costs, snapping and failures on the office map (its endpoints by room,
building or a misspelt id: ``test_plan_endpoints.py``)."""

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
