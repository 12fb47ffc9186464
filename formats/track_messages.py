"""Detection batches as the messages of a log: spencer ``TrackedPersons`` serialized with
numpy (every row's ``TrackedPerson`` record built at once as a structured array, CDR or ROS 1
layout) and ``geometry_msgs/PoseArray`` messages (numpy ``Pose`` records the same way, or
dicts for rosbags to serialize: the empty markers).
:mod:`formats.tracks_log` writes them into logs; ``formats.detections.fast`` reads the same
offsets back."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, BoolA, DetectionBatch

UNSET_VARIANCE = 1e6
"""Spencer's convention: a variance above 99999 marks a velocity / orientation as not set."""


def orientation_velocity(batch: DetectionBatch) -> tuple[F64, F64, BoolA, BoolA]:
    """Yaw quaternions (x, y, z, w) from the headings and planar velocities from heading and
    speed, with masks of which are known (unknown: identity / zero, flagged by the caller)."""
    known_h = np.isfinite(batch.heading)
    known_v = known_h & np.isfinite(batch.speed)
    h = np.where(known_h, batch.heading, 0.0)
    quat = np.zeros((len(batch), 4))
    quat[:, 2], quat[:, 3] = np.sin(h / 2), np.cos(h / 2)
    s = np.where(known_v, batch.speed, 0.0)
    vel = np.zeros((len(batch), 3))
    vel[:, 0], vel[:, 1] = s * np.cos(h), s * np.sin(h)
    return quat, vel, known_h, known_v


# spencer_tracking_msgs/TrackedPerson on the wire: uint64 track_id, bool is_occluded, bool
# is_matched, uint64 detection_id, duration age, PoseWithCovariance, TwistWithCovariance.
# CDR aligns the uint64s to 8 (record 712 bytes, a multiple of 8); ROS 1 packs (706 bytes).
# The same offsets are what formats.detections.fast reads.
_TP_NAMES = (
    "track_id",
    "is_occluded",
    "is_matched",
    "detection_id",
    "age_sec",
    "age_nsec",
    "pose",
    "pose_cov",
    "twist",
    "twist_cov",
)
_TP_LAYOUT = {
    True: ((0, 8, 9, 16, 24, 28, 32, 88, 376, 424), 712, "<u4"),
    False: ((0, 8, 9, 10, 18, 22, 26, 82, 370, 418), 706, "<i4"),
}
_CDR_LE = b"\x00\x01\x00\x00"  # CDR little-endian encapsulation header


def tracked_person_records(
    batch: DetectionBatch, cdr: bool, first_id: int = 0
) -> npt.NDArray[np.void]:
    """Every row's serialized TrackedPerson, built in one go as a structured array; detection
    ids count from ``first_id`` (the row's index in the whole log)."""
    offsets, itemsize, nsec_type = _TP_LAYOUT[cdr]
    formats = [
        "<u8",
        "u1",
        "u1",
        "<u8",
        "<i4",
        nsec_type,
        ("<f8", (7,)),
        ("<f8", (36,)),
        ("<f8", (6,)),
        ("<f8", (36,)),
    ]
    dtype = np.dtype(
        {"names": _TP_NAMES, "formats": formats, "offsets": offsets, "itemsize": itemsize}
    )
    quat, vel, known_h, known_v = orientation_velocity(batch)
    rec = np.zeros(len(batch), dtype=dtype)
    rec["track_id"] = batch.track_id.astype(np.uint64)
    rec["is_matched"] = 1
    rec["detection_id"] = np.arange(first_id, first_id + len(batch), dtype=np.uint64)
    rec["pose"][:, :3] = batch.xyz
    rec["pose"][:, 3:] = quat
    rec["pose_cov"][~known_h, 35] = UNSET_VARIANCE
    rec["twist"][:, :3] = vel
    unset_v = np.flatnonzero(~known_v)
    for k in (0, 7, 14):  # the x, y, z velocity variances
        rec["twist_cov"][unset_v, k] = UNSET_VARIANCE
    return rec


def tracked_persons_bytes(
    records: npt.NDArray[np.void], t_ns: int, frame_id: str, cdr: bool, seq: int
) -> bytes:
    """A whole serialized TrackedPersons message: header, count, then the records' bytes."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    frame = frame_id.encode()
    count = struct.pack("<I", len(records))
    if not cdr:  # ROS 1: seq, time, string without terminator, packed
        head = struct.pack("<IIII", seq, sec, nsec, len(frame)) + frame
        return head + count + records.tobytes()
    frame += b"\x00"
    head = struct.pack("<iII", sec, nsec, len(frame)) + frame
    head += b"\x00" * (-len(head) % 4) + count
    head += b"\x00" * (-len(head) % 8 if len(records) else 0)  # first uint64 aligned to 8
    return _CDR_LE + head + records.tobytes()


def pose_records(batch: DetectionBatch) -> npt.NDArray[np.void]:
    """Every row's serialized ``geometry_msgs/Pose`` (position, then the heading's yaw
    quaternion, all zero where the heading is unknown, as :func:`pose_array_message`
    is given it), one 56-byte record a row: what :func:`tracked_persons_many` joins into
    PoseArray messages (the same header, count and 8-alignment as TrackedPersons)."""
    quat, _, known_h, _ = orientation_velocity(batch)
    rec = np.zeros(len(batch), dtype=[("pose", "<f8", (7,))])
    rec["pose"][:, :3] = batch.xyz
    rec["pose"][:, 3:] = np.where(known_h[:, None], quat, 0.0)
    return rec


def tracked_persons_many(
    records: npt.NDArray[np.void],
    bounds: list[int],
    stamps: npt.NDArray[np.int64],
    seqs: npt.NDArray[np.int64],
    frame_id: str,
    cdr: bool,
) -> Iterator[bytes]:
    """Many TrackedPersons messages, yielded one at a time (memory for one message's bytes
    beyond ``records``): message ``i`` holds ``records[bounds[i] : bounds[i + 1]]``, stamped
    ``stamps[i]`` with header seq ``seqs[i]``, byte for byte :func:`tracked_persons_bytes` of
    the same arguments. The headers are built as one numpy array and each message is one
    join of its header and its records' bytes (one copy), not two ``struct.pack`` calls, a
    ``tobytes`` and three concatenations per message. PoseArray messages have the same
    layout (header, count, 8-aligned records): ``records`` from :func:`pose_records` gives
    them, byte for byte what rosbags serializes. Messages without records, and values
    the header's fields do not hold (which ``struct`` refuses), go through
    :func:`tracked_persons_bytes` itself, so they come out (or fail) as they did there."""
    stamps = np.asarray(stamps, dtype=np.int64)
    seqs = np.asarray(seqs, dtype=np.int64)
    first, ends = np.asarray(bounds[:-1], np.int64), np.asarray(bounds[1:], np.int64)
    count = ends - first
    sec, nsec = np.divmod(stamps, 1_000_000_000)
    sec_max = 2**31 - 1 if cdr else 2**32 - 1
    if len(stamps) and (
        int(count.min()) < 1
        or int(sec.min()) < 0
        or int(sec.max()) > sec_max
        or (not cdr and (int(seqs.min()) < 0 or int(seqs.max()) > 2**32 - 1))
    ):
        for a, b, t, q in zip(bounds[:-1], bounds[1:], stamps.tolist(), seqs.tolist(),
                              strict=True):
            yield tracked_persons_bytes(records[a:b], t, frame_id, cdr, q)
        return
    frame = frame_id.encode() + (b"\x00" if cdr else b"")
    if cdr:  # encapsulation, sec, nsec, string with terminator, count aligned to 4, then 8
        at_count = 4 + 12 + len(frame) + (-(12 + len(frame)) % 4)
        size = at_count + 4 + (-at_count % 8)  # the 8 counts after the 4 bytes
        fields = [("enc", "V4", 0), ("sec", "<i4", 4), ("nsec", "<u4", 8), ("flen", "<u4", 12)]
    else:  # ROS 1: seq, sec, nsec, string without terminator, count, packed
        at_count = 16 + len(frame)
        size = at_count + 4
        fields = [("seq", "<u4", 0), ("sec", "<u4", 4), ("nsec", "<u4", 8), ("flen", "<u4", 12)]
    fields += [("count", "<u4", at_count)] + ([("frame", f"V{len(frame)}", 16)] if frame else [])
    dtype = np.dtype({"names": [f[0] for f in fields], "formats": [f[1] for f in fields],
                      "offsets": [f[2] for f in fields], "itemsize": size})
    head = np.zeros(len(stamps), dtype=dtype)
    if cdr:
        head["enc"] = np.void(_CDR_LE)
    else:
        head["seq"] = seqs
    head["sec"], head["nsec"], head["flen"], head["count"] = sec, nsec, len(frame), count
    if frame:
        head["frame"] = np.void(frame)
    heads = memoryview(head.tobytes())
    body = np.ascontiguousarray(records).view(np.uint8).data
    item = records.dtype.itemsize
    for h, a, b in zip(range(0, len(stamps) * size, size), bounds[:-1], bounds[1:], strict=True):
        yield b"".join((heads[h : h + size], body[a * item : b * item]))


def pose_array_message(
    t_ns: int, xyz: list[list[float]], quat: list[list[float]], frame_id: str
) -> dict[str, Any]:
    """A geometry_msgs/PoseArray dict (ROS 2 naming) for one stamp's rows."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    poses = [
        {
            "position": {"x": p[0], "y": p[1], "z": p[2]},
            "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
        }
        for p, q in zip(xyz, quat, strict=True)
    ]
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": frame_id},
        "poses": poses,
    }
