"""ROS messages for the decoder tests (detections, TF, scene-graph updates): built from dicts
with ``formats.writers.to_message``, serialized with rosbags into RawMessages, and rosbags' own
deserialization of them as the independent reference."""

from __future__ import annotations

from typing import Any

from aion_cli.formats import msgdefs
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.writers import to_message


def serialize(msgtype: str, message: dict[str, Any], ros: int, little_endian: bool = True) -> bytes:
    """Wire bytes of ``message`` (ROS 2 naming dict) as rosbags serializes it."""
    store = msgdefs.typestore(1 if ros == 1 else 2)
    obj = to_message(msgtype, message, ros)
    if ros == 1:
        return bytes(store.serialize_ros1(obj, msgtype))
    return bytes(store.serialize_cdr(obj, msgtype, little_endian=little_endian))


def raw(
    msgtype: str, message: dict[str, Any], ros: int, log_time_ns: int = 0, topic: str = "/t"
) -> RawMessage:
    """``message`` serialized as a RawMessage on ``topic`` (ROS 1 or little-endian CDR)."""
    return RawMessage(
        topic, msgtype, log_time_ns, serialize(msgtype, message, ros), "ros1" if ros == 1 else "cdr"
    )


def reference(m: RawMessage) -> Any:
    """rosbags' own deserialization of a raw message (the independent reference)."""
    store = msgdefs.typestore(1 if m.encoding == "ros1" else 2)
    if m.encoding == "ros1":
        return store.deserialize_ros1(m.data, m.msgtype)
    return store.deserialize_cdr(m.data, m.msgtype)


def header(sec: int, nanosec: int, frame: str) -> dict[str, Any]:
    """A ``std_msgs/Header`` dict stamped ``sec.nanosec`` in ``frame``."""
    return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame}


def pose(x: float, y: float, z: float, q: tuple[float, float, float, float]) -> dict[str, Any]:
    """A ``geometry_msgs/Pose`` dict at ``(x, y, z)`` with the quaternion ``q`` (x, y, z, w)."""
    return {
        "position": {"x": x, "y": y, "z": z},
        "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
    }
