"""A spark_dsg graph's navigational layer (and rooms, buildings, mesh, agents) as arrays.

:func:`navigation` reads the layer :func:`formats.dsg_layers.choose_nav_layer` picks into the
:class:`GraphSnapshot` every command uses, whether the graph came from a file or a DsgUpdate
payload. spark_dsg has no bulk accessors, so this is the per-node pass whose cost is counted
in binding calls; it is kept apart from how graphs are read and how the layer is chosen.
DsgUpdate payloads usually skip it: :mod:`formats.dsg_fast` builds the same snapshot from the
payload's bytes (reusing :func:`_labels` and :class:`NavGraph`), this pass serves graph files
and the payloads that reader leaves to spark_dsg.
"""

from __future__ import annotations

import datetime
import itertools
import operator
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.node_ids import INDEX_BITS, INDEX_MASK
from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory
from aion_cli.formats.dsg_layers import (
    AGENTS_LAYER,
    BUILDINGS_LAYER,
    ROOMS_LAYER,
    NavLayer,
    _named_key,
    choose_nav_layer,
)


@dataclass(frozen=True)
class NavGraph:
    """The navigational part of one spark_dsg graph, and how it was found.

    ``frontiers`` counts the frontier places (``real_place`` false) left out; ``clearance``
    (only when asked for) is each place's free-space ``distance`` attribute, 0 where the node
    type has none (2D places).
    """

    snapshot: GraphSnapshot
    layer: NavLayer
    frontiers: int = 0
    clearance: npt.NDArray[np.float64] | None = None


def _layer_view(G: Any, layer_id: int, partition: int = 0) -> Any | None:
    return G.get_layer(layer_id, partition) if G.has_layer(layer_id, partition) else None


#: NodeSymbol layout (spark_dsg ``NodeSymbol``): the category character in the top byte of the
#: uint64, the index in the lower 56 bits.
_SYMBOL_INDEX_BITS = INDEX_BITS  # the one NodeSymbol layout (aion_cli.engine.node_ids)
_SYMBOL_INDEX_MASK = INDEX_MASK
_ID = operator.attrgetter("id.value")
_ATTRIBUTES = operator.attrgetter("attributes")
_POSITION = operator.attrgetter("position")
_NAME = operator.attrgetter("name")
_REAL_PLACE = operator.attrgetter("real_place")
_PARENT = operator.methodcaller("get_parent")
_SIBLINGS = operator.methodcaller("siblings")


def _symbol_strings(value: int) -> tuple[str, str]:
    """``(symbol.str(), str(symbol))`` of a NodeSymbol value, as spark_dsg prints them.

    spark_dsg (``NodeSymbol::str`` and ``operator<<``): a category that is a letter gives
    ``p12`` and ``p(12)``; any other category byte gives the index alone and the whole value.
    Computed arithmetically for ASCII categories (``isalpha`` of the C library is the ASCII
    letters there in every locale); spark_dsg is asked for the rest (bytes >= 128, where the
    C locale decides)."""
    category, index = value >> _SYMBOL_INDEX_BITS, value & _SYMBOL_INDEX_MASK
    if category >= 128:
        import spark_dsg

        symbol = spark_dsg.NodeSymbol(value)
        return symbol.str(), str(symbol)
    char = chr(category)
    if char.isascii() and char.isalpha():
        return f"{char}{index}", f"{char}({index})"
    return str(index), str(value)


def _labels(ids: npt.NDArray[np.uint64], names: list[Any]) -> tuple[str, ...]:
    """The label of every node of a layer — its semantic name when it has one, else the
    symbol's short form (``R0``); spark_dsg may fill ``name`` with the long form ``R(0)``,
    which is no name either — from the ids and the ``name`` attributes (``""`` where a node
    has none), without a spark_dsg call per node.

    A layer of one letter category (the usual case) is one comprehension over the indices;
    other layers go through :func:`_symbol_strings` node by node."""
    n = len(ids)
    if n == 0:
        return ()
    cats = ids >> np.uint64(_SYMBOL_INDEX_BITS)
    first = int(cats[0])  # one category in the layer? (np.unique's hashing is slower)
    if first < 128 and chr(first).isalpha() and bool((cats == cats[0]).all()):
        char = chr(first)
        indices = (ids & np.uint64(_SYMBOL_INDEX_MASK)).tolist()
        if not any(names):
            return tuple([char + str(i) for i in indices])
        index = list(map(str, indices))
        shorts = [char + i for i in index]
        return tuple(
            name if (name and name != short and name != f"{char}({i})") else short
            for name, short, i in zip(names, shorts, index, strict=True)
        )
    out = []
    for value, name in zip(ids.tolist(), names, strict=True):
        short, long = _symbol_strings(value)
        out.append(name if (name and name != short and name != long) else short)
    return tuple(out)


def _all_have(attrs: list[Any], name: str) -> bool:
    """Whether every attributes object's *type* defines ``name`` (one check per distinct type,
    so one ``attrgetter`` pass may replace a ``getattr`` with a default per node)."""
    return all(hasattr(tp, name) for tp in set(map(type, attrs)))


@dataclass
class _LayerScan:
    """One pass over a layer's nodes: the layer and, per kept node, its in-layer neighbours
    (``siblings``, which hold the layer's edges seen from each end), the number of frontier
    nodes left out and (when asked) each kept node's ``distance``."""

    layer: Layer
    neighbours: list[set[int]]
    frontiers: int = 0
    clearance: npt.NDArray[np.float64] | None = None


def _scan(
    view: Any | None, skip_frontiers: bool = False, edges: bool = False, clearance: bool = False
) -> _LayerScan:
    """Collect ids, positions, parents, labels (and neighbour sets) of a layer in one pass.

    spark_dsg has no bulk accessors, so the cost is the number of binding calls: one per node
    and field (node, attributes, id, position, parent, name, ``real_place``, siblings), each
    made by ``map`` over ``operator`` getters (no Python frame per node); labels come from the
    ids arithmetically (:func:`_labels`), positions are copied into one array at once. Those
    ~9 binding calls per node are the floor: a 5,000-place layer takes ~16-17 ms of CPU (was
    ~17-20 ms with two more binding calls and a Python function per node, docs/BENCHMARKS.md).
    """
    none = np.zeros(0) if clearance else None
    if view is None:
        return _LayerScan(Layer.empty(), [], 0, none)
    nodes = list(view.nodes)
    attrs = list(map(_ATTRIBUTES, nodes))
    frontiers = 0
    if skip_frontiers and attrs:
        if _all_have(attrs, "real_place"):
            keep = list(map(_REAL_PLACE, attrs))
        else:
            keep = [getattr(a, "real_place", True) for a in attrs]
        if not all(keep):
            frontiers = len(keep) - sum(map(bool, keep))
            nodes = list(itertools.compress(nodes, keep))
            attrs = list(itertools.compress(attrs, keep))
    if not nodes:
        return _LayerScan(Layer.empty(), [], frontiers, none)
    n = len(nodes)
    ids = np.fromiter(map(_ID, nodes), dtype=np.uint64, count=n)
    xyz = np.concatenate(list(map(_POSITION, attrs))).astype(np.float64).reshape(-1, 3)
    parents = list(map(_PARENT, nodes))  # None without a parent
    parent = np.fromiter((0 if p is None else p for p in parents), dtype=np.uint64, count=n)
    if _all_have(attrs, "name"):
        names = list(map(_NAME, attrs))
    else:
        names = [getattr(a, "name", "") or "" for a in attrs]
    labels = _labels(ids, names)
    neighbours = list(map(_SIBLINGS, nodes)) if edges else []
    dist = None
    if clearance:
        dist = np.fromiter((float(getattr(a, "distance", 0.0)) for a in attrs), np.float64, n)
    return _LayerScan(Layer(ids, xyz, parent, labels), neighbours, frontiers, dist)


def _nodes(view: Any | None, skip_frontiers: bool = False) -> Layer:
    """Collect ids, positions, parents and labels of a layer in one pass."""
    return _scan(view, skip_frontiers).layer


def _keep_parents_in(layer: Layer, parents: Layer) -> Layer:
    """Parents outside the layer above (e.g. objects or missing nodes) become 0."""
    valid = np.isin(layer.parent, parents.ids)
    if valid.all():
        return layer
    return Layer(
        layer.ids, layer.xyz, np.where(valid, layer.parent, 0).astype(np.uint64), layer.labels
    )


def _edges(ids: npt.NDArray[np.uint64], neighbours: list[set[int]]) -> npt.NDArray[np.int64]:
    """Intralayer edges as unique sorted row-index pairs from each node's neighbour set (every
    edge appears from both ends); edges to dropped nodes are left out. Ids map to rows with
    ``searchsorted`` over the sorted ids."""
    if len(ids) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    counts = np.fromiter(map(len, neighbours), dtype=np.int64, count=len(neighbours))
    other = np.fromiter(
        itertools.chain.from_iterable(neighbours), dtype=np.uint64, count=int(counts.sum())
    )
    src = np.repeat(np.arange(len(ids), dtype=np.int64), counts)
    order = np.argsort(ids)
    sorted_ids = ids[order]
    pos = np.searchsorted(sorted_ids, other).clip(0, len(ids) - 1)
    found = sorted_ids[pos] == other
    dst = order[pos[found]].astype(np.int64)
    src = src[found]
    lo, hi = np.minimum(src, dst), np.maximum(src, dst)
    keep = lo != hi
    key = np.unique(lo[keep] * len(ids) + hi[keep])
    return np.column_stack([key // len(ids), key % len(ids)]).astype(np.int64).reshape(-1, 2)


def _mesh(G: Any) -> Mesh | None:
    if not G.has_mesh():
        return None
    m = G.mesh
    if m is None or m.num_vertices() == 0:
        return None
    vertices = np.asarray(m.get_vertices(), dtype=np.float64)
    faces = np.asarray(m.get_faces(), dtype=np.int32).reshape(3, -1)
    colors = vertices[3:6].T if vertices.shape[0] >= 6 else np.zeros((0, 3))
    return Mesh(
        np.ascontiguousarray(vertices[:3].T),
        np.ascontiguousarray(faces.T),
        np.ascontiguousarray(colors),
    )


def _timedelta_ns(td: datetime.timedelta) -> int:
    """Exact integer ns of a timedelta (spark_dsg gives agent stamps as timedelta)."""
    return ((td.days * 86_400 + td.seconds) * 1_000_000 + td.microseconds) * 1000


def _agents(G: Any) -> Trajectory | None:
    """The first robot's agent partition (lowest partition id, robot 'a') as a trajectory."""
    agents_layer = _named_key(G, "AGENTS", (AGENTS_LAYER, 0))[0]
    views = sorted(
        (v for v in G.layer_partitions if v.id == agents_layer and v.partition != 0),
        key=lambda v: int(v.partition),
    )
    views = [v for v in views if v.num_nodes() > 0]
    if not views:
        return None
    attrs = [node.attributes for node in views[0].nodes]
    stamps = [a.timestamp for a in attrs]
    us = None
    if all(type(st) is datetime.timedelta for st in stamps):
        # timedelta has microsecond resolution: timedelta64[us] holds it exactly
        us = np.array(stamps, dtype="timedelta64[us]").astype(np.int64)
    lim = np.iinfo(np.int64).max // 1000
    if us is not None and (len(us) == 0 or (-lim <= us.min() and us.max() <= lim)):
        t_arr = us * 1000
    else:  # other stamp types, or ns outside int64 (raises like a Python int would)
        t_arr = np.array(
            [_timedelta_ns(st) if isinstance(st, datetime.timedelta) else int(st) for st in stamps],
            dtype=np.int64,
        )
    xyz = np.concatenate([a.position for a in attrs]).astype(np.float64).reshape(-1, 3)
    order = np.argsort(t_arr, kind="stable")
    return Trajectory(t_arr[order], xyz[order])


def navigation(
    G: Any, t_ns: int, layer: str | int | None = None, clearance: bool = False
) -> NavGraph:
    """The navigational graph of a spark_dsg ``DynamicSceneGraph`` (a saved file or a decoded
    DsgUpdate payload alike) and the layer it came from.

    ``layer``: ``--nav-layer`` (None: MESH_PLACES when present and non-empty, else PLACES; see
    :func:`choose_nav_layer`). Frontier places (``real_place == False``) are left out; edges to
    them too. Parents are kept only when they are in the layer above.
    """
    nav = choose_nav_layer(G, layer)
    view = _layer_view(G, nav.layer, nav.partition)
    buildings = _nodes(_layer_view(G, *_named_key(G, "BUILDINGS", (BUILDINGS_LAYER, 0))))
    rooms = _keep_parents_in(
        _nodes(_layer_view(G, *_named_key(G, "ROOMS", (ROOMS_LAYER, 0)))), buildings
    )
    scan = _scan(view, skip_frontiers=True, edges=True, clearance=clearance)
    places = _keep_parents_in(scan.layer, rooms)
    snapshot = GraphSnapshot(
        t_ns=int(t_ns),
        places=places,
        edges=_edges(places.ids, scan.neighbours),
        rooms=rooms,
        buildings=buildings,
        mesh=_mesh(G),
        agents=_agents(G),
        layer_name=nav.snapshot_name,
    )
    return NavGraph(snapshot, nav, scan.frontiers, scan.clearance)


def snapshot_from_dsg(G: Any, t_ns: int, layer: str | int | None = None) -> GraphSnapshot:
    """The navigational :class:`GraphSnapshot` of a spark_dsg graph (:func:`navigation`)."""
    return navigation(G, t_ns, layer).snapshot
