"""ROS message dicts (ROS 2 field naming, as :class:`formats.writers.LogWriter` takes them).

Detections of one sensor tick become one message of the selected type; TF ticks become one
``tf2_msgs/TFMessage`` with ``map→odom`` and ``odom→base_link``; scene-graph frames become full
``hydra_msgs/DsgUpdate`` messages (``full_update`` true, nothing in ``deleted_*``, like Hydra).
The arrays come in already transformed into the message frame; these functions only lay them out.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np

from aion_cli.engine.types import F64, I64
from aion_cli.errors import InputError

TRACKED_PERSONS = "spencer_tracking_msgs/msg/TrackedPersons"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
PEOPLE = "people_msgs/msg/People"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"

DETECTION_TYPES: dict[str, str] = {
    "tracked_persons": TRACKED_PERSONS,
    "pose_array": POSE_ARRAY,
    "people": PEOPLE,
}
DETECTION_TOPICS: dict[str, str] = {
    TRACKED_PERSONS: "/spencer/perception/tracked_persons",
    POSE_ARRAY: "/people_tracker/pose_array",
    PEOPLE: "/people",
}
UNKNOWN_COV = 99999.0  # spencer convention: components with a larger variance are not set

Message = dict[str, Any]


def detection_msgtype(name: str) -> str:
    """Normalise a --detection-type value (short alias or full type name) to a message type."""
    key = name.strip()
    if key in DETECTION_TYPES:
        return DETECTION_TYPES[key]
    full = key.replace("/msg/", "/").replace("/", "/msg/", 1)
    if full in DETECTION_TOPICS:
        return full
    choices = ", ".join([*DETECTION_TYPES, *DETECTION_TOPICS])
    raise InputError(f"unsupported detection type {name!r}", hint=f"use one of: {choices}")


def header(t_ns: int, frame: str) -> Message:
    """std_msgs/Header in ROS 2 naming."""
    return {
        "stamp": {"sec": t_ns // 1_000_000_000, "nanosec": t_ns % 1_000_000_000},
        "frame_id": frame,
    }


def _point(p: F64) -> Message:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _quat(yaw: float) -> Message:
    return {"x": 0.0, "y": 0.0, "z": float(np.sin(yaw / 2)), "w": float(np.cos(yaw / 2))}


@cache
def _covariance(position_var: float, rotation_var: float) -> F64:
    """A 6×6 diagonal covariance (row-major, 36 values); cached: every track shares it."""
    cov = np.zeros((6, 6))
    cov[np.arange(3), np.arange(3)] = position_var
    cov[np.arange(3, 6), np.arange(3, 6)] = rotation_var
    flat = cov.ravel()
    flat.flags.writeable = False
    return flat


def detection_message(
    msgtype: str,
    t_ns: int,
    frame: str,
    xyz: F64,
    velocity: F64,
    track_id: I64,
    age_ns: I64,
    first_detection_id: int,
    noise: float,
) -> Message:
    """One detection message with rows ``xyz[i]``, ``velocity[i]`` in ``frame``."""
    yaw = np.arctan2(velocity[:, 1], velocity[:, 0])
    hdr = header(t_ns, frame)
    if msgtype == POSE_ARRAY:
        return {
            "header": hdr,
            "poses": [
                {"position": _point(p), "orientation": _quat(y)}
                for p, y in zip(xyz, yaw, strict=True)
            ],
        }
    if msgtype == PEOPLE:
        return {
            "header": hdr,
            "people": [
                {
                    "name": str(int(k)),
                    "position": _point(p),
                    "velocity": _point(v),
                    "reliability": 1.0,
                    "tagnames": [],
                    "tags": [],
                }
                for p, v, k in zip(xyz, velocity, track_id, strict=True)
            ],
        }
    pose_cov = _covariance(max(noise, 0.01) ** 2, 0.1)
    twist_cov = _covariance(0.05**2, UNKNOWN_COV * 10)
    return {
        "header": hdr,
        "tracks": [
            {
                "track_id": int(k),
                "is_occluded": False,
                "is_matched": True,
                "detection_id": first_detection_id + i,
                "age": {"sec": int(a) // 1_000_000_000, "nanosec": int(a) % 1_000_000_000},
                "pose": {
                    "pose": {"position": _point(p), "orientation": _quat(y)},
                    "covariance": pose_cov,
                },
                "twist": {
                    "twist": {"linear": _point(v), "angular": _point(np.zeros(3))},
                    "covariance": twist_cov,
                },
            }
            for i, (p, v, k, a, y) in enumerate(
                zip(xyz, velocity, track_id, age_ns, yaw, strict=True)
            )
        ],
    }


def _transform(t_ns: int, parent: str, child: str, pose: F64) -> Message:
    return {
        "header": header(t_ns, parent),
        "child_frame_id": child,
        "transform": {
            "translation": {"x": float(pose[0]), "y": float(pose[1]), "z": 0.0},
            "rotation": _quat(float(pose[2])),
        },
    }


def tf_message(t_ns: int, map_odom: F64, odom_base: F64) -> Message:
    """/tf with map→odom (loop-closure correction) and odom→base_link (drifting odometry)."""
    return {
        "transforms": [
            _transform(t_ns, "map", "odom", map_odom),
            _transform(t_ns, "odom", "base_link", odom_base),
        ]
    }


def dsg_message(t_ns: int, payload: bytes, sequence: int) -> Message:
    """A full Hydra scene-graph update."""
    return {
        "header": header(t_ns, "map"),
        "layer_contents": payload,
        "deleted_nodes": [],
        "deleted_edges": [],
        "full_update": True,
        "sequence_number": sequence,
    }
