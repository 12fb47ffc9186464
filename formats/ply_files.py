"""Binary PLY scene files written with numpy, byte for byte as open3d writes them (and
:func:`formats.scene_files.seal` marks them) but for open3d's ``comment Created by Open3D``
header line, which these files would carry falsely, a block of rows at a time.

open3d took a PLY part as its own copy of the arrays (``Vector3dVector``), wrote it, and
:func:`~formats.scene_files.seal` read the file back to check its size and copy it again
with aion's marker; ``scene.ply`` first concatenated every part into one more copy. For a
scene of 94 k places that peaked at 4.85 GB. Here a file is written once from the parts'
own arrays: its header (open3d's lines with aion's marker after the ``format`` line), then
each part's rows packed into a numpy record block and written (:data:`ROWS` rows at a
time), the parts of ``scene.ply`` one after the other with their faces offset as
``TriMesh.concat`` offsets them. Python's writes raise on a full disk, which open3d's did
not: no size check is needed.

Layouts (open3d 0.17+, ``write_ascii=False``): triangle mesh ``element vertex`` (double x,
y, z and, when every vertex has a colour, uchar red, green, blue) and ``element face``
(``list uchar uint``); line set ``element vertex`` (double x, y, z) and ``element edge``
(int vertex1, vertex2, uchar red, green, blue). A colour byte is ``round(c * 255)``, halves
up, of the colour clipped to 0..1, as open3d rounds. ``tests/cli/test_ply_files.py``
compares these files with open3d's.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO, Protocol

import numpy as np
import numpy.typing as npt

from aion_cli.formats.scene_files import PLY_MARKER, header_comments, writing

F64 = npt.NDArray[np.float64]

ROWS = 1 << 16
"""Rows packed and written at a time (a few MB per block)."""

_HEAD = b"ply\nformat binary_little_endian 1.0\n" + PLY_MARKER
_XYZ = b"property double x\nproperty double y\nproperty double z\n"
_RGB = b"property uchar red\nproperty uchar green\nproperty uchar blue\n"
_XYZ_T = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
_RGB_T = [("red", "u1"), ("green", "u1"), ("blue", "u1")]
_FACE_T = np.dtype([("n", "u1"), ("a", "<u4"), ("b", "<u4"), ("c", "<u4")])
_EDGE_T = np.dtype([("a", "<i4"), ("b", "<i4"), *_RGB_T])


class MeshPart(Protocol):
    """A triangle mesh written a block at a time: ``formats.export.TriMesh`` (its arrays
    sliced) or ``Instanced`` (a template's instances made per block)."""

    def counts(self) -> tuple[int, int, int]: ...
    def vertex_blocks(self, rows: int) -> Iterator[tuple[F64, F64]]: ...
    def face_blocks(self, rows: int) -> Iterator[npt.NDArray[np.int64]]: ...


def colour_bytes(colors: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """open3d's colour bytes: each channel clipped to 0..1, times 255, rounded half up."""
    scaled = np.clip(np.asarray(colors, dtype=np.float64), 0.0, 1.0) * 255.0
    return np.floor(scaled + 0.5).astype(np.uint8)


def write_mesh(path: Path, parts: Sequence[MeshPart], about: Sequence[str] = ()) -> Path:
    """The triangle mesh of ``parts`` concatenated (those without vertices left out, faces
    offset by the vertices before them) as the PLY file ``path``: what open3d wrote for
    ``TriMesh.concat(parts)``, marked (with the comments ``about`` after the marker, as
    ``scene_files.seal`` writes them). Colours are written when the parts hold as many
    colours as vertices in all, as open3d's mesh then had them."""
    parts = [p for p in parts if p.counts()[0]]
    counts = [p.counts() for p in parts]
    vertices = sum(c[0] for c in counts)
    coloured = sum(c[2] for c in counts) == vertices
    header = (
        _HEAD
        + header_comments(about, ply=True)
        + b"element vertex %d\n" % vertices
        + _XYZ
        + (_RGB if coloured else b"")
        + b"element face %d\n" % sum(c[1] for c in counts)
        + b"property list uchar uint vertex_indices\nend_header\n"
    )
    vertex_t = np.dtype(_XYZ_T + (_RGB_T if coloured else []))
    with writing(path) as fh:
        fh.write(header)
        for part in parts:
            for xyz, colors in part.vertex_blocks(ROWS):
                _write_vertices(fh, vertex_t, xyz, colors if coloured else None)
        offset = 0
        for part, (count, _, _) in zip(parts, counts, strict=True):
            for faces in part.face_blocks(ROWS):
                block = np.asarray(faces, dtype=np.int64) + offset
                rows = np.empty(len(block), _FACE_T)
                rows["n"] = 3
                rows["a"], rows["b"], rows["c"] = block.T.astype(np.int32).astype(np.uint32)
                fh.write(rows.tobytes())
            offset += count
    return path


def write_lines(
    path: Path,
    points: F64,
    lines: npt.ArrayLike,
    color: tuple[float, float, float],
    about: Sequence[str] = (),
) -> Path:
    """The line set of ``points`` and ``lines`` (index pairs), every line ``color``, as the
    PLY file ``path``: what open3d's ``write_line_set`` wrote, marked (and ``about``, as
    :func:`write_mesh`)."""
    pairs = np.asarray(lines, dtype=np.int64).reshape(-1, 2)
    header = (
        _HEAD
        + header_comments(about, ply=True)
        + b"element vertex %d\n" % len(points)
        + _XYZ
        + b"element edge %d\n" % len(pairs)
        + b"property int vertex1\nproperty int vertex2\n"
        + _RGB
        + b"end_header\n"
    )
    rgb = colour_bytes(np.asarray(color, dtype=np.float64).reshape(1, 3))[0]
    with writing(path) as fh:
        fh.write(header)
        _write_vertices(fh, np.dtype(_XYZ_T), points, None)
        for a in range(0, len(pairs), ROWS):
            block = pairs[a : a + ROWS].astype(np.int32)
            rows = np.empty(len(block), _EDGE_T)
            rows["a"], rows["b"] = block[:, 0], block[:, 1]
            rows["red"], rows["green"], rows["blue"] = rgb
            fh.write(rows.tobytes())
    return path


def _write_vertices(fh: BinaryIO, dtype: np.dtype, xyz: F64, colors: F64 | None) -> None:
    for a in range(0, len(xyz), ROWS):
        block = np.asarray(xyz[a : a + ROWS], dtype=np.float64)
        rows = np.empty(len(block), dtype)
        rows["x"], rows["y"], rows["z"] = block[:, 0], block[:, 1], block[:, 2]
        if colors is not None:
            rgb = colour_bytes(colors[a : a + ROWS])
            rows["red"], rows["green"], rows["blue"] = rgb[:, 0], rgb[:, 1], rgb[:, 2]
        fh.write(rows.tobytes())
