"""Scene-graph decoding: real Hydra graphs, a hand-built graph round trip, the version fallback."""

from __future__ import annotations

import datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import InputError, MessageDecodeError
from aion_cli.formats import dsg as fdsg
from tests.formats.dsg_builders import payload_pair_1_1_2, place_attributes
from tests.shared_data import SHARED_DATA, needs, real_path

DATA = SHARED_DATA / "dsg"
APARTMENT = real_path("dsg", "apartment_dsg.json")
MP3D = DATA / "mp3d_x8F5xyUWy9e_dsg.json"


def sym(c: str, i: int) -> int:
    return (ord(c) << 56) | i


def _edges_valid(snap: Any) -> None:
    e = snap.edges
    assert e.dtype == np.int64
    assert e.ndim == 2
    assert e.shape[1] == 2
    assert (e >= 0).all()
    assert (e < len(snap.places)).all()
    assert (e[:, 0] < e[:, 1]).all()  # each undirected pair once, no self loops
    assert len(np.unique(e, axis=0)) == len(e)


# ----------------------------------------------------------------------------- real graphs


@needs(APARTMENT, "the apartment scene graph")
def test_apartment_counts_and_hierarchy() -> None:
    snap = fdsg.load_graph_file(APARTMENT)
    assert snap.layer_name == "places"
    assert len(snap.places) == 185
    assert len(snap.edges) == 396
    _edges_valid(snap)
    assert len(snap.rooms) == 1
    assert len(snap.buildings) == 1
    assert snap.rooms.labels == ("R0",)
    assert int(snap.rooms.ids[0]) == sym("R", 0)
    assert int(snap.rooms.parent[0]) == int(snap.buildings.ids[0]) == sym("B", 0)
    # The file links 135 of its 185 places to R0 (interlayer edges); the rest have no room.
    assert set(snap.places.parent.tolist()) == {0, sym("R", 0)}
    assert int((snap.places.parent == sym("R", 0)).sum()) == 135
    assert all(lbl.startswith("p") for lbl in snap.places.labels)
    assert snap.agents is not None
    assert len(snap.agents) == 102
    assert snap.mesh is None
    assert np.isfinite(snap.places.xyz).all()


@needs(MP3D, "the mp3d scene graph")
def test_mp3d_counts() -> None:
    snap = fdsg.load_graph_file(MP3D, t_ns=123)
    assert snap.t_ns == 123
    assert len(snap.places) == 423
    assert len(snap.edges) == 1261
    _edges_valid(snap)
    assert len(snap.rooms) == 5
    assert sorted(snap.rooms.labels) == ["R0", "R1", "R2", "R3", "R4"]
    assert (snap.rooms.parent == snap.buildings.ids[0]).all()
    assert set(snap.places.parent.tolist()) <= {0, *snap.rooms.ids.tolist()}


@needs(DATA, "the real scene graphs")
def test_real_graph_binary_round_trip_matches_file() -> None:
    """Real graph -> to_binary -> decode gives the same nodes, edges and parents as the file."""
    graph = fdsg.load_dsg_file(APARTMENT)
    direct = fdsg.snapshot_from_dsg(graph, 0)
    decoded = fdsg.decode_dsg(graph.to_binary(True), 5)
    assert decoded.version == fdsg.installed_version()
    snap = decoded.snapshot
    assert snap.t_ns == 5
    order_a = np.argsort(direct.places.ids)
    order_b = np.argsort(snap.places.ids)
    np.testing.assert_array_equal(direct.places.ids[order_a], snap.places.ids[order_b])
    np.testing.assert_allclose(direct.places.xyz[order_a], snap.places.xyz[order_b])
    np.testing.assert_array_equal(direct.places.parent[order_a], snap.places.parent[order_b])

    def id_pairs(s: Any) -> set[tuple[int, int]]:
        ids = s.places.ids[s.edges]
        return {(int(min(a, b)), int(max(a, b))) for a, b in ids}

    assert id_pairs(direct) == id_pairs(snap)


# ----------------------------------------------------------------------------- a built graph


def _build_graph() -> Any:
    """p0..p2 real places under room R3 (building B1), p9 a frontier; a mesh and 3 agent poses."""
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    positions = {0: (0.0, 0.0, 1.0), 1: (2.0, 0.0, 1.0), 2: (2.0, 3.0, 1.5)}
    for i, xyz in positions.items():
        G.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", i), place_attributes(xyz))
    G.add_node(
        spark_dsg.DsgLayers.PLACES,
        spark_dsg.NodeSymbol("p", 9),
        place_attributes((9, 9, 9), real=False),
    )
    room = spark_dsg.RoomNodeAttributes()
    room.position = np.array([1.0, 1.0, 1.0])
    room.name = "kitchen"
    G.add_node(spark_dsg.DsgLayers.ROOMS, spark_dsg.NodeSymbol("R", 3), room)
    building = spark_dsg.SemanticNodeAttributes()
    building.position = np.array([1.0, 1.0, 5.0])
    G.add_node(spark_dsg.DsgLayers.BUILDINGS, spark_dsg.NodeSymbol("B", 1), building)
    for s, t in [(0, 1), (1, 2), (2, 9)]:
        G.insert_edge(spark_dsg.NodeSymbol("p", s), spark_dsg.NodeSymbol("p", t))
    for i in (0, 1, 2):
        G.insert_edge(spark_dsg.NodeSymbol("p", i), spark_dsg.NodeSymbol("R", 3))
    G.insert_edge(spark_dsg.NodeSymbol("R", 3), spark_dsg.NodeSymbol("B", 1))
    for k, sec in enumerate((30, 10, 20)):
        agent = spark_dsg.AgentNodeAttributes()
        agent.position = np.array([float(k), 0.5, 0.0])
        agent.timestamp = datetime.timedelta(seconds=1_700_000_000 + sec, microseconds=250)
        G.add_node(2, spark_dsg.NodeSymbol("a", k), agent, ord("a"))
    mesh = spark_dsg.Mesh()
    verts = np.array(
        [
            [0, 1, 1, 0],
            [0, 0, 1, 1],
            [0, 0, 0, 0.5],
            [1, 0, 0, 0.2],
            [0, 1, 0, 0.4],
            [0, 0, 1, 0.6],
        ],
        dtype=np.float64,
    )
    mesh.set_vertices(verts)
    mesh.set_faces(np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32).T.copy())
    G.mesh = mesh
    return G


def test_built_graph_round_trip_through_payload() -> None:
    G = _build_graph()
    snap = fdsg.decode_dsg_update(G.to_binary(True), 42)
    assert snap.t_ns == 42
    assert snap.layer_name == "places"
    order = np.argsort(snap.places.ids)
    ids = snap.places.ids[order]
    assert ids.tolist() == [sym("p", 0), sym("p", 1), sym("p", 2)]  # frontier p9 left out
    np.testing.assert_allclose(snap.places.xyz[order], [[0, 0, 1], [2, 0, 1], [2, 3, 1.5]])
    assert [snap.places.labels[i] for i in order] == ["p0", "p1", "p2"]
    assert (snap.places.parent == sym("R", 3)).all()
    pairs = {tuple(sorted((int(a), int(b)))) for a, b in snap.places.ids[snap.edges]}
    assert pairs == {(sym("p", 0), sym("p", 1)), (sym("p", 1), sym("p", 2))}  # not p2-p9
    _edges_valid(snap)
    assert snap.rooms.ids.tolist() == [sym("R", 3)]
    assert snap.rooms.labels == ("kitchen",)
    assert snap.rooms.parent.tolist() == [sym("B", 1)]
    assert snap.buildings.ids.tolist() == [sym("B", 1)]
    assert snap.buildings.labels == ("B1",)
    assert snap.mesh is not None
    np.testing.assert_allclose(snap.mesh.vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.5]])
    np.testing.assert_allclose(
        snap.mesh.colors, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.4, 0.6]], atol=1e-6
    )
    assert snap.mesh.faces.dtype == np.int32
    assert snap.mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert snap.agents is not None
    base = 1_700_000_000 * 10**9 + 250_000
    assert snap.agents.t_ns.tolist() == [base + 10 * 10**9, base + 20 * 10**9, base + 30 * 10**9]
    np.testing.assert_allclose(snap.agents.xyz[:, 0], [1, 2, 0])  # sorted by time


def test_payload_without_mesh_has_no_mesh_and_uint8_array_accepted() -> None:
    G = _build_graph()
    payload = np.frombuffer(G.to_binary(False), dtype=np.uint8)  # as rosbags returns uint8[]
    snap = fdsg.decode_dsg_update(payload, 0)
    assert snap.mesh is None
    assert len(snap.places) == 3


def _mesh_places_graph() -> Any:
    import spark_dsg

    keys = [spark_dsg.LayerKey(k) for k in (2, 3, 4, 5)] + [spark_dsg.LayerKey(3, 1)]
    names = {
        "AGENTS": spark_dsg.LayerKey(2),
        "PLACES": spark_dsg.LayerKey(3),
        "MESH_PLACES": spark_dsg.LayerKey(3, 1),
        "ROOMS": spark_dsg.LayerKey(4),
        "BUILDINGS": spark_dsg.LayerKey(5),
    }
    G = spark_dsg.DynamicSceneGraph(keys, names)
    G.add_node(
        spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", 0), place_attributes((0, 0, 0))
    )
    for i in range(3):
        a = spark_dsg.Place2dNodeAttributes()
        a.position = np.array([float(i), 1.0, 0.0])
        G.add_node(spark_dsg.LayerKey(3, 1), spark_dsg.NodeSymbol("S", i), a)
    G.insert_edge(spark_dsg.NodeSymbol("S", 0), spark_dsg.NodeSymbol("S", 2))
    return G


def test_mesh_places_preferred_and_layer_override() -> None:
    G = _mesh_places_graph()
    snap = fdsg.decode_dsg_update(G.to_binary(), 0)
    assert snap.layer_name == "mesh_places"
    assert sorted(snap.places.ids.tolist()) == [sym("S", i) for i in range(3)]
    assert {tuple(sorted(map(int, p))) for p in snap.places.ids[snap.edges]} == {
        (sym("S", 0), sym("S", 2))
    }
    places = fdsg.snapshot_from_dsg(G, 0, layer="places")
    assert places.layer_name == "places"
    assert places.places.ids.tolist() == [sym("p", 0)]
    assert len(places.edges) == 0
    by_id = fdsg.snapshot_from_dsg(G, 0, layer=3)
    assert by_id.places.ids.tolist() == [sym("p", 0)]


def test_missing_or_unknown_layer_errors() -> None:
    G = _build_graph()
    with pytest.raises(fdsg.GraphLayerError, match=r"no layer MESH_PLACES \(3\[1\] or 20\)"):
        fdsg.snapshot_from_dsg(G, 0, layer="mesh_places")
    with pytest.raises(fdsg.GraphLayerError, match="no layer named OBJECTS_AND_STUFF"):
        fdsg.snapshot_from_dsg(G, 0, layer="objects_and_stuff")


# ----------------------------------------------------------------------------- version fallback


def test_older_payload_decodes_through_fallback() -> None:
    new, old = payload_pair_1_1_2()
    import spark_dsg

    with pytest.raises(ValueError, match="bool"):
        spark_dsg.DynamicSceneGraph.from_binary(old)  # the failure the fallback exists for
    decoded = fdsg.decode_dsg(old, 1)
    assert decoded.version == "1.1.2"
    assert decoded.snapshot.places.ids.tolist() == [sym("p", 7)]
    np.testing.assert_allclose(decoded.snapshot.places.xyz, [[1, 2, 3]])
    pinned = fdsg.decode_dsg(old, 1, version="1.1.2")
    assert pinned.version == "1.1.2"
    assert fdsg.decode_dsg(new, 1).version == fdsg.installed_version()


def test_pinned_wrong_version_fails_loudly() -> None:
    new, old = payload_pair_1_1_2()
    with pytest.raises(MessageDecodeError, match=r"1\.1\.2") as err:
        fdsg.decode_dsg_update(new, 0, version="1.1.2")
    assert "1.1.3" not in str(err.value)  # pinned: nothing else tried
    with pytest.raises(MessageDecodeError, match=r"1\.1\.3"):
        fdsg.decode_dsg_update(old, 0, version=fdsg.installed_version())


def test_header_layout() -> None:
    h = fdsg.spark_header("1.0.6")
    assert len(h) == 29
    assert h[:5] == b"\xdd\x09\x00\x00\x00"
    assert h[5:14] == b"SPARK_DSG"
    assert h[-6:] == bytes([0xCC, 1, 0xCC, 0, 0xCC, 6])


@pytest.mark.parametrize("bad", [b"", b"garbage!" * 10, b"\xdd\x04\x00\x00\x00\xdd"])
def test_garbage_payload_lists_versions(bad: bytes) -> None:
    with pytest.raises(MessageDecodeError) as err:
        fdsg.decode_dsg_update(bad, 0)
    text = str(err.value)
    for v in (fdsg.installed_version(), *fdsg.FALLBACK_VERSIONS):
        assert v in text
    assert isinstance(err.value, InputError)


@needs(APARTMENT, "the apartment scene graph")
def test_truncated_real_payload_fails() -> None:
    payload = fdsg.load_dsg_file(APARTMENT).to_binary()
    with pytest.raises(MessageDecodeError, match="versions tried"):
        fdsg.decode_dsg_update(payload[: len(payload) // 2], 0)


@pytest.mark.parametrize("version", ["1.1", "a.b.c", "1.1.300"])
def test_invalid_pinned_version(version: str) -> None:
    with pytest.raises(MessageDecodeError, match="invalid spark_dsg version"):
        fdsg.decode_dsg_update(b"", 0, version=version)


# ----------------------------------------------------------------------------- files


@pytest.mark.parametrize("suffix", [".json", ".sparkdsg"])
def test_saved_files_round_trip(tmp_path: Path, suffix: str) -> None:
    G = _build_graph()
    path = tmp_path / f"dsg_with_mesh{suffix}"
    G.save(str(path), include_mesh=True)
    snap = fdsg.load_graph_file(path)
    assert sorted(snap.places.ids.tolist()) == [sym("p", i) for i in range(3)]
    assert snap.mesh is not None
    assert snap.mesh.faces.shape == (2, 3)
    assert len(snap.edges) == 2


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(fdsg.GraphFileError, match="not found"):
        fdsg.load_graph_file(tmp_path / "nope.json")
    empty = tmp_path / "dsg.json"
    empty.write_text("")
    with pytest.raises(fdsg.GraphFileError, match="empty"):
        fdsg.load_graph_file(empty)
    garbage = tmp_path / "g.json"
    garbage.write_text("not json at all")
    with pytest.raises(fdsg.GraphFileError, match="cannot read"):
        fdsg.load_graph_file(garbage)
    binary = tmp_path / "g.sparkdsg"
    binary.write_bytes(b"\x00\x01garbage")
    with pytest.raises(fdsg.GraphFileError, match="cannot read"):
        fdsg.load_graph_file(binary)
    other = tmp_path / "g.ply"
    other.write_text("ply")
    with pytest.raises(fdsg.GraphFileError, match="extension"):
        fdsg.load_graph_file(other)


def test_version_sniff_orders_candidates() -> None:
    """Byte 5 tells layer keys (>= 1.1.2, 0xdd) from layer ids (<= 1.1.1, 0xd3): the likely
    family is tried first, the other still tried after it."""
    new_style = fdsg._candidate_versions(b"\xdd\x04\x00\x00\x00\xdd" + b"\x00" * 8)
    assert new_style[:2] == [fdsg.installed_version(), "1.1.2"]
    old_style = fdsg._candidate_versions(b"\xdd\x04\x00\x00\x00\xd3" + b"\x00" * 8)
    assert old_style[0] == "1.1.1"
    assert old_style[-2:] == [fdsg.installed_version(), "1.1.2"]
    assert sorted(old_style) == sorted(new_style)
