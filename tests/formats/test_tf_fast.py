"""formats.tf_fast decodes TFMessages exactly like rosbags' own deserializers (ROS 2 CDR and
ROS 1, random transform counts, frame-id lengths that shift the CDR alignment, random floats),
many messages per call; truncated or garbage payloads raise MessageDecodeError."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.tf import TfBuffer, normalize_frame
from aion_cli.formats.tf_fast import TfArrays, decode_tf_messages
from tests.formats.ros_messages import raw, reference

TF = "tf2_msgs/msg/TFMessage"
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])

floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
frames = st.text(alphabet="abcxyz_/ 019é", min_size=0, max_size=17)


@st.composite
def transforms(draw: st.DrawFn, ros: int) -> dict[str, Any]:
    # ROS 1 time: uint32 seconds (to 2106); ROS 2 builtin_interfaces/Time: int32
    sec = draw(st.integers(0, 2**32 - 1) if ros == 1 else st.integers(-(2**31), 2**31 - 1))
    return {
        "header": {
            "stamp": {"sec": sec, "nanosec": draw(st.integers(0, 2**32 - 1))},
            "frame_id": draw(frames),
        },
        "child_frame_id": draw(frames),
        "transform": {
            "translation": {k: draw(floats) for k in "xyz"},
            "rotation": {k: draw(floats) for k in "xyzw"},
        },
    }


@st.composite
def tf_messages(draw: st.DrawFn, ros: int) -> dict[str, Any]:
    return {"transforms": draw(st.lists(transforms(ros), min_size=0, max_size=5))}


def expected(messages: list[RawMessage]) -> dict[str, Any]:
    """Columns built in plain Python from rosbags' deserialized objects."""
    rows: list[tuple[Any, ...]] = []
    counts = []
    for i, m in enumerate(messages):
        obj = reference(m)
        counts.append(len(obj.transforms))
        for tf in obj.transforms:
            s = tf.header.stamp
            sec, nsec = (s.sec, s.nanosec) if hasattr(s, "nanosec") else (s.secs, s.nsecs)
            tr, q = tf.transform.translation, tf.transform.rotation
            rows.append(
                (
                    normalize_frame(tf.header.frame_id),
                    normalize_frame(tf.child_frame_id),
                    int(sec) * 1_000_000_000 + int(nsec),
                    (tr.x, tr.y, tr.z),
                    (q.x, q.y, q.z, q.w),
                    i,
                )
            )
    return {
        "parent": [r[0] for r in rows],
        "child": [r[1] for r in rows],
        "t": np.array([r[2] for r in rows], dtype=np.int64),
        "tr": np.array([r[3] for r in rows], dtype=np.float64).reshape(-1, 3),
        "q": np.array([r[4] for r in rows], dtype=np.float64).reshape(-1, 4),
        "msg": np.array([r[5] for r in rows], dtype=np.int64),
        "counts": np.array(counts, dtype=np.int64),
    }


def check(got: TfArrays, messages: list[RawMessage]) -> None:
    exp = expected(messages)
    assert got.parent == exp["parent"]
    assert got.child == exp["child"]
    assert got.t_ns.dtype == np.int64
    assert np.array_equal(got.t_ns, exp["t"])
    # bit-exact, NaN payloads included
    assert np.array_equal(got.translation.view(np.int64), exp["tr"].view(np.int64))
    assert np.array_equal(got.quat_xyzw.view(np.int64), exp["q"].view(np.int64))
    assert got.translation.shape == (len(exp["t"]), 3)
    assert got.quat_xyzw.shape == (len(exp["t"]), 4)
    assert np.array_equal(got.msg_index, exp["msg"])
    assert np.array_equal(got.counts, exp["counts"])
    assert got.names[0] == ""
    assert sorted(got.names[1:]) == got.names[1:]


@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.data())
def test_matches_rosbags(ros: int, data: st.DataObject) -> None:
    msgs = data.draw(st.lists(tf_messages(ros), min_size=1, max_size=8))
    raws = [raw(TF, m, ros, log_time_ns=i) for i, m in enumerate(msgs)]
    check(decode_tf_messages(raws), raws)


@SETTINGS
@given(data=st.data())
def test_mixed_encodings_keep_message_order(data: st.DataObject) -> None:
    kinds = data.draw(st.lists(st.sampled_from([1, 2]), min_size=1, max_size=8))
    raws = [raw(TF, data.draw(tf_messages(r)), r) for r in kinds]
    check(decode_tf_messages(raws), raws)


def test_empty_batch_and_empty_message() -> None:
    assert len(decode_tf_messages([])) == 0
    got = decode_tf_messages([raw(TF, {"transforms": []}, 2)])
    assert len(got) == 0
    assert got.counts.tolist() == [0]


def _one(ros: int, n: int = 3) -> RawMessage:
    tf = {
        "header": {"stamp": {"sec": 5, "nanosec": 7}, "frame_id": "/map"},
        "child_frame_id": "base_link_x",
        "transform": {
            "translation": {"x": 1.0, "y": 2.0, "z": 3.0},
            "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        },
    }
    return raw(TF, {"transforms": [tf] * n}, ros)


@pytest.mark.parametrize("ros", [1, 2])
def test_truncation_raises(ros: int) -> None:
    good = _one(ros)
    for cut in range(len(good.data)):
        bad = RawMessage(good.topic, good.msgtype, 0, good.data[:cut], good.encoding)
        with pytest.raises(MessageDecodeError):
            decode_tf_messages([good, bad, good])


@pytest.mark.parametrize("ros", [1, 2])
def test_trailing_garbage_and_huge_counts_raise(ros: int) -> None:
    good = _one(ros)
    for data in (good.data + bytes(8), good.data[:4] + b"\xff\xff\xff\x7f" + good.data[8:]):
        if ros == 1:
            data = data if len(data) > len(good.data) else b"\xff\xff\xff\x7f" + good.data[4:]
        bad = RawMessage(good.topic, good.msgtype, 0, data, good.encoding)
        with pytest.raises(MessageDecodeError):
            decode_tf_messages([bad])


def test_big_endian_and_wrong_type_raise() -> None:
    good = _one(2)
    big = RawMessage(good.topic, good.msgtype, 0, b"\x00\x00\x00\x00" + good.data[4:], "cdr")
    with pytest.raises(MessageDecodeError):
        decode_tf_messages([good, big])
    other = RawMessage(good.topic, "geometry_msgs/msg/PoseArray", 0, good.data, "cdr")
    with pytest.raises(MessageDecodeError):
        decode_tf_messages([other])


@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(data=st.binary(max_size=200), seed=st.integers(0, 2**32 - 1))
def test_garbage_never_escapes(ros: int, data: bytes, seed: int) -> None:
    """Random bytes (and random mutations of a valid message) either decode exactly like
    rosbags or raise MessageDecodeError; never IndexError or made-up values."""
    good = _one(ros, 2).data
    rng = np.random.default_rng(seed)
    mutated = bytearray(good)
    for i in rng.integers(0, len(good), 3).tolist():
        mutated[i] = int(rng.integers(0, 256))
    for payload in (data, bytes(mutated), (b"\x00\x01\x00\x00" if ros == 2 else b"") + data):
        m = RawMessage("/tf", TF, 0, payload, "ros1" if ros == 1 else "cdr")
        try:
            got = decode_tf_messages([m])
        except MessageDecodeError:
            continue
        try:
            reference(m)
        except Exception:
            pytest.fail(f"fast decoder accepted a payload rosbags rejects: {payload.hex()}")
        check(got, [m])


def test_arrays_feed_tfbuffer_like_generic_path() -> None:
    msgs = [_one(2, 1), _one(1, 2)]
    got = decode_tf_messages(msgs)
    keep = got.usable()
    fast = TfBuffer()
    sel = got.select(keep)
    fast.add_transforms(sel.parent, sel.child, sel.t_ns, sel.translation, sel.quat_xyzw)
    slow = TfBuffer()
    for m in msgs:
        slow.add_message(reference(m))
    t = np.array([5_000_000_007], dtype=np.int64)
    for a, b in zip(
        fast.lookup("map", "base_link_x", t), slow.lookup("map", "base_link_x", t), strict=True
    ):
        assert np.array_equal(a, b)


@SETTINGS
@given(data=st.data())
def test_by_edge_groups_rows_in_order(data: st.DataObject) -> None:
    pairs = st.sampled_from([("map", "odom"), ("/odom", "base"), ("map", "base"), ("a", "")])
    msgs = []
    for _ in range(data.draw(st.integers(1, 6))):
        tfs = []
        for p, c in data.draw(st.lists(pairs, max_size=4)):
            tf = data.draw(transforms(2))
            tf["header"]["frame_id"], tf["child_frame_id"] = p, c
            tfs.append(tf)
        msgs.append(raw(TF, {"transforms": tfs}, 2))
    got = decode_tf_messages(msgs)
    seen: list[tuple[str, str]] = []
    rows: list[int] = []
    for parent, child, sub in got.by_edge():
        seen.append((parent, child))
        idx = [
            i
            for i, (p, c) in enumerate(zip(got.parent, got.child, strict=True))
            if (p, c) == (parent, child)
        ]
        assert np.array_equal(sub.t_ns, got.t_ns[idx])
        assert np.array_equal(sub.msg_index, got.msg_index[idx])
        rows.extend(idx)
    assert sorted(rows) == list(range(len(got)))
    firsts = list(dict.fromkeys(zip(got.parent, got.child, strict=True)))
    assert seen == firsts


def test_a_message_must_end_where_its_layout_does() -> None:
    """ROS 1 messages are consumed exactly: one byte more is another layout. CDR may end in
    up to 7 bytes of padding (the next 8-byte boundary), not 8."""
    ros1 = _one(1)
    with pytest.raises(MessageDecodeError, match="unread bytes"):
        decode_tf_messages([RawMessage(ros1.topic, ros1.msgtype, 0, ros1.data + b"\0", "ros1")])
    cdr = _one(2)
    padded = RawMessage(cdr.topic, cdr.msgtype, 0, cdr.data + bytes(7), "cdr")
    np.testing.assert_array_equal(decode_tf_messages([padded]).t_ns, decode_tf_messages([cdr]).t_ns)
    with pytest.raises(MessageDecodeError, match="unread bytes"):
        decode_tf_messages([RawMessage(cdr.topic, cdr.msgtype, 0, cdr.data + bytes(8), "cdr")])
