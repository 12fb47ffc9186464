"""The navigational graph a plan searches: nodes (ids, positions) and undirected edges, and
their directed arcs in CSR order with lengths and horizontal travel directions.

Why apart from :mod:`aion_cli.engine.planning` (costs and search): the graph is built and
checked from a scene graph's places or from plain arrays (``aion plan``, the pictures' path,
the benchmarks), and its construction rules — self loops and duplicate edges dropped, a graph
without edges connected within ``plan_connect_radius`` — are a job of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from aion_cli.engine.nearest import distances_from
from aion_cli.engine.node_ids import node_label, other_case
from aion_cli.engine.types import GraphSnapshot
from aion_cli.errors import AionError, UnknownNodeError

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]


class NavGraphError(AionError, ValueError):
    """Graph arrays or a path are inconsistent (a caller bug, not a user error)."""


@dataclass(frozen=True)
class Arcs:
    """Both directions of every edge, sorted by source (CSR): ``indptr`` over nodes."""

    src: I64
    dst: I64
    length: F64
    alpha: F64  # horizontal travel direction, NaN for vertical arcs
    indptr: I64

    @cached_property
    def lists(self) -> tuple[list[int], list[int], list[float]]:
        """``indptr``, ``dst``, ``length`` as Python lists for the A* loop (made once)."""
        return self.indptr.tolist(), self.dst.tolist(), self.length.tolist()


@dataclass(frozen=True)
class NavGraph:
    """The navigational graph: node ``ids`` uint64[m], ``xyz`` float64[m,3], undirected
    ``edges`` int64[k,2] of row indices (each pair once, no self loops after construction)."""

    ids: U64
    xyz: F64
    edges: I64
    # the radius its edges were made within (:meth:`connect_within`: the scene graph had no
    # place edges), None for edges of its own: said when start and goal are not connected
    joined_within: float | None = None

    def __post_init__(self) -> None:
        m = len(self.ids)
        if self.xyz.shape != (m, 3):
            raise NavGraphError(f"xyz must have shape ({m}, 3), got {self.xyz.shape}")
        if self.edges.ndim != 2 or self.edges.shape[1] != 2:
            raise NavGraphError(f"edges must have shape (k, 2), got {self.edges.shape}")
        if len(self.edges) and (self.edges.min() < 0 or self.edges.max() >= m):
            raise NavGraphError("edges refer to rows outside the node table")
        if not np.isfinite(self.xyz).all():
            raise NavGraphError("node positions must be finite")

    @classmethod
    def build(cls, ids: npt.ArrayLike, xyz: npt.ArrayLike, edges: npt.ArrayLike) -> NavGraph:
        """Coerce dtypes, drop self loops and duplicate (either-direction) edges."""
        node_ids = np.ascontiguousarray(ids, dtype=np.uint64).reshape(-1)
        pos = np.ascontiguousarray(xyz, dtype=np.float64).reshape(-1, 3)
        e = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
        e = np.sort(e, axis=1)
        e = e[e[:, 0] != e[:, 1]]
        if len(e):  # unique pairs via one int64 key (much faster than unique(axis=0))
            key = np.sort(e[:, 0] * np.int64(len(node_ids)) + e[:, 1])
            key = key[np.r_[True, key[1:] != key[:-1]]]
            e = np.stack([key // len(node_ids), key % len(node_ids)], axis=1)
        return cls(node_ids, pos, np.ascontiguousarray(e))

    @classmethod
    def from_snapshot(cls, snapshot: GraphSnapshot, connect_radius: float) -> NavGraph:
        """The places and place edges of a scene graph; a graph with no edges at all is
        connected by :meth:`connect_within` (``config.plan_connect_radius``)."""
        graph = cls.build(snapshot.places.ids, snapshot.places.xyz, snapshot.edges)
        if len(graph.edges) == 0 and len(graph.ids) > 1:
            graph = graph.connect_within(connect_radius)
        return graph

    def connect_within(self, radius: float) -> NavGraph:
        """A copy with an edge between every pair of nodes closer than ``radius`` (3-D),
        replacing the existing edges."""
        if not (math.isfinite(radius) and radius > 0):
            raise NavGraphError(f"radius must be positive, got {radius!r}")
        from scipy.spatial import cKDTree  # slow to import: only here
        pairs = cKDTree(self.xyz).query_pairs(radius, output_type="ndarray")
        joined = NavGraph.build(self.ids, self.xyz, pairs.astype(np.int64).reshape(-1, 2))
        return NavGraph(joined.ids, joined.xyz, joined.edges, float(radius))

    def __len__(self) -> int:
        return len(self.ids)

    def index_of(self, node_id: int) -> int:
        """Row of ``node_id``; :class:`UnknownNodeError` with examples when absent."""
        hits = np.flatnonzero(self.ids == np.uint64(node_id))
        if len(hits) == 0:
            examples = ", ".join(node_label(int(i)) for i in self.ids[:5])
            other = other_case(node_id)  # P103 for p103: ids keep their letter's case
            hint = (
                f"did you mean {node_label(other)}? (node ids are case-sensitive)"
                if other is not None and bool((self.ids == np.uint64(other)).any())
                else f"nodes include {examples or '(none: the graph is empty)'}"
            )
            raise UnknownNodeError(
                f"node {node_label(node_id)} is not in the navigational graph", hint=hint
            )
        return int(hits[0])

    def nearest(self, point: npt.ArrayLike) -> int:
        """Row of the node nearest to ``point`` (x, y, z)."""
        if len(self.ids) == 0:
            raise UnknownNodeError("the navigational graph has no nodes")
        return int(np.argmin(distances_from(self.xyz, point)))

    @cached_property
    def components(self) -> I64:
        """The connected component of each node (labels 0..k-1, int64[m])."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        m, e = len(self.ids), self.edges
        adj = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(m, m))
        labels = connected_components(adj, directed=False)[1]
        return np.asarray(labels, dtype=np.int64)

    @cached_property
    def arcs(self) -> Arcs:
        """Directed arcs (both directions of each edge), sorted by source row."""
        src = np.concatenate([self.edges[:, 0], self.edges[:, 1]])
        dst = np.concatenate([self.edges[:, 1], self.edges[:, 0]])
        order = np.argsort(src, kind="stable")
        src, dst = src[order], dst[order]
        delta = self.xyz[dst] - self.xyz[src]
        length = np.sqrt((delta**2).sum(axis=1))
        horizontal = np.hypot(delta[:, 0], delta[:, 1])
        alpha = np.where(horizontal > 1e-9, np.arctan2(delta[:, 1], delta[:, 0]), np.nan)
        indptr = np.zeros(len(self.ids) + 1, dtype=np.int64)
        np.cumsum(np.bincount(src, minlength=len(self.ids)), out=indptr[1:])
        return Arcs(src, dst, length, alpha, indptr)

