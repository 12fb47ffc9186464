"""The numpy fast decoders give exactly what rosbags' own deserializer gives, for random
messages in both encodings (random counts, floats, frame_id lengths that shift the CDR
alignment, random strings), many messages per call; bad bytes raise MessageDecodeError."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.detections import FrameDetections, adapter_for, hash_id
from aion_cli.formats.detections.frame import quat_yaw
from aion_cli.formats.detections.wire import join_payloads
from aion_cli.formats.raw import RawMessage, normalize_frame
from tests.formats.detection_strategies import (
    DET3D,
    PEOPLE,
    POSE_ARRAY,
    TRACKED,
    detections,
    headers,
    persons,
    poses,
    tracked,
)
from tests.formats.ros_messages import header, pose, raw, reference

SETTINGS = settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


def _v3(d: Any) -> tuple[float, float, float]:
    return (float(d.x), float(d.y), float(d.z))


def _q(d: Any) -> tuple[float, float, float, float]:
    return (float(d.x), float(d.y), float(d.z), float(d.w))


class Expected:
    """Rows built in plain Python from rosbags' deserialized objects."""

    def __init__(self) -> None:
        self.t: list[int] = []
        self.xyz: list[tuple[float, float, float]] = []
        self.vel: list[tuple[float, float, float]] = []
        self.quat: list[tuple[float, float, float, float]] = []
        self.track: list[int] = []
        self.frame: list[str] = []
        self.msg: list[int] = []

    def add(self, i: int, t: int, frame: str, xyz: Any, vel: Any, quat: Any, track: int) -> None:
        self.t.append(t)
        self.frame.append(normalize_frame(frame))
        self.xyz.append(xyz)
        self.vel.append(vel)
        self.quat.append(quat)
        self.track.append(track)
        self.msg.append(i)

    def check(self, got: FrameDetections) -> None:
        n = len(self.t)
        assert len(got) == n
        np.testing.assert_array_equal(got.t_ns, np.asarray(self.t, np.int64))
        np.testing.assert_array_equal(got.xyz, np.asarray(self.xyz, np.float64).reshape(n, 3))
        np.testing.assert_array_equal(
            got.velocity, np.asarray(self.vel, np.float64).reshape(n, 3)
        )
        np.testing.assert_array_equal(
            got.yaw, quat_yaw(np.asarray(self.quat, np.float64).reshape(n, 4))
        )
        np.testing.assert_array_equal(got.track_id, np.asarray(self.track, np.int64))
        assert got.frame_names() == self.frame
        np.testing.assert_array_equal(got.msg_index, np.asarray(self.msg, np.int64))


def _stamp(h: Any, log_time: int) -> int:
    t = int(h.stamp.sec) * 1_000_000_000 + int(h.stamp.nanosec)
    return t or log_time


NAN3 = (np.nan, np.nan, np.nan)
NANQ = (np.nan, np.nan, np.nan, np.nan)


def _decode_both(msgtype: str, msgs: list[RawMessage], ros: int) -> FrameDetections:
    """Run the fast decoder alone (it must accept every valid message, no fallback) and the
    adapter; return the adapter's result."""
    adapter = adapter_for(msgtype)
    assert adapter is not None
    assert adapter.fast is not None
    adapter.fast(join_payloads(msgs, ros == 2))
    return adapter.decode(msgs)


# --- PoseArray ----------------------------------------------------------------------------------

@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.data())
def test_pose_array_matches_rosbags(ros: int, data: st.DataObject) -> None:
    specs = data.draw(
        st.lists(st.tuples(headers(), st.lists(poses(), max_size=20)), min_size=1, max_size=5)
    )
    msgs = [
        raw(POSE_ARRAY, {"header": h, "poses": p}, ros, log_time_ns=1000 + i)
        for i, (h, p) in enumerate(specs)
    ]
    exp = Expected()
    for i, m in enumerate(msgs):
        ref = reference(m)
        for p in ref.poses:
            exp.add(
                i, _stamp(ref.header, m.log_time_ns), ref.header.frame_id, _v3(p.position), NAN3,
                _q(p.orientation), -1,
            )
    got = _decode_both(POSE_ARRAY, msgs, ros)
    exp.check(got)
    zero = sum(len(p) for h, p in specs if h["stamp"] == {"sec": 0, "nanosec": 0})
    assert got.stamp_fallbacks == zero


# --- spencer TrackedPersons ---------------------------------------------------------------------

@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.data())
def test_tracked_persons_matches_rosbags(ros: int, data: st.DataObject) -> None:
    specs = data.draw(
        st.lists(st.tuples(headers(), st.lists(tracked(), max_size=20)), min_size=1, max_size=4)
    )
    msgs = [
        raw(TRACKED, {"header": h, "tracks": t}, ros, log_time_ns=77 + i)
        for i, (h, t) in enumerate(specs)
    ]
    exp = Expected()
    for i, m in enumerate(msgs):
        ref = reference(m)
        for tr in ref.tracks:
            tcov = tr.twist.covariance
            vel = tuple(
                np.nan if tcov[7 * k] > 99999.0 else v
                for k, v in enumerate(_v3(tr.twist.twist.linear))
            )
            quat = NANQ if tr.pose.covariance[35] > 99999.0 else _q(tr.pose.pose.orientation)
            exp.add(
                i, _stamp(ref.header, m.log_time_ns), ref.header.frame_id,
                _v3(tr.pose.pose.position), vel, quat, int(tr.track_id) & (2**63 - 1),
            )
    exp.check(_decode_both(TRACKED, msgs, ros))


# --- people_msgs/People -------------------------------------------------------------------------

@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.data())
def test_people_matches_rosbags(ros: int, data: st.DataObject) -> None:
    specs = data.draw(
        st.lists(st.tuples(headers(), st.lists(persons(), max_size=20)), min_size=1, max_size=4)
    )
    msgs = [
        raw(PEOPLE, {"header": h, "people": p}, ros, log_time_ns=5 + i)
        for i, (h, p) in enumerate(specs)
    ]
    exp = Expected()
    for i, m in enumerate(msgs):
        ref = reference(m)
        for p in ref.people:
            exp.add(
                i, _stamp(ref.header, m.log_time_ns), ref.header.frame_id, _v3(p.position),
                _v3(p.velocity), NANQ, hash_id(p.name),
            )
    exp.check(_decode_both(PEOPLE, msgs, ros))


# --- vision_msgs/Detection3DArray ---------------------------------------------------------------

@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.data())
def test_detection3d_matches_rosbags(ros: int, data: st.DataObject) -> None:
    specs = data.draw(
        st.lists(
            st.tuples(headers(), st.lists(detections(ros), max_size=6)), min_size=1, max_size=3
        )
    )
    msgs = [
        raw(DET3D, {"header": h, "detections": d}, ros, log_time_ns=9 + i)
        for i, (h, d) in enumerate(specs)
    ]
    exp = Expected()
    dropped = 0
    for i, m in enumerate(msgs):
        ref = reference(m)
        for d in ref.detections:
            if ros == 2 and not any(r.hypothesis.class_id == "person" for r in d.results):
                dropped += 1
                continue
            own = int(d.header.stamp.sec) * 1_000_000_000 + int(d.header.stamp.nanosec)
            t = own or _stamp(ref.header, m.log_time_ns)
            frame = d.header.frame_id or ref.header.frame_id
            track = -1 if ros == 1 else hash_id(d.id)
            c = d.bbox.center
            exp.add(i, t, frame, _v3(c.position), NAN3, _q(c.orientation), track)
    got = _decode_both(DET3D, msgs, ros)
    exp.check(got)
    assert got.filtered == ({"class": dropped} if dropped else {})  # as the generic path's


# --- bad input ----------------------------------------------------------------------------------


def _samples(ros: int) -> dict[str, RawMessage]:
    q = (0.0, 0.0, 0.0, 1.0)
    people = [{"name": "ann", "position": {"x": 1.0}, "tagnames": ["a"], "tags": ["b"]}]
    d3: dict[str, Any] = {
        "header": header(1, 2, "cam"),
        "results": [{"hypothesis": {"class_id": "person"}}] if ros == 2 else [{"id": 3}],
        "bbox": {"center": pose(1, 2, 3, q)},
    }
    if ros == 1:
        d3["source_cloud"] = {"fields": [{"name": "x"}], "data": b"abc"}
    return {
        POSE_ARRAY: raw(
            POSE_ARRAY, {"header": header(1, 2, "map"), "poses": [pose(1, 2, 3, q)]}, ros
        ),
        TRACKED: raw(
            TRACKED, {"header": header(1, 2, "odom"), "tracks": [{"track_id": 4}] * 2}, ros
        ),
        PEOPLE: raw(PEOPLE, {"header": header(1, 2, "odom"), "people": people * 2}, ros),
        DET3D: raw(DET3D, {"header": header(1, 2, "x"), "detections": [d3, d3]}, ros),
    }


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("msgtype", [POSE_ARRAY, TRACKED, PEOPLE, DET3D])
def test_every_truncation_raises_message_decode_error(msgtype: str, ros: int) -> None:
    good = _samples(ros)[msgtype]
    adapter = adapter_for(msgtype)
    assert adapter is not None
    assert adapter.fast is not None
    assert len(adapter.decode([good])) >= 1
    n = len(good.data)
    # Every cut in the header region and the tail, every few bytes in between.
    cuts = sorted({*range(min(n, 64)), *range(0, n, max(1, n // 80)), *range(max(0, n - 24), n)})
    for k, cut in enumerate(cuts):
        bad = RawMessage(good.topic, msgtype, 0, good.data[:cut], good.encoding)
        with pytest.raises(MessageDecodeError):
            adapter.fast(join_payloads([good, bad, good], ros == 2))
        if k % 8 == 0:  # the adapter also tries rosbags: slower, so every few cuts
            with pytest.raises(MessageDecodeError):
                adapter.decode([good, bad])


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("msgtype", [POSE_ARRAY, TRACKED, PEOPLE, DET3D])
def test_trailing_garbage_is_rejected(msgtype: str, ros: int) -> None:
    good = _samples(ros)[msgtype]
    adapter = adapter_for(msgtype)
    assert adapter is not None
    assert adapter.fast is not None
    bad = RawMessage(good.topic, msgtype, 0, good.data + b"\x01" * 9, good.encoding)
    with pytest.raises(MessageDecodeError, match="unread bytes"):
        adapter.fast(join_payloads([bad], ros == 2))


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("msgtype", [POSE_ARRAY, TRACKED, PEOPLE, DET3D])
@settings(max_examples=60, deadline=None)
@given(junk=st.binary(max_size=200))
def test_garbage_raises_or_agrees_with_rosbags(msgtype: str, ros: int, junk: bytes) -> None:
    """Random bytes (behind a valid CDR header): the fast decoder raises MessageDecodeError, or
    decodes what rosbags decodes from the same bytes -- never another exception."""
    data = (b"\x00\x01\x00\x00" + junk) if ros == 2 else junk
    m = RawMessage("/t", msgtype, 123, data, "cdr" if ros == 2 else "ros1")
    adapter = adapter_for(msgtype)
    assert adapter is not None
    assert adapter.fast is not None
    try:
        adapter.fast(join_payloads([m], ros == 2))
    except MessageDecodeError:
        return
    fast = adapter.decode([m])
    generic = adapter.decode_generic([m])
    np.testing.assert_array_equal(fast.xyz, generic.xyz)
    np.testing.assert_array_equal(fast.track_id, generic.track_id)


def test_huge_sequence_count_is_rejected_before_allocating() -> None:
    data = b"\x00\x01\x00\x00" + b"\x00" * 8 + b"\x01\x00\x00\x00\x00" + b"\x00" * 3
    data += b"\xff\xff\xff\x7f"
    m = RawMessage("/t", POSE_ARRAY, 0, data, "cdr")
    adapter = adapter_for(POSE_ARRAY)
    assert adapter is not None
    assert adapter.fast is not None
    with pytest.raises(MessageDecodeError, match="sequence length"):
        adapter.fast(join_payloads([m], True))


def test_big_endian_cdr_goes_through_the_generic_decoder() -> None:
    from tests.formats.ros_messages import serialize

    msg = {"header": header(3, 4, "/odom"), "poses": [pose(1.5, -2.0, 0.25, (0, 0, 1, 0))]}
    le = RawMessage("/t", POSE_ARRAY, 0, serialize(POSE_ARRAY, msg, 2), "cdr")
    be = RawMessage("/t", POSE_ARRAY, 0, serialize(POSE_ARRAY, msg, 2, False), "cdr")
    assert be.data[:2] == b"\x00\x00"
    adapter = adapter_for(POSE_ARRAY)
    assert adapter is not None
    got = adapter.decode([le, be])
    np.testing.assert_array_equal(got.xyz, [[1.5, -2.0, 0.25]] * 2)
    np.testing.assert_allclose(got.yaw, [np.pi, np.pi])
    assert got.frame_names() == ["odom", "odom"]
    np.testing.assert_array_equal(got.msg_index, [0, 1])


def test_skip_mode_drops_only_the_bad_message() -> None:
    good = _samples(2)[TRACKED]
    bad = RawMessage("/t", TRACKED, 0, good.data[:30], "cdr")
    adapter = adapter_for(TRACKED)
    assert adapter is not None
    got = adapter.decode([good, bad, good], on_error="skip")
    np.testing.assert_array_equal(got.msg_index, [0, 0, 2, 2])
    assert got.filtered == {"undecodable": 1}
    assert got.n_messages == 3


@pytest.mark.parametrize("collide", [False, True])
def test_unique_rows_groups_equal_rows_even_when_hashes_collide(
    collide: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    from aion_cli.formats.detections import wire

    if collide:  # every row hashes to 0: the byte-wise fallback must take over
        monkeypatch.setattr(wire, "_MIX", np.uint64(0))
    rng = np.random.default_rng(3)
    for width in (1, 7, 8, 13):
        base = rng.integers(0, 3, size=(5, width), dtype=np.uint8)
        rows = base[rng.integers(0, 5, size=200)]
        first, inv = wire.unique_rows(rows)
        np.testing.assert_array_equal(rows, rows[first][inv])  # every row maps to its equal
        distinct = {r.tobytes() for r in rows}
        assert len(first) == len(distinct)
