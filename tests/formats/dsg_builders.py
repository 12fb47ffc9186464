"""Scene graphs written with spark_dsg itself, shaped like current and older Hydra output.

``hydra_graph`` is what Hydra with spark_dsg 1.1.x saves: named layer keys, 2D places
(``Place2dNodeAttributes``) in the ``MESH_PLACES`` partition ``3[1]``, a few 3D places in
``PLACES`` (layer 3), rooms and a building. ``legacy_mesh_graph`` puts the 2D places in layer 20,
where spark_dsg < 1.1 (no partitions) kept them.
"""

from __future__ import annotations

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
