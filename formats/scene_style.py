"""The drawn scene of one time, the same for every scene format (PLY and PCD in
:mod:`formats.export`, MCAP in :mod:`formats.scene_mcap`).

:func:`style_scene` checks the plain arrays of a scene (nodes, unbound cells, edges, mesh,
path) and applies the drawing rules of :mod:`formats.scene_colours` (what is drawn:
:mod:`formats.export`'s docstring): sphere radius and colour per node, the arrow along its
dominant direction, colour per cell. Writers draw a :class:`SceneStyle`; none sizes or
colours anything itself, so a PLY and an MCAP export of the same time agree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import Mesh
from aion_cli.formats.export import F64, ExportError, TriMesh
from aion_cli.formats.scene_colours import (
    NO_FLOW_GREY,
    busy_fraction,
    display_flow_scale,
    flow_colors,
    sphere_radii,
)


@dataclass(frozen=True)
class SceneStyle:
    """The drawn scene, one source for every scene format (PLY, PCD and MCAP): per node its
    centre, sphere radius, colour and arrow (``arrow_angle`` NaN: no arrow; length from the
    centre, shaft ``arrow_width`` thick), per unbound cell its centre, colour and dominant
    direction (``cells_angle``, rad, NaN: none) and arrow (``cell_arrow_angle``,
    ``cell_arrow_length``: drawn only in a scene without nodes, a map of hash cells only,
    whose direction no node shows; beside nodes, NaN), the edges [k,2,3], the mesh and the
    path [p,3]; with the flow (NaN-free) and entropy they show and the ``flow_scale`` drawn at
    full size."""

    nodes_xyz: F64
    node_flow: F64
    node_entropy: F64
    radii: F64
    colors: F64
    angle: F64  # dominant direction (rad, NaN: none)
    arrow_angle: F64
    arrow_length: F64
    arrow_width: float
    cells_xyz: F64
    cells_flow: F64
    cells_entropy: F64  # NaN where the cell has no flow
    cells_angle: F64  # dominant direction (rad, NaN: none)
    cell_colors: F64
    edges: F64
    mesh: TriMesh
    path: F64
    cell_size: float
    flow_scale: float
    cell_arrow_angle: F64
    cell_arrow_length: F64


def style_scene(
    nodes_xyz: npt.ArrayLike,
    node_flow: npt.ArrayLike,
    node_entropy: npt.ArrayLike,
    node_dominant_angle: npt.ArrayLike,
    cells_xyz: npt.ArrayLike | None = None,
    cells_flow: npt.ArrayLike | None = None,
    cells_entropy: npt.ArrayLike | None = None,
    edges_xyz_pairs: npt.ArrayLike | None = None,
    mesh: Mesh | None = None,
    path_xyz: npt.ArrayLike | None = None,
    cell_size: float = 0.5,
    *,
    node_concentration: npt.ArrayLike | None = None,
    flow_scale: float | None = None,
    cells_dominant_angle: npt.ArrayLike | None = None,
) -> SceneStyle:
    """Check the arrays of :func:`export_scene` (same meaning) and size and colour every part
    (the module docstring's rules); an :class:`ExportError` for inconsistent arrays."""
    if not (np.isfinite(cell_size) and cell_size > 0):
        raise ExportError(f"cell_size must be positive, got {cell_size!r}")
    xyz = _rows("nodes_xyz", nodes_xyz, None, (3,))
    n = len(xyz)
    flow = _rows("node_flow", node_flow, n, ())
    entropy = _rows("node_entropy", node_entropy, n, ())
    angle = _rows("node_dominant_angle", node_dominant_angle, n, ())
    conc = (
        np.ones(n)
        if node_concentration is None
        else np.clip(np.nan_to_num(_rows("node_concentration", node_concentration, n, ())), 0, 1)
    )
    c_xyz = _rows("cells_xyz", cells_xyz, None, (3,))
    c_flow = _rows(
        "cells_flow",
        cells_flow if cells_flow is not None else np.ones(len(c_xyz)),
        len(c_xyz),
        (),
    )
    c_ent = _rows(
        "cells_entropy",
        cells_entropy if cells_entropy is not None else np.full(len(c_xyz), np.nan),
        len(c_xyz),
        (),
    )
    c_ent = np.where(np.nan_to_num(c_flow, nan=0.0) > 0, c_ent, np.nan)  # no flow: grey
    c_angle = _rows(
        "cells_dominant_angle",
        cells_dominant_angle if cells_dominant_angle is not None else np.full(len(c_xyz), np.nan),
        len(c_xyz),
        (),
    )
    scale = _flow_scale(flow, flow_scale)
    busy = busy_fraction(flow, scale)
    radii = sphere_radii(flow, scale, cell_size)
    arrow_angle = np.where(busy > 0, angle, np.nan)
    cell_arrow_angle, cell_arrow_length = _cell_arrows(
        n, c_flow, c_angle, cell_size, flow_scale
    )
    return SceneStyle(
        nodes_xyz=xyz,
        node_flow=np.nan_to_num(flow, nan=0.0),
        node_entropy=entropy,
        radii=radii,
        colors=flow_colors(flow, entropy),
        angle=angle,
        arrow_angle=arrow_angle,
        arrow_length=radii + cell_size * (0.3 + 2.0 * busy * conc),
        arrow_width=0.08 * cell_size,
        cells_xyz=c_xyz,
        cells_flow=np.nan_to_num(c_flow, nan=0.0),
        cells_entropy=c_ent,
        cells_angle=c_angle,
        cell_colors=flow_colors(c_flow, c_ent),
        edges=_edge_pairs(edges_xyz_pairs),
        mesh=_mesh_part(mesh),
        path=_rows("path_xyz", path_xyz, None, (3,)),
        cell_size=float(cell_size),
        flow_scale=scale,
        cell_arrow_angle=cell_arrow_angle,
        cell_arrow_length=cell_arrow_length,
    )


def _cell_arrows(
    nodes: int, flow: F64, angle: F64, cell_size: float, flow_scale: float | None
) -> tuple[F64, F64]:
    """The cells' arrows (angle, NaN: none; length from the centre) of a scene without nodes
    (a map of hash cells only, as the pictures draw them): like a node's, out of the square's
    edge by ``δ·(0.3 + 2·busy)``, the busy share on the cells' flow scale (or ``flow_scale``).
    Beside nodes the cells draw none (the scene of a map with places is unchanged)."""
    if nodes or not len(flow):
        return np.full(len(flow), np.nan), np.zeros(len(flow))
    busy = busy_fraction(flow, _flow_scale(flow, flow_scale))
    return (
        np.where(busy > 0, angle, np.nan),
        cell_size * (0.5 + 0.3 + 2.0 * busy),
    )


# -- inputs ----------------------------------------------------------------------------------


def _rows(name: str, a: npt.ArrayLike | None, n: int | None, tail: tuple[int, ...]) -> F64:
    arr = np.zeros((0, *tail)) if a is None else np.asarray(a, dtype=np.float64)
    if arr.size == 0:
        arr = arr.reshape((0, *tail))
    if arr.shape[1:] != tail or (n is not None and len(arr) != n):
        want = f"({n if n is not None else 'n'}{''.join(', ' + str(t) for t in tail)})"
        raise ExportError(f"{name} must have shape {want}, got {arr.shape}")
    return arr


def _edge_pairs(edges_xyz_pairs: npt.ArrayLike | None) -> F64:
    if edges_xyz_pairs is None:
        return np.zeros((0, 2, 3))
    arr = np.asarray(edges_xyz_pairs, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 2, 3))
    if arr.ndim == 2 and arr.shape[1] == 6:
        arr = arr.reshape(-1, 2, 3)
    if arr.ndim != 3 or arr.shape[1:] != (2, 3):
        raise ExportError(f"edges_xyz_pairs must have shape (k, 2, 3), got {arr.shape}")
    return arr


def _flow_scale(flow: F64, flow_scale: float | None) -> float:
    if flow_scale is not None:
        if not (np.isfinite(flow_scale) and flow_scale > 0):
            raise ExportError(f"flow_scale must be positive, got {flow_scale!r}")
        return float(flow_scale)
    return display_flow_scale(flow)[0]


def _mesh_part(mesh: Mesh | None) -> TriMesh:
    if mesh is None or len(mesh.vertices) == 0:
        return TriMesh.empty()
    v = _rows("mesh.vertices", mesh.vertices, None, (3,))
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if len(f) and (f.min() < 0 or f.max() >= len(v)):
        raise ExportError("mesh faces refer to vertices that do not exist")
    c = np.asarray(mesh.colors, dtype=np.float64)
    if c.shape != v.shape:
        c = np.tile(np.asarray(NO_FLOW_GREY), (len(v), 1))
    return TriMesh(v, f, c)
