"""A map's scenes over time as one MCAP file for Foxglove and RViz (``aion export --format mcap``).

One message per time step on each scene topic, logged at the step's time, so a viewer's
timeline scrubs through the day:

- ``/aion/scene``: ``foxglove.SceneUpdate`` (protobuf, the schema from
  ``foxglove_schemas_protobuf`` as a file descriptor set). One entity per entry whose id is
  the entry id of ``aion predict`` (``p12``, ``c<key>``): a node is one sphere (diameter
  ``2r``) plus an arrow along its dominant direction when it has flow, a hash cell one flat
  cube (δ × δ × 0.02·δ), plus in a scene without nodes (a map of hash cells only) an arrow
  like a node's when it has flow and a direction, as the PLY scene draws it; each carries
  ``kind``, ``flow``, ``entropy`` and ``direction_deg`` as metadata (the numbers in full, as
  ``aion predict --format json`` writes them; ``null`` for none). The entities
  ``aion/edges`` (line list), ``aion/mesh`` (triangle list, indexed) and ``aion/path`` (line
  strip) hold the rest. Every update starts with a deletion of all
  entities older than the step, so each message is the whole scene at its time.
- ``/aion/markers``: ``visualization_msgs/msg/MarkerArray`` (ROS 2 CDR) with the same content
  for RViz: a ``DELETEALL`` marker first, then namespace ``nodes`` (one ``SPHERE`` per node,
  ``text`` = the entry id), ``arrows`` (``ARROW``, the node's id; the cell's in a scene
  without nodes), ``cells`` (one ``CUBE_LIST``), ``edges`` (``LINE_LIST``), ``mesh``
  (``TRIANGLE_LIST``) and ``path`` (``LINE_STRIP``). A node's marker id is its position in
  the map's entry order, which is the same at every step of a file.
- ``/tf_static``: one ``tf2_msgs/msg/TFMessage``, the identity ``world -> map``, so RViz and
  Foxglove know the frame ``map`` every scene is drawn in (its channel carries rosbag2's
  latched QoS, for ``ros2 bag play``). ``map`` is the map's frame: a map built with
  ``--map-frame odom`` (or a laser's frame) holds positions in that frame, and its scenes
  and this transform name it, so the scene lies where a log's TF puts that frame.

Sizes and colours come from :class:`formats.scene_style.SceneStyle` (as for PLY); line widths
are the diameters of the PLY tubes. The file is written beside the target and renamed into
place when complete (:class:`formats.outputs.Staged`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

import numpy as np

from aion_cli.errors import InputError
from aion_cli.formats.export import ExportError, ExportWriteError
from aion_cli.formats.outputs import OutputPathError, Staged, check_output
from aion_cli.formats.scene_colours import EDGE_GREY, PATH_GREEN
from aion_cli.formats.scene_markers import (
    CELL_THICKNESS,
    EDGE_WIDTH,
    FRAME,
    PATH_WIDTH,
    marker_array,
    tf_static,
)
from aion_cli.formats.scene_style import SceneStyle
from aion_cli.formats.writers import max_stamp_ns

SCENE_TOPIC = "/aion/scene"
MARKER_TOPIC = "/aion/markers"
TF_STATIC_TOPIC = "/tf_static"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
MCAP_MAGIC = b"\x89MCAP0\r\n"
_NO_LIMIT = "\n    sec: 0\n    nsec: 0"
LATCHED_QOS = (
    "- history: 1\n  depth: 1\n  reliability: 1\n  durability: 1\n"
    f"  deadline:{_NO_LIMIT}\n  lifespan:{_NO_LIMIT}\n  liveliness: 1\n"
    f"  liveliness_lease_duration:{_NO_LIMIT}\n  avoid_ros_namespace_conventions: false\n"
)
"""rosbag2's QoS of ``/tf_static`` (keep last 1, reliable, transient local: latched), so a
``ros2 bag play`` of the file offers it as a static transform publisher does."""


LAST_STEP_NS = max_stamp_ns("mcap")
"""The last time a step can be logged at: ``/aion/markers`` and ``/tf_static`` are ROS 2
messages, whose ``builtin_interfaces/Time`` holds signed 32-bit seconds (2038-01-19 03:14:07
UTC); an MCAP log time cannot be before 1970."""


class SceneTimeError(InputError):
    """A time an MCAP scene cannot log a step at (before 1970, after :data:`LAST_STEP_NS`)."""


def check_step_times(times_ns: Sequence[int]) -> None:
    """:class:`SceneTimeError` naming the first of ``times_ns`` (ns since 1970) a step cannot
    be logged at; checked for a whole series before any scene is computed."""
    from aion_cli.engine.time_text import utc_text

    for t_ns in times_ns:
        if 0 <= t_ns <= LAST_STEP_NS:
            continue
        raise SceneTimeError(
            f"cannot log a scene at {utc_text(t_ns)}: an MCAP scene's steps lie in 1970-01-01 .. "
            "2038-01-19 03:14:07 UTC (MCAP log times start in 1970, and its ROS 2 messages "
            "hold their time in 32-bit seconds)",
            hint="choose times in that span; png, ply, pcd and dsg exports take any time",
        )


def library_of(path: Path) -> tuple[str, str] | None:
    """(profile, library) of the MCAP file ``path``'s Header record, None when it is not an
    MCAP file or its header cannot be read (reads that record only, parsed as the log
    readers parse it: :func:`formats.mcap_linear._parse_record`)."""
    import struct

    from mcap.records import Header

    from aion_cli.formats.limits import ChunkError
    from aion_cli.formats.mcap_linear import _parse_record

    most = 16 * 1024  # a header is two short strings
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(MCAP_MAGIC) + 9)
            if not head.startswith(MCAP_MAGIC) or head[len(MCAP_MAGIC)] != 0x01:
                return None
            (length,) = struct.unpack_from("<Q", head, len(MCAP_MAGIC) + 1)
            if length > most:
                return None
            body = fh.read(length)
    except (OSError, IndexError, struct.error):
        return None
    if len(body) < length:
        return None
    try:
        record = _parse_record(Header, body)
    except ChunkError:
        return None
    return str(record.profile), str(record.library)


def is_scene_mcap(path: Path) -> bool:
    """Whether ``path`` is an MCAP file ``aion export`` wrote (no profile, library
    ``aion <version>``): a recorded log (profile ``ros2``...; ``aion convert``'s say library
    ``aion``) is never one."""
    header = library_of(path)
    return header is not None and header[0] == "" and header[1].startswith("aion ")


def check_scene_target(path: Path) -> None:
    """Refuse the output before anything is computed: a folder (the MCAP export writes one
    file), a name without ``.mcap``, a device, FIFO or socket, or an existing file that is not
    an MCAP file an export wrote (:func:`is_scene_mcap`; such a file is replaced, as a
    re-export replaces its PLY files; a recorded log never is). The messages name the output,
    not the option that gave it (``aion export -o``, ``Map.export``)."""
    if path.is_dir():
        raise OutputPathError(
            f"{path} is a folder: the MCAP scene export (format mcap) writes one file",
            hint=f"name the file, e.g. {path / 'scene.mcap'}",
        )
    if path.suffix.lower() != ".mcap":
        raise OutputPathError(
            f"the MCAP scene export (format mcap) writes an .mcap file, got {path.name!r}",
            hint="name the file, e.g. scene.mcap",
        )
    check_output(
        path, overwrite=True, recognise=is_scene_mcap, what="an MCAP scene", option=None
    )


class SceneMcapWriter:
    """Writes the scene MCAP file ``path`` (see the module docstring); a context manager: the
    file appears at ``path`` when the block ends without an exception, and not at all
    otherwise. ``metadata``: string pairs stored as the file's ``aion`` metadata record;
    ``frame``: the map's frame, which every entity and marker is in."""

    def __init__(self, path: Path, metadata: Mapping[str, str], frame: str = FRAME) -> None:
        from mcap.writer import CompressionType, Writer

        from aion_cli import __version__

        self.path = path
        self.frame = frame
        try:
            self._staged = Staged(path)
        except OSError as exc:
            raise _write_error(path, exc) from exc
        try:
            self._file: BinaryIO | None = self._staged.path.open("wb")
            self._writer = Writer(self._file, compression=CompressionType.ZSTD)
            self._writer.start(profile="", library=f"aion {__version__}")
            self._channels = self._register()
            self._writer.add_metadata("aion", dict(metadata))
        except BaseException as exc:
            self.abort()
            if isinstance(exc, OSError):
                raise _write_error(path, exc) from exc
            raise
        self.steps = 0

    def _register(self) -> dict[str, int]:
        from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
        from mcap_protobuf.schema import register_schema

        from aion_cli.formats import msgdefs

        channels = {
            SCENE_TOPIC: self._writer.register_channel(
                SCENE_TOPIC, "protobuf", register_schema(self._writer, SceneUpdate)
            )
        }
        for topic, msgtype in ((MARKER_TOPIC, MARKER_ARRAY), (TF_STATIC_TOPIC, TF_MESSAGE)):
            text = msgdefs.definition(msgtype, 2).encode()
            schema = self._writer.register_schema(msgtype, "ros2msg", text)
            latched = {"offered_qos_profiles": LATCHED_QOS} if topic == TF_STATIC_TOPIC else {}
            channels[topic] = self._writer.register_channel(topic, "cdr", schema, latched)
        return channels

    def write_step(
        self, t_ns: int, style: SceneStyle, node_ids: Sequence[str], cell_ids: Sequence[str]
    ) -> None:
        """The scene of one time step (``t_ns``: its log time, ns since 1970, increasing)."""
        if self._file is None:
            raise ExportWriteError(f"{self.path} is closed")
        check_step_times([t_ns])
        if len(node_ids) != len(style.nodes_xyz) or len(cell_ids) != len(style.cells_xyz):
            raise ExportError("write_step needs one id per node and per cell")  # a caller bug
        try:
            if self.steps == 0:
                self._add(TF_STATIC_TOPIC, t_ns, tf_static(t_ns, self.frame))
            scene = scene_update(t_ns, style, node_ids, cell_ids, self.frame)
            self._add(SCENE_TOPIC, t_ns, scene)
            markers = marker_array(t_ns, style, node_ids, cell_ids, self.frame)
            self._add(MARKER_TOPIC, t_ns, markers)
        except OSError as exc:
            raise _write_error(self.path, exc) from exc
        self.steps += 1

    def _add(self, topic: str, t_ns: int, data: bytes) -> None:
        self._writer.add_message(self._channels[topic], t_ns, data, t_ns, self.steps)

    def close(self) -> None:
        """Finish the file (summary and indexes) and move it into place."""
        if self._file is None:
            return
        file, self._file = self._file, None
        try:
            try:
                self._writer.finish()
            finally:
                file.close()
            self._staged.commit()
        except BaseException as exc:
            self._staged.discard()
            if isinstance(exc, OSError):
                raise _write_error(self.path, exc) from exc
            raise

    def abort(self) -> None:
        """Throw the partial file away (the target stays as it was). Idempotent."""
        file, self._file = getattr(self, "_file", None), None
        try:
            if file is not None:
                file.close()  # may fail again on a full disk
        finally:
            self._staged.discard()

    def __enter__(self) -> SceneMcapWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def _write_error(path: Path, exc: OSError) -> ExportWriteError:
    return ExportWriteError(
        f"cannot write {path}: {exc.strerror or exc}",
        hint="choose a writable folder with free space for -o",
    )


# -- foxglove.SceneUpdate ------------------------------------------------------------------


def _yaw(angle: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``angle`` about +z."""
    return 0.0, 0.0, math.sin(angle / 2.0), math.cos(angle / 2.0)


def _meta(value: float) -> str:
    """A metadata value: the float in full (the shortest text that reads back as exactly
    ``value``, as ``aion predict --format json`` writes it), ``null`` when not finite."""
    return repr(float(value)) if math.isfinite(value) else "null"


def _arrow(
    e: Any, at: Sequence[float], angle: float, length: float, width: float, color: Sequence[float]
) -> None:
    """Add to entity ``e`` an arrow from ``at`` along ``angle`` (rad about +z), ``length``
    long from its start, shaft ``width`` thick, as the PLY's arrows draw it."""
    a = e.arrows.add(
        shaft_length=0.75 * length,
        shaft_diameter=2.0 * width,
        head_length=0.25 * length,
        head_diameter=4.0 * width,
    )
    a.pose.position.x, a.pose.position.y, a.pose.position.z = at
    o = a.pose.orientation
    o.x, o.y, o.z, o.w = _yaw(angle)
    a.color.r, a.color.g, a.color.b = color
    a.color.a = 1.0


def scene_update(
    t_ns: int,
    style: SceneStyle,
    node_ids: Sequence[str],
    cell_ids: Sequence[str],
    frame: str = FRAME,
) -> bytes:
    """The serialized ``foxglove.SceneUpdate`` of one step (see the module docstring), its
    entities in ``frame`` (the map's frame)."""
    from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
    from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    update = SceneUpdate()
    sec, nanos = divmod(int(t_ns), 1_000_000_000)
    deletion = update.deletions.add(type=SceneEntityDeletion.ALL)
    deletion.timestamp.seconds, deletion.timestamp.nanos = sec, nanos
    delta = style.cell_size

    def entity(entity_id: str, meta: Sequence[tuple[str, str]]) -> Any:
        e = update.entities.add(id=entity_id, frame_id=frame)
        e.timestamp.seconds, e.timestamp.nanos = sec, nanos
        for key, value in meta:
            e.metadata.add(key=key, value=value)
        return e

    xyz, colors = style.nodes_xyz.tolist(), style.colors.tolist()
    diameters = (2.0 * style.radii).tolist()
    arrow = np.isfinite(style.arrow_angle) & (style.arrow_length > 0)
    angle_deg = np.degrees(style.angle).tolist()
    for i, node in enumerate(node_ids):
        e = entity(
            node,
            (
                ("kind", "node"),
                ("flow", _meta(float(style.node_flow[i]))),
                ("entropy", _meta(float(style.node_entropy[i]))),
                ("direction_deg", _meta(angle_deg[i])),
            ),
        )
        (x, y, z), (r, g, b), d = xyz[i], colors[i], diameters[i]
        s = e.spheres.add()
        s.pose.position.x, s.pose.position.y, s.pose.position.z = x, y, z
        s.pose.orientation.w = 1.0
        s.size.x = s.size.y = s.size.z = d
        s.color.r, s.color.g, s.color.b, s.color.a = r, g, b, 1.0
        if arrow[i]:
            angle, length = float(style.arrow_angle[i]), float(style.arrow_length[i])
            _arrow(e, xyz[i], angle, length, style.arrow_width, colors[i])
    c_xyz, c_colors = style.cells_xyz.tolist(), style.cell_colors.tolist()
    cell_deg = np.degrees(style.cells_angle).tolist()
    cell_arrow = np.isfinite(style.cell_arrow_angle) & (style.cell_arrow_length > 0)
    for i, cell in enumerate(cell_ids):
        e = entity(
            cell,
            (
                ("kind", "cell"),
                ("flow", _meta(float(style.cells_flow[i]))),
                ("entropy", _meta(float(style.cells_entropy[i]))),
                ("direction_deg", _meta(cell_deg[i])),
            ),
        )
        c = e.cubes.add()
        c.pose.position.x, c.pose.position.y, c.pose.position.z = c_xyz[i]
        c.pose.orientation.w = 1.0
        c.size.x, c.size.y, c.size.z = delta, delta, CELL_THICKNESS * delta
        c.color.r, c.color.g, c.color.b = c_colors[i]
        c.color.a = 1.0
        if cell_arrow[i]:  # a scene without nodes: the cells carry the arrows (as the PLY's)
            angle, length = float(style.cell_arrow_angle[i]), float(style.cell_arrow_length[i])
            _arrow(e, c_xyz[i], angle, length, style.arrow_width, c_colors[i])
    lines = (
        ("aion/edges", LinePrimitive.LINE_LIST, style.edges.reshape(-1, 3), EDGE_WIDTH, EDGE_GREY),
        ("aion/path", LinePrimitive.LINE_STRIP, style.path, PATH_WIDTH, PATH_GREEN),
    )
    for name, kind, points, width, color in lines:
        if len(points) < 2:
            continue
        line = entity(name, ()).lines.add(type=kind, thickness=width * delta)
        line.pose.orientation.w = 1.0
        line.color.r, line.color.g, line.color.b, line.color.a = (*color, 1.0)
        for x, y, z in points.tolist():
            line.points.add(x=x, y=y, z=z)
    mesh = style.mesh
    if len(mesh.faces):
        tri = entity("aion/mesh", ()).triangles.add()
        tri.pose.orientation.w = 1.0
        for x, y, z in mesh.vertices.tolist():
            tri.points.add(x=x, y=y, z=z)
        for r, g, b in np.clip(mesh.colors, 0.0, 1.0).tolist():
            tri.colors.add(r=r, g=g, b=b, a=1.0)
        tri.indices.extend(mesh.faces.reshape(-1).tolist())
    return bytes(update.SerializeToString())
