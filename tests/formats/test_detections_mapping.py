"""TOML mappings: reading a custom message type with known answers, filters, overrides, and
clear ConfigErrors for bad files and bad paths (naming the path and the available fields)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import ConfigError
from aion_cli.formats import msgdefs
from aion_cli.formats.detections import adapter_for, hash_id
from aion_cli.formats.detections.mapping import load_mapping
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import header, pose, raw

MSGTYPE = "my_tracker/msg/Tracks"


@pytest.fixture(scope="module")
def store() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(
        get_types_from_msg(
            "string label\nfloat32[3] position\ngeometry_msgs/Vector3 vel\nstring uid\n"
            "std_msgs/Header header\n",
            "my_tracker/msg/Track",
        )
    )
    ts.register(
        get_types_from_msg("std_msgs/Header header\nmy_tracker/Track[] tracks\n", MSGTYPE)
    )
    return ts


def _message(store: Any, frame: str = "/odom") -> RawMessage:
    T = store.types
    Time = T["builtin_interfaces/msg/Time"]

    def track(label: str, xyz: list[float], uid: str, sec: int) -> Any:
        return T["my_tracker/msg/Track"](
            label=label,
            position=np.asarray(xyz, np.float32),
            vel=T["geometry_msgs/msg/Vector3"](x=0.5, y=0.0, z=0.0),
            uid=uid,
            header=T["std_msgs/msg/Header"](stamp=Time(sec=sec, nanosec=0), frame_id=""),
        )

    msg = T[MSGTYPE](
        header=T["std_msgs/msg/Header"](stamp=Time(sec=10, nanosec=5), frame_id=frame),
        tracks=[
            track("person", [1.0, 2.0, 0.5], "a", 0),
            track("dog", [9.0, 9.0, 0.0], "b", 0),
            track("person", [-1.5, 0.25, 0.0], "c", 11),
        ],
    )
    return RawMessage("/tracks", MSGTYPE, 77, bytes(store.serialize_cdr(msg, MSGTYPE)), "cdr")


MAPPING = """
[[topic]]
topic = "/tracks"
msgtype = "my_tracker/Tracks"
array = "tracks"
position = "position[0..2]"
velocity = "vel"
id = "uid"
item_header = "header"
filter = { field = "label", equals = ["person", "pedestrian"] }
"""


def test_custom_type_known_answers(store: Any) -> None:
    (m,) = load_mapping(MAPPING)
    assert m.topic == "/tracks"
    assert m.msgtype == MSGTYPE
    m.check(store)
    got = m.adapter(store).decode([_message(store)])
    np.testing.assert_array_equal(got.xyz, [[1.0, 2.0, 0.5], [-1.5, 0.25, 0.0]])
    np.testing.assert_array_equal(got.velocity, [[0.5, 0, 0]] * 2)
    assert np.isnan(got.yaw).all()
    np.testing.assert_array_equal(got.track_id, [hash_id("a"), hash_id("c")])
    np.testing.assert_array_equal(got.t_ns, [10_000_000_005, 11_000_000_000])
    assert got.frame_names() == ["odom", "odom"]
    assert got.filtered == {"filter": 1, 'seen: label = "dog"': 1}  # the value it dropped


def test_a_filter_counts_the_first_values_it_dropped(store: Any) -> None:
    """A filter on ``uid`` that keeps none of 10 tracks (uids u0..u9, labels alternating):
    every track dropped as ``filter``; the first 8 uids counted by value (a filter on an id
    would see thousands); the build's hint names them and the 2 of other values."""
    from aion_cli.build_hints import no_detection_hint
    from aion_cli.detection_counts import DetectionCounts

    T = store.types
    Time = T["builtin_interfaces/msg/Time"]
    header = T["std_msgs/msg/Header"](stamp=Time(sec=10, nanosec=0), frame_id="odom")
    tracks = [
        T["my_tracker/msg/Track"](
            label="person" if k % 2 else "dog", position=np.zeros(3, np.float32),
            vel=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0), uid=f"u{k}", header=header,
        )
        for k in range(10)
    ]  # fmt: skip
    msg = T[MSGTYPE](header=header, tracks=tracks)
    data = bytes(store.serialize_cdr(msg, MSGTYPE))
    mapping = MAPPING.replace('field = "label", equals = ["person", "pedestrian"]',
                              'field = "uid", equals = ["nobody"]')  # fmt: skip
    (m,) = load_mapping(mapping)
    got = m.adapter(store).decode([RawMessage("/tracks", MSGTYPE, 77, data, "cdr")] * 2)
    assert len(got) == 0
    firsts = {f'seen: uid = "u{k}"': 2 for k in range(8)}
    assert got.filtered == {"filter": 20, **firsts}
    counts = DetectionCounts()
    counts.add_decoded(counts.topic("/tracks"), got.filtered)
    assert (counts.read, dict(counts.dropped)) == (20, {"filter": 20})
    hint = no_detection_hint(["/tracks"], counts.dropped, counts.filter_seen)
    assert hint.startswith(
        'the --detections-mapping\'s filter dropped all 20 items; its field held uid = "u0" '
        '(2), uid = "u1" (2),'
    )
    assert 'uid = "u7" (2), 4 of other values; list the values' in hint
    assert "u8" not in hint


def test_frame_override_and_log_time_stamps(store: Any, tmp_path: Path) -> None:
    text = MAPPING.replace('item_header = "header"\n', 'stamp = ""\nframe_override = "map"\n')
    path = tmp_path / "m.toml"
    path.write_text(text)
    (m,) = load_mapping(path)
    m.check(store)
    got = m.adapter(store).decode([_message(store)])
    np.testing.assert_array_equal(got.t_ns, [77, 77])
    assert got.stamp_fallbacks == 2
    assert got.frame_names() == ["map", "map"]


def test_mapping_of_a_known_type_matches_the_builtin_adapter() -> None:
    text = """
[[topic]]
topic = "/spencer"
msgtype = "spencer_tracking_msgs/msg/TrackedPersons"
array = "tracks"
position = "pose.pose.position"
velocity = "twist.twist.linear"
orientation = "pose.pose.orientation"
id = "track_id"
"""
    (m,) = load_mapping(text)
    m.check(msgdefs.typestore(1))
    tracks = [
        {"track_id": 3, "pose": {"pose": pose(1, 2, 3, (0, 0, 1, 0))},
         "twist": {"twist": {"linear": {"x": 1.0, "y": -1.0}}}},
        {"track_id": 8, "pose": {"pose": pose(-4, 5, 0, (0, 0, 0, 1))}},
    ]
    msg = raw(m.msgtype, {"header": header(2, 3, "odom"), "tracks": tracks}, 1, 1)
    mine = m.adapter().decode([msg])
    builtin = adapter_for(m.msgtype)
    assert builtin is not None
    ref = builtin.decode([msg])
    for field in ("t_ns", "xyz", "velocity", "yaw", "track_id"):
        np.testing.assert_array_equal(getattr(mine, field), getattr(ref, field))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (('position = "position[0..2]"', 'position = "pos"'),
         r"my_tracker/msg/Track has no field 'pos'; available: label, position, vel, uid"),
        (('position = "position[0..2]"', 'position = "position[1..3]"'),
         "index 3 out of range"),
        (('position = "position[0..2]"', 'position = "label"'),
         "position must point to 3 numbers"),
        (('array = "tracks"', 'array = "header"'), "not an array"),
        (('velocity = "vel"', 'velocity = "header.stamp"'), "must be a Point/Vector3"),
        (('id = "uid"', 'id = "header.seq"'), "std_msgs/msg/Header has no field 'seq'"),
        (('id = "uid"', 'id = "vel.x"'),
         "id path 'vel.x' must lead to an integer, a string or a UUID, not a float64 value"),
        (('id = "uid"', 'id = "vel"'), "not a message geometry_msgs/msg/Vector3"),
        (('field = "label"', 'field = "kind"'), "filter.field path 'kind'"),
        (('id = "uid"', 'id = "uid"\nstamp = "header.frame_id"'),
         "stamp path 'header.frame_id' must lead to a time stamp .* not a string value"),
        (('id = "uid"', 'id = "uid"\nstamp = "tracks"'),
         "stamp path 'tracks' must lead to a time stamp .* not an array"),
        # a filter value of another kind than its field never matches: every item dropped
        (('equals = ["person", "pedestrian"]', "equals = [1, 2]"),
         r"filter on 'label' \(string value\): equals must list strings, got \[1, 2\]"),
        (('equals = ["person", "pedestrian"]', "equals = []"), "equals must list strings"),
        (('field = "label"', 'field = "vel.x"'),
         r"filter on 'vel.x' \(float64 value\): equals must list numbers"),
        (('field = "label"', 'field = "vel"'),
         "filter.field path 'vel' must lead to a string, number or bool to compare"),
        (('id = "uid"', 'id = "uid"\nframe = "header.stamp"'),
         "frame path 'header.stamp' must lead to a frame name .* not a message "
         "builtin_interfaces/msg/Time"),
    ],
)
def test_check_names_bad_paths(store: Any, change: tuple[str, str], message: str) -> None:
    assert change[0] in MAPPING
    (m,) = load_mapping(MAPPING.replace(*change))
    with pytest.raises(ConfigError, match=message):
        m.check(store)


def test_check_unknown_message_type(store: Any) -> None:
    (m,) = load_mapping(MAPPING.replace("my_tracker/Tracks", "nobody/Nothing"))
    with pytest.raises(ConfigError, match="'nobody/msg/Nothing' is not known"):
        m.check(store)


def test_bad_path_at_decode_time_names_the_fields(store: Any) -> None:
    (m,) = load_mapping(MAPPING.replace('id = "uid"', 'id = "track_id"'))
    with pytest.raises(ConfigError, match="has no field 'track_id'; available: label, position"):
        m.adapter(store).decode([_message(store)])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[[topic]\n", "not valid TOML"),
        ("x = 1\n", "no \\[\\[topic\\]\\] tables"),
        ('[[topic]]\ntopic = "/a"\nmsgtype = "a/B"\n', "'position' is required"),
        (MAPPING + "colour = 'red'\n", "unknown keys \\['colour'\\]"),
        (MAPPING.replace('"position[0..2]"', '"position[2..0]"'), "range \\[2..0\\] is empty"),
        (MAPPING.replace('"position[0..2]"', '"position..x"'), "cannot parse ''"),
        (MAPPING.replace('id = "uid"', "id = 3"), "'id' must be a string"),
        (MAPPING.replace("equals = ", "is = "), "filter must be"),
    ],
)
def test_bad_mapping_files(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        load_mapping(text)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read mapping file"):
        load_mapping(tmp_path / "absent.toml")


def test_a_suggested_mapping_finds_a_pose_with_covariance_of_autoware_objects() -> None:
    """Autoware's ``TrackedObjects``: each object's position is
    ``kinematics.pose_with_covariance.pose.position``. The suggestion used to pass over it
    (the path says "covariance") and refuse the type as having no position; it now names it,
    the twist's linear part as the velocity and the UUID as the id, and decodes them."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from aion_cli.formats.detections.suggest import suggest_mapping

    ts = get_typestore(Stores.ROS2_HUMBLE)
    aw = "autoware_perception_msgs/msg/"
    for name, text in (
        ("unique_identifier_msgs/msg/UUID", "uint8[16] uuid\n"),
        (aw + "Shape", "uint8 type\ngeometry_msgs/Polygon footprint\n"
         "geometry_msgs/Vector3 dimensions\n"),
        (aw + "TrackedObjectKinematics", "geometry_msgs/PoseWithCovariance pose_with_covariance\n"
         "uint8 orientation_availability\ngeometry_msgs/TwistWithCovariance twist_with_covariance\n"
         "geometry_msgs/AccelWithCovariance acceleration_with_covariance\nbool is_stationary\n"),
        (aw + "TrackedObject", "unique_identifier_msgs/UUID object_id\n"
         "float32 existence_probability\nautoware_perception_msgs/TrackedObjectKinematics "
         "kinematics\nautoware_perception_msgs/Shape shape\n"),
        (aw + "TrackedObjects", "std_msgs/Header header\n"
         "autoware_perception_msgs/TrackedObject[] objects\n"),
    ):  # fmt: skip
        ts.register(get_types_from_msg(text, name))
    text = suggest_mapping("/objects", aw + "TrackedObjects", ts)
    kin = "kinematics."
    assert f'position = "{kin}pose_with_covariance.pose.position"' in text
    assert f'velocity = "{kin}twist_with_covariance.twist.linear"' in text
    assert 'id = "object_id"' in text
    (m,) = load_mapping(text)
    m = m.check(ts)
    T = ts.types
    vec = T["geometry_msgs/msg/Vector3"]
    pwc = T["geometry_msgs/msg/PoseWithCovariance"]
    twc = T["geometry_msgs/msg/TwistWithCovariance"]
    awc = T["geometry_msgs/msg/AccelWithCovariance"]

    def obj(uid: int, x: float, y: float, vx: float) -> Any:
        p = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        )
        kinematics = T[aw + "TrackedObjectKinematics"](
            pose_with_covariance=pwc(pose=p, covariance=np.zeros(36)),
            orientation_availability=0,
            twist_with_covariance=twc(
                twist=T["geometry_msgs/msg/Twist"](linear=vec(x=vx, y=0.0, z=0.0),
                                                   angular=vec(x=0.0, y=0.0, z=0.0)),
                covariance=np.zeros(36)),
            acceleration_with_covariance=awc(
                accel=T["geometry_msgs/msg/Accel"](linear=vec(x=9.0, y=9.0, z=9.0),
                                                   angular=vec(x=0.0, y=0.0, z=0.0)),
                covariance=np.zeros(36)),
            is_stationary=False,
        )  # fmt: skip
        return T[aw + "TrackedObject"](
            object_id=T["unique_identifier_msgs/msg/UUID"](uuid=np.full(16, uid, np.uint8)),
            existence_probability=1.0, kinematics=kinematics,
            shape=T[aw + "Shape"](type=0, footprint=T["geometry_msgs/msg/Polygon"](points=[]),
                                  dimensions=vec(x=0.5, y=0.5, z=1.7)),
        )  # fmt: skip

    msg = T[aw + "TrackedObjects"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=3, nanosec=0), frame_id="map"
        ),
        objects=[obj(1, 2.5, -1.0, 1.25), obj(2, -4.0, 6.0, -0.5)],
    )
    data = bytes(ts.serialize_cdr(msg, aw + "TrackedObjects"))
    got = m.adapter(ts).decode([RawMessage("/objects", aw + "TrackedObjects", 9, data, "cdr")])
    np.testing.assert_array_equal(got.xyz, [[2.5, -1.0, 0.0], [-4.0, 6.0, 0.0]])
    np.testing.assert_array_equal(got.velocity, [[1.25, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    assert got.track_id.tolist() == [hash_id(bytes([1] * 16)), hash_id(bytes([2] * 16))]


# -- a velocity of two numbers, an element's own time and frame without a header ------------

BLOBS = """
[[topic]]
topic = "/blobs"
msgtype = "blobs/msg/Blobs"
array = "blobs"
position = ["x", "y"]
velocity = ["vx", "vy"]
item_stamp = "t"
item_frame = "frame"
"""


def test_a_velocity_per_axis_and_item_times_and_frames_without_a_header() -> None:
    """Each element's ``t`` (a Time here; integer nanoseconds in tests/cli) and ``frame`` are
    its detection's time and frame; ``vx``, ``vy`` its velocity (vz = 0). The message has no
    header and no frame_override: the elements' own frames are enough."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(
        "builtin_interfaces/Time t\nstring frame\nfloat64 x\nfloat64 y\nfloat64 vx\n"
        "float64 vy\n", "blobs/msg/Blob",
    ))  # fmt: skip
    ts.register(get_types_from_msg("blobs/Blob[] blobs\n", "blobs/msg/Blobs"))
    T = ts.types
    Time, Blob = T["builtin_interfaces/msg/Time"], T["blobs/msg/Blob"]
    msg = T["blobs/msg/Blobs"](blobs=[
        Blob(t=Time(sec=12, nanosec=5), frame="laser", x=1.0, y=2.0, vx=-1.0, vy=0.25),
        Blob(t=Time(sec=13, nanosec=0), frame="odom", x=3.0, y=4.0, vx=0.0, vy=0.5),
    ])  # fmt: skip
    raw_msg = RawMessage(
        "/blobs", "blobs/msg/Blobs", 99, bytes(ts.serialize_cdr(msg, "blobs/msg/Blobs")), "cdr"
    )
    (m,) = load_mapping(BLOBS)
    m = m.check(ts)
    got = m.adapter(ts).decode([raw_msg])
    np.testing.assert_array_equal(got.t_ns, [12_000_000_005, 13_000_000_000])
    assert got.frame_names() == ["laser", "odom"]
    np.testing.assert_array_equal(got.xyz, [[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]])
    np.testing.assert_array_equal(got.velocity, [[-1.0, 0.25, 0.0], [0.0, 0.5, 0.0]])
    assert got.stamp_fallbacks == 0
