"""The scene of a map at one time as plain arrays: what every picture of a map draws.

One gathering for every output that shows a map's flows in space: the PLY/PCD scene
(``mapquery.export_map``), the top-down pictures (``aion_cli.pictures``) and any other scene
writer. The per-entry values come from the same entry table as ``aion predict``
(``predictions.entry_table``); positions, edges, rooms and the mesh from the map's latest
scene graph (``mapquery.latest_graph``). No click, rich or plotting here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import Mesh

if TYPE_CHECKING:
    from aion_cli.mapquery import LoadedMap

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]


@dataclass(frozen=True)
class Scene:
    """A map's scene at ``t_ns`` (None: as observed), arrays only.

    Nodes (entries bound to a navigational node): ``node_ids`` (NodeSymbol values),
    ``nodes_xyz`` f64[n,3], ``node_flow`` (expected detections per window, 0 where unknown),
    ``node_entropy`` (0..1, NaN without flow), ``node_angle`` (dominant direction, rad from +x,
    NaN without one), ``node_concentration`` (0..1, NaN without flow). Unbound hash cells:
    ``cells_xyz`` (centres), ``cells_flow``, ``cells_entropy``, ``cells_angle``. From the
    scene graph (empty for a map of hash cells only): ``places_xyz`` (every place, with or
    without an entry), ``edges_xyz`` f64[k,2,3] (place edge end points), ``room_ids`` /
    ``room_labels`` / ``room_xyz`` (one per room; a label is "" when the graph names none),
    ``place_room`` (the room row of each place, -1 for none) and ``mesh``. ``cell_size`` is
    the map's hash-cell edge (m), ``window_s`` its window (the flows are per window)."""

    t_ns: int | None
    cell_size: float
    window_s: float
    node_ids: U64
    nodes_xyz: F64
    node_flow: F64
    node_entropy: F64
    node_angle: F64
    node_concentration: F64
    cells_xyz: F64
    cells_flow: F64
    cells_entropy: F64
    cells_angle: F64
    places_xyz: F64
    edges_xyz: F64
    room_ids: U64
    room_labels: tuple[str, ...]
    room_xyz: F64
    place_room: I64
    mesh: Mesh | None


def scene_at(loaded: LoadedMap, t_ns: int | None) -> Scene:
    """The scene at ``t_ns`` (None: historical), from the entry table of ``aion predict``."""
    from aion_cli.predictions import entry_table

    return scene_of_table(loaded, entry_table(loaded, t_ns), t_ns)


def scene_of_table(loaded: LoadedMap, table: Any, t_ns: int | None = None) -> Scene:
    """The scene of an engine ``EntryTable`` (nodes and cells; rooms and buildings of an
    aggregated table are left out) with the geometry of the map's latest scene graph."""
    from aion_cli.engine.entries import CELL, NODE

    kind = np.asarray(table.kind)
    nodes, cells = kind == NODE, kind == CELL
    d = table.descriptors
    xyz = np.asarray(table.xyz, dtype=np.float64)
    flow = np.nan_to_num(np.asarray(d.flow_per_window, dtype=np.float64), nan=0.0)
    entropy = np.asarray(d.entropy, dtype=np.float64)
    graph = loaded.graph
    empty3 = np.zeros((0, 3))
    places_xyz, edges_xyz, room_xyz = empty3, np.zeros((0, 2, 3)), empty3
    labels: tuple[str, ...] = ()
    room_ids = np.zeros(0, np.uint64)
    place_room = np.zeros(0, np.int64)
    mesh = None
    if graph is not None:
        places_xyz = np.asarray(graph.places.xyz, dtype=np.float64)
        edges = np.asarray(graph.edges, dtype=np.int64).reshape(-1, 2)
        edges_xyz = places_xyz[edges] if len(edges) else edges_xyz
        rooms = graph.rooms
        room_ids = np.asarray(rooms.ids, dtype=np.uint64)
        room_xyz = np.asarray(rooms.xyz, dtype=np.float64).reshape(-1, 3)
        labels = tuple(rooms.labels) if len(rooms.labels) == len(rooms) else ("",) * len(rooms)
        place_room = _rows_of(room_ids, np.asarray(graph.places.parent))
        mesh = graph.mesh
    return Scene(
        t_ns=t_ns,
        cell_size=float(loaded.config.cell_size),
        window_s=float(loaded.config.window_s),
        node_ids=np.asarray(table.node_id, dtype=np.uint64)[nodes],
        nodes_xyz=xyz[nodes],
        node_flow=flow[nodes],
        node_entropy=entropy[nodes],
        node_angle=np.asarray(d.dominant_angle, dtype=np.float64)[nodes],
        node_concentration=np.asarray(d.concentration, dtype=np.float64)[nodes],
        cells_xyz=xyz[cells],
        cells_flow=flow[cells],
        cells_entropy=entropy[cells],
        cells_angle=np.asarray(d.dominant_angle, dtype=np.float64)[cells],
        places_xyz=places_xyz,
        edges_xyz=edges_xyz,
        room_ids=room_ids,
        room_labels=labels,
        room_xyz=room_xyz,
        place_room=place_room,
        mesh=mesh,
    )


def _rows_of(ids: npt.NDArray[Any], wanted: npt.NDArray[Any]) -> I64:
    """Row of each ``wanted`` id in ``ids`` (-1 where it is not there)."""
    ids = ids.astype(np.uint64)
    wanted = wanted.astype(np.uint64)
    if len(ids) == 0:
        return np.full(len(wanted), -1, np.int64)
    order = np.argsort(ids)
    pos = np.minimum(np.searchsorted(ids[order], wanted), len(ids) - 1)
    return np.where(ids[order][pos] == wanted, order[pos], -1).astype(np.int64)
