"""The scene as ``visualization_msgs/msg/MarkerArray`` (and ``/tf_static``) in ROS 2 CDR, for
RViz users of ``aion export --format mcap`` (:mod:`formats.scene_mcap` writes them).

The markers of one step (see :mod:`formats.scene_mcap`): ``DELETEALL`` first, then namespace
``nodes`` (a ``SPHERE`` per node, diameter ``2r``, ``text`` = its entry id), ``arrows``
(an ``ARROW`` per node with a direction: length, shaft and head diameters in ``scale``; in a
scene without nodes, a map of hash cells only, one per cell with flow and a direction instead,
id the node count plus the cell's index, ``text`` its cell id),
``cells`` (one ``CUBE_LIST``), ``edges`` (``LINE_LIST``), ``mesh`` (``TRIANGLE_LIST``, one
point and colour per triangle corner) and ``path`` (``LINE_STRIP``). A node's marker id is its
index in the scene, the same at every step of a file.

The bytes are written here rather than through rosbags' message objects: a scene of 10^4
nodes and a mesh of 10^5 triangles would be 10^6 small objects per step. Point and colour
lists are written straight from numpy arrays; the layout is plain little-endian CDR (4-byte
encapsulation header, every field aligned to its size counted from after the header), field
order as in the ROS 2 Humble definitions of :mod:`formats.msgdefs` (the tests compare the
bytes with rosbags' serializer and decode them with mcap-ros2).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.formats.scene_colours import EDGE_GREY, PATH_GREEN
from aion_cli.formats.scene_style import SceneStyle

FRAME = "map"
"""The frame of a map built without ``--map-frame``."""
WORLD = "world"
CELL_THICKNESS = 0.02  # x δ: the flat squares of the hash cells
EDGE_WIDTH = 0.06  # x δ, the PLY edge tubes' diameter
PATH_WIDTH = 0.24  # x δ, the PLY path tube's diameter

# visualization_msgs/Marker constants
ARROW, SPHERE, LINE_STRIP, LINE_LIST, CUBE_LIST, TRIANGLE_LIST = 0, 2, 4, 5, 6, 11
ADD, DELETEALL = 0, 3

_HEADER = b"\x00\x01\x00\x00"  # CDR, little endian
_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_KIND = struct.Struct("<iii")  # id, type, action
_POSE_SCALE = struct.Struct("<10d")  # position, orientation (x y z w), scale
_COLOR_LIFE = struct.Struct("<4fiI?")  # colour, lifetime, frame_locked
_IDENTITY = (0.0, 0.0, 0.0, 1.0)
_NO_COLOR = np.zeros((0, 4), np.float32)

Header = tuple[int, int, str]
"""A marker's ``std_msgs/Header``: stamp (seconds, nanoseconds) and frame."""


class _Cdr:
    """A CDR payload being written (offsets count from after the encapsulation header)."""

    __slots__ = ("buf",)

    def __init__(self) -> None:
        self.buf = bytearray()

    def align(self, size: int) -> None:
        pad = -len(self.buf) % size
        if pad:
            self.buf += bytes(pad)

    def u32(self, value: int) -> None:
        self.align(4)
        self.buf += _U32.pack(value)

    def packed(self, align: int, fmt: struct.Struct, *values: float | int | bool) -> None:
        self.align(align)
        self.buf += fmt.pack(*values)

    def string(self, text: str) -> None:
        data = text.encode()
        self.u32(len(data) + 1)
        self.buf += data
        self.buf += b"\x00"

    def array(self, values: npt.NDArray[np.generic], align: int) -> None:
        """A sequence of fixed-size elements (rows of ``values``, already of the wire type)."""
        self.u32(len(values))
        if len(values):
            self.align(align)
            self.buf += np.ascontiguousarray(values).tobytes()

    def payload(self) -> bytes:
        return _HEADER + bytes(self.buf)


def _rgba(rgb: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """float32 [n,4] colours, opaque, clipped to 0..1."""
    c = np.clip(np.asarray(rgb, dtype=np.float64).reshape(-1, 3), 0.0, 1.0)
    return np.concatenate([c, np.ones((len(c), 1))], axis=1).astype("<f4")


def _marker(
    out: _Cdr,
    header: Header,
    ns: str,
    marker_id: int,
    kind: int,
    pose: Sequence[float] = (0.0, 0.0, 0.0, *_IDENTITY),
    scale: Sequence[float] = (1.0, 1.0, 1.0),
    color: Sequence[float] = (1.0, 1.0, 1.0),
    points: npt.NDArray[np.float64] | None = None,
    colors: npt.NDArray[np.float32] = _NO_COLOR,
    text: str = "",
    action: int = ADD,
) -> None:
    """One ``visualization_msgs/Marker`` with ``header`` (its stamp and frame; no lifetime, not
    frame-locked)."""
    out.packed(4, _STAMP, *header[:2])
    out.string(header[2])
    out.string(ns)
    out.packed(4, _KIND, marker_id, kind, action)
    out.packed(8, _POSE_SCALE, *pose, *scale)
    out.packed(4, _COLOR_LIFE, *color, 1.0, 0, 0, False)
    out.array(np.zeros((0, 3), "<f8") if points is None else points.astype("<f8"), 8)
    out.array(colors, 4)
    out.string("")  # texture_resource
    out.packed(4, _STAMP, 0, 0)  # texture: sensor_msgs/CompressedImage (empty)
    out.string("")
    out.string("")  # its format
    out.u32(0)  # its data
    out.u32(0)  # uv_coordinates
    out.string(text)
    out.string("")  # mesh_resource
    out.string("")  # mesh_file.filename
    out.u32(0)  # mesh_file.data
    out.buf += b"\x00"  # mesh_use_embedded_materials


def _texted(
    out: _Cdr,
    header: Header,
    ns: str,
    kind: int,
    ids: Sequence[int],
    poses: Sequence[Sequence[float]],
    colors: Sequence[Sequence[float]],
    texts: Sequence[str],
) -> None:
    """:func:`_marker` of each (id, pose and scale, colour, text) in ``ns``, without points,
    written with a few byte operations per marker (a node scene writes 10^5 of them a step):
    every field but the id, pose, colour and text is the same in each, and where the padding
    falls depends only on the offset the marker starts at and the text's length."""
    if not ids:
        return
    probe = _Cdr()  # the fixed fields, from an 8-aligned start: [header .. ns] and [kind]
    probe.packed(4, _STAMP, *header[:2])
    probe.string(header[2])
    probe.string(ns)
    probe.align(4)
    head = bytes(probe.buf)
    mid = _Cdr()  # after the colour: from an 8-aligned offset + 25 to before the text
    mid.buf += bytes(1)
    mid.array(np.zeros((0, 3), "<f8"), 8)
    mid.array(_NO_COLOR, 4)
    mid.string("")
    mid.packed(4, _STAMP, 0, 0)
    mid.string("")
    mid.string("")
    mid.u32(0)
    mid.u32(0)
    middle = bytes(mid.buf[1:])
    tail_of = [b"", b"", b"", b""]  # by the text's end offset mod 4
    for r in range(4):
        t = _Cdr()
        t.buf += bytes(r)
        t.string("")
        t.string("")
        t.u32(0)
        t.buf += b"\x00"
        tail_of[r] = bytes(t.buf[r:])
    kind_at = len(head)
    pose_fmt = _POSE_SCALE.pack
    colour_fmt = _COLOR_LIFE.pack
    kind_fmt = _KIND.pack
    buf = out.buf
    for marker_id, pose, color, text in zip(ids, poses, colors, texts, strict=True):
        pad = -len(buf) % 4
        if pad:
            buf += bytes(pad)
        start = len(buf)
        buf += head
        buf += kind_fmt(marker_id, kind, ADD)
        pad = -(start + kind_at + 12) % 8
        if pad:
            buf += bytes(pad)
        buf += pose_fmt(*pose)
        buf += colour_fmt(*color, 1.0, 0, 0, False)
        buf += middle
        data = text.encode()
        buf += _U32.pack(len(data) + 1)
        buf += data
        buf += b"\x00"
        buf += tail_of[len(buf) % 4]


def _yaw(angle: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Quaternions (x, y, z, w) [n,4] of rotations by ``angle`` about +z."""
    q = np.zeros((len(angle), 4))
    q[:, 2], q[:, 3] = np.sin(angle / 2.0), np.cos(angle / 2.0)
    return q


def marker_array(
    t_ns: int,
    style: SceneStyle,
    node_ids: Sequence[str],
    cell_ids: Sequence[str],
    frame: str = FRAME,
) -> bytes:
    """The CDR payload of one step's ``MarkerArray`` (see the module docstring), its markers
    in ``frame`` (the map's frame)."""
    header: Header = (*divmod(int(t_ns), 1_000_000_000), frame)
    delta = style.cell_size
    arrows = np.flatnonzero(np.isfinite(style.arrow_angle) & (style.arrow_length > 0))
    # a scene without nodes: the cells carry the arrows, as the PLY's (none beside nodes)
    cell_arrows = np.flatnonzero(
        np.isfinite(style.cell_arrow_angle) & (style.cell_arrow_length > 0)
    )
    mesh = style.mesh
    widths = {
        "cells": (delta, delta, CELL_THICKNESS * delta),
        "edges": (EDGE_WIDTH * delta, 0.0, 0.0),
        "path": (PATH_WIDTH * delta, 0.0, 0.0),
    }
    path = style.path if len(style.path) >= 2 else style.path[:0]
    lists: list[tuple[str, int, Any, Any, Sequence[float]]] = [
        ("cells", CUBE_LIST, style.cells_xyz, _rgba(style.cell_colors), (1.0, 1.0, 1.0)),
        ("edges", LINE_LIST, style.edges.reshape(-1, 3), _NO_COLOR, EDGE_GREY),
        ("mesh", TRIANGLE_LIST, mesh.vertices[mesh.faces.reshape(-1)], None, (1.0, 1.0, 1.0)),
        ("path", LINE_STRIP, path, _NO_COLOR, PATH_GREEN),
    ]
    lists = [part for part in lists if len(part[2])]
    out = _Cdr()
    out.u32(1 + len(node_ids) + len(arrows) + len(cell_arrows) + len(lists))
    _marker(out, header, "", 0, ARROW, action=DELETEALL)
    centre = style.nodes_xyz.tolist()
    colors = style.colors.tolist()
    diameters = (2.0 * style.radii).tolist()
    _texted(
        out, header, "nodes", SPHERE, range(len(node_ids)),
        [(*centre[i], *_IDENTITY, d, d, d) for i, d in enumerate(diameters)], colors, node_ids,
    )
    width = style.arrow_width
    turn = _yaw(style.arrow_angle[arrows]).tolist()
    length = style.arrow_length[arrows].tolist()
    which = arrows.tolist()
    _texted(
        out, header, "arrows", ARROW, which,
        [(*centre[i], *turn[k], length[k], 2.0 * width, 4.0 * width) for k, i in enumerate(which)],
        [colors[i] for i in which], [node_ids[i] for i in which],
    )
    if len(cell_arrows):  # ids after the nodes' (a scene with cell arrows has no nodes)
        at = style.cells_xyz[cell_arrows].tolist()
        turn = _yaw(style.cell_arrow_angle[cell_arrows]).tolist()
        length = style.cell_arrow_length[cell_arrows].tolist()
        cells = cell_arrows.tolist()
        _texted(
            out, header, "arrows", ARROW, [len(node_ids) + i for i in cells],
            [(*at[k], *turn[k], length[k], 2.0 * width, 4.0 * width) for k in range(len(cells))],
            style.cell_colors[cell_arrows].tolist(), [cell_ids[i] for i in cells],
        )
    for ns, kind, points, rgba, color in lists:
        if rgba is None:  # the mesh: each triangle corner coloured as its vertex
            rgba = _rgba(mesh.colors)[mesh.faces.reshape(-1)]
        scale = widths.get(ns, (1.0, 1.0, 1.0))
        _marker(out, header, ns, 0, kind, scale=scale, color=color, points=points, colors=rgba)
    return out.payload()


def tf_static(t_ns: int, frame: str = FRAME) -> bytes:
    """The CDR payload of ``/tf_static``: one ``tf2_msgs/TFMessage`` with the identity
    transform ``world -> frame`` (the map's frame)."""
    out = _Cdr()
    out.u32(1)
    out.packed(4, _STAMP, *divmod(int(t_ns), 1_000_000_000))
    out.string(WORLD)
    out.string(frame)
    out.packed(8, struct.Struct("<7d"), 0.0, 0.0, 0.0, *_IDENTITY)
    return out.payload()
