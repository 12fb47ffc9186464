"""A spark_dsg 1.1 graph whose rooms hold its 3D places (``PLACES``, layer 3) while it also has
2D places (``MESH_PLACES``, ``3[1]``), which are taken as the navigational layer: ``predict
--layer rooms`` and ``plan --from ROOM`` say that none of the graph's rooms holds a place of the
navigational layer and how to pick the layer they hold (they said the graph had no rooms, with
the hint that a derived graph has places only), and ``--nav-layer PLACES`` answers per room.

Built from the real Matterport3D house of Hydra-GNN (``../shared/data/dsg``); its rooms and
their places are counted with spark_dsg itself.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import assert_one_line_error, run
from tests.shared_data import needs, shared

MP3D = shared("dsg", "mp3d_x8F5xyUWy9e_dsg.json")
pytestmark = needs(MP3D, "the Matterport3D scene graph of Hydra-GNN")

T0 = 1_700_000_000
AT = str(T0 + 600)


@pytest.fixture(scope="module")
def house(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict[str, set[str]]]:
    """The graph file with both place layers, a log of people standing at its places, and
    each room's 3D places (by spark_dsg)."""
    sd = pytest.importorskip("spark_dsg")
    folder = tmp_path_factory.mktemp("both")
    src = sd.DynamicSceneGraph.load(str(MP3D))
    graph = sd.DynamicSceneGraph()
    places = list(src.get_layer(sd.DsgLayers.PLACES).nodes)
    for node in places:
        attrs = sd.PlaceNodeAttributes()
        attrs.position = node.attributes.position
        graph.add_node(3, node.id.value, attrs, 0)
        flat = sd.Place2dNodeAttributes()
        flat.position = node.attributes.position
        graph.add_node(3, sd.NodeSymbol("S", node.id.category_id).value, flat, 1)
    for edge in src.get_layer(sd.DsgLayers.PLACES).edges:
        graph.insert_edge(edge.source, edge.target)
        s, t = (sd.NodeSymbol("S", sd.NodeSymbol(v).category_id).value
                for v in (edge.source, edge.target))
        graph.insert_edge(s, t)
    rooms: dict[str, set[str]] = {}
    for room in src.get_layer(sd.DsgLayers.ROOMS).nodes:
        attrs = sd.RoomNodeAttributes()
        attrs.position = room.attributes.position
        graph.add_node(4, room.id.value, attrs)
        rooms[room.id.str()] = set()
        for child in room.children():
            graph.insert_edge(room.id.value, child)
            rooms[room.id.str()].add(sd.NodeSymbol(child).str())
    path = folder / "both.json"
    graph.save(str(path), False)

    rows = io.StringIO()
    out = csv.writer(rows)
    out.writerow(["t_ns", "track_id", "x", "y", "z", "heading_rad", "speed_mps"])
    for k, node in enumerate(places[::7]):  # one person standing at every 7th place
        x, y, z = np.asarray(node.attributes.position, dtype=float)
        out.writerow([(T0 + 60 * k) * 10**9, k, x, y, z, 0.0, 0.0])
    (folder / "people.csv").write_text(rows.getvalue())
    log = folder / "people.mcap"
    assert run("convert", folder / "people.csv", "-o", log, "-q").exit_code == 0
    return path, log, rooms


def test_rooms_over_the_other_place_layer_are_named_in_the_error(
    house: tuple[Path, Path, dict[str, set[str]]], tmp_path: Path
) -> None:
    graph, log, rooms = house
    out = tmp_path / "both.aion"
    assert run("build", log, "--graph", graph, "-o", out, "-q").exit_code == 0

    result = run("predict", out, "--time", AT, "--layer", "rooms")
    assert result.exit_code == 2, result.stdout
    assert_one_line_error(
        result.stderr, f"none of the scene graph's {len(rooms)} rooms holds a place",
        "(mesh_places)",
    )
    assert "--nav-layer PLACES" in result.stderr
    assert "a graph aion derives" not in result.stderr

    plan = run("plan", out, "--from", "R1", "--to", "R0", "--time", AT)
    assert plan.exit_code == 2, plan.stdout
    assert_one_line_error(plan.stderr, "room R1 holds no place", f"{len(rooms)} rooms")
    assert "--nav-layer PLACES" in plan.stderr


def test_nav_layer_places_answers_per_room_with_the_sums_of_their_places(
    house: tuple[Path, Path, dict[str, set[str]]], tmp_path: Path
) -> None:
    graph, log, rooms = house
    out = tmp_path / "places.aion"
    built = run("build", log, "--graph", graph, "--nav-layer", "PLACES", "-o", out, "-q")
    assert built.exit_code == 0, built.stderr

    def flows(layer: str) -> dict[str, float]:
        result = run("predict", out, "--time", AT, "--layer", layer, "--format", "csv", "-q")
        assert result.exit_code == 0, result.stderr
        return {r["id"]: float(r["flow"]) for r in csv.DictReader(io.StringIO(result.stdout))}

    per_room, per_place = flows("rooms"), flows("places")
    assert set(per_room) == set(rooms)
    for room, held in rooms.items():
        assert per_room[room] == pytest.approx(sum(per_place.get(p, 0.0) for p in held))
    assert sum(per_room.values()) > 0


@pytest.mark.parametrize("graph_in", ["log", "file"])
def test_the_build_notes_rooms_that_hold_no_navigational_place(
    house: tuple[Path, Path, dict[str, set[str]]], tmp_path: Path, graph_in: str
) -> None:
    """The build says so (it said nothing; the first sign was predict refusing the map), for
    the graph of ``--graph FILE`` and for the DsgUpdate messages ``convert --graph`` writes."""
    graph, log, rooms = house
    if graph_in == "log":
        csv_file = tmp_path / "people.csv"
        csv_file.write_text((log.parent / "people.csv").read_text())
        log = tmp_path / "with_graph.mcap"
        converted = run("convert", csv_file, "-o", log, "--graph", graph, "-q")
        assert converted.exit_code == 0, converted.stderr
        extra: tuple[str | Path, ...] = ()
    else:
        extra = ("--graph", graph)
    built = run("build", log, *extra, "-o", tmp_path / "m.aion")
    assert built.exit_code == 0, built.stderr
    notes = [line for line in built.stderr.splitlines() if "rooms holds a place" in line]
    assert len(notes) == 1, built.stderr
    assert f"none of the scene graph's {len(rooms)} rooms" in notes[0]
    assert "--nav-layer PLACES" in notes[0]

    with_places = run("build", log, *extra, "--nav-layer", "PLACES", "-o", tmp_path / "p.aion")
    assert with_places.exit_code == 0, with_places.stderr
    assert "rooms holds a place" not in with_places.stderr


def test_info_map_names_the_layer_its_places_came_from(
    house: tuple[Path, Path, dict[str, set[str]]], tmp_path: Path
) -> None:
    """``aion info MAP`` said only ``graph: file both.json``: whether the map's places were
    the graph's 2D or 3D places could not be told from the map."""
    from tests.cli.conftest import run_json

    graph, log, _rooms = house
    for extra, layer in (((), "mesh_places"), (("--nav-layer", "PLACES"), "places")):
        out = tmp_path / f"{layer}.aion"
        assert run("build", log, "--graph", graph, *extra, "-o", out, "-q").exit_code == 0
        assert run_json("info", out, "--format", "json")["nav_layer"] == layer
        row = next(line for line in run("info", out).stdout.splitlines() if "graph" in line)
        assert f"places from layer {layer}" in row
