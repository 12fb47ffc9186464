"""PLY/PCD export: write, re-read with open3d, check counts, colours, sizes and directions."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import open3d as o3d
import pytest

from aion_cli.engine.types import Mesh
from aion_cli.formats.export import (
    ARROW_RESOLUTION,
    SPHERE_RESOLUTION,
    TUBE_RESOLUTION,
    ExportError,
    ExportWriteError,
    export_scene,
)

DELTA = 0.5
COLOR_TOL = 1.5 / 255  # PLY/PCD colours are stored as 8-bit
NODES = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [10.0, 0.0, 1.0], [15.0, 0.0, 0.0]])
FLOW = np.array([0.0, 5.0, 10.0, 2.0])
ENTROPY = np.array([np.nan, 0.0, 1.0, 0.5])
ANGLE = np.array([np.nan, 0.0, math.pi / 2, -3 * math.pi / 4])
CELLS = np.array([[1.0, 3.0, 0.0], [2.0, 3.0, 0.0]])
CELL_FLOW = np.array([4.0, 0.0])
CELL_ENTROPY = np.array([0.25, np.nan])
EDGES = np.stack([NODES[[0, 1, 2]], NODES[[1, 2, 3]]], axis=1)  # [3, 2, 3]
PATH = NODES[[0, 1, 2]]
MESH = Mesh(
    vertices=np.array([[0.0, 0, -1], [1, 0, -1], [0, 1, -1], [1, 1, -1]]),
    faces=np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int32),
    colors=np.array([[1.0, 1, 0], [0, 1, 0], [0, 1, 1], [1, 1, 1]]),
)


def template_vertices(kind: str) -> int:
    tm = o3d.geometry.TriangleMesh
    if kind == "sphere":
        return len(tm.create_sphere(radius=1.0, resolution=SPHERE_RESOLUTION).vertices)
    if kind == "arrow":
        arrow = tm.create_arrow(resolution=ARROW_RESOLUTION, cylinder_split=1, cone_split=1)
        return len(arrow.vertices)
    return len(tm.create_cylinder(resolution=TUBE_RESOLUTION, split=1).vertices)


def template_triangles() -> int:
    sphere = o3d.geometry.TriangleMesh.create_sphere(radius=1.0, resolution=SPHERE_RESOLUTION)
    return len(sphere.triangles)


def full_export(out: Path, fmt: str = "ply", prefix: str = "") -> list[Path]:
    return export_scene(
        out,
        NODES,
        FLOW,
        ENTROPY,
        ANGLE,
        CELLS,
        CELL_FLOW,
        CELL_ENTROPY,
        EDGES,
        MESH,
        PATH,
        fmt=fmt,  # type: ignore[arg-type]
        cell_size=DELTA,
        prefix=prefix,
    )


def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    m = o3d.io.read_triangle_mesh(path)
    return np.asarray(m.vertices), np.asarray(m.triangles), np.asarray(m.vertex_colors)


def test_ply_writes_one_file_per_part_and_a_scene(tmp_path: Path) -> None:
    files = full_export(tmp_path, prefix="t0830_")
    names = [p.name for p in files]
    assert names == [
        f"t0830_{part}.ply"
        for part in ("nodes", "arrows", "cells", "mesh", "edges", "path", "scene")
    ]
    assert all(p.is_file() and p.stat().st_size > 0 for p in files)


def test_node_spheres_count_colour_and_size(tmp_path: Path) -> None:
    full_export(tmp_path)
    v, f, c = read_mesh(tmp_path / "nodes.ply")
    per = template_vertices("sphere")
    assert len(v) == per * len(NODES)
    blocks_v = v.reshape(len(NODES), per, 3)
    blocks_c = c.reshape(len(NODES), per, 3)
    # Each block is one node's sphere, centred on the node.
    np.testing.assert_allclose(blocks_v.mean(axis=1), NODES, atol=1e-6)
    # Colours: NaN entropy grey, 0 blue, 1 red, 0.5 purple.
    np.testing.assert_allclose(blocks_c[0], np.tile([0.5, 0.5, 0.5], (per, 1)), atol=COLOR_TOL)
    np.testing.assert_allclose(blocks_c[1], np.tile([0.0, 0.0, 1.0], (per, 1)), atol=COLOR_TOL)
    np.testing.assert_allclose(blocks_c[2], np.tile([1.0, 0.0, 0.0], (per, 1)), atol=COLOR_TOL)
    np.testing.assert_allclose(blocks_c[3], np.tile([0.5, 0.0, 0.5], (per, 1)), atol=COLOR_TOL)
    # Radii from the z extent (the poles): 0.2 δ at no flow, δ at the largest flow, linear.
    radius = np.ptp(blocks_v[:, :, 2], axis=1) / 2
    busy = FLOW / FLOW.max()
    np.testing.assert_allclose(radius, DELTA * (0.2 + 0.8 * busy), rtol=1e-6)
    assert radius[2] > radius[1] > radius[3] > radius[0]
    assert len(f) == template_triangles() * len(NODES)
    assert f.max() == len(v) - 1


def test_flow_scale_fixes_sizes_across_exports(tmp_path: Path) -> None:
    export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, cell_size=DELTA, flow_scale=20.0)
    v, _, _ = read_mesh(tmp_path / "nodes.ply")
    radius = np.ptp(v.reshape(len(NODES), -1, 3)[:, :, 2], axis=1) / 2
    np.testing.assert_allclose(radius, DELTA * (0.2 + 0.8 * FLOW / 20.0), rtol=1e-6)


def test_arrows_point_along_the_dominant_direction(tmp_path: Path) -> None:
    full_export(tmp_path)
    v, _, c = read_mesh(tmp_path / "arrows.ply")
    per = template_vertices("arrow")
    with_arrow = [1, 2, 3]  # node 0 has no flow and no angle
    assert len(v) == per * len(with_arrow)
    blocks = v.reshape(len(with_arrow), per, 3)
    radius = DELTA * (0.2 + 0.8 * FLOW / FLOW.max())
    for block, node in zip(blocks, with_arrow, strict=True):
        rel = block - NODES[node]
        direction = np.array([math.cos(ANGLE[node]), math.sin(ANGLE[node]), 0.0])
        along = rel @ direction
        busy = FLOW[node] / FLOW.max()
        expected_len = radius[node] + DELTA * (0.3 + 2.0 * busy)
        assert along.max() == pytest.approx(expected_len, rel=1e-6)
        assert along.min() == pytest.approx(0.0, abs=1e-9)
        # Horizontal: the arrow stays within its width of the node's height.
        assert np.abs(rel[:, 2]).max() <= 2 * 0.08 * DELTA + 1e-9
    np.testing.assert_allclose(c[:per], np.tile([0.0, 0.0, 1.0], (per, 1)), atol=COLOR_TOL)


def test_concentration_shortens_arrows(tmp_path: Path) -> None:
    export_scene(
        tmp_path,
        NODES[1:3],
        FLOW[1:3],
        ENTROPY[1:3],
        [0.0, 0.0],
        cell_size=DELTA,
        node_concentration=[1.0, 0.0],
        flow_scale=10.0,
    )
    v, _, _ = read_mesh(tmp_path / "arrows.ply")
    blocks = v.reshape(2, -1, 3)
    lengths = [(blocks[i] - NODES[1 + i])[:, 0].max() for i in range(2)]
    radius = DELTA * (0.2 + 0.8 * FLOW[1:3] / 10.0)
    assert lengths[0] == pytest.approx(radius[0] + DELTA * (0.3 + 2.0 * 0.5))
    assert lengths[1] == pytest.approx(radius[1] + DELTA * 0.3)


def test_cells_are_flat_delta_squares_coloured_by_entropy(tmp_path: Path) -> None:
    full_export(tmp_path)
    v, f, c = read_mesh(tmp_path / "cells.ply")
    assert len(v) == 4 * len(CELLS)
    assert len(f) == 2 * len(CELLS)
    for k, centre in enumerate(CELLS):
        square = v[4 * k : 4 * k + 4]
        np.testing.assert_allclose(np.ptp(square, axis=0), [DELTA, DELTA, 0.0], atol=1e-9)
        np.testing.assert_allclose(square.mean(axis=0), centre, atol=1e-9)
    np.testing.assert_allclose(c[0], [0.25, 0.0, 0.75], atol=COLOR_TOL)
    np.testing.assert_allclose(c[4], [0.5, 0.5, 0.5], atol=COLOR_TOL)  # no flow: grey


def test_edges_path_and_mesh_round_trip(tmp_path: Path) -> None:
    full_export(tmp_path)
    edges = o3d.io.read_line_set(tmp_path / "edges.ply")
    assert len(edges.lines) == len(EDGES)
    pts = np.asarray(edges.points)
    segs = pts[np.asarray(edges.lines)]
    np.testing.assert_allclose(segs, EDGES, atol=1e-6)
    path = o3d.io.read_line_set(tmp_path / "path.ply")
    assert len(path.lines) == len(PATH) - 1
    np.testing.assert_allclose(np.asarray(path.points), PATH, atol=1e-6)
    v, f, c = read_mesh(tmp_path / "mesh.ply")
    np.testing.assert_allclose(v, MESH.vertices, atol=1e-6)
    np.testing.assert_array_equal(f, MESH.faces)
    np.testing.assert_allclose(c, MESH.colors, atol=COLOR_TOL)


def test_scene_ply_holds_every_part_as_triangles(tmp_path: Path) -> None:
    full_export(tmp_path)
    v, f, _ = read_mesh(tmp_path / "scene.ply")
    tube = template_vertices("tube")
    expected = (
        len(MESH.vertices)
        + 4 * len(CELLS)
        + template_vertices("sphere") * len(NODES)
        + template_vertices("arrow") * 3
        + tube * len(EDGES)
        + tube * (len(PATH) - 1)
    )
    assert len(v) == expected
    assert f.max() < len(v)


def test_pcd_writes_coloured_point_clouds(tmp_path: Path) -> None:
    files = full_export(tmp_path, fmt="pcd")
    assert [p.name for p in files] == [
        "nodes.pcd",
        "cells.pcd",
        "mesh.pcd",
        "path.pcd",
        "scene.pcd",
    ]
    nodes = o3d.io.read_point_cloud(tmp_path / "nodes.pcd")
    np.testing.assert_allclose(np.asarray(nodes.points), NODES, atol=1e-6)
    colours = np.asarray(nodes.colors)
    np.testing.assert_allclose(colours[1], [0, 0, 1], atol=COLOR_TOL)
    np.testing.assert_allclose(colours[2], [1, 0, 0], atol=COLOR_TOL)
    normals = np.asarray(nodes.normals)
    np.testing.assert_allclose(normals[0], [0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(normals[2], [0, 1, 0], atol=1e-6)
    assert len(o3d.io.read_point_cloud(tmp_path / "cells.pcd").points) == len(CELLS)
    scene = o3d.io.read_point_cloud(tmp_path / "scene.pcd")
    assert len(scene.points) == len(NODES) + len(CELLS) + len(MESH.vertices) + len(PATH)
    # the combined cloud keeps the nodes' directions (the mesh and the path have none)
    np.testing.assert_allclose(np.asarray(scene.normals)[: len(NODES)], normals, atol=1e-6)
    assert not np.asarray(scene.normals)[len(NODES):].any()


def test_pcd_cells_carry_their_directions_as_normals(tmp_path: Path) -> None:
    """Cells have dominant directions too (they were written without normals, also in
    scene.pcd): one along -x, one without a direction."""
    export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, CELLS, CELL_FLOW, CELL_ENTROPY,
                 fmt="pcd", cell_size=DELTA, cells_dominant_angle=[math.pi, np.nan])
    cells = np.asarray(o3d.io.read_point_cloud(tmp_path / "cells.pcd").normals)
    np.testing.assert_allclose(cells, [[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], atol=1e-6)
    scene = np.asarray(o3d.io.read_point_cloud(tmp_path / "scene.pcd").normals)
    np.testing.assert_allclose(scene[len(NODES):len(NODES) + 2], cells, atol=1e-6)
    wrong = r"cells_dominant_angle must have shape \(2\), got \(1,\)"
    for fmt in ("pcd", "ply"):  # checked once, in style_scene, whatever is written
        with pytest.raises(ExportError, match=wrong):
            export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, CELLS, fmt=fmt,
                         cells_dominant_angle=[0.0])


def test_empty_parts_are_not_written(tmp_path: Path) -> None:
    files = export_scene(tmp_path, NODES[:1], [0.0], [np.nan], [np.nan], cell_size=DELTA)
    assert [p.name for p in files] == ["nodes.ply", "scene.ply"]
    assert export_scene(tmp_path / "none", np.zeros((0, 3)), [], [], []) == []


def test_bad_inputs_are_typed_errors(tmp_path: Path) -> None:
    with pytest.raises(ExportError, match="node_flow"):
        export_scene(tmp_path, NODES, FLOW[:2], ENTROPY, ANGLE)
    with pytest.raises(ExportError, match="nodes_xyz"):
        export_scene(tmp_path, np.zeros((2, 2)), [0, 0], [0, 0], [0, 0])
    with pytest.raises(ExportError, match="edges_xyz_pairs"):
        export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, edges_xyz_pairs=np.zeros((2, 5)))
    with pytest.raises(ExportError, match="format"):
        export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, fmt="obj")  # type: ignore[arg-type]
    with pytest.raises(ExportError, match="cell_size"):
        export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, cell_size=0.0)
    bad_mesh = Mesh(np.zeros((2, 3)), np.array([[0, 1, 5]], dtype=np.int32))
    with pytest.raises(ExportError, match="mesh faces"):
        export_scene(tmp_path, NODES, FLOW, ENTROPY, ANGLE, mesh=bad_mesh)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ExportWriteError, match="output folder"):
        export_scene(blocker / "sub", NODES, FLOW, ENTROPY, ANGLE)
