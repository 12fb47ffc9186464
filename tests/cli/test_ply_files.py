"""PLY scene files written with numpy (``formats.ply_files``) are the bytes open3d wrote and
``scene_files.seal`` marked: the open3d path is kept here as the reference
(:func:`reference_write_ply` is the old ``export._write_ply``) and compared file by file on
exports of the office and sample maps (nodes, arrows, cells, mesh, edges, a path, the whole
scene) and on meshes made up for it (colours outside 0..1 and on the rounding halves, parts
without colours or without vertices), in blocks of a few rows too."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import aion_cli.formats.export as export_module
import aion_cli.formats.ply_files as ply_files
from aion_cli.formats.export import TriMesh, open3d, tubes
from aion_cli.formats.scene_colours import EDGE_GREY, PATH_GREEN
from aion_cli.formats.scene_files import seal
from tests.cli.conftest import Office, run

AT = "2026-11-23 08:30"


def _o3d_mesh(mesh: TriMesh) -> Any:
    o3d = open3d()
    out = o3d.geometry.TriangleMesh()
    out.vertices = o3d.utility.Vector3dVector(np.ascontiguousarray(mesh.vertices))
    out.triangles = o3d.utility.Vector3iVector(np.ascontiguousarray(mesh.faces, dtype=np.int32))
    if len(mesh.colors) == len(mesh.vertices):
        out.vertex_colors = o3d.utility.Vector3dVector(
            np.ascontiguousarray(np.clip(mesh.colors, 0.0, 1.0))
        )
    return out


def _o3d_lines(points: Any, lines: Any, color: tuple[float, float, float]) -> Any:
    o3d = open3d()
    ls = o3d.geometry.LineSet()
    ls.points = o3d.utility.Vector3dVector(np.ascontiguousarray(points))
    ls.lines = o3d.utility.Vector2iVector(np.ascontiguousarray(lines, dtype=np.int32))
    ls.colors = o3d.utility.Vector3dVector(np.tile(np.asarray(color, np.float64), (len(lines), 1)))
    return ls


def _write(path: Path, kind: str, geometry: Any, about: Any = ()) -> Path:
    o3d = open3d()
    writer = o3d.io.write_triangle_mesh if kind == "mesh" else o3d.io.write_line_set
    raw = path.with_name(f".open3d.{path.name}")
    assert writer(str(raw), geometry, write_ascii=False)
    sealed = seal(raw, path, about)  # open3d's bytes, but for the comment naming it, which
    # aion's omit
    data = sealed.read_bytes()
    header_end = data.index(b"end_header\n")
    ours = data[:header_end].replace(b"comment Created by Open3D\n", b"", 1) + data[header_end:]
    assert len(ours) < len(data)
    sealed.write_bytes(ours)
    return sealed


def reference_write_ply(
    out: Path, prefix: str, scene: Any, cell_size: float, about: Any = ()
) -> list[Path]:
    """The open3d ``_write_ply`` the numpy writer replaced (``about``: the header comments
    after aion's marker, which ``seal`` writes as it writes them)."""
    written: list[Path] = []
    nodes, arrows = scene.nodes.mesh(), scene.arrows.mesh()  # the TriMeshes of before
    for part, tri in (("nodes", nodes), ("arrows", arrows), ("cells", scene.cells),
                      ("mesh", scene.mesh)):
        if len(tri.vertices):
            written.append(_write(out / f"{prefix}{part}.ply", "mesh", _o3d_mesh(tri), about))
    k = len(scene.edges)
    if k:
        pts = scene.edges.reshape(-1, 3)
        lines = np.arange(2 * k, dtype=np.int64).reshape(k, 2)
        written.append(
            _write(out / f"{prefix}edges.ply", "lines", _o3d_lines(pts, lines, EDGE_GREY), about))
    p = len(scene.path)
    if p >= 2:
        lines = np.stack([np.arange(p - 1), np.arange(1, p)], axis=1)
        written.append(
            _write(out / f"{prefix}path.ply", "lines", _o3d_lines(scene.path, lines, PATH_GREEN),
                   about))
    combined = TriMesh.concat([
        scene.mesh, scene.cells, nodes, arrows,
        tubes(scene.edges[:, 0], scene.edges[:, 1], 0.03 * cell_size, EDGE_GREY),
        tubes(scene.path[:-1], scene.path[1:], 0.12 * cell_size, PATH_GREEN)
        if p >= 2 else TriMesh.empty(),
    ])
    if len(combined.vertices):
        written.append(_write(out / f"{prefix}scene.ply", "mesh", _o3d_mesh(combined), about))
    return written


@pytest.fixture(params=[1 << 16, 5], ids=["blocks", "tiny-blocks"])
def rows(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> int:
    monkeypatch.setattr(ply_files, "ROWS", request.param)
    return int(request.param)


def _same_files(a: Path, b: Path) -> None:
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("when", [("--time", AT), ("--historical",)])
def test_exports_equal_open3d(office: Office, sample_map: Path, tmp_path: Path, rows: int,
                              monkeypatch: pytest.MonkeyPatch, when: tuple[str, ...]) -> None:
    for name, path, extra in (
        ("office", office.map, ("--path-from", "p0", "--path-to", "p4")),
        ("sample", sample_map, ()),
    ):
        new, old = tmp_path / f"{name}-new", tmp_path / f"{name}-old"
        assert run("export", path, *when, "-o", new, *extra).exit_code == 0
        with monkeypatch.context() as patched:
            patched.setattr(export_module, "_write_ply", reference_write_ply)
            assert run("export", path, *when, "-o", old, *extra).exit_code == 0
        assert {p.name for p in new.glob("*.ply")} >= {"nodes.ply", "scene.ply", "edges.ply"}
        _same_files(new, old)


def _mesh(rng: np.random.Generator, n: int, colours: int) -> TriMesh:
    faces = rng.integers(0, max(n, 1), (2 * n, 3)) if n else np.zeros((0, 3), np.int64)
    colors = rng.choice([-0.5, 0.0, 0.5 / 255, 1.5 / 255, 0.3, 1.0, 1.7], (colours, 3))
    colors[: colours // 2] = rng.random((colours // 2, 3))
    return TriMesh(rng.normal(0, 50, (n, 3)), faces, colors)


@pytest.mark.parametrize("colours", ["all", "missing"])
def test_made_up_meshes_and_lines(tmp_path: Path, rows: int, colours: str) -> None:
    rng = np.random.default_rng(4)
    parts = [_mesh(rng, 40, 40), _mesh(rng, 0, 0), _mesh(rng, 17, 17 if colours == "all" else 0),
             _mesh(rng, 3, 3)]
    for k, chosen in enumerate([parts, parts[:1], parts[2:3]]):
        new, old = tmp_path / f"new{k}.ply", tmp_path / f"old{k}.ply"
        ply_files.write_mesh(new, chosen)
        _write(old, "mesh", _o3d_mesh(TriMesh.concat(chosen)))
        assert new.read_bytes() == old.read_bytes()
    about = ["aion time 2026-11-30 07:00:00+00:00", "aion zone Zürich\nline"]  # odd on purpose
    ply_files.write_mesh(tmp_path / "about-new.ply", parts, about)
    _write(tmp_path / "about-old.ply", "mesh", _o3d_mesh(TriMesh.concat(parts)), about)
    written = (tmp_path / "about-new.ply").read_bytes()
    assert written == (tmp_path / "about-old.ply").read_bytes()
    assert b"comment written by aion export\ncomment aion time 2026-11-30 07:00:00+00:00\n" \
        b"comment aion zone Z?rich line\nelement vertex" in written  # ASCII, one line each
    points = rng.normal(0, 10, (12, 3))
    lines = np.stack([np.arange(11), np.arange(1, 12)], axis=1)
    ply_files.write_lines(tmp_path / "l-new.ply", points, lines, (0.2, 0.5, 0.77))
    _write(tmp_path / "l-old.ply", "lines", _o3d_lines(points, lines, (0.2, 0.5, 0.77)))
    assert (tmp_path / "l-new.ply").read_bytes() == (tmp_path / "l-old.ply").read_bytes()


def test_colour_bytes_round_halves_up() -> None:
    halves = (np.arange(256) + 0.5) / 255
    assert ply_files.colour_bytes(halves).tolist()[:3] == [1, 2, 3]
    assert ply_files.colour_bytes(np.array([-1.0, 0.0, 1.0, 2.0])).tolist() == [0, 0, 255, 255]
