"""The graph of one scene-graph session that several robots log at once (``aion build
robot1.mcap robot2.mcap``, each log carrying the session's graphs on one topic over times that
overlap, :mod:`aion_cli.graph_owners` having found them of one session).

Read as one stream, each robot's graph replaced the other's at every message: the places one
robot's graph held and the other's not yet left the map's graph and came back, taking turns
(two simulated robots of one morning: 10 of 220 detections ended in hash cells, against 3 in
``aion merge`` of the robots' own maps). One session is one growing graph, so the map's graph
is the union of each recording's latest graph (:func:`aion_cli.engine.graph_union.union_graphs`:
a node while any robot's latest graph holds it, at the newest position) while their group's
time lasts (:func:`aion_cli.graph_owners.graph_groups`: recordings that overlap, directly or
through others). A graph of a later group (two robots of another Hydra session in the
afternoon, one robot's next ``--split`` file or day) replaces the earlier group's, as a later
graph replaces an earlier one in one stream (before, the afternoon's union held the morning's
session's latest graphs too: places the afternoon's session does not hold stayed in the map's
graph, at the morning's positions, and owned the afternoon's detections there).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aion_cli.engine.types import GraphSnapshot

__all__ = ["SessionGraphs", "same_graph"]

#: the group of a recording :func:`aion_cli.graph_owners.graph_groups` does not name
_NO_GROUP = -1


class SessionGraphs:
    """The graphs of the current group of graph streams (``groups``: per recording, its group
    of recordings whose graph messages overlap in time, numbered in time order; empty: one
    recording, every graph as it comes): each stream's latest graph and their union.
    :attr:`new_group`: whether the graph :meth:`join` took last is the first of a later
    group than the graph before it (a later log: another Hydra session may begin there,
    :meth:`aion_cli.build_stream.StreamStep._take_graph`)."""

    def __init__(self, groups: dict[int, int] | None = None) -> None:
        self.groups = groups or {}
        sizes = Counter(self.groups.values())
        self._at_once = {group for group, n in sizes.items() if n > 1}  # joined: a union
        self._group: int | None = None  # the group whose graphs _latest holds
        self.new_group = False
        self._latest: dict[int, GraphSnapshot] = {}  # in the order of their latest graphs
        self._union: GraphSnapshot | None = None
        self._made_of: tuple[int, ...] = ()  # the graphs the union was made of (ids)

    def join(self, recording: int, snapshot: GraphSnapshot) -> GraphSnapshot:
        """The map's graph once ``snapshot`` (a graph of ``recording``) came: ``snapshot``
        itself from a recording that overlaps no other, else the union of the latest graph of
        every stream of ``recording``'s group, with ``snapshot``'s time, mesh and agents; the
        first graph of another group (a later one) drops the graphs of the group before. A
        stream's graph that holds what its graph before held (Hydra repeating an unchanged
        graph) stays the one before, in its place in the order (a node both streams hold
        stays where the stream that last changed it put it, not taking turns between them),
        and the union of the same graphs reuses the union's layers, so the map sees the place
        layer it saw before (no node moved)."""
        self.new_group = False
        if not self.groups:
            return snapshot
        group = self.groups.get(recording, _NO_GROUP)
        if group != self._group:  # the earlier group's time is over
            self.new_group = self._group is not None
            self._latest.clear()
            self._union = None
            self._group = group
        if group not in self._at_once:
            return snapshot
        before = self._latest.get(recording)
        if before is None or not same_graph(before, snapshot):
            self._latest.pop(recording, None)
            self._latest[recording] = snapshot
        graphs = list(self._latest.values())
        made_of = tuple(id(g) for g in graphs)
        union = self._union
        if union is None or made_of != self._made_of:
            from aion_cli.engine.graph_union import union_graphs

            union = self._union = union_graphs(graphs)
            self._made_of = made_of
        return replace(
            snapshot, places=union.places, edges=union.edges, rooms=union.rooms,
            buildings=union.buildings,
        )  # fmt: skip


def same_graph(a: GraphSnapshot, b: GraphSnapshot) -> bool:
    """Whether ``a`` and ``b`` hold the same nodes (ids, positions, parents, labels of
    places, rooms and buildings) and edges: one stream's graph repeated."""
    import numpy as np

    if a.places is b.places and a.edges is b.edges and a.rooms is b.rooms:
        return a.buildings is b.buildings
    layers = ((a.places, b.places), (a.rooms, b.rooms), (a.buildings, b.buildings))
    return np.array_equal(a.edges, b.edges) and all(
        np.array_equal(x.ids, y.ids) and np.array_equal(x.xyz, y.xyz)
        and np.array_equal(x.parent, y.parent) and x.labels == y.labels
        for x, y in layers
    )  # fmt: skip
