"""PLY / PCD scene export from plain arrays (no engine objects): PLY files written by
:mod:`formats.ply_files` (open3d's bytes, without open3d's copies), PCD files by open3d.

What is drawn (DESIGN.md §7):

- **nodes**: a sphere per navigational node, radius growing with the flow magnitude from
  ``0.2·δ`` (no flow) to ``δ`` (flow >= ``flow_scale``), coloured by directional entropy
  ``H`` (0..1): ``(r, g, b) = (H, 0, 1 − H)``, blue = one direction, red = every direction;
  grey without flow, teal with flow but no heading (``H`` NaN: people standing still).
- **arrows**: one per node with flow and a dominant direction, from the node centre along it in
  the horizontal plane, length ``r + δ·(0.3 + 2·busy·κ)`` (r the sphere radius, so it always
  sticks out; busy = ``min(flow/flow_scale, 1)``, κ the concentration, 1 if not given),
  coloured like the node.
- **cells**: a flat horizontal δ×δ square per unbound hash cell centre, coloured by entropy
  (grey when the cell has no flow, teal with flow but no heading); in a scene without nodes
  (a map of hash cells only) an arrow per cell with flow and a dominant direction too, like a
  node's, from the centre out of the square by ``δ·(0.3 + 2·busy)`` (in ``arrows.ply``).
- **edges**: the place edges as a line set (grey); **path**: the planned path as a line set
  (green); **mesh**: the scene graph's mesh with its vertex colours.

PLY: one file per part (``nodes.ply``, ``arrows.ply``, ``cells.ply``, ``edges.ply``,
``mesh.ply``, ``path.ply``; edges and path are open3d LineSets, the others triangle meshes)
plus ``scene.ply``, one triangle mesh with everything (edges and path drawn as thin tubes, since
a triangle mesh cannot hold lines). PCD: a PCD file holds points only, no triangles or lines, so
the PCD export writes coloured point clouds: ``nodes.pcd`` (node centres, entropy colours,
normals = unit dominant direction or 0), ``cells.pcd`` (cell centres, normals likewise),
``mesh.pcd`` (mesh vertices), ``path.pcd`` (path points) and ``scene.pcd`` (all of them, the
mesh's and the path's normals 0); arrows and edges have no
PCD form. Parts with nothing in them are not written. Files are binary; every name gets
``prefix`` in front (e.g. ``t0830_nodes.ply`` for a time series).

Sizes and colours are computed once per scene by :func:`formats.scene_style.style_scene`
(with the rules of :mod:`formats.scene_colours`), which the MCAP export
(:mod:`formats.scene_mcap`) shares.

Geometry is instanced with numpy (one template sphere / arrow / tube transformed for every item),
so exporting 10^4 nodes does not build 10^4 open3d objects.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import Mesh
from aion_cli.errors import (
    AionError,
    InputError,
    MissingPackageError,
    MissingSystemLibraryError,
)
from aion_cli.formats.interrupts import interrupts_held
from aion_cli.formats.scene_colours import EDGE_GREY, PATH_GREEN
from aion_cli.formats.scene_meshes import ARROW_RESOLUTION as ARROW_RESOLUTION
from aion_cli.formats.scene_meshes import SPHERE_RESOLUTION as SPHERE_RESOLUTION
from aion_cli.formats.scene_meshes import TUBE_RESOLUTION as TUBE_RESOLUTION
from aion_cli.formats.scene_meshes import (
    Instanced,
    TriMesh,
    cell_squares,
    direction_arrows,
    node_spheres,
    tubes,
)

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]



class ExportError(AionError, ValueError):
    """Arrays handed to the exporter are inconsistent (a caller bug)."""


class ExportWriteError(InputError):
    """An export file could not be written (folder not writable, disk full...)."""


# -- open3d ----------------------------------------------------------------------------------


def open3d() -> Any:
    """The ``open3d`` module, or :class:`MissingSystemLibraryError` naming the missing system
    library: open3d's wheel links against ``libusb-1.0.so.0`` (Debian/Ubuntu package
    ``libusb-1.0-0``), which minimal machines and containers lack; ``make install`` installs it
    where it can. The import (about 0.4 s) holds Ctrl-C and SIGTERM back until it is done: one
    landing inside open3d's C++ initialisation became ``ImportError: initialization failed``,
    and the half-initialised library printed its memory statistics on stdout at exit and made
    the process exit 1 instead of 130."""
    try:
        with interrupts_held():
            import open3d as o3d
    except ModuleNotFoundError as exc:
        if exc.name != "open3d":
            raise
        raise MissingPackageError(
            "PLY/PCD scenes need open3d, an optional part of aion that is not installed",
            hint="pip install 'aion[export]' (make install does it); predict, plan and the "
            "entries tables work without it",
        ) from exc
    except (ImportError, OSError) as exc:
        missing = str(exc)
        if "libusb" in missing:
            raise MissingSystemLibraryError(
                f"open3d cannot be loaded: {missing}",
                hint="install the system library libusb-1.0 (Debian/Ubuntu: "
                "sudo apt-get install libusb-1.0-0; Fedora: sudo dnf install libusb1), "
                "or run make install, which does it where it can",
            ) from exc
        raise MissingSystemLibraryError(
            f"open3d cannot be loaded: {missing}",
            hint="reinstall aion's dependencies (make install) and check open3d's system "
            "requirements",
        ) from exc
    return o3d


# -- writing ---------------------------------------------------------------------------------


def _o3d_points(xyz: F64, colors: F64, normals: F64 | None = None) -> Any:
    o3d = open3d()

    pc = o3d.geometry.PointCloud()
    pc.points = o3d.utility.Vector3dVector(np.ascontiguousarray(xyz))
    pc.colors = o3d.utility.Vector3dVector(np.ascontiguousarray(np.clip(colors, 0.0, 1.0)))
    if normals is not None:
        pc.normals = o3d.utility.Vector3dVector(np.ascontiguousarray(normals))
    return pc


def _write(path: Path, kind: str, geometry: Any, about: Sequence[str] = ()) -> Path:
    """Write ``geometry`` with open3d beside ``path`` (a hidden name of the same suffix, which
    chooses the format), then check it complete and mark it as aion's, with the comments
    ``about`` (:func:`formats.scene_files.seal`): open3d's return value misses a full disk."""
    from aion_cli.formats.scene_files import native_stderr_quiet, seal

    o3d = open3d()

    writers: dict[str, Any] = {
        "mesh": o3d.io.write_triangle_mesh,
        "lines": o3d.io.write_line_set,
        "points": o3d.io.write_point_cloud,
    }
    raw = path.with_name(f".open3d.{path.name}")
    with native_stderr_quiet():
        ok = writers[kind](str(raw), geometry, write_ascii=False)
    if not ok:
        raw.unlink(missing_ok=True)
        raise ExportWriteError(
            f"cannot write {path}", hint="check that the output folder is writable"
        )
    return seal(raw, path, about)


# -- the scene -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Scene:
    nodes: Instanced
    arrows: Instanced
    cells: TriMesh
    mesh: TriMesh
    edges: F64  # [k,2,3]
    path: F64  # [p,3]


def export_scene(
    out_dir: str | os.PathLike[str],
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
    fmt: Literal["ply", "pcd"] = "ply",
    cell_size: float = 0.5,
    prefix: str = "",
    *,
    node_concentration: npt.ArrayLike | None = None,
    flow_scale: float | None = None,
    cells_dominant_angle: npt.ArrayLike | None = None,
    about: Sequence[str] = (),
) -> list[Path]:
    """Write the scene's parts (and a combined scene) to ``out_dir``; returns the files written.

    Per node: ``nodes_xyz`` f64[n,3], ``node_flow`` (expected detections per window),
    ``node_entropy`` (0..1, NaN = no flow), ``node_dominant_angle`` (rad, NaN = none) and
    optionally ``node_concentration`` (0..1). Per unbound cell: ``cells_xyz`` (centres),
    ``cells_flow`` (cells without flow are drawn grey), ``cells_entropy`` and
    ``cells_dominant_angle`` (rad, NaN = none; PCD normals, as the nodes').
    ``edges_xyz_pairs`` f64[k,2,3] (or [k,6]) segment end points, ``path_xyz`` f64[p,3] a
    planned path. ``flow_scale`` is the flow drawn at full size
    (default: the largest node flow, so the busiest node has radius δ). ``out_dir`` is created.
    ``about``: lines every file's header carries as comments after aion's marker (the time of
    the scene, whether its hour was observed: :func:`formats.scene_files.header_comments`).
    """
    if fmt not in ("ply", "pcd"):
        raise ExportError(f"export format must be 'ply' or 'pcd', got {fmt!r}")
    from aion_cli.formats.scene_style import style_scene  # it builds on this module's helpers

    style = style_scene(
        nodes_xyz,
        node_flow,
        node_entropy,
        node_dominant_angle,
        cells_xyz,
        cells_flow,
        cells_entropy,
        edges_xyz_pairs,
        mesh,
        path_xyz,
        cell_size,
        node_concentration=node_concentration,
        flow_scale=flow_scale,
        cells_dominant_angle=cells_dominant_angle,
    )
    xyz, colors = style.nodes_xyz, style.colors
    scene = _Scene(
        nodes=node_spheres(xyz, style.radii, colors),
        arrows=direction_arrows(
            np.concatenate([xyz, style.cells_xyz]),
            np.concatenate([style.arrow_angle, style.cell_arrow_angle]),
            np.concatenate([style.arrow_length, style.cell_arrow_length]),
            style.arrow_width,
            np.concatenate([colors, style.cell_colors]),
        ),
        cells=cell_squares(style.cells_xyz, cell_size, style.cell_colors),
        mesh=style.mesh,
        edges=style.edges,
        path=style.path,
    )
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportWriteError(
            f"cannot create output folder {out}: {exc.strerror or exc}",
            hint="choose a writable output folder",
        ) from exc
    if fmt == "ply":
        return _write_ply(out, prefix, scene, cell_size, about)
    return _write_pcd(
        out,
        prefix,
        scene,
        (xyz, colors, _direction_normals(style.angle)),
        (style.cells_xyz, style.cell_colors, _direction_normals(style.cells_angle)),
        about,
    )


SCENE_PARTS = ("nodes", "arrows", "cells", "mesh", "edges", "path", "scene")
"""The names of the scene files an export may write (``<part>.ply`` / ``<part>.pcd``)."""


def _write_ply(
    out: Path, prefix: str, scene: _Scene, cell_size: float, about: Sequence[str] = ()
) -> list[Path]:
    """The PLY files of ``scene``, written from its arrays by :mod:`formats.ply_files` (the
    bytes open3d wrote, marked, with the comments ``about``); ``scene.ply`` streams every
    part, the edges and the path as tubes, without concatenating them."""
    from aion_cli.formats.ply_files import write_lines, write_mesh

    open3d()  # a PLY export needs open3d (the templates), whatever the scene holds
    written: list[Path] = []
    for part, tri in (
        ("nodes", scene.nodes),
        ("arrows", scene.arrows),
        ("cells", scene.cells),
        ("mesh", scene.mesh),
    ):
        if tri.counts()[0]:
            written.append(write_mesh(out / f"{prefix}{part}.ply", [tri], about))
    k = len(scene.edges)
    if k:
        pts = scene.edges.reshape(-1, 3)
        lines = np.arange(2 * k, dtype=np.int64).reshape(k, 2)
        written.append(write_lines(out / f"{prefix}edges.ply", pts, lines, EDGE_GREY, about))
    p = len(scene.path)
    if p >= 2:
        lines = np.stack([np.arange(p - 1), np.arange(1, p)], axis=1)
        path_file = out / f"{prefix}path.ply"
        written.append(write_lines(path_file, scene.path, lines, PATH_GREEN, about))
    parts: list[TriMesh | Instanced] = [
        scene.mesh,
        scene.cells,
        scene.nodes,
        scene.arrows,
        tubes(scene.edges[:, 0], scene.edges[:, 1], 0.03 * cell_size, EDGE_GREY),
        tubes(scene.path[:-1], scene.path[1:], 0.12 * cell_size, PATH_GREEN)
        if p >= 2
        else TriMesh.empty(),
    ]
    if any(part.counts()[0] for part in parts):
        written.append(write_mesh(out / f"{prefix}scene.ply", parts, about))
    return written


def _direction_normals(angle: F64) -> F64:
    """Unit vectors along ``angle`` (rad from +x) in the ground plane; 0 where it is NaN."""
    finite = np.isfinite(angle)
    normals = np.zeros((len(angle), 3))
    normals[finite] = np.c_[np.cos(angle[finite]), np.sin(angle[finite]), np.zeros(finite.sum())]
    return normals


def _write_pcd(
    out: Path,
    prefix: str,
    scene: _Scene,
    nodes: tuple[F64, F64, F64],
    cells: tuple[F64, F64, F64],
    about: Sequence[str] = (),
) -> list[Path]:
    """``nodes`` / ``cells``: points, colours and normals (dominant directions, 0 where
    none); the mesh and the path have none (0), and ``scene.pcd`` holds every part; each
    file's header with the comments ``about``."""
    path_colors = np.tile(np.asarray(PATH_GREEN), (len(scene.path), 1))
    mesh_xyz = np.asarray(scene.mesh.vertices, dtype=np.float64).reshape(-1, 3)
    clouds = [
        ("nodes", *nodes),
        ("cells", *cells),
        ("mesh", mesh_xyz, scene.mesh.colors, np.zeros((len(mesh_xyz), 3))),
        ("path", scene.path, path_colors, np.zeros((len(scene.path), 3))),
    ]
    written: list[Path] = []
    for part, pts, cols, nrm in clouds:
        if len(pts):
            normals = nrm if part in ("nodes", "cells") else None
            written.append(
                _write(
                    out / f"{prefix}{part}.pcd", "points", _o3d_points(pts, cols, normals), about
                )
            )
    all_pts = np.concatenate([c[1] for c in clouds])
    if len(all_pts):
        all_cols = np.concatenate([c[2] for c in clouds])
        all_normals = np.concatenate([c[3] for c in clouds])
        written.append(
            _write(
                out / f"{prefix}scene.pcd",
                "points",
                _o3d_points(all_pts, all_cols, all_normals),
                about,
            )
        )
    return written
