"""Scene graphs written with spark_dsg itself, shaped like current and older Hydra output.

``hydra_graph`` is what Hydra with spark_dsg 1.1.x saves: named layer keys, 2D places
(``Place2dNodeAttributes``) in the ``MESH_PLACES`` partition ``3[1]``, a few 3D places in
``PLACES`` (layer 3), rooms and a building. ``legacy_mesh_graph`` puts the 2D places in layer 20,
where spark_dsg < 1.1 (no partitions) kept them. ``tricky_graph`` hits every branch of the
layer scan; ``payload_pair_1_1_2`` and ``five_places_payload_1_1_2`` are payloads as spark_dsg
1.1.2 wrote them.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np

COLS, ROWS = 12, 8  # the 2D places: a 12 x 8 grid, 1 m apart
MESH_PLACES = COLS * ROWS  # 96
MESH_EDGES = (COLS - 1) * ROWS + COLS * (ROWS - 1)  # 4-neighbour grid edges: 172
PLACES_3D = 10  # a chain of 3D places along y = -3, one frontier place besides
PLACES_3D_EDGES = PLACES_3D - 1


def sym(category: str, index: int) -> int:
    """spark_dsg NodeSymbol value."""
    return (ord(category) << 56) | index


def grid_xyz(i: int) -> tuple[float, float, float]:
    """Position of 2D place ``P(i)``."""
    return float(i % COLS), float(i // COLS), 0.0


def grid_edges() -> list[tuple[int, int]]:
    edges = []
    for i in range(MESH_PLACES):
        if i % COLS < COLS - 1:
            edges.append((i, i + 1))
        if i // COLS < ROWS - 1:
            edges.append((i, i + COLS))
    return edges


def _hierarchy(G: Any, dsg: Any, place_layer: Any, parents: bool = True) -> None:
    """The 2D places (added by ``place_layer``), two rooms (left and right half of the grid,
    the places' parents when ``parents``) and a building above the rooms."""
    building = dsg.SemanticNodeAttributes()
    building.position = np.array([5.5, 3.5, 3.0])
    G.add_node(dsg.DsgLayers.BUILDINGS, dsg.NodeSymbol("B", 0), building)
    for r in range(2):
        room = dsg.RoomNodeAttributes()
        room.position = np.array([2.5 + 6 * r, 3.5, 1.0])
        room.name = ("kitchen", "office")[r]
        G.add_node(dsg.DsgLayers.ROOMS, dsg.NodeSymbol("R", r), room)
        G.insert_edge(dsg.NodeSymbol("R", r), dsg.NodeSymbol("B", 0))
    for i in range(MESH_PLACES):
        attrs = dsg.Place2dNodeAttributes()
        attrs.position = np.array(grid_xyz(i))
        place_layer(G, dsg.NodeSymbol("P", i), attrs)
        if parents:
            room = dsg.NodeSymbol("R", int(i % COLS >= COLS // 2))
            G.insert_edge(dsg.NodeSymbol("P", i), room)
    for a, b in grid_edges():
        G.insert_edge(dsg.NodeSymbol("P", a), dsg.NodeSymbol("P", b))


def hydra_graph(with_mesh_places: bool = True) -> Any:
    """A spark_dsg 1.1.x graph as Hydra writes it (see the module docstring)."""
    import spark_dsg as dsg

    keys = [dsg.LayerKey(k) for k in (2, 3, 4, 5)] + [dsg.LayerKey(3, 1)]
    names = {
        "OBJECTS": dsg.LayerKey(2),
        "AGENTS": dsg.LayerKey(2),
        "PLACES": dsg.LayerKey(3),
        "MESH_PLACES": dsg.LayerKey(3, 1),
        "ROOMS": dsg.LayerKey(4),
        "BUILDINGS": dsg.LayerKey(5),
    }
    G = dsg.DynamicSceneGraph(keys, names)
    for i in range(PLACES_3D + 1):
        attrs = dsg.PlaceNodeAttributes()
        attrs.position = np.array([float(i), -3.0, 1.0])
        attrs.distance = 0.5 + 0.1 * i
        attrs.real_place = i < PLACES_3D  # the last one is a frontier
        G.add_node(dsg.DsgLayers.PLACES, dsg.NodeSymbol("p", i), attrs)
        if i:
            G.insert_edge(dsg.NodeSymbol("p", i - 1), dsg.NodeSymbol("p", i))
    if with_mesh_places:
        _hierarchy(G, dsg, lambda g, s, a: g.add_node(dsg.LayerKey(3, 1), s, a))
    return G


def legacy_mesh_graph() -> Any:
    """2D places in layer 20 of a graph without layer names (spark_dsg < 1.1 Hydra graphs).
    Layer 20 is above the rooms there, so the places have no room parents."""
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    _hierarchy(G, dsg, lambda g, s, a: g.add_node(20, s, a), parents=False)
    return G


def save(G: Any, path: Path) -> Path:
    G.save(str(path), False)
    return path


def place_attributes(xyz: tuple[float, float, float], real: bool = True) -> Any:
    """spark_dsg PlaceNodeAttributes at ``xyz``, a real place or (``real=False``) a frontier."""
    import spark_dsg

    a = spark_dsg.PlaceNodeAttributes()
    a.position = np.array(xyz)
    a.real_place = real
    return a


def tricky_graph() -> Any:
    """Places of several categories (letters, digits, a control byte, bytes >= 128), names
    empty, equal to the short or long symbol form, or real; frontiers; parents in and out of
    the room layer; rooms named and unnamed; a building without a name."""
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    b = dsg.SemanticNodeAttributes()
    b.position = np.array([0.0, 0.0, 9.0])
    G.add_node(dsg.DsgLayers.BUILDINGS, dsg.NodeSymbol("B", 7), b)
    rooms = [(ord("R") << 56) | 0, (ord("R") << 56) | 1, (200 << 56) | 5]
    for k, rid in enumerate(rooms):
        r = dsg.RoomNodeAttributes()
        r.position = np.array([float(k), 1.0, 2.0])
        r.name = ["hall", "", str(dsg.NodeSymbol(rid))][k]
        G.add_node(dsg.DsgLayers.ROOMS, rid, r)
        if k < 2:
            G.insert_edge(rid, dsg.NodeSymbol("B", 7))
    cats = [ord("p"), ord("P"), ord("3"), 0, 1, 127, 128, 200, 255, ord("z")]
    rng = np.random.default_rng(4)
    ids = []
    for k, (cat, index) in enumerate(
        itertools.product(cats, [0, 1, 12, 2**32 + 5, 2**56 - 1])
    ):
        nid = (cat << 56) | index
        a = dsg.PlaceNodeAttributes()
        a.position = rng.normal(size=3)
        a.distance = float(k) / 7.0
        a.real_place = k % 9 != 4
        sym = dsg.NodeSymbol(nid)
        a.name = ["", sym.str(), str(sym), f"door {k}", "p(0)"][k % 5]
        G.add_node(dsg.DsgLayers.PLACES, nid, a)
        if k % 3:
            G.insert_edge(nid, rooms[k % 3])
        ids.append(nid)
    for a, c in zip(ids, ids[1:] + ids[:1], strict=True):
        G.insert_edge(a, c)
    for a, c in zip(ids[::7], ids[3::7], strict=False):
        G.insert_edge(a, c)
    return G


def payload_pair_1_1_2() -> tuple[bytes, bytes]:
    """A 1.1.3 payload and the same graph as spark_dsg 1.1.2 writes it.

    1.1.3 appended one field to PlaceNodeAttributes, ``anti_frontier`` (a bool after
    ``num_frontier_voxels``, spark_dsg node_attributes.cpp). Marking ``num_frontier_voxels`` with a
    unique value lets us find it (UINT64 tag 0xcf + 8 bytes) and drop the bool that follows.
    """
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    a = place_attributes((1.0, 2.0, 3.0))
    a.num_frontier_voxels = 0x0BADF00D
    a.anti_frontier = True
    G.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", 7), a)
    new = G.to_binary()
    marker = b"\xcf" + (0x0BADF00D).to_bytes(8, "little")
    i = new.find(marker)
    assert i > 0
    assert new.count(marker) == 1
    j = i + len(marker)
    assert new[j] == 0xC3  # anti_frontier = True
    return new, new[:j] + new[j + 1 :]


def five_places_payload_1_1_2() -> bytes:
    """Five places as spark_dsg 1.1.2 wrote them: 1.1.3 added a bool (``anti_frontier``) after
    ``num_frontier_voxels``; unique voxel counts mark where to drop it (as in
    :func:`payload_pair_1_1_2`)."""
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    for i in range(5):
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.position = np.array([2.0 * i, 0.0, 0.0])
        attrs.real_place = True
        attrs.num_frontier_voxels = 0x0BADF000 + i
        attrs.anti_frontier = True
        G.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", i), attrs)
    data = G.to_binary()
    for i in range(5):
        marker = b"\xcf" + (0x0BADF000 + i).to_bytes(8, "little")
        j = data.index(marker) + len(marker)
        assert data[j] == 0xC3  # anti_frontier = True
        data = data[:j] + data[j + 1 :]
    return data
