"""The window of a top-down picture: every place, node, mesh vertex and path of its scenes,
and their hash cells but the outlying ones (:func:`.backdrop.outlying_cells`), with a margin
as long as the longest arrow drawn, at least :data:`PAD_SHARE` of the span (moved from
:mod:`.topdown`, which re-exports :func:`scene_extent`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.pictures.backdrop import Extent, outlying_cells
from aion_cli.scene import Scene

if TYPE_CHECKING:
    from aion_cli.pictures.topdown_panel import PathLine

F64 = npt.NDArray[np.float64]

PAD_SHARE = 0.04
"""The least margin around a map, a share of its longer span (a map without arrows, or with
arrows shorter than that, is framed by it)."""


def scene_extent(
    scenes: Sequence[Scene], paths: Sequence[PathLine] = (), margin: float = 0.0
) -> Extent:
    """The window holding every place, node, mesh vertex and path of ``scenes`` and their hash
    cells but outliers (:func:`.backdrop.outlying_cells`: a few stray cells far from all of
    those, which the extent counts as left out, with their share of all the flow, nodes'
    included), with ``margin`` metres each way for the arrows (the longest drawn, whose tail
    is on a place, node or cell: then no arrow runs out of the window), at least
    :data:`PAD_SHARE` of the longer span (the window is at least 2 m wide and high). A fixed
    margin of four cells framed a dense map (the Lincoln corridor, its arrows capped at 1 m
    by their spacing) with 2 m of white."""
    # the panels of a series show one map at several times: each cell, place and node is
    # taken once, with its flows over the panels summed, and each mesh once
    cell_xy, cell_flow = _summed_by_point(
        [s.cells_xyz[:, :2] for s in scenes], [s.cells_flow for s in scenes]
    )
    meshes = {id(s.mesh): s.mesh for s in scenes if s.mesh is not None}
    others = [s.places_xyz[:, :2] for s in scenes]
    others += [np.asarray(m.vertices, np.float64).reshape(-1, 3)[:, :2] for m in meshes.values()]
    others += [np.asarray(p.xyz, dtype=np.float64).reshape(-1, 3)[:, :2] for p in paths]
    # the points always shown, with their flow: a node's, 0 for the rest
    anchors, anchor_flow = _summed_by_point(
        [s.nodes_xyz[:, :2] for s in scenes] + others,
        [s.node_flow for s in scenes] + [np.zeros(len(o)) for o in others],
    )
    cell = min((s.cell_size for s in scenes), default=1.0)
    kept = ~outlying_cells(cell_xy, cell_flow, cell, anchors, anchor_flow)
    half = max((s.cell_size / 2.0 for s in scenes), default=0.0)
    xy = np.concatenate([anchors, cell_xy[kept] - half, cell_xy[kept] + half])
    if len(xy) == 0:
        xy = np.zeros((1, 2))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = max(margin, PAD_SHARE * float((hi - lo).max()))
    centre = (lo + hi) / 2.0
    half_span = np.maximum((hi - lo) / 2.0 + pad, 1.0)
    x0, x1 = float(centre[0] - half_span[0]), float(centre[0] + half_span[0])
    y0, y1 = float(centre[1] - half_span[1]), float(centre[1] + half_span[1])
    x, y = cell_xy[:, 0], cell_xy[:, 1]
    outside = ~((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1))
    total = float(cell_flow.sum() + anchor_flow.sum())
    share = float(cell_flow[outside].sum()) / total if total > 0 else 0.0
    return Extent(x0, x1, y0, y1, int(np.count_nonzero(outside)), share, pad)


def _summed_by_point(points: Sequence[F64], flows: Sequence[F64]) -> tuple[F64, F64]:
    """The distinct finite points among ``points`` (f64[k,2] arrays) with their ``flows``
    summed (NaN and negative flow count as 0), sorted by x, then y."""
    xy = np.concatenate([*points, np.zeros((0, 2))])
    flow = np.concatenate([*flows, np.zeros(0)])
    finite = np.isfinite(xy).all(axis=1)
    xy, flow = xy[finite], flow[finite]
    flow = np.where(np.isfinite(flow) & (flow > 0), flow, 0.0)
    key, of = np.unique(xy[:, 0] + 1j * xy[:, 1], return_inverse=True)
    summed: F64 = np.bincount(of.reshape(-1), flow, minlength=key.size).astype(np.float64)
    return np.column_stack([key.real, key.imag]), summed
