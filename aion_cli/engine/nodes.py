"""Navigational-node bookkeeping for ownership transfer: the node table and the redirect table.

:class:`NodeTable` holds the nodes of the latest graph sorted by id, with the log time since
which each has been *stable* (present and within ``stable_move_tolerance`` of its reference
position) — the τ timer of DESIGN.md §4. :class:`Redirects` is φ: sorted cell keys -> node ids.
:func:`nearest_nodes` finds, for many cells at once, the nearest node by horizontal distance
that also lies within the vertical tolerance (so floors stay apart).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from aion_cli.engine.types import F64, I64, U64, BoolA

_CANDIDATES = 8
"""Nearest horizontal candidates checked against the vertical tolerance per cell."""


@dataclass
class NodeTable:
    """Nodes of the latest graph: ``ids`` sorted, positions, reference positions, stable-since."""

    ids: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))
    xyz: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    ref_xyz: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    stable_since_ns: I64 = field(default_factory=lambda: np.zeros(0, np.int64))

    def __len__(self) -> int:
        return len(self.ids)

    def updated(
        self, ids: U64, xyz: F64, t_ns: int, move_tolerance: float
    ) -> tuple[NodeTable, BoolA]:
        """The table after a snapshot with nodes ``ids``/``xyz`` at ``t_ns``.

        New nodes start their stability timer at ``t_ns``; a node farther than
        ``move_tolerance`` (3D) from its reference position restarts it there. Duplicate ids
        keep their first row. Returns the new table and a mask over *this* table's rows of the
        nodes that are gone.
        """
        uniq, first = np.unique(np.asarray(ids, dtype=np.uint64), return_index=True)
        pos = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)[first]
        old_at = np.searchsorted(self.ids, uniq)
        old_at_c = np.minimum(old_at, max(len(self.ids) - 1, 0))
        known = np.zeros(len(uniq), bool)
        if len(self):
            known = (old_at < len(self.ids)) & (self.ids[old_at_c] == uniq)
        ref = pos.copy()
        since = np.full(len(uniq), np.int64(t_ns))
        if known.any():
            prev_ref = self.ref_xyz[old_at_c[known]]
            still = np.linalg.norm(pos[known] - prev_ref, axis=1) <= move_tolerance
            kept = np.flatnonzero(known)[still]
            ref[kept] = prev_ref[still]
            since[kept] = self.stable_since_ns[old_at_c[known]][still]
        gone = ~np.isin(self.ids, uniq)
        return NodeTable(uniq, pos, ref, since), gone

    def stable_mask(self, t_ns: int, stability_ns: int) -> BoolA:
        """Nodes stable for at least ``stability_ns`` at log time ``t_ns``."""
        out: BoolA = (np.int64(t_ns) - self.stable_since_ns) >= stability_ns
        return out

    def to_arrays(self, prefix: str = "node_") -> dict[str, np.ndarray]:
        return {
            f"{prefix}ids": self.ids.copy(),
            f"{prefix}xyz": self.xyz.copy(),
            f"{prefix}ref_xyz": self.ref_xyz.copy(),
            f"{prefix}stable_since_ns": self.stable_since_ns.copy(),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "node_") -> NodeTable:
        return cls(
            np.asarray(arrays[f"{prefix}ids"], dtype=np.uint64),
            np.asarray(arrays[f"{prefix}xyz"], dtype=np.float64).reshape(-1, 3),
            np.asarray(arrays[f"{prefix}ref_xyz"], dtype=np.float64).reshape(-1, 3),
            np.asarray(arrays[f"{prefix}stable_since_ns"], dtype=np.int64),
        )


@dataclass
class Redirects:
    """φ: cell ``keys`` (sorted, unique) -> owning ``nodes`` (node ids)."""

    keys: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    nodes: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))

    def __len__(self) -> int:
        return len(self.keys)

    def add(self, keys: I64, nodes: U64) -> None:
        """Record new redirects (keys must not be redirected already)."""
        all_keys = np.concatenate([self.keys, keys.astype(np.int64)])
        all_nodes = np.concatenate([self.nodes, nodes.astype(np.uint64)])
        order = np.argsort(all_keys, kind="stable")
        self.keys, self.nodes = all_keys[order], all_nodes[order]
        if len(self.keys) > 1 and np.any(self.keys[1:] == self.keys[:-1]):
            raise ValueError("a cell key was redirected twice")

    def drop_nodes(self, node_ids: U64) -> None:
        """Forget every redirect to the given nodes."""
        keep = ~np.isin(self.nodes, node_ids)
        self.keys, self.nodes = self.keys[keep], self.nodes[keep]

    def lookup(self, keys: I64) -> tuple[U64, BoolA]:
        """Node ids for ``keys`` and a found mask (0 where not redirected)."""
        if len(self.keys) == 0:
            return np.zeros(len(keys), np.uint64), np.zeros(len(keys), bool)
        pos = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        found = self.keys[pos] == keys
        return np.where(found, self.nodes[pos], np.uint64(0)).astype(np.uint64), found

    def to_arrays(self, prefix: str = "redirect_") -> dict[str, np.ndarray]:
        return {f"{prefix}keys": self.keys.copy(), f"{prefix}nodes": self.nodes.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "redirect_") -> Redirects:
        out = cls()
        out.add(
            np.asarray(arrays[f"{prefix}keys"], dtype=np.int64),
            np.asarray(arrays[f"{prefix}nodes"], dtype=np.uint64),
        )
        return out


def nearest_nodes(
    points: F64, node_xyz: F64, radius: float, vertical_tolerance: float
) -> I64:
    """Per point, the index of the nearest node horizontally within ``radius`` whose height
    differs by at most ``vertical_tolerance``; -1 where there is none.

    Checks the ``_CANDIDATES`` horizontally nearest nodes per point (one vectorized cKDTree
    query), so a point with more than that many nodes of other floors closer than the nearest
    same-floor node stays unbound.
    """
    n = len(points)
    if n == 0 or len(node_xyz) == 0:
        return np.full(n, -1, np.int64)
    k = min(_CANDIDATES, len(node_xyz))
    dist, idx = cKDTree(node_xyz[:, :2]).query(
        points[:, :2], k=k, distance_upper_bound=radius
    )
    dist = dist.reshape(n, k)
    idx = idx.reshape(n, k)
    found = np.isfinite(dist) & (dist <= radius)
    idx_c = np.where(found, idx, 0)
    dz = np.abs(node_xyz[idx_c, 2] - points[:, None, 2])
    ok = found & (dz <= vertical_tolerance)
    first = np.argmax(ok, axis=1)
    has = ok[np.arange(n), first]
    return np.where(has, idx_c[np.arange(n), first], -1).astype(np.int64)
