"""Logs whose schemas carry message definitions aion does not ship (no tests here).

:class:`OwnTypes` is a rosbags typestore with some types (re)defined from ``.msg`` texts --
the foxy-era ``vision_msgs``, a tracker's own agent array -- that builds messages, serializes
them and renders the full definition text (main type plus ``MSG:`` blocks) the way ROS
recorders embed it. :func:`write_mcap` writes such messages into an MCAP with the ``mcap``
library (the one :class:`formats.writers.LogWriter` writes with), each channel's schema being
that definition text, so the log's own definitions differ from aion's shipped ones.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: vision_msgs 2.x (ROS 2 foxy): string class ``id`` in the results, the source cloud and a
#: ``tracking_id`` in each detection (galactic and later differ: aion ships those).
FOXY_VISION_MSGS = {
    "vision_msgs/msg/ObjectHypothesisWithPose": (
        "# An object hypothesis that contains position information.\n"
        "string id\nfloat64 score\ngeometry_msgs/PoseWithCovariance pose\n"
    ),
    "vision_msgs/msg/BoundingBox3D": "geometry_msgs/Pose center\ngeometry_msgs/Vector3 size\n",
    "vision_msgs/msg/Detection3D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n"
        "vision_msgs/BoundingBox3D bbox\nsensor_msgs/PointCloud2 source_cloud\n"
        "bool is_tracking\n# ID used for consistency across multiple detection messages.\n"
        "string tracking_id\n"
    ),
    "vision_msgs/msg/Detection3DArray": (
        "std_msgs/Header header\nvision_msgs/Detection3D[] detections\n"
    ),
}
DETECTION3D_ARRAY = "vision_msgs/msg/Detection3DArray"


class OwnTypes:
    """A ROS 2 typestore (humble base) with ``definitions`` (type name -> ``.msg`` text)."""

    def __init__(self, definitions: dict[str, str]) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore
        from rosbags.typesys.store import Typestore

        types: dict[str, Any] = dict(get_typestore(Stores.ROS2_HUMBLE).fielddefs)
        for name, text in definitions.items():  # (re)definitions replace the standard ones
            types.update(get_types_from_msg(text, name))
        self.store = Typestore()
        self.store.register(types)
        self.T = self.store.types

    def definition(self, msgtype: str) -> str:
        """The full definition text a recorder embeds (``MSG:`` blocks for dependencies)."""
        text, _ = self.store.generate_msgdef(msgtype, ros_version=2)
        return str(text)

    def cdr(self, msg: Any, msgtype: str) -> bytes:
        return bytes(self.store.serialize_cdr(msg, msgtype))

    # -- common sub-messages --------------------------------------------------------------
    def header(self, t_ns: int, frame: str) -> Any:
        sec, nanosec = divmod(int(t_ns), 1_000_000_000)
        T = self.T
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame
        )

    def pose(self, x: float, y: float, z: float = 0.0, q: tuple[float, ...] = (0, 0, 0, 1)) -> Any:
        T = self.T
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=float(z)),
            orientation=T["geometry_msgs/msg/Quaternion"](
                x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
            ),
        )


def foxy_detection3d_array(
    own: OwnTypes, t_ns: int, frame: str, people: Iterable[tuple[str, str, float, float]]
) -> Any:
    """A foxy Detection3DArray: one detection per ``(class id, tracking id, x, y)``."""
    T = own.T
    hdr = own.header(t_ns, frame)
    cloud = T["sensor_msgs/msg/PointCloud2"](
        header=hdr, height=0, width=0, fields=[], is_bigendian=False, point_step=0,
        row_step=0, data=np.zeros(0, np.uint8), is_dense=True,
    )  # fmt: skip
    dets = []
    for cls, track, x, y in people:
        p = own.pose(x, y)
        pwc = T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36))
        dets.append(
            T["vision_msgs/msg/Detection3D"](
                header=own.header(0, ""),
                results=[
                    T["vision_msgs/msg/ObjectHypothesisWithPose"](id=cls, score=0.9, pose=pwc)
                ],
                bbox=T["vision_msgs/msg/BoundingBox3D"](
                    center=p, size=T["geometry_msgs/msg/Vector3"](x=0.5, y=0.5, z=1.8)
                ),
                source_cloud=cloud, is_tracking=True, tracking_id=track,
            )
        )  # fmt: skip
    return T[DETECTION3D_ARRAY](header=hdr, detections=dets)


@dataclass(frozen=True)
class Message:
    """One message to write: topic, type, serialized CDR payload, log time."""

    topic: str
    msgtype: str
    data: bytes
    t_ns: int


def write_mcap(path: Path, messages: Iterable[Message], definitions: dict[str, str]) -> Path:
    """An MCAP (ROS 2 profile, CDR) of ``messages``; the schema of each type is its text in
    ``definitions`` (type -> full definition), else aion's shipped definition."""
    from mcap.writer import CompressionType, Writer

    from aion_cli.formats import msgdefs

    with path.open("wb") as f:
        writer = Writer(f, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="aion tests")
        schemas: dict[str, int] = {}
        channels: dict[tuple[str, str], int] = {}
        for m in messages:
            if m.msgtype not in schemas:
                text = definitions.get(m.msgtype) or msgdefs.definition(m.msgtype, 2)
                schemas[m.msgtype] = writer.register_schema(m.msgtype, "ros2msg", text.encode())
            key = (m.topic, m.msgtype)
            if key not in channels:
                channels[key] = writer.register_channel(m.topic, "cdr", schemas[m.msgtype])
            writer.add_message(channels[key], m.t_ns, m.data, m.t_ns)
        writer.finish()
    return path
