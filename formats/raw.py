"""Raw log records shared by the log readers and the message adapters."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Encoding = Literal["cdr", "ros1"]


def normalize_msgtype(msgtype: str) -> str:
    """``pkg/msg/Type`` for every spelling (``pkg/Type``, ``pkg/msg/Type``)."""
    parts = msgtype.strip().strip("/").split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return "/".join(parts)


def normalize_frame(frame_id: str) -> str:
    """Frame ids without the leading slash ROS 1 tools sometimes add."""
    return frame_id.lstrip("/")


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a log: normalised type, message count, wire encoding, definition text."""

    topic: str
    msgtype: str
    count: int
    encoding: Encoding
    definition: str = ""
    source: str = ""


@dataclass(frozen=True)
class RawMessage:
    """One serialized message. ``data`` is the wire payload: CDR with its 4-byte encapsulation
    header for ROS 2, plain ROS 1 serialization for ROS 1."""

    topic: str
    msgtype: str
    log_time_ns: int
    data: bytes
    encoding: Encoding
