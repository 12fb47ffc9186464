"""``aion simulate --environment FILE`` reads scene graphs with the loader ``aion build`` uses:
a Hydra 1.1.x graph (96 2D places in ``MESH_PLACES`` = ``3[1]``, written by spark_dsg here),
``--nav-layer``, the real legacy file spark_dsg refuses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.formats import dsg_builders as b
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"
IGX = DATA / "apartment_igx_dsg.json"
# a fixed sensor for 72 minutes around noon, when people walk
SHORT = ("--days", "0.05", "--start", "2026-01-05T12:00", "--robot", "fixed")


@pytest.fixture(scope="module")
def hydra_json(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return b.save(b.hydra_graph(), tmp_path_factory.mktemp("graphs") / "dsg.json")


def test_simulate_walks_the_mesh_places_then_build_finds_them(
    hydra_json: Path, tmp_path: Path
) -> None:
    log = tmp_path / "sim.mcap"
    result = run("simulate", "-o", log, "--environment", hydra_json, *SHORT)
    assert result.exit_code == 0, result.stderr
    assert (
        "environment dsg.json: navigational layer MESH_PLACES (3[1]), 96 walkable places"
        in result.stderr
    )
    meta = json.loads((tmp_path / "sim.mcap.truth.json").read_text())
    assert meta["places"] == b.MESH_PLACES
    assert meta["nav_layer"] == "MESH_PLACES (3[1])"
    assert meta["environment_notes"] == []
    assert meta["detections"] > 0
    with np.load(tmp_path / "sim.mcap.truth.npz") as truth:
        assert sorted(truth["place_ids"].tolist()) == [b.sym("P", i) for i in range(96)]

    report = run_json(
        "build", log, "--graph", hydra_json, "-o", tmp_path / "a.aion", "--format", "json"
    )
    assert report["graph"]["layer"] == "MESH_PLACES (3[1])"
    assert report["nodes"] == b.MESH_PLACES
    assert report["detections"]["used"] == meta["detections"]
    # the simulated log's own scene graphs carry the same 96 places
    report = run_json("build", log, "-o", tmp_path / "b.aion", "--format", "json")
    assert report["graph"]["source"] == "log"
    assert report["nodes"] == b.MESH_PLACES


def test_simulate_nav_layer_places(hydra_json: Path, tmp_path: Path) -> None:
    binary = tmp_path / "dsg.sparkdsg"
    b.hydra_graph().save(str(binary), False)
    result = run(
        "simulate",
        "-o",
        tmp_path / "p.mcap",
        "--environment",
        binary,
        "--nav-layer",
        "PLACES",
        *SHORT,
    )
    assert result.exit_code == 0, result.stderr
    meta = json.loads((tmp_path / "p.mcap.truth.json").read_text())
    assert (meta["places"], meta["nav_layer"]) == (b.PLACES_3D, "PLACES (3)")
    with np.load(tmp_path / "p.mcap.truth.npz") as truth:
        assert sorted(truth["place_ids"].tolist()) == [b.sym("p", i) for i in range(10)]


def test_simulate_legacy_layer_20(tmp_path: Path) -> None:
    legacy = b.save(b.legacy_mesh_graph(), tmp_path / "legacy.json")
    result = run("simulate", "-o", tmp_path / "l.mcap", "--environment", legacy, *SHORT)
    assert result.exit_code == 0, result.stderr
    meta = json.loads((tmp_path / "l.mcap.truth.json").read_text())
    assert (meta["places"], meta["nav_layer"]) == (96, "MESH_PLACES (20)")


@pytest.mark.skipif(not IGX.is_file(), reason=f"real data not present: {IGX}")
def test_simulate_in_the_real_file_spark_dsg_refuses(tmp_path: Path) -> None:
    result = run("simulate", "-o", tmp_path / "igx.mcap", "--environment", IGX, *SHORT)
    assert result.exit_code == 0, result.stderr
    assert (
        "note: apartment_igx_dsg.json: spark_dsg refused it (failed to add O(23) → p(8928)); "
        "read leniently: 6 dangling edges skipped" in result.stderr
    )
    meta = json.loads((tmp_path / "igx.mcap.truth.json").read_text())
    assert meta["nav_layer"] == "PLACES (3)"
    assert meta["environment_notes"][0] == (
        "apartment_igx_dsg.json: spark_dsg refused it (failed to add O(23) → p(8928)); "
        "read leniently: 6 dangling edges skipped"
    )
    assert 2 <= meta["places"] <= 437  # the largest connected part of the 437 places


MP3D = DATA / "mp3d_x8F5xyUWy9e_dsg.json"


@pytest.mark.skipif(not MP3D.is_file(), reason=f"real data not present: {MP3D}")
def test_simulate_says_which_places_and_rooms_it_leaves_out(tmp_path: Path) -> None:
    """The Matterport house has 423 places in 5 rooms, not all joined by place edges; people
    walk the largest connected part, so the simulation left the other places out, and the
    rooms that hold only those, without a word: its maps had 2 of the house's 5 rooms. The
    counts expected are those of the file's own edges, its connected parts found here."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    doc = json.loads(MP3D.read_text())
    layer = {n["id"]: n["layer"] for n in doc["nodes"]}
    places = sorted(i for i, k in layer.items() if k == 3)
    at = {p: k for k, p in enumerate(places)}
    pairs = np.array([(at[e["source"]], at[e["target"]]) for e in doc["edges"]
                      if e["source"] in at and e["target"] in at])
    n = len(places)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    kept = np.flatnonzero(label == np.bincount(label).argmax())
    room_of = {}  # place -> room: the edges between layers 4 and 3
    for e in doc["edges"]:
        ends = (e["source"], e["target"])
        kinds = (layer.get(ends[0]), layer.get(ends[1]))
        if kinds in ((4, 3), (3, 4)):
            room_of[ends[kinds.index(3)]] = ends[kinds.index(4)]
    rooms = {i for i, k in layer.items() if k == 4}
    rooms_kept = {room_of[places[k]] for k in kept if places[k] in room_of}
    gone = len(rooms) - len(rooms_kept)
    assert (n, len(rooms)) == (423, 5)  # ../shared/data/README.md
    assert gone > 1  # some rooms and places lie apart
    assert len(kept) < n
    result = run("simulate", "-o", tmp_path / "h.mcap", "--environment", MP3D, *SHORT)
    assert result.exit_code == 0, result.stderr
    said = (
        f"mp3d_x8F5xyUWy9e_dsg.json: {n - len(kept)} of its 423 places lie apart from the "
        "largest connected part of the place edges, where people walk: left out, and so are "
        f"{gone} of its 5 rooms (they hold only such places)"
    )
    assert f"note: {said}" in " ".join(result.stderr.split())
    meta = json.loads((tmp_path / "h.mcap.truth.json").read_text())
    assert meta["places"] == len(kept)
    assert said in meta["environment_notes"]


def test_simulate_graph_errors_exit_2(hydra_json: Path, tmp_path: Path) -> None:
    out = tmp_path / "x.mcap"
    cases = [
        (("--nav-layer", "PLACES"), "--nav-layer needs a scene-graph file as --environment"),
        (("--environment", hydra_json, "--nav-layer", "ROOMS"), "ROOMS (4) has no place edges"),
        (("--environment", hydra_json, "--nav-layer", "20"), "scene graph has no layer 20"),
        (("--environment", hydra_json, "--nav-layer", "x["), "bad navigational layer 'x['"),
    ]
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    cases.append((("--environment", broken), "not valid JSON"))
    one = tmp_path / "one.json"
    b.save(_one_place_graph(), one)
    cases.append((("--environment", one), "MESH_PLACES (3[1]) has 1 place; at least two"))
    for extra, fragment in cases:
        result = run("simulate", "-o", out, "--quiet", *extra)
        assert result.exit_code == 2, (extra, result.stderr)
        assert_one_line_error(result.stderr, fragment)
    assert not out.exists()


def _one_place_graph() -> object:
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph([dsg.LayerKey(3), dsg.LayerKey(3, 1)], {})
    a = dsg.Place2dNodeAttributes()
    a.position = np.zeros(3)
    G.add_node(dsg.LayerKey(3, 1), dsg.NodeSymbol("P", 0), a)
    return G


def test_simulate_says_when_the_rooms_hold_none_of_the_walked_places(tmp_path: Path) -> None:
    """A Hydra graph whose rooms hold its 3D places (``PLACES``) while its 2D places
    (``MESH_PLACES``) are walked: the simulated graphs carry only the walked places' rooms,
    so they had none, without a word; now a note says so. With ``--nav-layer PLACES`` the
    rooms are the walked places' and there is no note."""
    import spark_dsg as dsg

    G = b.hydra_graph(with_mesh_places=False)
    b._hierarchy(G, dsg, lambda g, s, a: g.add_node(dsg.LayerKey(3, 1), s, a), parents=False)
    for i in range(b.PLACES_3D):
        G.insert_edge(dsg.NodeSymbol("p", i), dsg.NodeSymbol("R", int(i >= 5)))
    path = b.save(G, tmp_path / "rooms3d.json")
    back = dsg.DynamicSceneGraph.load(str(path))  # spark_dsg: the rooms hold 'p' places only
    kids = {dsg.NodeSymbol(c).category for r in back.get_layer(4).nodes for c in r.children()}
    assert kids == {"p"}
    result = run("simulate", "-o", tmp_path / "m.mcap", "--environment", path, *SHORT)
    assert result.exit_code == 0, result.stderr
    note = (
        "rooms3d.json: none of its 2 rooms holds a place of the navigational layer "
        "MESH_PLACES (3[1]): the simulated scene graphs have no rooms"
    )
    assert f"note: {note}" in result.stderr
    meta = json.loads((tmp_path / "m.mcap.truth.json").read_text())
    assert meta["nav_layer"] == "MESH_PLACES (3[1])"
    assert [n for n in meta["environment_notes"] if n.startswith(note)]
    result = run(
        "simulate", "-o", tmp_path / "p.mcap", "--environment", path, "--nav-layer", "PLACES",
        *SHORT,
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert "rooms3d.json: none of its" not in result.stderr
    assert json.loads((tmp_path / "p.mcap.truth.json").read_text())["environment_notes"] == []
