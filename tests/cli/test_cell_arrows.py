"""A map of hash cells only (no scene graph: ATC tracks converted with ``--layout atc``) showed
no direction in its 3-D scene: ``aion export MAP -o dir/`` wrote no ``arrows.ply`` (the PNG
drew the cells' arrows). Its cells now carry arrows as a node does; a map with places draws
its nodes' arrows only, as before."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import open3d as o3d
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoders
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders

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


def _cell_map(tmp_path: Path) -> Path:
    csv, log, out = tmp_path / "t.csv", tmp_path / "t.mcap", tmp_path / "t.aion"
    csv.write_text(CSV)
    assert run("convert", csv, "-o", log, "-q").exit_code == 0
    assert run("build", log, "-o", out, "-q").exit_code == 0
    return out


def _mcap_arrows(path: Path) -> tuple[list[Any], list[Any]]:
    """The last step's (Foxglove arrows with their entity, RViz arrow markers) of a scene."""
    last: dict[str, Any] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[ProtobufDecoders(), Ros2Decoders()])
        for _schema, channel, _message, decoded in reader.iter_decoded_messages():
            last[channel.topic] = decoded
    fox = [(e, a) for e in last["/aion/scene"].entities for a in e.arrows]
    rviz = [m for m in last["/aion/markers"].markers if m.ns == "arrows"]
    return fox, rviz


def _yaw(q: Any) -> float:
    return 2 * math.atan2(q.z, q.w)


@pytest.mark.parametrize("series", [False, True])
def test_the_mcap_scene_of_a_cell_only_map_draws_the_ply_arrows(
    tmp_path: Path, series: bool
) -> None:
    out = _cell_map(tmp_path)
    scene = tmp_path / "scene"
    # a series' last step is compared with the PLY scene of the same time
    at = ["--time", "2026-01-05T11:00Z"] if series else ["--historical"]
    assert run("export", out, *at, "-o", f"{scene}/").exit_code == 0
    ply = o3d.io.read_triangle_mesh(str(scene / "arrows.ply"))
    verts, colours = np.asarray(ply.vertices), np.asarray(ply.vertex_colors)
    when = ["--from", "2026-01-05T09:00Z", "--to", "2026-01-05T11:00Z", "--step", "1h"]
    mcap = tmp_path / "s.mcap"
    done = run("export", out, *(when if series else at), "--format", "mcap", "-o", mcap)
    assert done.exit_code == 0, done.stderr
    fox, rviz = _mcap_arrows(mcap)
    # east cell (0.25, 0.25) heading +x, north cell (5.25, 5.25) heading +y, 1.4 m each
    expected = [((0.25, 0.25), 0.0), ((5.25, 5.25), math.pi / 2)]
    assert len(fox) == len(rviz) == 2
    fox.sort(key=lambda ea: ea[1].pose.position.y)
    rviz.sort(key=lambda m: m.pose.position.y)
    for (entity, a), m, (centre, yaw) in zip(fox, rviz, expected, strict=True):
        assert entity.id.startswith("c")
        assert m.text == entity.id
        for p in (a.pose.position, m.pose.position):
            assert np.allclose((p.x, p.y), centre)
        assert np.isclose(_yaw(a.pose.orientation), yaw)
        assert np.isclose(_yaw(m.pose.orientation), yaw)
        assert np.isclose(a.shaft_length + a.head_length, 1.4)
        assert np.isclose(m.scale.x, 1.4)
        # the PLY's arrow from this centre: same tip and colour
        mine = np.hypot(*(verts[:, :2] - centre).T) < 2.0
        along = 0 if yaw == 0 else 1
        assert np.isclose(verts[mine][:, along].max() - centre[along], 1.4)
        # (the PLY stores colours in 8 bits)
        assert np.allclose(colours[mine], (a.color.r, a.color.g, a.color.b), atol=0.5 / 255)
        assert np.allclose((m.color.r, m.color.g, m.color.b), (a.color.r, a.color.g, a.color.b))
