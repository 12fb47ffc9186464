"""The triangles of a PLY scene, instanced with numpy: one template sphere / arrow / tube
(from open3d) scaled, rotated and moved for every item, so exporting 10^4 nodes builds no
10^4 open3d objects; flat squares for hash cells. Spheres and arrows stay
:class:`Instanced` (their template and per-item transforms) until written, a block of items
at a time (:mod:`formats.ply_files`). Split from :mod:`formats.export`, which re-exports
these names."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]

SPHERE_RESOLUTION = 8
ARROW_RESOLUTION = 8
TUBE_RESOLUTION = 6


@dataclass(frozen=True)
class TriMesh:
    """A plain triangle mesh: vertices f64[v,3], faces i64[f,3], vertex colours f64[v,3]."""

    vertices: F64
    faces: I64
    colors: F64

    @classmethod
    def empty(cls) -> TriMesh:
        return cls(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)))

    def counts(self) -> tuple[int, int, int]:
        """Vertices, faces and colours (what ``formats.ply_files`` writes)."""
        return len(self.vertices), len(self.faces), len(self.colors)

    def vertex_blocks(self, rows: int) -> Iterator[tuple[F64, F64]]:
        """(vertices, colours) ``rows`` at a time."""
        for a in range(0, len(self.vertices), rows):
            yield self.vertices[a : a + rows], self.colors[a : a + rows]

    def face_blocks(self, rows: int) -> Iterator[I64]:
        """Faces ``rows`` at a time."""
        for a in range(0, len(self.faces), rows):
            yield self.faces[a : a + rows]

    @classmethod
    def concat(cls, parts: list[TriMesh]) -> TriMesh:
        parts = [p for p in parts if len(p.vertices)]
        if not parts:
            return cls.empty()
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
        return cls(
            np.concatenate([p.vertices for p in parts]),
            np.concatenate([p.faces + off for p, off in zip(parts, offsets, strict=True)]),
            np.concatenate([p.colors for p in parts]),
        )


def _template(kind: str) -> tuple[F64, I64]:
    """Unit template geometry from open3d: sphere (r = 1), arrow (shaft radius 1, length 1
    along +z from the origin), tube (radius 1, height 1 along +z centred on the origin)."""
    from aion_cli.formats.export import open3d

    o3d = open3d()

    tm = o3d.geometry.TriangleMesh
    if kind == "sphere":
        mesh = tm.create_sphere(radius=1.0, resolution=SPHERE_RESOLUTION)
    elif kind == "arrow":
        mesh = tm.create_arrow(
            cylinder_radius=1.0,
            cone_radius=2.0,
            cylinder_height=0.75,
            cone_height=0.25,
            resolution=ARROW_RESOLUTION,
            cylinder_split=1,
            cone_split=1,
        )
    else:
        mesh = tm.create_cylinder(radius=1.0, height=1.0, resolution=TUBE_RESOLUTION, split=1)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.triangles, np.int64)


def _rotations_from_z(direction: F64) -> F64:
    """Rotation matrices [n,3,3] taking +z onto each unit ``direction`` (Rodrigues)."""
    d = direction / np.linalg.norm(direction, axis=1, keepdims=True)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, d)
    s = np.linalg.norm(axis, axis=1)
    c = d[:, 2]
    k = np.zeros((len(d), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = axis[:, 2], -axis[:, 1], axis[:, 0]
    eye = np.broadcast_to(np.eye(3), k.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(s > 1e-12, (1.0 - c) / np.maximum(s, 1e-300) ** 2, 0.0)
    rot = eye + k + (k @ k) * factor[:, None, None]
    flip = (s <= 1e-12) & (c < 0)  # pointing straight down: rotate pi about x
    rot[flip] = np.diag([1.0, -1.0, -1.0])
    return np.asarray(rot)


def _instances(
    verts: F64, faces: I64, scale: F64, rot: F64 | None, centre: F64, colors: F64
) -> TriMesh:
    """Template scaled per axis (scale [n,3]), rotated (rot [n,3,3] or None), translated."""
    n, v = len(centre), len(verts)
    if n == 0:
        return TriMesh.empty()
    local = verts[None, :, :] * scale[:, None, :]
    if rot is not None:
        local = np.einsum("nij,nvj->nvi", rot, local)
    world = (local + centre[:, None, :]).reshape(-1, 3)
    all_faces = (faces[None, :, :] + (np.arange(n) * v)[:, None, None]).reshape(-1, 3)
    return TriMesh(world, all_faces, np.repeat(colors, v, axis=0))


@dataclass(frozen=True)
class Instanced:
    """A template mesh (``verts`` [v,3], ``faces`` [f,3]) placed once per instance: scaled
    per axis (``scale`` [n,3]), rotated (``rot`` [n,3,3] or None), moved to ``centre``
    [n,3], in one colour each (``colors`` [n,3]). Its triangles are made a block of
    instances at a time (:meth:`vertex_blocks`, as :func:`_instances` makes them all), so a
    PLY export of 10^5 nodes never holds their spheres' 10^7 vertices; :meth:`mesh` makes
    them all."""

    verts: F64
    faces: I64
    scale: F64
    rot: F64 | None
    centre: F64
    colors: F64

    def counts(self) -> tuple[int, int, int]:
        """Vertices, faces and colours of every instance."""
        n = len(self.centre)
        return n * len(self.verts), n * len(self.faces), n * len(self.verts)

    def block(self, a: int, b: int) -> TriMesh:
        """Instances ``a .. b - 1``, their faces numbered as in the whole part."""
        rot = None if self.rot is None else self.rot[a:b]
        part = _instances(
            self.verts, self.faces, self.scale[a:b], rot, self.centre[a:b], self.colors[a:b]
        )
        return TriMesh(part.vertices, part.faces + a * len(self.verts), part.colors)

    def mesh(self) -> TriMesh:
        return self.block(0, len(self.centre))

    def _spans(self, rows: int, per: int) -> Iterator[tuple[int, int]]:
        step = max(1, rows // max(1, per))
        for a in range(0, len(self.centre), step):
            yield a, min(len(self.centre), a + step)

    def vertex_blocks(self, rows: int) -> Iterator[tuple[F64, F64]]:
        """(vertices, colours) of about ``rows`` vertices at a time."""
        for a, b in self._spans(rows, len(self.verts)):
            part = self.block(a, b)
            yield part.vertices, part.colors

    def face_blocks(self, rows: int) -> Iterator[I64]:
        """The faces of about ``rows`` faces' instances at a time."""
        v = len(self.verts)
        for a, b in self._spans(rows, len(self.faces)):
            offsets = (np.arange(a, b) * v)[:, None, None]
            yield (self.faces[None, :, :] + offsets).reshape(-1, 3)


def node_spheres(xyz: F64, radii: F64, colors: F64) -> Instanced:
    """One sphere per node."""
    verts, faces = _template("sphere")
    return Instanced(verts, faces, np.repeat(radii[:, None], 3, axis=1), None, xyz, colors)


def direction_arrows(
    xyz: F64, angle: F64, length: F64, width: float, colors: F64
) -> Instanced:
    """Horizontal arrows from each ``xyz`` along ``angle`` (rad); rows with NaN angle or zero
    length are skipped."""
    keep = np.isfinite(angle) & (length > 0)
    direction = np.stack([np.cos(angle[keep]), np.sin(angle[keep]), np.zeros(keep.sum())], 1)
    verts, faces = _template("arrow")
    scale = np.stack([np.full(keep.sum(), width), np.full(keep.sum(), width), length[keep]], 1)
    return Instanced(verts, faces, scale, _rotations_from_z(direction), xyz[keep], colors[keep])


def tubes(p0: F64, p1: F64, radius: float, color: tuple[float, float, float]) -> TriMesh:
    """A thin cylinder per segment (zero-length segments skipped)."""
    delta = p1 - p0
    length = np.linalg.norm(delta, axis=1)
    keep = length > 1e-12
    verts, faces = _template("tube")
    n = int(keep.sum())
    scale = np.stack([np.full(n, radius), np.full(n, radius), length[keep]], 1)
    centre = 0.5 * (p0[keep] + p1[keep])
    colors = np.tile(np.asarray(color, dtype=np.float64), (n, 1))
    return _instances(verts, faces, scale, _rotations_from_z(delta[keep]), centre, colors)


def cell_squares(xyz: F64, cell_size: float, colors: F64) -> TriMesh:
    """A flat δ×δ horizontal square (2 triangles) centred on each cell centre."""
    n = len(xyz)
    h = cell_size / 2.0
    corners = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    verts = (xyz[:, None, :] + corners[None, :, :]).reshape(-1, 3)
    quad = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    faces = (quad[None] + (np.arange(n) * 4)[:, None, None]).reshape(-1, 3)
    return TriMesh(verts, faces, np.repeat(colors, 4, axis=0))
