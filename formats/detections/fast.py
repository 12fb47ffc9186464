"""Fast decoders: detections read with numpy straight from serialized bytes, many messages per
call, for the common types (PoseArray, spencer TrackedPersons, people_msgs/People,
vision_msgs/Detection3DArray), in ROS 2 CDR and ROS 1 encodings.

Fixed-size elements (Pose, TrackedPerson) are located by arithmetic after reading each
message's header and array count, then read with one gather per field over all elements of all
messages. Variable-size elements (People.Person, Detection3D, strings of a string[]) are read
by :func:`formats.detections.wire.walk`: vectorized over all messages and over runs of equally
sized elements (the Python loop runs once per change of element size, not once per detection:
a message of a million equal persons takes two steps). Every decoder checks that it consumed
the whole payload, so a message of a different layout under the same type name is rejected
(and the adapter falls back to the generic decoder) instead of yielding garbage.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aion_cli.formats.detections.frame import F64, I64, quat_yaw, unsigned_ids
from aion_cli.formats.detections.wire import (
    Cursors,
    Joined,
    equals_any,
    gather,
    gather_f64,
    hashed_strings,
    string_codes,
    walk,
)

NAN3 = np.array([np.nan, np.nan, np.nan])
#: spencer convention: a velocity/rotation variance above this means "not set".
UNSET_VARIANCE = 99999.0


@dataclass
class Decoded:
    """Per-row output of a fast decoder, before stamps and frame names are finalised."""

    owner: I64
    sec: I64
    nsec: I64
    frame_names: list[str]
    frame_code: I64
    xyz: F64
    velocity: F64
    yaw: F64
    track_id: I64
    filtered: dict[str, int] = field(default_factory=dict)


@dataclass
class Header:
    sec: I64
    nsec: I64
    frame_names: list[str]
    frame_code: I64


def read_header(c: Cursors) -> Header:
    """std_msgs/Header: ROS 1 (seq, uint32 sec, nsec, frame) or ROS 2 (int32 sec, nsec,
    frame)."""
    if c.j.cdr:
        sec = c.scalar(np.int32).astype(np.int64)
    else:
        c.skip(4)
        sec = c.scalar(np.uint32).astype(np.int64)
    nsec = c.u32()
    fs, fl = c.string()
    if c.bad is None:
        names, codes = string_codes(c.j, fs, fl, f"{c.what} frame_id")
    else:  # a speculative read: a frame_id that is not UTF-8 only marks the guess wrong
        invalid = np.zeros(len(fs), dtype=bool)
        names, codes = string_codes(c.j, fs, fl, f"{c.what} frame_id", invalid)
        c.fail(invalid, "frame_id is not UTF-8")
    return Header(sec, nsec, names, codes)


def _fixed_elements(c: Cursors, stride: int, align: int) -> tuple[Cursors, I64]:
    """Read a sequence count and return one cursor per fixed-size element."""
    n = c.count(stride)
    first = np.where(n > 0, c.aligned(align), c.pos)
    c.pos = first
    c.need(n * stride)
    c.pos = first + n * stride
    c.check_consumed()
    return c.repeat(n, first, stride), n


def _f64_at(e: Cursors, offset: int, k: int) -> F64:
    return gather_f64(e.j, e.pos + offset, k)


def _rows(h: Header, n: I64) -> tuple[I64, I64, I64, I64]:
    owner = np.repeat(np.arange(len(n)), n)
    return owner, h.sec[owner], h.nsec[owner], h.frame_code[owner]


def decode_pose_array(j: Joined) -> Decoded:
    """geometry_msgs/PoseArray: Header, Pose[] (7 float64 each, no padding)."""
    c = Cursors.over_messages(j, "geometry_msgs/msg/PoseArray")
    h = read_header(c)
    e, n = _fixed_elements(c, 56, 8)
    pose = _f64_at(e, 0, 7)
    owner, sec, nsec, code = _rows(h, n)
    m = len(owner)
    return Decoded(
        owner, sec, nsec, h.frame_names, code, pose[:, :3], np.tile(NAN3, (m, 1)),
        quat_yaw(pose[:, 3:7]), np.full(m, -1, np.int64),
    )


# spencer_tracking_msgs/TrackedPerson byte offsets: uint64 track_id, bool, bool, uint64
# detection_id, duration age, PoseWithCovariance (7 + 36 float64), TwistWithCovariance (6 + 36).
# ROS 1: packed (duration = int32+int32). CDR: detection_id aligned to 16, Duration (int32,
# uint32) at 24, Pose at 32, and the record size 712 is a multiple of 8, so it tiles.
_TRACKED = {
    True: {"stride": 712, "pose": 32},
    False: {"stride": 706, "pose": 26},
}


def decode_tracked_persons(j: Joined) -> Decoded:
    """spencer_tracking_msgs/TrackedPersons: Header, TrackedPerson[] (fixed size)."""
    lay = _TRACKED[j.cdr]
    pose_off = lay["pose"]
    pose_cov = pose_off + 56
    twist_off = pose_cov + 288
    twist_cov = twist_off + 48
    c = Cursors.over_messages(j, "spencer_tracking_msgs/msg/TrackedPersons")
    h = read_header(c)
    e, n = _fixed_elements(c, lay["stride"], 8)
    track = unsigned_ids(gather(j, e.pos, np.uint64).astype(np.uint64))
    pose = _f64_at(e, pose_off, 7)
    yaw_var = _f64_at(e, pose_cov + 35 * 8, 1)[:, 0]
    vel = _f64_at(e, twist_off, 3)
    vel_var = np.concatenate([_f64_at(e, twist_cov + k * 8, 1) for k in (0, 7, 14)], axis=1)
    vel = np.where(vel_var > UNSET_VARIANCE, np.nan, vel)
    yaw = np.where(yaw_var > UNSET_VARIANCE, np.nan, quat_yaw(pose[:, 3:7]))
    owner, sec, nsec, code = _rows(h, n)
    return Decoded(owner, sec, nsec, h.frame_names, code, pose[:, :3], vel, yaw, track)


def decode_people(j: Joined) -> Decoded:
    """people_msgs/People: Header, Person[] {string name, Point position, Point velocity,
    float64 reliability, string[] tagnames, string[] tags}; the name is the track id."""
    c = Cursors.over_messages(j, "people_msgs/msg/People")
    h = read_header(c)
    n = c.count(4 + 56 + 8)
    total = int(n.sum())
    xyz = np.empty((total, 3))
    vel = np.empty((total, 3))
    name_start = np.empty(total, np.int64)
    name_len = np.empty(total, np.int64)

    def step(s: Cursors, rows: np.ndarray) -> None:
        name_start[rows], name_len[rows] = s.string()
        xyz[rows] = s.f64(3)
        vel[rows] = s.f64(3)
        s.skip(8, align=8)  # reliability
        s.skip_strings(s.count(4))  # tagnames
        s.skip_strings(s.count(4))  # tags

    walk(c, n, step)
    c.check_consumed()
    owner, sec, nsec, code = _rows(h, n)
    track = hashed_strings(j, name_start, name_len)
    return Decoded(
        owner, sec, nsec, h.frame_names, code, xyz, vel, np.full(total, np.nan), track
    )


@dataclass(frozen=True)
class ClassFilter:
    """Which Detection3D results count as people: ROS 2 ``class_id`` strings, ROS 1 integer
    ids. ``None`` keeps every detection."""

    names: tuple[str, ...] | None = ("person",)
    ids: tuple[int, ...] | None = None


def _skip_point_cloud2_ros1(s: Cursors) -> None:
    """sensor_msgs/PointCloud2 (ROS 1): Header, height, width, PointField[] {string name,
    uint32 offset, uint8 datatype, uint32 count}, bool, point_step, row_step, uint8[] data,
    bool is_dense."""
    read_header(s)
    s.skip(8)

    def field_step(f: Cursors, rows: np.ndarray) -> None:
        f.string()
        f.skip(9)

    walk(s, s.count(13), field_step)
    s.skip(1 + 8)
    s.skip_bytes_seq(1)
    s.skip(1)


def decode_detection3d(j: Joined, flt: ClassFilter) -> Decoded:
    """vision_msgs/Detection3DArray: ROS 1 noetic (results {int64 id, float64 score,
    PoseWithCovariance}, bbox, PointCloud2 source_cloud; no track id) or ROS 2 >= galactic
    (results {ObjectHypothesis {string class_id, float64 score}, PoseWithCovariance}, bbox,
    string id = track id). Position and yaw come from ``bbox.center``; the per-detection header
    overrides the array header where it is set."""
    c = Cursors.over_messages(j, "vision_msgs/msg/Detection3DArray")
    h = read_header(c)
    n = c.count(4)
    total = int(n.sum())
    center = np.empty((total, 7))
    keep = np.ones(total, dtype=bool)
    sec = np.empty(total, np.int64)
    nsec = np.empty(total, np.int64)
    dcode = np.empty(total, np.int64)
    id_start = np.zeros(total, np.int64)
    id_len = np.zeros(total, np.int64)
    names: list[str] = list(h.frame_names)
    active_filter = (flt.names if j.cdr else flt.ids) is not None

    def result_step(r: Cursors, result_rows: np.ndarray, hit: np.ndarray) -> None:
        # stored per result (rows are overwritten by later reads, see wire.walk), combined
        # per detection after the walk
        if j.cdr:
            cs, cl = r.string()
            if flt.names is not None:
                hit[result_rows] = equals_any(j, cs, cl, flt.names)
            r.skip(8 * (1 + 7 + 36), align=8)
        else:
            cid = r.scalar(np.int64).astype(np.int64)
            if flt.ids is not None:
                hit[result_rows] = np.isin(cid, np.asarray(flt.ids, np.int64))
            r.skip(8 * (1 + 7 + 36))

    def step(s: Cursors, rows: np.ndarray) -> None:
        dh = read_header(s)
        sec[rows], nsec[rows] = dh.sec, dh.nsec
        dcode[rows] = np.where(dh.frame_code > 0, dh.frame_code + len(names), -1)
        names.extend(dh.frame_names)
        nres = s.count(8)
        hit = np.zeros(int(nres.sum()), dtype=bool)  # per result of this step's detections
        walk(s, nres, lambda r, ri: result_step(r, ri, hit))
        if active_filter:
            owner = np.repeat(np.arange(len(rows)), nres)
            keep[rows] = np.bincount(owner, weights=hit, minlength=len(rows)) > 0
        center[rows] = s.f64(7)
        s.skip(24, align=8)  # bbox.size
        if j.cdr:
            id_start[rows], id_len[rows] = s.string()
        else:
            _skip_point_cloud2_ros1(s)

    walk(c, n, step)
    c.check_consumed()
    owner = np.repeat(np.arange(len(n)), n)
    unset = (sec == 0) & (nsec == 0)
    sec = np.where(unset, h.sec[owner], sec)
    nsec = np.where(unset, h.nsec[owner], nsec)
    code = np.where(dcode < 0, h.frame_code[owner], dcode)
    track = hashed_strings(j, id_start, id_len) if j.cdr else np.full(total, -1, np.int64)
    out = Decoded(
        owner, sec, nsec, names, code, center[:, :3], np.tile(NAN3, (total, 1)),
        quat_yaw(center[:, 3:7]), track,
    )
    if active_filter:
        out = _select(out, keep)
        if not keep.all():  # a reason with no drop is not listed, as Rows.drop lists them
            out.filtered["class"] = int((~keep).sum())
    return out


def _select(d: Decoded, keep: np.ndarray) -> Decoded:
    return Decoded(
        d.owner[keep], d.sec[keep], d.nsec[keep], d.frame_names, d.frame_code[keep],
        d.xyz[keep], d.velocity[keep], d.yaw[keep], d.track_id[keep], dict(d.filtered),
    )
