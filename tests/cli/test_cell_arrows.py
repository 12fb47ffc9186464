"""A map of hash cells only (no scene graph: ATC tracks converted with ``--layout atc``) showed
no direction in its 3-D scene: ``aion export MAP -o dir/`` wrote no ``arrows.ply`` (the PNG
drew the cells' arrows). Its cells now carry arrows as a node does; a map with places draws
its nodes' arrows only, as before."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import open3d as o3d

from tests.cli.conftest import run

#: two walkers, one cell each: +x through (0.25, 0.25), +y through (5.25, 5.25) (0.5 m cells)
CSV = (
    "t_ns,track_id,x,y,z,heading_rad,speed_mps\n"
    "1767603600000000000,1,0.25,0.25,0,0,1\n"
    "1767603600000000000,2,5.25,5.25,0,1.5707963267948966,1\n"
)


def test_a_cell_only_map_exports_an_arrow_per_cell_along_its_direction(tmp_path: Path) -> None:
    csv, log, out = tmp_path / "t.csv", tmp_path / "t.mcap", tmp_path / "t.aion"
    csv.write_text(CSV)
    assert run("convert", csv, "-o", log, "-q").exit_code == 0
    assert run("build", log, "-o", out, "-q").exit_code == 0
    scene = tmp_path / "scene"
    done = run("export", out, "--historical", "-o", f"{scene}/")
    assert done.exit_code == 0, done.stderr
    assert not (scene / "nodes.ply").exists()  # no places: the cells carry the arrows
    verts = np.asarray(o3d.io.read_triangle_mesh(str(scene / "arrows.ply")).vertices)
    east = verts[verts[:, 1] < 2.5]
    north = verts[verts[:, 1] >= 2.5]
    # equally busy cells, each at full length from its centre: 0.5 * (0.5 + 0.3 + 2) = 1.4 m
    assert np.isclose(east[:, 0].max(), 0.25 + 1.4)
    assert np.isclose(east[:, 0].min(), 0.25, atol=0.05)
    assert np.ptp(east[:, 1]) < 0.2  # along x, thin across
    assert np.isclose(north[:, 1].max(), 5.25 + 1.4)
    assert np.ptp(north[:, 0]) < 0.2
    whole = np.asarray(o3d.io.read_triangle_mesh(str(scene / "scene.ply")).vertices)
    # the whole scene holds them too, beyond the cells' squares
    assert np.isclose(whole[whole[:, 1] < 2.5][:, 0].max(), 0.25 + 1.4)
