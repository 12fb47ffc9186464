"""One scene-graph session's graph as several robots log it: the union of each robot's latest
graph (``aion build robot1.mcap robot2.mcap`` whose graphs on one topic are of one Hydra
session, :mod:`aion_cli.session_graphs`).

Each robot's graph holds the places it has mapped so far; applied one after the other as whole
graphs, the places one robot's graph holds and the other's not yet would leave the map's graph
and come back at every message ("take turns"), releasing and rebinding the flows near them.
One session is one growing graph: a node is in it while any robot's latest graph holds it, at
the position of the newest graph that holds it; an edge while any robot's latest graph holds
it (between the nodes of its two ids). Pure numpy, no loop over nodes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from aion_cli.engine.types import GraphSnapshot, Layer

__all__ = ["union_graphs", "union_layers"]


def union_graphs(graphs: Sequence[GraphSnapshot]) -> GraphSnapshot:
    """The union of ``graphs`` (each robot's latest, the newest last): the newest graph with
    its places, rooms and buildings joined by id with those of the older graphs it lacks
    (:func:`union_layers`) and the edges of all of them. Its time, mesh, agents, layer name
    and frame are the newest graph's. The newest graph's nodes and edges come first, in its
    order, so the union of graphs that hold nothing the newest lacks is the newest graph."""
    newest = graphs[-1]
    if len(graphs) == 1:
        return newest
    order = list(reversed(graphs))  # newest first: its values win
    places = union_layers([g.places for g in order])
    return replace(
        newest,
        places=places,
        edges=_union_edges(order, places),
        rooms=union_layers([g.rooms for g in order]),
        buildings=union_layers([g.buildings for g in order]),
    )


def union_layers(layers: Sequence[Layer]) -> Layer:
    """The nodes of ``layers`` joined by id, the first layer holding an id giving its position,
    parent and label; in the order of the first layer, then the ids only later layers hold
    (each in its own order)."""
    if all(len(layer) == 0 for layer in layers[1:]):
        return layers[0]
    ids = np.concatenate([np.asarray(la.ids, np.uint64) for la in layers])
    _, first = np.unique(ids, return_index=True)
    keep = np.sort(first)
    if keep.size == len(layers[0]):  # nothing the first layer lacks
        return layers[0]
    xyz = np.concatenate([np.asarray(la.xyz, np.float64).reshape(-1, 3) for la in layers])
    parent = np.concatenate([np.asarray(la.parent, np.uint64) for la in layers])
    labels: tuple[str, ...] = ()
    if any(la.labels for la in layers):
        every = [lab for la in layers for lab in (la.labels or ("",) * len(la))]
        labels = tuple(every[k] for k in keep.tolist())
    return Layer(ids[keep], xyz[keep], parent[keep], labels)


def _union_edges(order: Sequence[GraphSnapshot], places: Layer) -> np.ndarray:
    """The edges of the graphs of ``order`` (newest first) as rows of ``places``, each
    undirected pair once, the first graph's first, in their order."""
    first = np.asarray(order[0].edges, np.int64).reshape(-1, 2)
    if places is order[0].places and all(len(g.edges) == 0 for g in order[1:]):
        return first
    union_ids = np.asarray(places.ids, np.uint64)
    by_id = np.argsort(union_ids, kind="stable")
    pairs = []
    for g in order:  # one array operation per robot's graph, not per edge
        e = np.asarray(g.edges, np.int64).reshape(-1, 2)
        ends = np.asarray(g.places.ids, np.uint64)[e]
        pairs.append(by_id[np.searchsorted(union_ids[by_id], ends)])
    rows = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
    key = np.sort(rows, axis=1)
    _, at = np.unique(key[:, 0] * np.int64(len(union_ids)) + key[:, 1], return_index=True)
    return rows[np.sort(at)].astype(np.int64)
