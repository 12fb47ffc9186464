"""Where simulated people walk: a navigational graph of places with rooms, walls and roles.

An :class:`Environment` holds the same fields as a :class:`GraphSnapshot` (place ids, positions,
edges, room parents, rooms, building) as numpy arrays, plus what the simulator needs on top: wall
segments for occlusion, a simple mesh for export, each place's clearance, and named *roles*
(entrance, kitchen, meeting room, robot dock, desks) that the daily schedule refers to.

Two sources: the paper's office (:func:`aion_cli.sim.office.office_environment`) and any real
spark_dsg scene graph file (:func:`load_graph_environment`), whose largest connected component of
real places becomes the walkable graph. A file is read by the loader every command uses
(:func:`formats.dsg.load_graph`): the same navigational layer (MESH_PLACES when the graph has
2D places, else PLACES, or ``--nav-layer``), the same lenient reading of damaged JSON.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from aion_cli.engine.types import F64, I64, U64, BoolA, GraphSnapshot, Mesh
from aion_cli.errors import InputError, NoPathError
from aion_cli.sim.geometry import segments_blocked

PLACE_CHAR = "p"
ROOM_CHAR = "R"
BUILDING_CHAR = "B"


def symbol(char: str, index: int | I64) -> U64:
    """spark_dsg NodeSymbol values ``(ord(char) << 56) | index`` for one or many indices."""
    return (np.uint64(ord(char)) << np.uint64(56)) | np.asarray(index, dtype=np.uint64)


@dataclass(frozen=True)
class Roles:
    """Place indices (rows of :attr:`Environment.xyz`) that the schedule and robot use."""

    entrance: int
    kitchen: int
    meeting: int
    dock: int
    desks: I64
    patrol: I64  # waypoints of the robot's tour, starting and ending at the dock


@dataclass(frozen=True)
class Environment:
    """A walkable place graph with its hierarchy; arrays, one row per place / room."""

    name: str
    place_ids: U64
    xyz: F64
    edges: I64
    place_room: U64
    clearance: F64
    room_ids: U64
    room_xyz: F64
    room_labels: tuple[str, ...]
    building_id: int
    roles: Roles
    walls: F64 = field(default_factory=lambda: np.zeros((0, 4)))
    mesh: Mesh | None = None
    layer: str = ""  # the scene graph's navigational layer, e.g. "MESH_PLACES (3[1])"
    notes: tuple[str, ...] = ()  # what reading the scene graph file had to skip

    @property
    def n_places(self) -> int:
        return len(self.place_ids)

    @cached_property
    def _graph(self) -> object:
        """The place edges as a symmetric sparse matrix of edge lengths."""
        from scipy.sparse import coo_matrix

        a, b = self.edges[:, 0], self.edges[:, 1]
        w = np.linalg.norm(self.xyz[a] - self.xyz[b], axis=1)
        m = self.n_places
        return coo_matrix(
            (np.concatenate([w, w]), (np.concatenate([a, b]), np.concatenate([b, a]))),
            shape=(m, m),
        ).tocsr()

    @cached_property
    def _trees(self) -> dict[int, I64]:
        """Shortest-path predecessor arrays, computed per source on first use (memory grows
        with the few sources the schedule uses, not with the square of the graph)."""
        return {}

    def path(self, src: int, dst: int) -> I64:
        """Place indices of a shortest path src → dst over the place edges (both ends included)."""
        if src == dst:
            return np.array([src], dtype=np.int64)
        pred = self._trees.get(src)
        if pred is None:
            from scipy.sparse.csgraph import dijkstra

            _, p = dijkstra(self._graph, directed=True, indices=src, return_predecessors=True)
            pred = self._trees[src] = np.asarray(p, dtype=np.int64)
        if pred[dst] < 0:
            raise NoPathError(
                f"places {src} and {dst} of environment {self.name!r} are not connected"
            )
        out = [dst]
        while out[-1] != src:
            out.append(int(pred[out[-1]]))
        return np.asarray(out[::-1], dtype=np.int64)

    def polyline(self, places: I64) -> F64:
        """Concatenated shortest paths through the given place sequence, as positions."""
        pieces: list[I64] = [places[:1]]
        for a, b in itertools.pairwise(places):
            pieces.append(self.path(int(a), int(b))[1:])
        return self.xyz[np.concatenate(pieces)]

    def visible(self, p: F64, q: F64) -> BoolA:
        """True where no wall blocks the sight line p[i]→q[i]."""
        return ~segments_blocked(p, q, self.walls)

    def visibility_matrix(self, sensor_range: float, line_of_sight: bool) -> BoolA:
        """V[i, j]: a sensor at place i sees place j (within range, and unblocked if asked)."""
        d = np.linalg.norm(self.xyz[:, None, :2] - self.xyz[None, :, :2], axis=-1)
        vis = d <= sensor_range
        if line_of_sight and len(self.walls):
            i, j = np.nonzero(vis)
            ok = self.visible(self.xyz[i], self.xyz[j])
            vis[i[~ok], j[~ok]] = False
        return vis


def largest_component(n: int, edges: I64) -> I64:
    """Indices of the nodes in the largest connected component of an undirected graph."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    biggest = np.bincount(labels).argmax()
    return np.flatnonzero(labels == biggest).astype(np.int64)


def spread_places(xyz: F64, count: int, first: int) -> I64:
    """``count`` well-separated place indices by farthest-point sampling from ``first``."""
    chosen = [first]
    dist = np.linalg.norm(xyz - xyz[first], axis=1)
    for _ in range(count - 1):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(xyz - xyz[nxt], axis=1))
    return np.asarray(chosen, dtype=np.int64)


def roles_for_graph(xyz: F64, n_desks: int, n_patrol: int = 6) -> Roles:
    """Roles for a graph without semantic labels: spread out over the places.

    The entrance is the place farthest from the centroid, the rest follow by farthest-point
    sampling so that trips cross the whole graph; the dock is the place nearest the centroid.
    """
    centroid = xyz.mean(axis=0)
    entrance = int(np.argmax(np.linalg.norm(xyz - centroid, axis=1)))
    dock = int(np.argmin(np.linalg.norm(xyz - centroid, axis=1)))
    spread = spread_places(xyz, min(len(xyz), 3 + max(n_desks, 1)), entrance)
    desks = np.resize(spread[3:], n_desks) if len(spread) > 3 else np.resize(spread, n_desks)
    tour = spread_places(xyz, min(len(xyz), n_patrol), dock)
    return Roles(
        entrance=entrance,
        kitchen=int(spread[min(1, len(spread) - 1)]),
        meeting=int(spread[min(2, len(spread) - 1)]),
        dock=dock,
        desks=np.asarray(desks, dtype=np.int64),
        patrol=np.concatenate([tour, [dock]]).astype(np.int64),
    )


def load_graph_environment(path: Path, n_desks: int, nav_layer: str | None = None) -> Environment:
    """An environment from a spark_dsg scene graph file (Hydra dsg.json, .sparkdsg, legacy JSON).

    Keeps the real places of the navigational layer (``nav_layer``, see
    :func:`formats.dsg.choose_nav_layer`) that lie in the largest connected component of the
    place edges, their room parents, and the rooms' building.
    """
    from aion_cli.formats.dsg import layers_text, load_graph

    loaded = load_graph(path, 0, nav_layer, clearance=True)
    snap, layer = loaded.snapshot, loaded.nav.layer
    places = snap.places
    other = f"choose another layer with --nav-layer; layers: {layers_text(loaded.file.graph)}"
    if len(places) < 2:
        raise InputError(
            f"scene graph {path.name}: its navigational layer {layer} has "
            f"{len(places)} place{'' if len(places) == 1 else 's'}; at least two are needed",
            hint=other,
        )
    if len(snap.edges) == 0:
        raise InputError(
            f"scene graph {path.name}: its navigational layer {layer} has no place edges to "
            "walk on",
            hint=other,
        )
    keep = largest_component(len(places), snap.edges)
    remap = np.full(len(places), -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    edges = remap[snap.edges]
    edges = edges[(edges >= 0).all(axis=1)]
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    xyz = np.array(places.xyz[keep], dtype=np.float64)
    place_room = np.asarray(places.parent, dtype=np.uint64)[keep]
    clearance = loaded.nav.clearance
    room_ids, room_xyz, labels, building = _rooms_of(snap, place_room)
    notes = (
        tuple(loaded.notes())
        + _rooms_left_out(path, snap, layer)
        + _apart(path, np.asarray(places.parent, dtype=np.uint64), keep)
    )
    return Environment(
        name=path.name,
        place_ids=np.asarray(places.ids, dtype=np.uint64)[keep],
        xyz=xyz,
        edges=edges,
        place_room=place_room,
        clearance=np.zeros(len(keep)) if clearance is None else clearance[keep],
        room_ids=room_ids,
        room_xyz=room_xyz,
        room_labels=labels,
        building_id=building,
        roles=roles_for_graph(xyz, n_desks),
        layer=str(layer),
        notes=notes,
    )


def _apart(path: Path, parent: U64, keep: I64) -> tuple[str, ...]:
    """The note for places apart from the largest connected part of the place edges, which
    people cannot walk to and the simulation leaves out, and for the rooms that held only
    such places (a house of five rooms simulated with two, without a word)."""
    if len(keep) == len(parent):
        return ()
    rooms = np.unique(parent[parent != 0])
    kept = np.unique(parent[keep][parent[keep] != 0])
    gone = len(rooms) - len(kept)
    return (
        f"{path.name}: {len(parent) - len(keep):,} of its {len(parent):,} places lie apart "
        "from the largest connected part of the place edges, where people walk: left out"
        + (f", and so {'is' if gone == 1 else 'are'} {gone:,} of its {len(rooms):,} rooms "
           f"({'it holds' if gone == 1 else 'they hold'} only such places)" if gone else ""),
    )


def _rooms_left_out(path: Path, snap: GraphSnapshot, layer: object) -> tuple[str, ...]:
    """The note for a graph whose rooms hold none of the navigational layer's places (a Hydra
    graph whose rooms hold its 3D places while its 2D places are walked): the simulated
    graphs carry only the rooms of the walked places, so they have none, and the logs' maps
    answer per place only (:func:`aion_cli.room_names.rooms_off_the_nav_layer`)."""
    from aion_cli.room_names import rooms_off_the_nav_layer

    if rooms_off_the_nav_layer(snap) is None:
        return ()
    n = len(snap.rooms)
    return (
        f"{path.name}: none of its {n:,} room{'s' if n != 1 else ''} holds a place of the "
        f"navigational layer {layer}: the simulated scene graphs have no rooms (rooms "
        "that hold another layer's places: give --nav-layer naming it, e.g. --nav-layer PLACES)",
    )


def _rooms_of(snap: GraphSnapshot, place_room: U64) -> tuple[U64, F64, tuple[str, ...], int]:
    """The rooms that parent the kept places, and their building (B0 when the file has none)."""
    used = np.unique(place_room[place_room != 0])
    rooms = snap.rooms  # every used parent is one of them (the loader zeroes other parents)
    order = np.argsort(rooms.ids)
    rows = order[np.searchsorted(rooms.ids, used, sorter=order)] if len(used) else order[:0]
    parents = [int(p) for p in rooms.parent[rows] if int(p) != 0]
    building = parents[0] if parents else int(symbol(BUILDING_CHAR, 0))
    return (
        used.astype(np.uint64),
        np.asarray(rooms.xyz[rows], dtype=np.float64).reshape(-1, 3),
        tuple(rooms.labels[int(r)] for r in rows),
        building,
    )
