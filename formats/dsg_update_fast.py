"""A ``hydra_msgs/DsgUpdate``'s header stamp and ``layer_contents`` read straight from its
serialized bytes: no generic deserialisation, the payload a zero-copy view of the message.

Why: a used scene graph needs only those two fields, and decoding the whole message with
rosbags (``LogSet.decode``) costs its own pass over it. The layout, ROS 1 and ROS 2 alike::

    std_msgs/Header header   ROS 1: uint32 seq, time stamp (uint32 sec, nsec), frame_id
                             ROS 2: int32 sec, uint32 nanosec, string frame_id
    uint8[] layer_contents
    uint64[] deleted_nodes
    uint64[] deleted_edges
    bool full_update
    int64 sequence_number

ROS 1 serialisation is packed little-endian with uint32 lengths; CDR (ROS 2) has a 4-byte
encapsulation header, aligns each primitive to its size relative to the payload start
(a sequence's elements only when it has any, as rosbags reads it) and counts a string's NUL.
The whole message is checked the way rosbags checks it (lengths within the message, the
frame id UTF-8 and, in CDR, NUL-terminated, the message consumed exactly in ROS 1 and up to
3 bytes of padding in CDR), so a message either gives what rosbags gives or None: big-endian
CDR and every malformed message go to the generic decoder, which reads or refuses them as
before. The log's own definition of the type must have this layout
(:func:`layout_matches`, like :func:`formats.tf_fast.layout_matches` for TF).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from aion_cli.formats.raw import RawMessage, from_recording, normalize_msgtype

#: The message type this module reads (normalised spelling).
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"


@dataclass(frozen=True)
class DsgUpdateFields:
    """What a build reads of a DsgUpdate: the header stamp, the payload (a view of the
    message's own bytes), ``full_update`` (whether the payload is the whole graph) and the
    header's ``frame_id`` (the frame of the graph's positions; empty from Hydra's ROS 1
    sender)."""

    sec: int
    nanosec: int
    payload: memoryview
    full_update: bool = True
    frame_id: str = ""


@dataclass(frozen=True)
class FieldsRead(RawMessage):
    """A DsgUpdate message with the fields :func:`update_fields` read of it, which it then
    gives without reading the message again: the build's stream passes it on from the check
    of a used graph (whole or partial update, ``aion_cli.graph_thin``) to the graph's
    decoding, so that a message the generic decoder reads (a whole rosbags deserialisation)
    is read once."""

    fields: DsgUpdateFields

    @classmethod
    def of(cls, msg: RawMessage, fields: DsgUpdateFields) -> FieldsRead:
        """``msg`` with ``fields``, what :func:`update_fields` read of it, of ``msg``'s
        recording (:attr:`RawMessage.recording`: whose graph it is, for the union of one
        session's graphs that robots log at once, :mod:`aion_cli.session_graphs`)."""
        out = cls(msg.topic, msg.msgtype, msg.log_time_ns, msg.data, msg.encoding, fields)
        if msg.recording:
            from_recording(out, msg.recording)  # in place
        return out


def _u32(data: memoryview, p: int) -> int:
    if p + 4 > len(data):
        raise ValueError("cut short")
    return int.from_bytes(data[p : p + 4], "little")


def _string(data: memoryview, p: int, cdr: bool) -> tuple[str, int]:
    """The string whose length field is at ``p`` (its text must be UTF-8) and its end."""
    n = _u32(data, p)
    end = p + 4 + n
    if end > len(data) or (cdr and (n < 1 or data[end - 1] != 0)):
        raise ValueError("bad string")
    return bytes(data[p + 4 : end - 1 if cdr else end]).decode("utf-8"), end


def _ros1(data: memoryview) -> DsgUpdateFields:
    if len(data) < 12:
        raise ValueError("cut short")
    sec = _u32(data, 4)  # ROS 1 time: unsigned seconds, to 2106
    nanosec = _u32(data, 8)
    frame, p = _string(data, 12, cdr=False)
    n = _u32(data, p)
    start, p = p + 4, p + 4 + n
    if p > len(data):
        raise ValueError("cut short")
    for _ in range(2):  # deleted_nodes, deleted_edges
        p = p + 4 + 8 * _u32(data, p)
    if p + 9 != len(data):  # full_update, sequence_number
        raise ValueError("size mismatch")
    return DsgUpdateFields(sec, nanosec, data[start : start + n], data[p] != 0, frame)


def _cdr(data: memoryview) -> DsgUpdateFields:
    if bytes(data[:2]) != b"\x00\x01":  # little-endian CDR only (big-endian: rosbags)
        raise ValueError("not little-endian CDR")
    body = data[4:]
    if len(body) < 12:
        raise ValueError("cut short")
    sec = int.from_bytes(body[0:4], "little", signed=True)
    nanosec = _u32(body, 4)
    frame, p = _string(body, 8, cdr=True)
    p = (p + 3) & -4
    n = _u32(body, p)
    start, p = p + 4, p + 4 + n
    if p > len(body):
        raise ValueError("cut short")
    for _ in range(2):  # deleted_nodes, deleted_edges
        p = (p + 3) & -4
        count = _u32(body, p)
        p += 4
        if count:
            p = ((p + 7) & -8) + 8 * count
    full = p
    p += 1  # full_update
    p = ((p + 7) & -8) + 8  # sequence_number
    if p > len(body) or len(body) - p > 3:
        raise ValueError("size mismatch")
    return DsgUpdateFields(sec, nanosec, body[start : start + n], body[full] != 0, frame)


def read_dsg_update(data: bytes | memoryview, encoding: str) -> DsgUpdateFields | None:
    """The stamp and payload of one serialized DsgUpdate (``encoding`` ``"ros1"`` or
    ``"cdr"``), or None when the generic decoder must read it (see the module docstring)."""
    view = memoryview(data).cast("B") if not isinstance(data, bytes) else memoryview(data)
    try:
        return _ros1(view) if encoding == "ros1" else _cdr(view)
    except (ValueError, UnicodeDecodeError):
        return None


def layout_matches(msgtype: str, encoding: str, definition: str, idl: bool = False) -> bool:
    """Whether a log's ``definition`` of ``msgtype`` is the DsgUpdate layout this module reads
    (an empty definition, a log embedding none, counts as that layout)."""
    from aion_cli.formats import msg_layouts

    if normalize_msgtype(msgtype) != DSG_UPDATE:
        return False
    ros_version = 1 if encoding == "ros1" else 2
    return msg_layouts.same_layout(definition, DSG_UPDATE, ros_version, idl)


def update_fields(
    logset: Any, msg: Any, layouts: dict[tuple[str, str, str], bool]
) -> DsgUpdateFields:
    """A DsgUpdate message's stamp, payload and ``full_update``, read straight from its bytes
    (:func:`read_dsg_update`) where the log defines the type in that layout (checked once per
    (topic, type, encoding) and kept in ``layouts``), else by the log's generic decoder
    (``logset.decode``), which also reads the messages the fast reader declines. A
    :class:`FieldsRead` message gives the fields read before."""
    import numpy as np

    if isinstance(msg, FieldsRead):  # read already, on its way through the stream
        return msg.fields
    key = (msg.topic, msg.msgtype, msg.encoding)
    fast = layouts.get(key)
    if fast is None:
        fast = layouts[key] = layout_matches(msg.msgtype, msg.encoding, *logset.definition(*key))
    fields = read_dsg_update(msg.data, msg.encoding) if fast else None
    if fields is not None:
        return fields
    decoded = logset.decode(msg)
    payload = np.ascontiguousarray(decoded.layer_contents, dtype=np.uint8).data
    stamp = decoded.header.stamp
    full = bool(getattr(decoded, "full_update", True))
    frame = getattr(decoded.header, "frame_id", "")
    return DsgUpdateFields(
        int(stamp.sec), int(stamp.nanosec), payload, full, frame if isinstance(frame, str) else ""
    )
