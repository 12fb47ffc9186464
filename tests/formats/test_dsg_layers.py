"""The navigational layer rule of every scene-graph reader, on graphs written by spark_dsg itself:
MESH_PLACES by name (``3[1]`` in 1.1.x, layer 20 before), else PLACES, ``--nav-layer`` to
override; the same answer from a saved JSON, a ``.sparkdsg`` and a DsgUpdate payload."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats import dsg as fdsg
from tests.formats import dsg_builders as b


def _ids(category: str, n: int) -> list[int]:
    return [b.sym(category, i) for i in range(n)]


def _pairs(snap: Any) -> set[tuple[int, int]]:
    return {tuple(sorted(map(int, p))) for p in snap.places.ids[snap.edges]}  # type: ignore[misc]


def _grid_pairs() -> set[tuple[int, int]]:
    return {tuple(sorted((b.sym("P", x), b.sym("P", y)))) for x, y in b.grid_edges()}  # type: ignore[misc]


def _sources(tmp_path: Path, G: Any) -> dict[str, Any]:
    """The graph as each reader sees it: a saved JSON, a saved .sparkdsg and a payload."""
    js = b.save(G, tmp_path / "dsg.json")
    binary = tmp_path / "dsg.sparkdsg"
    G.save(str(binary), False)
    return {
        "json": lambda layer=None: fdsg.load_graph(js, 7, layer).nav,
        "sparkdsg": lambda layer=None: fdsg.load_graph(binary, 7, layer).nav,
        "payload": lambda layer=None: fdsg.navigation(
            fdsg.read_dsg_payload(G.to_binary())[0], 7, layer
        ),
    }


@pytest.mark.parametrize("source", ["json", "sparkdsg", "payload"])
def test_hydra_1_1_mesh_places_are_chosen_by_name(tmp_path: Path, source: str) -> None:
    read = _sources(tmp_path, b.hydra_graph())[source]
    nav = read()
    assert (nav.layer.name, nav.layer.key, nav.layer.legacy) == ("MESH_PLACES", "3[1]", False)
    snap = nav.snapshot
    assert snap.layer_name == "mesh_places"
    assert snap.t_ns == 7
    order = np.argsort(snap.places.ids)
    assert snap.places.ids[order].tolist() == _ids("P", b.MESH_PLACES)
    np.testing.assert_array_equal(
        snap.places.xyz[order], [b.grid_xyz(i) for i in range(b.MESH_PLACES)]
    )
    assert len(snap.edges) == b.MESH_EDGES
    assert _pairs(snap) == _grid_pairs()
    # the rooms above the 2D places are their parents: left half R0, right half R1
    left = snap.places.xyz[:, 0] < b.COLS // 2
    assert (snap.places.parent[left] == b.sym("R", 0)).all()
    assert (snap.places.parent[~left] == b.sym("R", 1)).all()
    assert sorted(snap.rooms.labels) == ["kitchen", "office"]
    assert snap.buildings.ids.tolist() == [b.sym("B", 0)]


@pytest.mark.parametrize("source", ["json", "sparkdsg", "payload"])
@pytest.mark.parametrize("request_", ["PLACES", "places", "3", 3])
def test_nav_layer_places_overrides(tmp_path: Path, source: str, request_: Any) -> None:
    nav = _sources(tmp_path, b.hydra_graph())[source](request_)
    assert (nav.layer.name, nav.layer.key) == ("PLACES", "3")
    assert nav.snapshot.layer_name == "places"
    assert sorted(nav.snapshot.places.ids.tolist()) == _ids("p", b.PLACES_3D)
    assert nav.frontiers == 1  # p10 is a frontier: left out, and its edge too
    assert len(nav.snapshot.edges) == b.PLACES_3D_EDGES


@pytest.mark.parametrize("request_", ["MESH_PLACES", "mesh-places", "3[1]", " 3 [ 1 ] "])
def test_nav_layer_mesh_places_by_name_or_key(tmp_path: Path, request_: str) -> None:
    nav = _sources(tmp_path, b.hydra_graph())["json"](request_)
    assert str(nav.layer) == "MESH_PLACES (3[1])"
    assert len(nav.snapshot.places) == b.MESH_PLACES


def test_clearance_is_the_place_distance() -> None:
    nav = fdsg.navigation(b.hydra_graph(), 0, "PLACES", clearance=True)
    assert nav.clearance is not None
    order = np.argsort(nav.snapshot.places.ids)
    np.testing.assert_allclose(nav.clearance[order], 0.5 + 0.1 * np.arange(b.PLACES_3D))
    mesh = fdsg.navigation(b.hydra_graph(), 0, clearance=True)
    assert mesh.clearance is not None
    assert (mesh.clearance == 0).all()  # 2D places carry no free-space distance


@pytest.mark.parametrize("source", ["json", "sparkdsg", "payload"])
def test_legacy_layer_20_is_mesh_places(tmp_path: Path, source: str) -> None:
    read = _sources(tmp_path, b.legacy_mesh_graph())[source]
    for request_ in (None, "MESH_PLACES", "20"):
        nav = read(request_)
        assert (nav.layer.name, nav.layer.key, nav.layer.legacy) == ("MESH_PLACES", "20", True)
        assert sorted(nav.snapshot.places.ids.tolist()) == _ids("P", b.MESH_PLACES)
        assert _pairs(nav.snapshot) == _grid_pairs()
    # its empty PLACES layer can still be asked for: no places
    assert len(read("PLACES").snapshot.places) == 0


def test_empty_mesh_places_fall_back_to_places() -> None:
    G = b.hydra_graph(with_mesh_places=False)  # 3[1] declared, no node in it
    nav = fdsg.navigation(G, 0)
    assert str(nav.layer) == "PLACES (3)"
    assert len(nav.snapshot.places) == b.PLACES_3D
    forced = fdsg.navigation(G, 0, "MESH_PLACES")  # asked for: the empty layer, not PLACES
    assert str(forced.layer) == "MESH_PLACES (3[1])"
    assert len(forced.snapshot.places) == 0


def test_a_graph_naming_its_own_mesh_places_key() -> None:
    """The graph's own name wins over the default key: 2D places in 3[2], named MESH_PLACES."""
    import spark_dsg as dsg

    keys = [dsg.LayerKey(3), dsg.LayerKey(3, 1), dsg.LayerKey(3, 2)]
    G = dsg.DynamicSceneGraph(keys, {"MESH_PLACES": dsg.LayerKey(3, 2)})
    for partition, char in ((1, "X"), (2, "P")):
        for i in range(3):
            a = dsg.Place2dNodeAttributes()
            a.position = np.array([float(i), float(partition), 0.0])
            G.add_node(dsg.LayerKey(3, partition), dsg.NodeSymbol(char, i), a)
    for source in (G, fdsg.read_dsg_payload(G.to_binary())[0]):
        nav = fdsg.navigation(source, 0)
        assert str(nav.layer) == "MESH_PLACES (3[2])"
        assert sorted(nav.snapshot.places.ids.tolist()) == _ids("P", 3)
        unnamed = fdsg.navigation(source, 0, "3[1]")
        assert unnamed.layer.name == ""  # the graph names 3[2], not 3[1]
        assert unnamed.snapshot.layer_name == "layer_3[1]"
        assert sorted(unnamed.snapshot.places.ids.tolist()) == _ids("X", 3)


def test_decode_dsg_reports_the_layer() -> None:
    decoded = fdsg.decode_dsg(b.hydra_graph().to_binary(), 11)
    assert str(decoded.layer) == "MESH_PLACES (3[1])"
    assert len(decoded.snapshot.places) == b.MESH_PLACES
    assert decoded.version == fdsg.installed_version()
    places = fdsg.decode_dsg(b.hydra_graph().to_binary(), 11, layer="PLACES")
    assert len(places.snapshot.places) == b.PLACES_3D


def test_graph_layers_lists_keys_names_and_counts() -> None:
    assert fdsg.graph_layers(b.hydra_graph()) == [
        ("2", "OBJECTS", 0),
        ("3", "PLACES", b.PLACES_3D + 1),
        ("3[1]", "MESH_PLACES", b.MESH_PLACES),
        ("4", "ROOMS", 2),
        ("5", "BUILDINGS", 1),
    ]


def test_missing_layer_error_lists_the_graph_layers() -> None:
    G = b.hydra_graph()
    with pytest.raises(fdsg.GraphLayerError) as info:
        fdsg.navigation(G, 0, "20")
    assert info.value.message == (
        "scene graph has no layer 20; its layers: 2 OBJECTS (0 nodes), 3 PLACES (11 nodes), "
        "3[1] MESH_PLACES (96 nodes), 4 ROOMS (2 nodes), 5 BUILDINGS (1 node)"
    )
    assert "--nav-layer" in str(info.value.hint)
    with pytest.raises(fdsg.GraphLayerError, match="no layer named TRAVERSABILITY"):
        fdsg.navigation(G, 0, "traversability")


@pytest.mark.parametrize("bad", ["", "3[", "[1]", "3[1]x", "mesh places!", "-3", 3.0, True])
def test_bad_nav_layer_syntax(bad: Any) -> None:
    with pytest.raises(fdsg.GraphLayerError, match="bad navigational layer"):
        fdsg.parse_nav_layer(bad)


def test_parse_nav_layer_forms() -> None:
    assert fdsg.parse_nav_layer(None) is None
    assert fdsg.parse_nav_layer("20") == (20, 0)
    assert fdsg.parse_nav_layer(" 3[1] ") == (3, 1)
    assert fdsg.parse_nav_layer(4) == (4, 0)
    assert fdsg.parse_nav_layer("mesh-places") == "MESH_PLACES"
    with pytest.raises(fdsg.GraphLayerError, match="out of range"):
        fdsg.parse_nav_layer(f"3[{2**32}]")
