"""The navigational snapshot of a DsgUpdate payload from its bytes, without spark_dsg.

:func:`fast_navigation` reads the payload with :func:`formats.dsg_binary.read_graph` and
builds the :class:`formats.dsg_scan.NavGraph` that :func:`formats.dsg_scan.navigation` gives
for the graph spark_dsg would decode from it, with numpy over the node and edge arrays:

- layers: the keys the payload declares, names and node keys make; the navigational layer is
  chosen by :func:`formats.dsg_layers.choose_nav_layer` itself, on a stand-in for the graph
  (:class:`_Layers`) that answers its few questions;
- a layer's nodes in spark_dsg's order (a ``std::map`` by id), frontier places
  (``real_place`` false) left out of the navigational layer;
- a node's parent: its one neighbour in a higher layer (spark_dsg's ``get_parent`` is None
  for zero or several), edges whose nodes are both there (spark_dsg skips the others);
- labels by :func:`formats.dsg_scan._labels`, mesh and agents as :mod:`formats.dsg_scan`
  converts spark_dsg's (float32 vertices widened, colours / 255, stamps in microseconds).

None whenever the result could differ from spark_dsg's (a payload the reader does not vouch
for, a name that is not UTF-8, a missing requested layer, an agent partition holding other
node types): the caller then decodes with spark_dsg, which also gives the errors and
messages of those cases.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory
from aion_cli.formats.dsg_binary import BinaryGraph, read_graph
from aion_cli.formats.dsg_layers import (
    AGENTS_LAYER,
    BUILDINGS_LAYER,
    ROOMS_LAYER,
    GraphLayerError,
    choose_nav_layer,
)
from aion_cli.formats.dsg_scan import NavGraph, _labels

if TYPE_CHECKING:
    from aion_cli.formats.dsg_delta import GraphReader

I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]


class _Key(NamedTuple):
    layer: int
    partition: int


class _View:
    def __init__(self, key: tuple[int, int], n: int) -> None:
        self.id, self.partition = key
        self.n = n

    def num_nodes(self) -> int:
        return self.n


class _Layers:
    """What :func:`choose_nav_layer` asks of a spark_dsg graph (names, keys, node counts),
    answered from a :class:`BinaryGraph` the way spark_dsg's graph would: a key exists when
    the payload declares it, names it or has a node in it."""

    def __init__(self, g: BinaryGraph, counts: dict[tuple[int, int], int]) -> None:
        self.names = {n: _Key(*k) for n, k in g.layer_names.items()}
        self.keys = set(g.layer_keys) | set(g.layer_names.values()) | set(counts)
        self.counts = counts

    @property
    def layer_names(self) -> dict[str, _Key]:
        return self.names

    def get_layer_key(self, name: str) -> _Key | None:
        return self.names.get(name)

    def has_layer(self, layer: int, partition: int = 0) -> bool:
        return (int(layer), int(partition)) in self.keys

    def get_layer(self, layer: int, partition: int = 0) -> _View:
        key = (int(layer), int(partition))
        return _View(key, self.counts.get(key, 0))

    @property
    def layers(self) -> list[_View]:
        return [self.get_layer(*k) for k in sorted(self.keys) if k[1] == 0]

    @property
    def layer_partitions(self) -> list[_View]:
        return [self.get_layer(*k) for k in sorted(self.keys) if k[1] != 0]

    def named(self, name: str, default: tuple[int, int]) -> tuple[int, int]:
        key = self.names.get(name)
        return (key.layer, key.partition) if key is not None else default


class _UnsureError(Exception):
    """spark_dsg may give something else here: let it decode."""


class _Graph:
    """A :class:`BinaryGraph` with the lookups the snapshot needs (rows by id, parents)."""

    def __init__(self, g: BinaryGraph, labels: LabelMemo | None = None) -> None:
        self.g = g
        self.labels = labels
        self.counts: dict[tuple[int, int], int] = {}  # nodes per layer key
        for layer in _distinct(g.layer).tolist():
            parts, n = _distinct(g.partition[g.layer == layer], counts=True)
            for part, k in zip(parts.tolist(), n.tolist(), strict=True):
                self.counts[(int(layer), int(part))] = int(k)
        self.order = np.argsort(g.ids)
        self.sorted_ids = g.ids[self.order]
        src, dst = self.rows(g.edge_source), self.rows(g.edge_target)
        both = (src >= 0) & (dst >= 0)  # spark_dsg skips an edge to a missing node
        self.src, self.dst = src[both], dst[both]
        self.parent = self._parents()

    def rows(self, ids: U64) -> I64:
        """Node rows of ``ids`` (-1: no such node)."""
        if len(self.sorted_ids) == 0:
            return np.full(len(ids), -1, np.int64)
        at = np.searchsorted(self.sorted_ids, ids).clip(0, len(self.sorted_ids) - 1)
        found = self.sorted_ids[at] == ids
        return np.where(found, self.order[at], -1).astype(np.int64)

    def _parents(self) -> U64:
        """Per node the id of its one parent (a neighbour in a higher layer), 0 if it has none
        or several (spark_dsg's ``get_parent``)."""
        g = self.g
        ls, ld = g.layer[self.src], g.layer[self.dst]
        child = np.concatenate([self.dst[ls > ld], self.src[ld > ls]])
        parent = np.concatenate([self.src[ls > ld], self.dst[ld > ls]])
        out = np.zeros(len(g.ids), np.uint64)
        if len(child) == 0:
            return out
        order = np.lexsort((parent, child))  # by child, then parent
        child, parent = child[order], parent[order]
        new = np.ones(len(child), dtype=bool)  # each (child, parent) pair once
        new[1:] = (child[1:] != child[:-1]) | (parent[1:] != parent[:-1])
        child, parent = child[new], parent[new]
        kids, n = _distinct(child, counts=True)
        first = np.searchsorted(child, kids)
        one = n == 1
        out[kids[one]] = g.ids[parent[first[one]]]
        return out

    def layer_rows(self, key: tuple[int, int] | None) -> I64:
        """The rows of a layer's nodes in spark_dsg's order (by id)."""
        if key is None:
            return np.zeros(0, np.int64)
        rows = np.flatnonzero((self.g.layer == key[0]) & (self.g.partition == key[1]))
        return rows[np.argsort(self.g.ids[rows])]

    def names(self, rows: I64) -> list[str]:
        """The ``name`` of each node ("" for types without one); a name that is not UTF-8 is
        :class:`_UnsureError` (spark_dsg raises reading it)."""
        g = self.g
        length = g.name_len[rows]
        if not length.any():
            return [""] * len(rows)
        out = [""] * len(rows)
        data = g.data
        for i in np.flatnonzero(length).tolist():
            s = int(g.name_start[rows[i]])
            try:
                out[i] = bytes(data[s : s + int(length[i])]).decode("utf-8")
            except UnicodeDecodeError as exc:
                raise _UnsureError from exc
        return out

    def layer(self, rows: I64) -> Layer:
        if len(rows) == 0:
            return Layer.empty()
        g = self.g
        ids = g.ids[rows]
        names = self.names(rows)
        labels = self.labels.get(ids, names) if self.labels is not None else _labels(ids, names)
        return Layer(ids, g.xyz[rows], self.parent[rows], labels)


class LabelMemo:
    """The labels of the last few layers a stream's graphs gave (:func:`dsg_scan._labels` of
    their ids and names, 1.5 ms for 5,000 places): a live graph repeats its layers' ids and
    names, so they are compared (exactly) instead of made again."""

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self._kept: list[tuple[U64, list[str], tuple[str, ...]]] = []

    def get(self, ids: U64, names: list[str]) -> tuple[str, ...]:
        for kept_ids, kept_names, labels in self._kept:
            if np.array_equal(kept_ids, ids) and kept_names == names:
                return labels
        labels = _labels(ids, names)
        self._kept = [(ids.copy(), names, labels), *self._kept[: self.size - 1]]
        return labels


def _distinct(a: npt.NDArray[Any], counts: bool = False) -> Any:
    """``np.unique(a)`` (with the counts when asked) by sorting: numpy's hashing unique is
    ~20x slower on a few thousand integers."""
    s = np.sort(a)
    first = np.ones(len(s), dtype=bool)
    first[1:] = s[1:] != s[:-1]
    if not counts:
        return s[first]
    at = np.flatnonzero(first)
    return s[at], np.diff(np.append(at, len(s)))


def _keep_parents_in(layer: Layer, parents: Layer) -> Layer:
    valid = np.isin(layer.parent, parents.ids)
    if valid.all():
        return layer
    parent = np.where(valid, layer.parent, 0).astype(np.uint64)
    return Layer(layer.ids, layer.xyz, parent, layer.labels)


def _edges(gr: _Graph, rows: I64) -> npt.NDArray[np.int64]:
    """Edges among ``rows`` as unique sorted row-index pairs (as :func:`dsg_scan._edges`)."""
    n = len(rows)
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64)
    where = np.full(len(gr.g.ids), -1, np.int64)
    where[rows] = np.arange(n)
    a, b = where[gr.src], where[gr.dst]
    keep = (a >= 0) & (b >= 0) & (a != b)
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    key = _distinct(lo * n + hi)
    return np.column_stack([key // n, key % n]).astype(np.int64).reshape(-1, 2)


def _mesh(g: BinaryGraph) -> Mesh | None:
    if g.mesh is None or len(g.mesh[0]) == 0:
        return None
    points, colors, faces = g.mesh
    v = len(points)
    rgb = np.zeros((v, 3))
    k = min(v, len(colors))
    rgb[:k] = colors[:k, :3] / 255.0
    return Mesh(
        np.ascontiguousarray(points.astype(np.float64)),
        np.ascontiguousarray(faces.astype(np.int32)),
        np.ascontiguousarray(rgb),
    )


def _agent_rows(gr: _Graph, layers: _Layers) -> I64 | None:
    """The rows of the lowest non-empty agent partition (robot 'a'), or None."""
    agents = layers.named("AGENTS", (AGENTS_LAYER, 0))[0]
    parts = sorted(p for (k, p), n in gr.counts.items() if k == agents and p != 0 and n > 0)
    if not parts:
        return None
    rows = gr.layer_rows((agents, parts[0]))
    g = gr.g
    if g.kinds and (np.asarray(g.kinds, dtype=object)[g.kind[rows]] != "AgentNodeAttributes").any():
        raise _UnsureError  # spark_dsg's nodes would have no timestamp
    return rows


def _trajectory(g: BinaryGraph, rows: I64 | None) -> Trajectory | None:
    """The agents at ``rows`` as a trajectory, stamps truncated to microseconds as
    spark_dsg's ``timedelta`` has them."""
    if rows is None:
        return None
    ns = g.stamp_ns[rows]
    us = ns // 1000 + ((ns < 0) & (ns % 1000 != 0))  # toward zero, as pybind's timedelta
    t = us * 1000
    order = np.argsort(t, kind="stable")
    return Trajectory(t[order].astype(np.int64), g.xyz[rows][order])


def fast_navigation(
    payload: bytes | bytearray | memoryview | npt.NDArray[np.uint8],
    t_ns: int,
    layer: str | int | None,
    reader: GraphReader | None = None,
) -> NavGraph | None:
    """:func:`formats.dsg_scan.navigation` of the graph spark_dsg would decode from a DsgUpdate
    payload, or None when this module cannot vouch for the result (see the module
    docstring). ``clearance`` is not read (the stream never asks for it). ``reader``: a
    stream's :class:`formats.dsg_delta.GraphReader`, which re-reads only what changed since
    its last payload (the same graph)."""
    g = reader.read(payload) if reader is not None else read_graph(payload)
    if g is None:
        return None
    kept = reader.navigation if reader is not None and reader.values_only else None
    if isinstance(kept, _Moved) and kept.layer_asked == layer:
        return kept.at(g, t_ns)
    if reader is not None:
        reader.navigation = None
    try:
        nav, moved = _navigation(g, t_ns, layer, reader.labels if reader is not None else None)
    except (_UnsureError, GraphLayerError):
        return None
    if reader is not None:
        reader.navigation = moved
    return nav


def _navigation(
    g: BinaryGraph, t_ns: int, layer: str | int | None, labels: LabelMemo | None = None
) -> tuple[NavGraph, _Moved]:
    gr = _Graph(g, labels)
    layers = _Layers(g, gr.counts)
    nav = choose_nav_layer(layers, layer)
    building_rows = gr.layer_rows(layers.named("BUILDINGS", (BUILDINGS_LAYER, 0)))
    room_rows = gr.layer_rows(layers.named("ROOMS", (ROOMS_LAYER, 0)))
    buildings = gr.layer(building_rows)
    rooms = _keep_parents_in(gr.layer(room_rows), buildings)
    rows = gr.layer_rows((nav.layer, nav.partition))
    place_kind = g.kinds.index("PlaceNodeAttributes") if "PlaceNodeAttributes" in g.kinds else -1
    frontier = (g.kind[rows] == place_kind) & ~g.real_place[rows]
    rows = rows[~frontier]
    places = _keep_parents_in(gr.layer(rows), rooms)
    agent_rows = _agent_rows(gr, layers)
    snapshot = GraphSnapshot(
        t_ns=int(t_ns),
        places=places,
        edges=_edges(gr, rows),
        rooms=rooms,
        buildings=buildings,
        mesh=_mesh(g),
        agents=_trajectory(g, agent_rows),
        layer_name=nav.snapshot_name,
    )
    out = NavGraph(snapshot, nav, int(frontier.sum()), None)
    return out, _Moved(layer, out, rows, room_rows, building_rows, agent_rows)


class _Moved:
    """A snapshot and the payload rows its layers came from, for the next payload of a
    stream that changed node positions and stamps only (``GraphReader.values_only``): the
    layers, parents, labels, edges and mesh are then the same, and only the positions and
    the agents' trajectory are read again — what :func:`_navigation` would make."""

    def __init__(
        self,
        layer_asked: str | int | None,
        nav: NavGraph,
        places: I64,
        rooms: I64,
        buildings: I64,
        agents: I64 | None,
    ) -> None:
        self.layer_asked = layer_asked
        self.nav = nav
        self.rows = (places, rooms, buildings)
        self.agents = agents

    def at(self, g: BinaryGraph, t_ns: int) -> NavGraph:
        """The snapshot of ``g`` (the same nodes, moved) at ``t_ns``."""
        before = self.nav.snapshot
        places, rooms, buildings = (
            _moved(layer, g, rows)
            for layer, rows in zip(
                (before.places, before.rooms, before.buildings), self.rows, strict=True
            )
        )
        snapshot = dataclasses.replace(
            before,
            t_ns=int(t_ns),
            places=places,
            rooms=rooms,
            buildings=buildings,
            agents=_trajectory(g, self.agents),
        )
        return NavGraph(snapshot, self.nav.layer, self.nav.frontiers, None)


def _moved(layer: Layer, g: BinaryGraph, rows: I64) -> Layer:
    if len(rows) == 0:
        return layer
    return Layer(layer.ids, g.xyz[rows], layer.parent, layer.labels)
