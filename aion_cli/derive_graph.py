"""A navigational graph derived from where people walk, for logs without a scene graph.

Detections are counted on a horizontal grid of ``spacing`` metres (floors are kept apart by
binning z with the same spacing). Every grid cell with at least ``min_detections`` becomes a
place node at the cell's centre (z = mean height of its detections), connected to its occupied
8-neighbours on the same floor. Node ids are spark_dsg NodeSymbols ``p0, p1, ...`` in the
deterministic order of the cell indices (floor, y, x), so the same detections always give the
same graph. Pure numpy; streamed: :meth:`OccupancyGrid.add` takes detections batch by batch.

Only detections the map can hold are counted: a non-finite position, or one outside the
spatial hash's packable range for the map's ``cell_size`` (the rows a build drops and counts
as ``nan`` / ``out_of_range``), is skipped here too, and so is a row whose place (the centre of
its grid cell) would fall outside that range. Three absurd detections used to become a place
at 1e12 m that refused the whole build.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.spatial_hash import hashable_indices
from aion_cli.engine.types import GraphSnapshot, Layer

DERIVED_LAYER = "derived"
"""The layer name of a graph derived from walking people (``nav_layer`` in ``aion info
MAP``'s JSON), which its table's graph row does not repeat."""

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]

PLACE_CATEGORY = ord("p")
# the 4 "forward" neighbour offsets; with their mirror images they make the 8-neighbourhood
_FORWARD = np.array([[1, 0], [0, 1], [1, 1], [1, -1]], dtype=np.int64)


class OccupancyGrid:
    """Detection counts per (x, y, floor) grid cell, accumulated batch by batch.

    ``cell_size`` is the map's spatial-hash cell (default: :class:`ModelConfig`'s): rows the
    map cannot hold at that cell size are not counted (module docstring)."""

    def __init__(self, spacing: float, cell_size: float | None = None) -> None:
        if not (spacing > 0 and np.isfinite(spacing)):
            raise ValueError(f"spacing must be positive, got {spacing!r}")
        self.spacing = float(spacing)
        self.cell_size = float(ModelConfig().cell_size if cell_size is None else cell_size)
        self._ijk = np.zeros((0, 3), dtype=np.int64)
        self._count = np.zeros(0, dtype=np.int64)
        self._zsum = np.zeros(0, dtype=np.float64)
        #: rows of :meth:`add` that were not counted (non-finite or outside the hash range)
        self.skipped = 0

    def add(self, xyz: F64) -> None:
        """Count the rows of ``xyz`` (float64[n,3], map frame) the map can hold."""
        pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        keep = self._holdable(pts)
        self.skipped += int(len(pts) - np.count_nonzero(keep))
        pts = pts[keep]
        if len(pts) == 0:
            return
        ijk = np.floor(pts / self.spacing).astype(np.int64)
        all_ijk = np.concatenate([self._ijk, ijk])
        counts = np.concatenate([self._count, np.ones(len(pts), np.int64)])
        zsum = np.concatenate([self._zsum, pts[:, 2]])
        uniq, inverse = np.unique(all_ijk, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        self._ijk = uniq
        self._count = np.bincount(inverse, weights=counts, minlength=len(uniq)).astype(np.int64)
        self._zsum = np.asarray(
            np.bincount(inverse, weights=zsum, minlength=len(uniq)), dtype=np.float64
        )

    def _holdable(self, pts: F64) -> npt.NDArray[np.bool_]:
        """Rows whose position and whose place (grid-cell centre, same height) hash at the
        map's cell size: what a build keeps, and places it can bind."""
        _, _, ok = hashable_indices(pts, self.cell_size)
        if not ok.any():
            return ok
        centre = pts.copy()
        with np.errstate(invalid="ignore", over="ignore"):
            centre[:, :2] = (np.floor(pts[:, :2] / self.spacing) + 0.5) * self.spacing
        centre[~ok] = 0.0
        _, _, centre_ok = hashable_indices(centre, self.cell_size)
        return ok & centre_ok

    @property
    def total(self) -> int:
        """Detections counted so far."""
        return int(self._count.sum())

    def graph(self, min_detections: int, t_ns: int) -> GraphSnapshot:
        """The derived place graph: occupied cells (>= ``min_detections``) and 8-neighbour edges."""
        keep = self._count >= max(int(min_detections), 1)
        ijk = self._ijk[keep]
        # deterministic order: floor, then y, then x
        order = np.lexsort((ijk[:, 0], ijk[:, 1], ijk[:, 2]))
        ijk = ijk[order]
        counts = self._count[keep][order]
        z = self._zsum[keep][order] / np.maximum(counts, 1)
        xyz = (
            np.column_stack([(ijk[:, :2] + 0.5) * self.spacing, z])
            if len(ijk)
            else (np.zeros((0, 3)))
        )
        ids = (np.uint64(PLACE_CATEGORY) << np.uint64(56)) | np.arange(len(ijk), dtype=np.uint64)
        places = Layer(
            ids=ids,
            xyz=np.ascontiguousarray(xyz, dtype=np.float64),
            parent=np.zeros(len(ijk), np.uint64),
            labels=tuple("" for _ in range(len(ijk))),
        )
        return GraphSnapshot(
            t_ns=int(t_ns), places=places, edges=_neighbour_edges(ijk), layer_name=DERIVED_LAYER
        )


def _neighbour_edges(ijk: I64) -> I64:
    """Row pairs (i < j not required, each pair once) of 8-neighbour cells on one floor."""
    if len(ijk) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    index = {tuple(row): n for n, row in enumerate(ijk.tolist())}
    edges: list[tuple[int, int]] = []
    for n, (i, j, k) in enumerate(ijk.tolist()):
        for di, dj in _FORWARD.tolist():
            other = index.get((i + di, j + dj, k))
            if other is not None:
                edges.append((n, other))
    if not edges:
        return np.zeros((0, 2), dtype=np.int64)
    return np.asarray(edges, dtype=np.int64)
