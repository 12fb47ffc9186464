"""Moving a map's dynamics onto another scene graph (``aion merge`` of maps from different
scene-graph sessions).

Node ids are only meaningful within one scene-graph lineage: two Hydra sessions both number
their places ``p0, p1, ...`` from zero, at unrelated positions, so adding node entries by id
(:func:`aion_cli.engine.merge.merge_maps`) would put one session's flow at the other's
places. Three steps avoid that, each one an ownership rule the build already applies:

* :func:`graph_agreement` decides whether two maps share a lineage: of the node ids both
  latest graphs hold, how many lie within ``tolerance`` of each other (most of them for one
  session, whose places move only by loop closures; few or none for two sessions).
* :func:`release_all` is the release rule (:func:`~aion_cli.engine.ownership.release_nodes`)
  applied to every node at once, as if every node had left the graph: each node entry's whole
  state (counts, speed sums, temporal accumulators, pending-day windows) goes to the hash cell
  at the node's position, the redirects go with the nodes, and the map forgets its graph. The
  map then holds cells only, which merge by key without any lineage.
* :func:`bind_to_graph` takes a target graph as the map's latest graph (as ``add_graph``
  would: node table, entries follow their nodes, vanished nodes release) and binds every cell
  in reach of a node (:func:`~aion_cli.engine.ownership.bind_cells`). A merge has no log time
  over which to watch the target graph's nodes hold still, so they are treated as *stable at
  the merge time*: each node's stability timer starts at the latest ``stability_s`` before it
  (a node already stable for longer keeps its own start).

Counts are conserved through all three (moves add, never overwrite). Pure numpy, no files.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.nodes import NodeTable, Redirects
from aion_cli.engine.ownership import apply_graph, bind_cells, release_nodes
from aion_cli.engine.types import GraphSnapshot

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


@dataclass(frozen=True)
class Agreement:
    """How two graphs' node ids agree: ``shared`` ids in both, ``agreeing`` of them within the
    tolerance. The same lineage when more than half of the shared ids agree."""

    shared: int
    agreeing: int

    @property
    def same(self) -> bool:
        return self.shared > 0 and 2 * self.agreeing > self.shared


def graph_agreement(
    a: GraphSnapshot | None, b: GraphSnapshot | None, tolerance: float
) -> Agreement:
    """The node ids (places) both graphs hold and how many lie within ``tolerance`` (3D) of
    each other in both (none shared when either graph is missing)."""
    if a is None or b is None or len(a.places) == 0 or len(b.places) == 0:
        return Agreement(0, 0)
    ids_a, first_a = np.unique(np.asarray(a.places.ids, np.uint64), return_index=True)
    ids_b, first_b = np.unique(np.asarray(b.places.ids, np.uint64), return_index=True)
    shared, at_a, at_b = np.intersect1d(ids_a, ids_b, assume_unique=True, return_indices=True)
    xyz_a = np.asarray(a.places.xyz, np.float64).reshape(-1, 3)[first_a[at_a]]
    xyz_b = np.asarray(b.places.xyz, np.float64).reshape(-1, 3)[first_b[at_b]]
    close = np.linalg.norm(xyz_a - xyz_b, axis=1) <= tolerance
    return Agreement(len(shared), int(np.count_nonzero(close)))


def release_all(state: MapState) -> int:
    """Release every node entry of ``state`` into the hash cell at its node's position and
    forget the graph (node table, redirects, latest graph); returns how many were released.

    ``state`` is changed in place (callers pass a copy, or a state they own)."""
    rows = state.entries.node_rows()
    release_nodes(state, rows)  # also drops every redirect to the released nodes
    state.nodes = NodeTable()
    state.redirects = Redirects()
    state.graph = None
    state.rebuild_routes()
    return len(rows)


def bind_to_graph(state: MapState, snapshot: GraphSnapshot, t_ns: int) -> int:
    """Make ``snapshot`` (restamped ``t_ns``) the latest graph of ``state`` and bind every cell
    within reach of its nodes, the nodes treated as stable at ``t_ns`` (see the module
    docstring); returns how many cells were bound. No window is closed: the open window and
    the pending day stay as they are, so the map can be continued. Changes ``state`` in
    place."""
    apply_graph(state, replace(snapshot, t_ns=int(t_ns)))
    stability_ns = round(state.config.stability_s * 1e9)
    nodes = state.nodes
    nodes.stable_since_ns = np.minimum(nodes.stable_since_ns, np.int64(t_ns) - stability_ns)
    return bind_cells(state, int(t_ns))
