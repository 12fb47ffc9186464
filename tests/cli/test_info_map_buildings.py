"""``aion info MAP`` lists the buildings of the map's scene graph beside its rooms (text and
JSON ``buildings[{id, name, rooms}]``): it showed rooms only, so a map's buildings could not be
checked against its graph. Counted against spark_dsg's own reading of the real graphs of
``../shared/data/dsg``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json
from tests.shared_data import require, shared

T0 = 1_700_000_000


@pytest.mark.parametrize("name", ["apartment_dsg.json", "mp3d_x8F5xyUWy9e_dsg.json"])
def test_info_map_counts_the_graphs_buildings_and_rooms(name: str, tmp_path: Path) -> None:
    sd = pytest.importorskip("spark_dsg")
    graph_file = require(shared("dsg", name), f"the real scene graph {name}")
    graph = sd.DynamicSceneGraph.load(str(graph_file))
    buildings = {n.id.str(): len(list(n.children()))
                 for n in graph.get_layer(sd.DsgLayers.BUILDINGS).nodes}
    rooms = {n.id.str(): len(list(n.children()))
             for n in graph.get_layer(sd.DsgLayers.ROOMS).nodes}
    assert buildings
    assert rooms

    place = next(iter(graph.get_layer(sd.DsgLayers.PLACES).nodes)).attributes.position
    (tmp_path / "people.csv").write_text(
        "t_ns,track_id,x,y,z,heading_rad,speed_mps\n"
        + "".join(f"{(T0 + 60 * k) * 10**9},{k},{place[0]},{place[1]},{place[2]},0,1\n"
                  for k in range(3))
    )
    assert run("convert", tmp_path / "people.csv", "-o", tmp_path / "p.mcap", "-q").exit_code == 0
    out = tmp_path / "m.aion"
    built = run("build", tmp_path / "p.mcap", "--graph", graph_file, "-o", out, "-q")
    assert built.exit_code == 0, built.stderr

    doc = run_json("info", out, "--format", "json")
    assert {b["id"]: b["rooms"] for b in doc["buildings"]} == buildings
    assert {r["id"]: r["places"] for r in doc["rooms"]} == rooms
    text = run("info", out).stdout
    row = next(line for line in text.splitlines() if "buildings" in line)
    assert f"{len(buildings)}: " + ", ".join(buildings) in row
