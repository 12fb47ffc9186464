"""TOML mappings of planar poses -- a path per coordinate, a path to an x, y message (a Pose2D,
two numbers), a yaw -- with known answers, bad planar mappings as clear ConfigErrors, and the
suggested mappings of planar types (turtlesim's poses of a real bag among them).

Split from tests/formats/test_detections_mapping.py (a custom 3D type, filters, overrides)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.errors import ConfigError
from aion_cli.formats.detections.mapping import load_mapping
from aion_cli.formats.raw import RawMessage

PLANAR = """
[[topic]]
topic = "/turtle"
msgtype = "turtles/msg/Pose"
position = ["x", "y"]
yaw = "theta"
frame_override = "world"
"""


@pytest.fixture(scope="module")
def planar_store() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg("float32 x\nfloat32 y\nfloat32 theta\n", "turtles/msg/Pose"))
    ts.register(get_types_from_msg("geometry_msgs/Pose2D pose\nuint32 id\n", "crowd/msg/Person"))
    ts.register(
        get_types_from_msg("std_msgs/Header header\ncrowd/Person[] people\n", "crowd/msg/Planar")
    )
    return ts


def _turtle(store: Any, x: float, y: float, theta: float, t: int) -> RawMessage:
    msg = store.types["turtles/msg/Pose"](x=x, y=y, theta=theta)
    return RawMessage(
        "/turtle", "turtles/msg/Pose", t, bytes(store.serialize_cdr(msg, msg.__msgtype__)), "cdr"
    )


def test_a_planar_pose_maps_with_a_path_per_coordinate_and_a_yaw(planar_store: Any) -> None:
    (m,) = load_mapping(PLANAR)
    m = m.check(planar_store)
    got = m.adapter(planar_store).decode(
        [_turtle(planar_store, 1.5, -2.0, 0.5, 10), _turtle(planar_store, 3.0, 4.0, -3.0, 20)]
    )
    np.testing.assert_array_equal(got.xyz, [[1.5, -2.0, 0.0], [3.0, 4.0, 0.0]])
    np.testing.assert_allclose(got.yaw, np.float32([0.5, -3.0]), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(got.t_ns, [10, 20])  # no header: the log times
    assert got.frame_names() == ["world", "world"]
    with_z = load_mapping(PLANAR.replace('["x", "y"]', '["x", "y", "theta"]'))[0]
    z = (
        with_z.check(planar_store)
        .adapter(planar_store)
        .decode([_turtle(planar_store, 1, 2, 0.25, 1)])
    )
    np.testing.assert_array_equal(z.xyz, [[1.0, 2.0, 0.25]])


def test_a_path_to_a_planar_message_reads_z_as_zero(planar_store: Any) -> None:
    """``position`` naming a Pose2D (x, y, theta: no z) reads z = 0; ``yaw`` its theta."""
    T = planar_store.types
    (m,) = load_mapping(
        '[[topic]]\ntopic = "/crowd"\nmsgtype = "crowd/msg/Planar"\narray = "people"\n'
        'position = "pose"\nyaw = "pose.theta"\nid = "id"\n'
    )
    m.check(planar_store)
    Time = T["builtin_interfaces/msg/Time"]
    person = T["crowd/msg/Person"]
    pose2d = T["geometry_msgs/msg/Pose2D"]
    msg = T["crowd/msg/Planar"](
        header=T["std_msgs/msg/Header"](stamp=Time(sec=5, nanosec=0), frame_id="map"),
        people=[
            person(pose=pose2d(x=1.0, y=2.0, theta=0.5), id=7),
            person(pose=pose2d(x=-3.0, y=0.5, theta=-1.0), id=9),
        ],
    )
    data = bytes(planar_store.serialize_cdr(msg, "crowd/msg/Planar"))
    got = m.adapter(planar_store).decode([RawMessage("/crowd", "crowd/msg/Planar", 9, data, "cdr")])
    np.testing.assert_array_equal(got.xyz, [[1.0, 2.0, 0.0], [-3.0, 0.5, 0.0]])
    np.testing.assert_allclose(got.yaw, [0.5, -1.0], atol=1e-12)
    np.testing.assert_array_equal(got.t_ns, [5 * 10**9] * 2)
    assert got.frame_names() == ["map", "map"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (('["x", "y"]', '["x"]'), "names 2 or 3 number fields"),
        (('["x", "y"]', '["x", 2]'), "names 2 or 3 number fields"),
        (('yaw = "theta"', 'yaw = "theta"\norientation = "q"'), "not both"),
        (('yaw = "theta"', "yaw = 1"), "'yaw' must be a string"),
    ],
)
def test_bad_planar_mappings(change: tuple[str, str], message: str) -> None:
    assert change[0] in PLANAR
    with pytest.raises(ConfigError, match=message):
        load_mapping(PLANAR.replace(*change))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (('yaw = "theta"', 'yaw = "nothing"'), "has no field 'nothing'"),
        (('["x", "y"]', '["x", "nothing"]'), "has no field 'nothing'"),
    ],
)
def test_planar_paths_are_checked(planar_store: Any, change: tuple[str, str], message: str) -> None:
    (m,) = load_mapping(PLANAR.replace(*change))
    with pytest.raises(ConfigError, match=message):
        m.check(planar_store)


def test_a_yaw_or_coordinate_that_is_not_a_number_is_refused(planar_store: Any) -> None:
    text = (
        '[[topic]]\ntopic = "/crowd"\nmsgtype = "crowd/msg/Planar"\narray = "people"\n'
        'position = ["pose.x", "pose.y"]\nyaw = "pose"\n'
    )
    (m,) = load_mapping(text)
    with pytest.raises(ConfigError, match="yaw path 'pose' must lead to a number"):
        m.check(planar_store)


def test_turtlesim_poses_of_a_real_bag_map_as_suggested() -> None:
    """rosbag.js' example bag (turtlesim/Pose: float32 x, y, theta, no header): the mapping
    ``aion info --suggest-mapping`` prints reads every /turtle1/pose message, each position
    and yaw equal to rosbags' own decoding of it."""
    from aion_cli.formats.detections.suggest import suggest_mapping
    from aion_cli.formats.logs import open_logs
    from tests.shared_data import real

    bag = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    with open_logs([bag]) as logs:
        messages = list(logs.messages(["/turtle1/pose"]))
        store = logs.typestore("/turtle1/pose", messages[0].msgtype, messages[0].encoding)
        text = suggest_mapping("/turtle1/pose", "turtlesim/msg/Pose", store)
        assert 'position = ["x", "y"]' in text
        assert 'yaw = "theta"' in text
        (m,) = load_mapping(text)
        m = m.check(store)
        got = m.adapter(store).decode(messages)
        poses = [logs.decode(msg) for msg in messages]
    assert len(messages) == len(got) == 1344
    np.testing.assert_array_equal(got.xyz[:, 0], [p.x for p in poses])
    np.testing.assert_array_equal(got.xyz[:, 1], [p.y for p in poses])
    assert not got.xyz[:, 2].any()
    theta = np.array([p.theta for p in poses], np.float64)  # turtlesim's grows past pi
    np.testing.assert_allclose(np.angle(np.exp(1j * (got.yaw - theta))), 0.0, atol=1e-6)
    assert got.frame_names() == ["map"] * 1344


def test_a_suggested_mapping_finds_an_array_of_planar_people(planar_store: Any) -> None:
    """``crowd/Planar``: ``Person[] people``, each a Pose2D and an id: the suggestion names
    the array, the Pose2D as the position and its theta as the yaw, and it decodes."""
    from aion_cli.formats.detections.suggest import suggest_mapping

    text = suggest_mapping("/crowd", "crowd/msg/Planar", planar_store)
    assert 'array = "people"' in text
    assert 'position = "pose"' in text
    assert 'yaw = "pose.theta"' in text
    (m,) = load_mapping(text)
    m.check(planar_store)


def test_a_suggested_mapping_reads_two_numbers_as_a_planar_position() -> None:
    """A tracker's items with ``float32[2] pos`` (a fixed array of two numbers, no z) and a
    ``heading``: the mapping accepts ``pos[0..1]``, so the suggestion names it (it used to
    refuse the type as having no position, and ``aion info`` said no mapping could read
    it), with the heading beside it as the yaw; the suggestion decodes the written values."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from aion_cli.formats.detections.suggest import suggest_mapping

    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(
        get_types_from_msg("int64 track_id\nfloat32[2] pos\nfloat32 heading\n", "trk/msg/Obj")
    )
    ts.register(get_types_from_msg("std_msgs/Header header\ntrk/Obj[] objects\n", "trk/msg/Objs"))
    text = suggest_mapping("/objects", "trk/msg/Objs", ts)
    assert 'array = "objects"' in text
    assert 'position = "pos[0..1]"' in text
    assert 'yaw = "heading"' in text
    assert 'id = "track_id"' in text
    (m,) = load_mapping(text)
    m = m.check(ts)
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]
    obj = T["trk/msg/Obj"]
    msg = T["trk/msg/Objs"](
        header=T["std_msgs/msg/Header"](stamp=Time(sec=7, nanosec=5), frame_id="odom"),
        objects=[
            obj(track_id=3, pos=np.array([1.25, -2.5], np.float32), heading=np.float32(0.5)),
            obj(track_id=8, pos=np.array([4.0, 0.75], np.float32), heading=np.float32(-1.0)),
        ],
    )
    data = bytes(ts.serialize_cdr(msg, "trk/msg/Objs"))
    got = m.adapter(ts).decode([RawMessage("/objects", "trk/msg/Objs", 9, data, "cdr")])
    np.testing.assert_array_equal(got.xyz, [[1.25, -2.5, 0.0], [4.0, 0.75, 0.0]])
    np.testing.assert_allclose(got.yaw, [0.5, -1.0], atol=1e-7)
    np.testing.assert_array_equal(got.t_ns, [7 * 10**9 + 5] * 2)
    assert got.frame_names() == ["odom", "odom"]
    assert got.track_id.tolist() == [3, 8]


def test_the_suggested_frame_override_is_the_logs_tf_root() -> None:
    """turtlesim's poses carry no header, so the mapping needs a ``frame_override``: it used
    to say "map" although the bag's TF tree hangs from ``world`` (read here with rosbags);
    it now names that root."""
    from rosbags.highlevel import AnyReader

    from aion_cli.log_report import suggest
    from tests.shared_data import real

    bag = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    parents, children = set(), set()
    with AnyReader([bag]) as reader:
        tf = [c for c in reader.connections if c.topic in ("/tf", "/tf_static")]
        for conn, _, raw in reader.messages(connections=tf):
            for t in reader.deserialize(raw, conn.msgtype).transforms:
                parents.add(t.header.frame_id.lstrip("/"))
                children.add(t.child_frame_id.lstrip("/"))
    (top,) = parents - children
    text = suggest([bag], None, "/turtle1/pose")
    assert f'frame_override = "{top}"' in text
    assert 'frame_override = "map"' not in text
