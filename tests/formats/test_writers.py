"""LogWriter: every container is written, then read back with an independent reader (rosbags
AnyReader, or mcap + the mcap_ros1 / mcap_ros2 decoders) and compared field by field."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats.writers import (
    CONTAINERS,
    LogWriteError,
    LogWriter,
    MessageEncodeError,
    stamp,
    to_message,
)

T0 = 1_700_000_000_123_456_789


def _name(container: str) -> str:
    return {"bag": "log.bag", "mcap": "log.mcap", "mcap-ros1": "log.mcap"}.get(container, "bag2")


def _tracks(k: int) -> dict[str, Any]:
    return {
        "header": {"stamp": stamp(T0 + k), "frame_id": "odom"},
        "tracks": [
            {
                "track_id": 10 + i,
                "is_matched": True,
                "age": {"sec": 3, "nanosec": 5},
                "pose": {"pose": {"position": {"x": k + 0.5, "y": -i, "z": 0.25}}},
                "twist": {"twist": {"linear": {"x": 0.75, "y": 0.0}}},
            }
            for i in range(2)
        ],
    }


def _write_sample(path: Path, container: str) -> None:
    with LogWriter(path, container) as w:
        w.write(
            "/tf_static",
            "tf2_msgs/TFMessage",
            {
                "transforms": [
                    {
                        "header": {"stamp": stamp(T0), "frame_id": "base_link"},
                        "child_frame_id": "laser",
                        "transform": {"translation": {"x": 0.1}, "rotation": {"w": 1.0}},
                    }
                ]
            },
            T0,
        )
        for k in range(3):
            w.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", _tracks(k), T0 + k)
        w.write(
            "/dsg",
            "hydra_msgs/DsgUpdate",
            {
                "header": {"stamp": stamp(T0 + 5)},
                "layer_contents": b"\x00\x01payload\xff",
                "deleted_nodes": [1, 2**63 + 5],
                "full_update": True,
                "sequence_number": -4,
            },
            T0 + 5,
        )
        w.write(
            "/poses",
            "geometry_msgs/PoseArray",
            {"header": {"frame_id": "map"}, "poses": [{"position": {"x": 1, "y": 2, "z": 3}}]},
            T0 + 6,
        )


def _check(by_topic: dict[str, list[tuple[int, Any]]], ros1_naming: bool) -> None:
    """Compare decoded messages with what _write_sample wrote. ``ros1_naming``: genpy objects
    (``secs``/``nsecs``, Duration objects) instead of ROS 2 ``sec``/``nanosec``."""

    def sec_ns(t: Any) -> tuple[int, int]:
        return (t.secs, t.nsecs) if ros1_naming else (t.sec, t.nanosec)

    assert sorted(by_topic) == ["/dsg", "/poses", "/tf_static", "/tracks"]
    ((t, tf),) = by_topic["/tf_static"]
    assert t == T0
    tr = tf.transforms[0]
    assert (tr.header.frame_id, tr.child_frame_id) == ("base_link", "laser")
    assert tr.transform.translation.x == 0.1
    assert tr.transform.rotation.w == 1.0

    tracks = by_topic["/tracks"]
    assert [t for t, _ in tracks] == [T0, T0 + 1, T0 + 2]
    for k, (_, msg) in enumerate(tracks):
        assert sec_ns(msg.header.stamp) == divmod(T0 + k, 10**9)
        assert msg.header.frame_id == "odom"
        assert [p.track_id for p in msg.tracks] == [10, 11]
        p = msg.tracks[1]
        assert p.is_matched is True
        assert p.is_occluded is False
        assert sec_ns(p.age) == (3, 5)
        pos = p.pose.pose.position
        assert (pos.x, pos.y, pos.z) == (k + 0.5, -1.0, 0.25)
        assert p.twist.twist.linear.x == 0.75
        assert p.pose.pose.orientation.w == 0.0  # unset fields are zero
        assert len(p.pose.covariance) == 36
        assert not any(p.pose.covariance)
        if ros1_naming:
            assert msg.header.seq == k  # ROS 1 headers are numbered per topic

    ((t, dsg),) = by_topic["/dsg"]
    assert t == T0 + 5
    payload = dsg.layer_contents
    payload = payload.tobytes() if isinstance(payload, np.ndarray) else bytes(payload)
    assert payload == b"\x00\x01payload\xff"
    assert [int(x) for x in dsg.deleted_nodes] == [1, 2**63 + 5]
    assert len(dsg.deleted_edges) == 0
    assert dsg.full_update is True
    assert dsg.sequence_number == -4

    ((t, poses),) = by_topic["/poses"]
    assert poses.header.frame_id == "map"
    pos = poses.poses[0].position
    assert (pos.x, pos.y, pos.z) == (1.0, 2.0, 3.0)


def _read_anyreader(path: Path) -> dict[str, list[tuple[int, Any]]]:
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path]) as reader:
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return out


def _read_mcap(path: Path) -> dict[str, list[tuple[int, Any]]]:
    from mcap.reader import make_reader
    from mcap_ros1.decoder import DecoderFactory as Ros1Decoder
    from mcap_ros2.decoder import DecoderFactory as Ros2Decoder

    out: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[Ros1Decoder(), Ros2Decoder()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


@pytest.mark.parametrize("container", ["mcap", "bag", "rosbag2-sqlite3", "rosbag2-mcap"])
def test_round_trip_with_rosbags_anyreader(container: str, tmp_path: Path) -> None:
    path = tmp_path / _name(container)
    _write_sample(path, container)
    _check(_read_anyreader(path), ros1_naming=False)


@pytest.mark.parametrize("container", ["mcap", "mcap-ros1"])
def test_round_trip_with_mcap_decoders(container: str, tmp_path: Path) -> None:
    path = tmp_path / _name(container)
    _write_sample(path, container)
    _check(_read_mcap(path), ros1_naming=container == "mcap-ros1")


def test_mcap_profiles_and_encodings(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    for container, profile, schema_enc, msg_enc, schema_name in [
        ("mcap", "ros2", "ros2msg", "cdr", "hydra_msgs/msg/DsgUpdate"),
        ("mcap-ros1", "ros1", "ros1msg", "ros1", "hydra_msgs/DsgUpdate"),
    ]:
        path = tmp_path / f"{profile}.mcap"
        _write_sample(path, container)
        with path.open("rb") as f:
            reader = make_reader(f)
            assert reader.get_header().profile == profile
            summary = reader.get_summary()
            assert summary is not None
            schemas = {s.name: s for s in summary.schemas.values()}
            assert schemas[schema_name].encoding == schema_enc
            assert {c.message_encoding for c in summary.channels.values()} == {msg_enc}
            counts = summary.statistics.channel_message_counts
            by_topic = {summary.channels[c].topic: n for c, n in counts.items()}
            assert by_topic == {"/tf_static": 1, "/tracks": 3, "/dsg": 1, "/poses": 1}


def test_ros1_bag_latches_tf_static_and_uses_real_md5(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Reader

    path = tmp_path / "x.bag"
    _write_sample(path, "bag")
    with Reader(path) as reader:
        conns = {c.topic: c for c in reader.connections}
    assert conns["/tf_static"].ext.latching == 1
    assert conns["/tracks"].ext.latching in (0, None)
    assert conns["/dsg"].digest == "03ee31d525f5142f9392a515100c2d93"
    assert conns["/tf_static"].digest == "94810edda583a504dfda3829e70d7eec"


@pytest.mark.parametrize("container", CONTAINERS)
def test_write_raw_stores_payload_verbatim(container: str, tmp_path: Path) -> None:
    path = tmp_path / _name(container)
    with LogWriter(path, container) as w:
        data = w.serialize("people_msgs/People", {"people": [{"name": "ann", "reliability": 1}]})
        w.write_raw("/people", "people_msgs/People", data, T0)
    if container == "mcap-ros1":
        msgs = _read_mcap(path)
    else:
        msgs = _read_anyreader(path)
    ((t, msg),) = msgs["/people"]
    assert t == T0
    assert msg.people[0].name == "ann"
    assert msg.people[0].reliability == 1.0


def test_numpy_arrays_and_fixed_arrays(tmp_path: Path) -> None:
    cov = np.arange(36, dtype=np.float64)
    msg = to_message(
        "geometry_msgs/PoseWithCovariance", {"pose": {"position": {"x": 2}}, "covariance": cov}
    )
    assert np.array_equal(msg.covariance, cov)
    with pytest.raises(MessageEncodeError, match="36"):
        to_message("geometry_msgs/PoseWithCovariance", {"covariance": [1.0, 2.0]})


def test_bad_messages_are_rejected_with_the_field_name(tmp_path: Path) -> None:
    with pytest.raises(MessageEncodeError, match="nanosecs"):
        to_message("std_msgs/Header", {"stamp": {"sec": 1, "nanosecs": 2}})
    with pytest.raises(MessageEncodeError, match="expected a dict"):
        to_message("geometry_msgs/Pose", {"position": [1, 2, 3]})
    with pytest.raises(MessageEncodeError):
        to_message("geometry_msgs/Point", {"x": "not a number"})
    with LogWriter(tmp_path / "a.mcap", "mcap") as w, pytest.raises(Exception, match="Bar"):
        w.write("/x", "foo_msgs/Bar", {}, T0)


def test_writer_refuses_bad_container_existing_path_and_writes_after_close(
    tmp_path: Path,
) -> None:
    with pytest.raises(LogWriteError, match="unknown log container 'rosbag3'"):
        LogWriter(tmp_path / "a", "rosbag3")
    existing = tmp_path / "b.mcap"
    existing.write_bytes(b"old")
    with pytest.raises(LogWriteError, match="exists already"):
        LogWriter(existing, "mcap")
    with pytest.raises(LogWriteError, match="not an MCAP log aion wrote"):  # not ours: kept
        LogWriter(existing, "mcap", overwrite=True)
    assert existing.read_bytes() == b"old"
    existing.unlink()
    with LogWriter(existing, "mcap") as w:  # an MCAP log, replaced below
        w.write("/p", "geometry_msgs/PoseStamped", {"pose": {"position": {"x": 3}}}, T0)
    with LogWriter(existing, "mcap", overwrite=True) as w:
        w.write("/p", "geometry_msgs/PoseStamped", {"pose": {"position": {"x": 4}}}, T0)
    with pytest.raises(LogWriteError, match="closed"):
        w.write("/q", "geometry_msgs/PoseStamped", {}, T0)
    ((_t, msg),) = _read_anyreader(existing)["/p"]
    assert msg.pose.position.x == 4.0


@pytest.mark.parametrize("container", ["mcap", "mcap-ros1"])
def test_every_shipped_schema_is_accepted_by_the_mcap_decoders(
    container: str, tmp_path: Path
) -> None:
    """The definition texts must parse in mcap_ros2 / mcap_ros1 (genpy), as in Foxglove."""
    from aion_cli.formats.msgdefs import SUPPORTED_MSGTYPES

    ros_version = 1 if container == "mcap-ros1" else 2
    path = tmp_path / "all.mcap"
    types = SUPPORTED_MSGTYPES[ros_version]
    with LogWriter(path, container) as w:
        for k, msgtype in enumerate(types):
            w.write(f"/t{k}", msgtype, {}, T0 + k)
    decoded = _read_mcap(path)
    assert sorted(decoded) == sorted(f"/t{k}" for k in range(len(types)))
    for k in range(len(types)):
        ((t, _),) = decoded[f"/t{k}"]
        assert t == T0 + k


def test_type_spellings_share_one_connection(tmp_path: Path) -> None:
    path = tmp_path / "b2"
    with LogWriter(path, "rosbag2-sqlite3") as w:
        w.write("/p", "geometry_msgs/Point", {"x": 1}, T0)
        w.write("/p", "geometry_msgs/msg/Point", {"x": 2}, T0 + 1)
        w.write_raw(
            "/p", "geometry_msgs/Point", w.serialize("geometry_msgs/Point", {"x": 3}), T0 + 2
        )
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        assert len(reader.connections) == 1
    assert [m.x for _, m in _read_anyreader(path)["/p"]] == [1.0, 2.0, 3.0]
