"""Lenient reading of JSON scene graphs that spark_dsg refuses: the real
``apartment_igx_dsg.json`` (dangling edges) and files spark_dsg wrote, then damaged here."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats import dsg as fdsg
from aion_cli.formats.dsg_json import skipped_text
from tests.formats import dsg_builders as b
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"
IGX = DATA / "apartment_igx_dsg.json"
APARTMENT = DATA / "apartment_dsg.json"


def _spark_refuses(path: Path) -> str:
    """spark_dsg's own error for the file (the tests below only mean something if it fails)."""
    import spark_dsg

    with pytest.raises(RuntimeError) as info, fdsg._native_output_silenced():
        spark_dsg.DynamicSceneGraph.load(str(path))
    return str(info.value)


# ----------------------------------------------------------------------------- the real file


@pytest.mark.skipif(not IGX.is_file(), reason=f"real data not present: {IGX}")
def test_real_igx_file_with_dangling_edges() -> None:
    assert "failed to add O(23)" in _spark_refuses(IGX)
    raw = json.loads(IGX.read_text())
    # what the file holds, counted from its JSON here, independently of the reader
    ids = {n["id"] for n in raw["nodes"]}
    dangling = [e for e in raw["edges"] if e["source"] not in ids or e["target"] not in ids]
    places = {n["id"] for n in raw["nodes"] if n["layer"] == 3}
    place_edges = {
        tuple(sorted((e["source"], e["target"])))
        for e in raw["edges"]
        if e["source"] in places and e["target"] in places
    }
    rooms = [n for n in raw["nodes"] if n["layer"] == 4]
    assert len(dangling) == 6
    assert len(places) == 437

    loaded = fdsg.load_graph(IGX)
    assert loaded.file.reader == "lenient"
    assert loaded.file.skipped == {"dangling_edges": len(dangling)}
    assert not loaded.file.rebuilt  # spark_dsg read the repaired file itself
    assert loaded.file.version is None  # legacy: no version header
    assert loaded.notes() == [
        "apartment_igx_dsg.json: spark_dsg refused it (failed to add O(23) → p(8928)); "
        "read leniently: 6 dangling edges skipped"
    ]
    snap = loaded.snapshot
    assert str(loaded.nav.layer) == "PLACES (3)"
    assert set(snap.places.ids.tolist()) == places
    assert _pairs(snap) == place_edges
    assert len(snap.rooms) == len(rooms)
    assert snap.agents is not None
    assert len(snap.agents) == sum(1 for n in raw["nodes"] if n["layer"] == 2 and "prefix" in n)
    by_id = {n["id"]: n["attributes"]["position"] for n in raw["nodes"]}
    np.testing.assert_allclose(snap.places.xyz, [by_id[int(i)] for i in snap.places.ids])


def _pairs(snap: Any) -> set[tuple[int, int]]:
    return {tuple(sorted(map(int, p))) for p in snap.places.ids[snap.edges]}  # type: ignore[misc]


# ----------------------------------------------------------------------------- damaged files


def _hydra_doc(tmp_path: Path) -> dict[str, Any]:
    """A Hydra 1.1.x graph saved by spark_dsg, as a JSON document to damage."""
    return dict(json.loads(b.save(b.hydra_graph(), tmp_path / "good.json").read_text()))


def _write(tmp_path: Path, doc: dict[str, Any], name: str = "bad.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def _node(doc: dict[str, Any], symbol: int) -> dict[str, Any]:
    return next(n for n in doc["nodes"] if n["id"] == symbol)


def test_every_kind_of_invalid_item_is_skipped_and_counted(tmp_path: Path) -> None:
    doc = _hydra_doc(tmp_path)
    P = lambda i: b.sym("P", i)  # noqa: E731
    nodes, edges = doc["nodes"], doc["edges"]
    first_edge = next(e for e in edges if {e["source"], e["target"]} == {P(0), P(1)})
    nodes.append(copy.deepcopy(_node(doc, P(5))))  # the same id twice
    moved = copy.deepcopy(_node(doc, P(6)))
    moved["attributes"]["position"] = [99.0, 99.0, 0.0]
    nodes.append(moved)  # a second P(6): the first one is kept
    del _node(doc, P(95))["attributes"]["position"]  # P(95): no position
    nodes.append({"id": "P7", "layer": 3})  # malformed
    edges.append({"source": P(0), "target": b.sym("P", 500)})  # dangling
    edges.append({"source": b.sym("O", 3), "target": P(1)})  # dangling
    edges.append(copy.deepcopy(first_edge))  # duplicate
    edges.append({"source": P(1), "target": P(0)})  # duplicate, the other way round
    edges.append({"source": P(2), "target": P(2)})  # self-loop
    edges.append({"source": P(3)})  # malformed
    path = _write(tmp_path, doc)
    assert "failed to add" in _spark_refuses(path)

    loaded = fdsg.load_graph(path)
    assert loaded.file.skipped == {
        "malformed_nodes": 1,
        "nodes_without_position": 1,
        "duplicate_nodes": 2,
        "malformed_edges": 1,
        "dangling_edges": 2,
        "edges_of_skipped_nodes": 3,  # P(95): two grid neighbours and its room
        "self_loops": 1,
        "duplicate_edges": 2,
    }
    assert loaded.notes() == [
        "bad.json: spark_dsg refused it (failed to add P(5)); read leniently: 1 malformed node, "
        "1 node without a position, 2 duplicate nodes, 1 malformed edge, 2 dangling edges, "
        "3 edges of skipped nodes, 1 self-loop edge and 2 duplicate edges skipped"
    ]
    snap = loaded.snapshot
    assert str(loaded.nav.layer) == "MESH_PLACES (3[1])"  # the file's layer names survive
    assert sorted(snap.places.ids.tolist()) == [P(i) for i in range(b.MESH_PLACES - 1)]
    assert len(snap.edges) == b.MESH_EDGES - 2
    row6 = int(np.flatnonzero(snap.places.ids == P(6))[0])
    np.testing.assert_array_equal(snap.places.xyz[row6], b.grid_xyz(6))


def test_attribute_spark_dsg_cannot_parse_rebuilds_the_graph(tmp_path: Path) -> None:
    """spark_dsg refuses the repaired file too: the graph is built from what aion reads."""
    doc = _hydra_doc(tmp_path)
    _node(doc, b.sym("P", 0))["attributes"]["type"] = "FancyPlaceAttributes"
    doc["edges"].append({"source": b.sym("P", 0), "target": b.sym("x", 1)})
    path = _write(tmp_path, doc)
    _spark_refuses(path)
    loaded = fdsg.load_graph(path, layer=None)
    assert loaded.file.rebuilt
    assert loaded.file.skipped == {"dangling_edges": 1}
    assert loaded.notes() == [
        "bad.json: spark_dsg refused it (invalid attributes for P(0)); read leniently: "
        "1 dangling edge skipped; spark_dsg refused the repaired file too (invalid "
        "attributes for P(0)), so only positions, names, labels, place distances and agent "
        "stamps were read"
    ]
    snap = loaded.snapshot
    assert str(loaded.nav.layer) == "MESH_PLACES (3[1])"
    assert sorted(snap.places.ids.tolist()) == [b.sym("P", i) for i in range(b.MESH_PLACES)]
    assert len(snap.edges) == b.MESH_EDGES
    assert sorted(snap.rooms.labels) == ["kitchen", "office"]
    places = fdsg.navigation(loaded.file.graph, 0, "PLACES", clearance=True)
    assert len(places.snapshot.places) == b.PLACES_3D  # the frontier flag was read too
    assert places.clearance is not None
    order = np.argsort(places.snapshot.places.ids)
    np.testing.assert_allclose(places.clearance[order], 0.5 + 0.1 * np.arange(b.PLACES_3D))


@pytest.mark.skipif(not APARTMENT.is_file(), reason=f"real data not present: {APARTMENT}")
def test_rebuilt_legacy_file_keeps_agents_and_hierarchy(tmp_path: Path) -> None:
    good = fdsg.load_graph(APARTMENT).snapshot
    doc = json.loads(APARTMENT.read_text())
    room = next(n for n in doc["nodes"] if n["layer"] == 4)
    room["attributes"]["type"] = "NoSuchAttributes"
    path = _write(tmp_path, doc, "apartment.json")
    loaded = fdsg.load_graph(path)
    assert loaded.file.rebuilt
    snap = loaded.snapshot
    assert sorted(snap.places.ids.tolist()) == sorted(good.places.ids.tolist())
    assert _pairs(snap) == _pairs(good)
    # the robot poses with their stamps, as the file gives them beside each agent node
    # (spark_dsg's own reader of legacy files leaves those stamps at 0)
    agents = sorted(
        (n["timestamp"], n["attributes"]["position"])
        for n in doc["nodes"]
        if n["layer"] == 2 and "prefix" in n
    )
    assert snap.agents is not None
    np.testing.assert_array_equal(snap.agents.t_ns, [t for t, _ in agents])
    np.testing.assert_allclose(snap.agents.xyz, [p for _, p in agents])
    assert int((snap.places.parent != 0).sum()) == int((good.places.parent != 0).sum())


def test_nan_in_an_attribute_rebuilds_the_graph(tmp_path: Path) -> None:
    """JSON has no NaN; a file with one (as some writers emit) is refused by spark_dsg's parser
    and read node by node; the place whose distance is NaN gets none (0)."""
    doc = _hydra_doc(tmp_path)
    _node(doc, b.sym("p", 2))["attributes"]["distance"] = float("nan")
    path = _write(tmp_path, doc)  # json.dumps writes the NaN literal
    assert "NaN" in path.read_text()
    _spark_refuses(path)
    loaded = fdsg.load_graph(path, layer="PLACES", clearance=True)
    assert loaded.file.rebuilt
    assert loaded.file.skipped == {}
    assert loaded.file.rebuild_reason == "a number in the file is not finite (NaN or Infinity)"
    assert "read leniently: nothing skipped" in loaded.notes()[0]
    nav = loaded.nav
    assert nav.clearance is not None
    order = np.argsort(nav.snapshot.places.ids)
    expected = 0.5 + 0.1 * np.arange(b.PLACES_3D)
    expected[2] = 0.0
    np.testing.assert_allclose(nav.clearance[order], expected)


# ----------------------------------------------------------------------------- bad files


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        (b'{"nodes": [', "not valid JSON (Expecting value at line 1 column 12)"),
        (b"\xff\xfe{}", "not JSON text"),
        (b'{"directed": false}', "without a 'nodes' list is not a spark_dsg graph"),
        (b"[1, 2, 3]", "without a 'nodes' list"),
        (b'{"nodes": [], "edges": 5}', "its 'edges' is not a list"),
        (b'{"nodes": [{"id": 1, "layer": 3, "attributes": {}}]}', "no node can be read"),
        (b'{"nodes": [{"id": -1, "layer": 3}]}', "(1 malformed node)"),
    ],
)
def test_files_that_are_no_graph_are_clear_errors(
    tmp_path: Path, content: bytes, fragment: str
) -> None:
    path = tmp_path / "broken.json"
    path.write_bytes(content)
    with pytest.raises(fdsg.GraphFileError) as info:
        fdsg.load_graph(path)
    assert fragment in info.value.message
    assert str(path) in info.value.message


def test_binary_file_is_never_read_leniently(tmp_path: Path) -> None:
    path = tmp_path / "g.sparkdsg"
    path.write_bytes(b"SPARK_DSG" + bytes(100))
    with pytest.raises(fdsg.GraphFileError, match="cannot read scene-graph file"):
        fdsg.load_graph(path)


def test_skipped_text() -> None:
    assert skipped_text({}) == "nothing skipped"
    assert skipped_text({"duplicate_nodes": 1}) == "1 duplicate node skipped"
    assert (
        skipped_text({"duplicate_nodes": 1, "dangling_edges": 3})
        == "1 duplicate node and 3 dangling edges skipped"
    )
