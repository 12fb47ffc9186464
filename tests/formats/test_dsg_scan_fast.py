"""The layer scan behind :func:`formats.dsg.navigation` (issue 15: fewer binding calls per node)
gives exactly what the per-node scan before it gave.

The old scan is kept here verbatim (``_old_scan``, ``_old_label``: spark_dsg's own
``NodeSymbol.str()`` / ``str(NodeSymbol)`` per node) and swapped into the module; every
snapshot array, label and count must be equal, on real Hydra graphs, on graphs shaped like
current and older Hydra output and on graphs built to hit every branch (names equal to the
symbol's short and long forms and real names, categories that are no letter or no ASCII,
frontier places, nodes without parents, attribute types without ``name`` or ``real_place``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.engine.types import Layer
from aion_cli.formats import dsg as fdsg
from aion_cli.formats import dsg_scan
from tests.formats.dsg_builders import hydra_graph, legacy_mesh_graph, tricky_graph
from tests.formats.snapshot_checks import assert_same_snapshot
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"


def _old_label(symbol: Any, attrs: Any) -> str:
    short = symbol.str()
    name = getattr(attrs, "name", "") or ""
    return short if (not name or name == short or name == str(symbol)) else name


def _old_scan(
    view: Any | None, skip_frontiers: bool = False, edges: bool = False, clearance: bool = False
) -> Any:
    """``formats.dsg._scan`` as it was before issue 15."""
    none = np.zeros(0) if clearance else None
    if view is None:
        return fdsg._LayerScan(Layer.empty(), [], 0, none)
    nodes = list(view.nodes)
    attrs = [node.attributes for node in nodes]
    frontiers = 0
    if skip_frontiers:
        keep = [getattr(a, "real_place", True) for a in attrs]
        if not all(keep):
            frontiers = len(keep) - sum(map(bool, keep))
            nodes = [n for n, k in zip(nodes, keep, strict=True) if k]
            attrs = [a for a, k in zip(attrs, keep, strict=True) if k]
    if not nodes:
        return fdsg._LayerScan(Layer.empty(), [], frontiers, none)
    n = len(nodes)
    symbols = [node.id for node in nodes]
    ids = np.fromiter((s.value for s in symbols), dtype=np.uint64, count=n)
    xyz = np.concatenate([a.position for a in attrs]).astype(np.float64).reshape(-1, 3)
    parents = [node.get_parent() for node in nodes]
    parent = np.fromiter((0 if p is None else p for p in parents), dtype=np.uint64, count=n)
    labels = tuple(map(_old_label, symbols, attrs))
    neighbours = [node.siblings() for node in nodes] if edges else []
    dist = None
    if clearance:
        dist = np.fromiter((float(getattr(a, "distance", 0.0)) for a in attrs), np.float64, n)
    return fdsg._LayerScan(Layer(ids, xyz, parent, labels), neighbours, frontiers, dist)


def _assert_same_as_old(G: Any, monkeypatch: pytest.MonkeyPatch, layers: list[Any]) -> int:
    """navigation() with the new scan equals it with the old one, for every layer asked;
    returns the places compared (so a test knows it compared something)."""
    compared = 0
    for layer in layers:
        new = fdsg.navigation(G, 123, layer, clearance=True)
        with monkeypatch.context() as m:
            m.setattr(dsg_scan, "_scan", _old_scan)  # navigation() lives there
            old = fdsg.navigation(G, 123, layer, clearance=True)
        assert_same_snapshot(new.snapshot, old.snapshot)
        assert new.frontiers == old.frontiers
        assert new.layer == old.layer
        assert new.clearance is not None
        assert old.clearance is not None
        np.testing.assert_array_equal(new.clearance, old.clearance)
        compared += len(new.snapshot.places)
    return compared


REAL = [
    "apartment_dsg.json",
    "mp3d_x8F5xyUWy9e_dsg.json",
    "mp3d_x8F5xyUWy9e_partial_600_dsg.json",
    "apartment_igx_dsg.json",  # read leniently (spark_dsg refuses it)
]


@pytest.mark.parametrize("name", REAL)
def test_real_hydra_graphs_scan_as_before(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    path = DATA / name
    if not path.exists():
        pytest.skip(f"{path} not available")
    G = fdsg.read_dsg_file(path).graph
    assert _assert_same_as_old(G, monkeypatch, [None, "PLACES"]) > 100


def test_hydra_shaped_graphs_scan_as_before(monkeypatch: pytest.MonkeyPatch) -> None:
    G = hydra_graph()
    # 2D places (Place2dNodeAttributes: no real_place), 3D places with a frontier, objects
    assert _assert_same_as_old(G, monkeypatch, [None, "PLACES", "MESH_PLACES", "ROOMS"]) > 0
    assert _assert_same_as_old(legacy_mesh_graph(), monkeypatch, [None, "20"]) > 0
    # a payload round trip (what a DsgUpdate gives)
    decoded = fdsg.read_dsg_payload(G.to_binary(False))[0]
    assert _assert_same_as_old(decoded, monkeypatch, [None]) == 96


def test_tricky_ids_and_names_scan_as_before(monkeypatch: pytest.MonkeyPatch) -> None:
    G = tricky_graph()
    assert _assert_same_as_old(G, monkeypatch, [None, "ROOMS", "BUILDINGS"]) > 40
    decoded = fdsg.read_dsg_payload(G.to_binary(False))[0]
    assert _assert_same_as_old(decoded, monkeypatch, [None]) > 40


def test_symbol_strings_are_spark_dsgs() -> None:
    """The arithmetic short / long symbol forms equal spark_dsg's for every category byte."""
    import spark_dsg as dsg

    for cat in range(256):
        for index in (0, 9, 10, 123456, 2**56 - 1):
            value = (cat << 56) | index
            sym = dsg.NodeSymbol(value)
            assert fdsg._symbol_strings(value) == (sym.str(), str(sym)), value


def test_large_layer_labels_from_ids() -> None:
    """The one-category fast path of the labels (a 5,000-place layer without names)."""
    import spark_dsg as dsg

    ids = np.array([(ord("p") << 56) | i for i in range(5000)], np.uint64)
    labels = fdsg._labels(ids, [""] * 5000)
    assert labels == tuple(dsg.NodeSymbol(int(v)).str() for v in ids.tolist())
    named = [""] * 5000
    named[17], named[18], named[19] = "stairs", "p18", "p(19)"
    got = fdsg._labels(ids, named)
    assert got[17] == "stairs"
    assert got[18] == "p18"
    assert got[19] == "p19"
    assert got[:17] == labels[:17]
    # spark_dsg's default name is the long form: no name at all
    assert fdsg._labels(ids, [f"p({i})" for i in range(5000)]) == labels
    # several categories: node by node, the same rule
    mixed = np.array([(ord("p") << 56) | 3, (ord("R") << 56) | 3, 7], np.uint64)
    assert fdsg._labels(mixed, ["", "R(3)", "lobby"]) == ("p3", "R3", "lobby")


def test_empty_and_all_frontier_layers() -> None:
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    a = dsg.PlaceNodeAttributes()
    a.position = np.array([1.0, 2.0, 3.0])
    a.real_place = False
    G.add_node(dsg.DsgLayers.PLACES, dsg.NodeSymbol("p", 0), a)
    scan = fdsg._scan(G.get_layer(3), skip_frontiers=True, edges=True, clearance=True)
    old = _old_scan(G.get_layer(3), skip_frontiers=True, edges=True, clearance=True)
    assert scan.frontiers == old.frontiers == 1
    assert len(scan.layer) == len(old.layer) == 0
    assert fdsg._scan(None).layer.ids.size == 0


def test_module_has_no_per_node_label_call() -> None:
    """The fast path does not ask spark_dsg for symbol strings per node."""
    import spark_dsg as dsg

    ids = np.array([(ord("p") << 56) | i for i in range(50)], np.uint64)
    calls = 0
    real = dsg.NodeSymbol

    class Counting(real):  # type: ignore[misc,valid-type]
        def __init__(self, *args: Any) -> None:
            nonlocal calls
            calls += 1
            super().__init__(*args)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(dsg, "NodeSymbol", Counting)
        fdsg._labels(ids, ["x"] * 50)
    assert calls == 0
