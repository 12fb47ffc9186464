"""``aion export --format dsg`` gives back the scene graph the map was built from: every layer
the map stores (places in their own layer key, rooms, buildings, their edges, the robot poses,
the mesh) under the source graph's node ids, read back with spark_dsg and compared with the
source graph — a real Hydra file (read with :mod:`json` alone, :mod:`tests.dsg_real_files`) and
a generated ``hydra_msgs/DsgUpdate`` log whose navigational layer is Hydra's 2D places at
``3[1]``. What the map does not store (objects, the other places layer) is said in a note."""

from __future__ import annotations

from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import spark_dsg

from aion_cli.formats.dsg_export import place_layer
from tests.cli.conftest import run
from tests.dsg_real_files import from_json
from tests.shared_data import real
from tests.test_dsg_real_logs import _graph_members, _write_log

AGENTS = ord("a")


def _export(log: Path, tmp_path: Path, out_name: str, *graph: str) -> tuple[Any, str]:
    """Build ``log`` (with ``graph`` options) and export its scene graph as ``out_name``:
    the file read back with spark_dsg, and the export's stderr."""
    built = tmp_path / "m.aion"
    result = run("build", log, "-o", built, *graph)
    assert result.exit_code == 0, result.stderr
    out = tmp_path / out_name
    result = run("export", built, "--historical", "--format", "dsg", "-o", out)
    assert result.exit_code == 0, result.stderr
    return spark_dsg.DynamicSceneGraph.load(str(out)), result.stderr


def _nodes(G: Any, layer: int, partition: int = 0) -> dict[int, Any]:
    if not G.has_layer(layer, partition):
        return {}
    return {int(n.id.value): n.attributes for n in G.get_layer(layer, partition).nodes}


def _edges(G: Any, layer: int, partition: int = 0) -> set[tuple[int, int]]:
    return {
        (min(e.source, e.target), max(e.source, e.target))
        for e in G.get_layer(layer, partition).edges
    }


def _parents(G: Any, nodes: dict[int, Any]) -> dict[int, int]:
    """Each node's parent (0: none), from the interlayer edges spark_dsg read."""
    return {i: (next(iter(G.get_node(spark_dsg.NodeSymbol(i)).parents()), 0) or 0) for i in nodes}


@pytest.mark.parametrize(
    ("name", "out_name"),
    [("apartment_dsg.json", "g.json"), ("mp3d_x8F5xyUWy9e_dsg.json", "g.sparkdsg")],
)
def test_a_real_hydra_graph_comes_back_whole(name: str, out_name: str, tmp_path: Path) -> None:
    source = real("dsg", name)
    want = from_json(source)
    people = np.array(sorted(want.places.values())[:3])
    log = _write_log(tmp_path / "people.mcap", None, people)
    G, stderr = _export(log, tmp_path, out_name, "--graph", str(source))

    places = _nodes(G, 3)
    assert sorted(places) == sorted(want.places)  # the source's ids, in layer 3
    for i, attrs in places.items():
        np.testing.assert_array_equal(attrs.position, want.places[i])
    assert _edges(G, 3) == want.place_edges
    assert _parents(G, places) == want.place_room
    rooms = _nodes(G, 4)
    assert _parents(G, rooms) == want.rooms
    assert set(_nodes(G, 5)) == want.buildings
    # per layer key, the nodes the map stores: the source's counts but for what it drops
    assert G.get_layer(4).num_nodes() == want.layer_counts.get("4", 0)
    assert G.get_layer(5).num_nodes() == want.layer_counts.get("5", 0)
    agents = _nodes(G, 2, AGENTS)
    assert len(agents) == want.layer_counts.get("2[97]", 0) == len(want.agent_ns)
    order = [int(spark_dsg.NodeSymbol("a", k).value) for k in range(len(agents))]
    assert sorted(agents) == sorted(order)
    np.testing.assert_array_equal([agents[i].position for i in order], want.agent_xyz)
    stamps = [agents[i].timestamp.total_seconds() * 1e6 for i in order]
    np.testing.assert_array_equal(np.round(stamps).astype(np.int64), want.agent_ns // 1000)
    # unrotated, not spark_dsg's uninitialised quaternion (garbage, at times NaN: a JSON file
    # with a null its own reader refuses)
    rotations = [agents[i].world_R_body for i in order]
    assert [(q.w, q.x, q.y, q.z) for q in rotations] == [(1.0, 0.0, 0.0, 0.0)] * len(order)
    # objects are in the source (layer 2) but not in the map: none written, and said so
    assert want.layer_counts.get("2", 0) > 0
    assert G.get_layer(2).num_nodes() == 0
    assert "does not store a scene graph's objects" in stderr
    assert {n: (k.layer, k.partition) for n, k in G.layer_names.items()}["PLACES"] == (3, 0)
    # the places carry aion's dynamics, the graph says which layer they came from
    assert all("aion" in attrs.metadata.get() for attrs in places.values())
    assert G.metadata.get()["aion"]["nav_layer"] == "places"


def _two_d_graph() -> Any:
    """A Hydra-like graph of spark_dsg 1.1: 2D places ``S`` at MESH_PLACES ``3[1]`` (the
    navigational layer) with edges and rooms, 3D places ``p`` at ``3``, an object, two rooms,
    a building, five robot poses and a coloured two-triangle mesh."""
    key = spark_dsg.LayerKey
    names = {"OBJECTS": key(2), "AGENTS": key(2), "PLACES": key(3), "MESH_PLACES": key(3, 1)}
    names.update({"ROOMS": key(4), "BUILDINGS": key(5)})
    G = spark_dsg.DynamicSceneGraph(
        [key(2), key(2, AGENTS), key(3), key(3, 1), key(4), key(5)], names
    )

    def add(layer: Any, attrs: Any, symbol: Any, xyz: tuple[float, ...]) -> None:
        attrs.position = np.array(xyz, np.float64)
        assert G.add_node(layer, symbol, attrs)

    add(key(5), spark_dsg.SemanticNodeAttributes(), spark_dsg.NodeSymbol("B", 0), (2, 2, 0))
    for r in range(2):
        add(key(4), spark_dsg.RoomNodeAttributes(), spark_dsg.NodeSymbol("R", r), (r * 4, 2, 0))
        G.insert_edge(spark_dsg.NodeSymbol("R", r), spark_dsg.NodeSymbol("B", 0))
    for k in range(8):
        add(
            key(3, 1),
            spark_dsg.Place2dNodeAttributes(),
            spark_dsg.NodeSymbol("S", 10 + k),
            (k, 1.5 * (k % 2), 0),
        )
        G.insert_edge(spark_dsg.NodeSymbol("S", 10 + k), spark_dsg.NodeSymbol("R", k // 4))
        if k:
            G.insert_edge(spark_dsg.NodeSymbol("S", 9 + k), spark_dsg.NodeSymbol("S", 10 + k))
    for k in range(3):
        add(key(3), spark_dsg.PlaceNodeAttributes(), spark_dsg.NodeSymbol("p", k), (k, 0, 1))
    add(key(2), spark_dsg.ObjectNodeAttributes(), spark_dsg.NodeSymbol("O", 0), (1, 1, 0))
    for k in range(5):
        attrs = spark_dsg.AgentNodeAttributes()
        attrs.timestamp = timedelta(seconds=k + 1)
        add(key(2, AGENTS), attrs, spark_dsg.NodeSymbol("a", k), (k * 0.5, 0, 0))
    mesh = spark_dsg.Mesh(True, False, False, False)
    vertices = np.array([[0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 1, 0], [0, 1, 0, 0, 0, 1],
                         [1, 1, 0, 0.5, 0.5, 0.5]], np.float64)  # fmt: skip
    mesh.set_vertices(np.ascontiguousarray(vertices.T))
    mesh.set_faces(np.ascontiguousarray(np.array([[0, 1, 2], [1, 3, 2]], np.int32).T))
    G.mesh = mesh
    return G


def test_a_dsg_update_log_of_2d_places_keeps_their_layer_and_mesh(tmp_path: Path) -> None:
    source = _two_d_graph()
    payload = bytes(source.to_binary(True))
    want = _nodes(source, 3, 1)
    people = np.array([want[i].position for i in sorted(want)][:3])
    log = _write_log(tmp_path / "hydra.mcap", payload, people)
    G, stderr = _export(log, tmp_path, "g.json")

    assert {n: (k.layer, k.partition) for n, k in G.layer_names.items()}["MESH_PLACES"] == (3, 1)
    got = _nodes(G, 3, 1)
    assert sorted(got) == sorted(want)
    assert all(isinstance(a, spark_dsg.Place2dNodeAttributes) for a in got.values())
    for i, attrs in got.items():
        np.testing.assert_array_equal(attrs.position, want[i].position)
        # zeros, not spark_dsg's uninitialised memory (at times NaN: a null in the JSON file)
        assert not attrs.ellipse_centroid.any()
        assert not attrs.ellipse_matrix_compress.any()
        assert not attrs.ellipse_matrix_expand.any()
    assert _edges(G, 3, 1) == _edges(source, 3, 1)
    assert _parents(G, got) == _parents(source, want)
    assert _parents(G, _nodes(G, 4)) == _parents(source, _nodes(source, 4))
    assert set(_nodes(G, 5)) == set(_nodes(source, 5))
    # the 3D places and the object are not stored by the map: not written
    assert G.get_layer(3).num_nodes() == 0
    assert G.get_layer(2).num_nodes() == 0
    assert "other layers" in stderr
    agents, source_agents = _nodes(G, 2, AGENTS), _nodes(source, 2, AGENTS)
    assert sorted(agents) == sorted(source_agents)
    for i, attrs in agents.items():
        np.testing.assert_array_equal(attrs.position, source_agents[i].position)
        assert attrs.timestamp == source_agents[i].timestamp
    assert G.has_mesh()
    np.testing.assert_array_equal(G.mesh.get_vertices(), source.mesh.get_vertices())
    np.testing.assert_array_equal(G.mesh.get_faces(), source.mesh.get_faces())
    assert G.metadata.get()["aion"]["nav_layer"] == "mesh_places"
    # and aion reads the file back as the graph the log held: every graph_* member equal
    plain = _write_log(tmp_path / "plain.mcap", None, people)
    again = tmp_path / "again.aion"
    assert run("build", plain, "-o", again, "--graph", tmp_path / "g.json").exit_code == 0
    first, second = _graph_members(tmp_path / "m.aion")[0], _graph_members(again)[0]
    assert sorted(first) == sorted(second)
    for name, values in first.items():
        np.testing.assert_array_equal(values, second[name], err_msg=name)


@pytest.mark.parametrize(
    ("name", "key", "layer_name"),
    [
        ("places", (3, 0), "PLACES"),
        ("mesh_places", (3, 1), "MESH_PLACES"),  # spark_dsg 1.1's key of Hydra's 2D places
        ("layer_20", (20, 0), "MESH_PLACES"),  # a legacy graph's unnamed layer 20
        ("layer_3[2]", (3, 2), ""),
        ("rooms", (4, 0), "ROOMS"),
        ("derived", (3, 0), "PLACES"),  # aion's own places: no source layer
    ],
)
def test_the_places_layer_key_from_the_name_the_map_keeps(
    name: str, key: tuple[int, int], layer_name: str
) -> None:
    nav = place_layer(name)
    assert (nav.layer, nav.partition, nav.name) == (*key, layer_name)
