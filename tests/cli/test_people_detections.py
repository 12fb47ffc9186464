"""People detections from the command line, on logs with known contents: the log's own
definitions (a foxy-era Detection3DArray MCAP, a TF fork), decoding failures (all: exit 2,
some: a warning with counts), no usable detection (never a success), topic choice for generic
types (the real leg_tracker bags: tests/cli/test_leg_tracker_bags.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.cli.conftest import assert_one_line_error, map_cells, run, run_json
from tests.cli.own_definitions import (
    DETECTION3D_ARRAY,
    FOXY_VISION_MSGS,
    Message,
    OwnTypes,
    foxy_detection3d_array,
    write_mcap,
)

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
TF = "tf2_msgs/msg/TFMessage"


# --- the log's own definitions ----------------------------------------------------------------


def foxy_log(path: Path, cut: set[int] | None = None, classes: tuple[str, str] = ("person",
             "person")) -> Path:  # fmt: skip
    """The issue's case: 10 foxy Detection3DArrays, each with two people (tracking ids a, b:
    a walks +x, b walks +y, 0.5 m per message) and a car; payloads ``cut`` are truncated."""
    own = OwnTypes(FOXY_VISION_MSGS)
    msgs = []
    for k in range(10):
        t = T0 + k * S // 2
        people = [
            (classes[0], "a", 1.0 + 0.5 * k, 1.0),
            (classes[1], "b", 8.0, 1.0 + 0.5 * k),
            ("car", "c", 20.0, 20.0),
        ]
        data = own.cdr(foxy_detection3d_array(own, t, "map", people), DETECTION3D_ARRAY)
        if cut and k in cut:
            data = data[: len(data) // 2]
        msgs.append(Message("/detections", DETECTION3D_ARRAY, data, t))
    return write_mcap(path, msgs, {DETECTION3D_ARRAY: own.definition(DETECTION3D_ARRAY)})


def test_foxy_detection3d_array_mcap_builds_with_its_20_detections(tmp_path: Path) -> None:
    log = foxy_log(tmp_path / "foxy.mcap")
    info = run_json("info", log, "--format", "json")
    assert info["will_use"]["detections"] == ["/detections"]
    out = tmp_path / "foxy.aion"
    report = run_json("build", log, "-o", out, "--format", "json")
    assert report["detections"] == {"read": 30, "used": 20, "dropped": {"class": 10}}
    assert report["detection_decoding"]["/detections"] == {
        "type": DETECTION3D_ARRAY, "why": "people type", "decoder": "generic",
        "messages": 10, "undecodable": 0,
    }  # fmt: skip
    assert any("differs from the layout of aion's fast decoder" in n for n in report["notes"])
    assert report["warnings"] == []
    # tracks a and b are differenced; their first sightings have no heading: every
    # orientation of the topic is the identity, which says nothing about direction
    assert report["headings"] == {"velocity": 0, "track": 18, "linked": 0, "pose_yaw": 0,
                                  "none": 2}  # fmt: skip
    xy, counts, nodir = map_cells(out)
    assert counts.sum() == 18
    assert nodir.sum() == 2
    # bin(θ) = floor((θ + π) / (π/4)): a heads 0 -> bin 4, b heads π/2 -> bin 6
    assert counts.sum(axis=0).tolist() == [0, 0, 0, 0, 9, 0, 9, 0]
    # every detection in its own 0.5-m cell: a at (1 + 0.5k, 1), b at (8, 1 + 0.5k)
    expected = {(1.25 + 0.5 * k, 1.25) for k in range(10)} | {
        (8.25, 1.25 + 0.5 * k) for k in range(10)
    }
    assert {(float(x), float(y)) for x, y in xy} == expected


def test_every_message_undecodable_is_an_error_with_the_reason(tmp_path: Path) -> None:
    log = foxy_log(tmp_path / "cut.mcap", cut=set(range(10)))
    out = tmp_path / "cut.aion"
    result = run("build", log, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr, "none of the 10 messages on /detections", "could be decoded", "cannot"
    )
    assert not out.exists()


def test_some_messages_undecodable_is_a_warning_with_counts(tmp_path: Path) -> None:
    log = foxy_log(tmp_path / "some.mcap", cut={2, 5, 7})
    out = tmp_path / "some.aion"
    report = run_json("build", log, "-o", out, "--format", "json")
    assert report["detections"]["used"] == 14
    assert report["detections"]["dropped"]["undecodable_messages"] == 3
    assert report["detection_decoding"]["/detections"]["undecodable"] == 3
    (warning,) = report["warnings"]
    assert warning.startswith("3 of 10 messages on /detections could not be decoded")
    table = run("build", log, "-o", out)
    assert table.exit_code == 0
    assert "warning: 3 of 10 messages on /detections" in table.stderr


def test_no_usable_detection_is_never_a_success(tmp_path: Path) -> None:
    log = foxy_log(tmp_path / "cars.mcap", classes=("car", "bicycle"))
    out = tmp_path / "cars.aion"
    result = run("build", log, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no people detection in the 10 messages",
                          "dropped: class 30")  # fmt: skip
    assert not out.exists()


def test_a_tracker_that_saw_nobody_is_counted_in_parallel_too(tmp_path: Path) -> None:
    """Six hours of a fixed sensor's empty messages (every 10 s: 2,160), cut into time shards
    by two workers: the refusal counts the topic's messages as one pass does (the parallel
    check rebuilt its counts from the shards' reports without the topics: "in the 0
    messages")."""
    log = tmp_path / "empty.mcap"
    made = run("simulate", "-o", log, "--days", "0.25", "--robot", "fixed", "--agents", "0",
               "-q")  # fmt: skip
    assert made.exit_code == 0, made.stderr
    for workers in ("1", "2"):
        result = run("build", log, "-o", tmp_path / "e.aion", "--workers", workers)
        assert result.exit_code == 2
        assert_one_line_error(result.stderr, "no people detection in the 2,160 messages")


def test_detections_without_a_transform_are_never_a_success(tmp_path: Path) -> None:
    """TF exists but only long after the detections: every detection is a counted drop, and
    a map of nothing is an error that says so."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "late_tf.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(5):
            t = T0 + k * S
            poses = [{"position": {"x": 1.0, "y": 0.0}}]
            w.write("/people/poses", POSE_ARRAY,
                    {"header": {"stamp": stamp(t), "frame_id": "laser"}, "poses": poses}, t)
        for k in range(3):
            t = T0 + (100 + k) * S
            tf = {"header": {"stamp": stamp(t), "frame_id": "map"}, "child_frame_id": "laser",
                  "transform": {"rotation": {"w": 1.0}}}
            w.write("/tf", TF, {"transforms": [tf]}, t)
    result = run("build", log, "-o", tmp_path / "late.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "none of the 5 people detections read could be used",
                          "no_transform 5")  # fmt: skip
    assert "--map-frame" in result.stderr


def _swapped_tf_log(path: Path) -> Path:
    """People at (1, 2) in frame laser; TF map->laser = translation (10, 0, 0), identity
    rotation, in a TFMessage fork whose transforms hold the rotation before the translation
    (same byte size as the standard layout: numpy over the bytes would misread it)."""
    own = OwnTypes(
        {
            "my_geometry/msg/Transform": "geometry_msgs/Quaternion rotation\n"
            "geometry_msgs/Vector3 translation\n",
            "my_geometry/msg/TransformStamped": "std_msgs/Header header\n"
            "string child_frame_id\nmy_geometry/Transform transform\n",
            TF: "my_geometry/TransformStamped[] transforms\n",
        }
    )
    T = own.T
    msgs = []
    for k in range(21):
        t = T0 + k * S // 2
        tr = T["my_geometry/msg/Transform"](
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            translation=T["geometry_msgs/msg/Vector3"](x=10.0, y=0.0, z=0.0),
        )
        ts = T["my_geometry/msg/TransformStamped"](
            header=own.header(t, "map"), child_frame_id="laser", transform=tr
        )
        msgs.append(Message("/tf", TF, own.cdr(T[TF](transforms=[ts]), TF), t))
        if 1 <= k <= 19:
            people = T[POSE_ARRAY](header=own.header(t, "laser"), poses=[own.pose(1.0, 2.0)])
            msgs.append(Message("/people/poses", POSE_ARRAY, own.cdr(people, POSE_ARRAY), t))
    return write_mcap(path, msgs, {TF: own.definition(TF)})


def test_tf_in_another_layout_is_read_with_the_logs_own_definition(tmp_path: Path) -> None:
    out = tmp_path / "tf.aion"
    report = run_json("build", _swapped_tf_log(tmp_path / "tf.mcap"), "-o", out, "--format",
                      "json")  # fmt: skip
    assert report["detections"]["used"] == 19
    xy, _counts, _nodir = map_cells(out)
    assert len(xy) == 1
    np.testing.assert_allclose(xy[0], [11.25, 2.25])  # the 0.5-m cell holding (11, 2)
    # what the layout check prevents: numpy over these bytes reads the rotation as the
    # translation, without an error
    from aion_cli.formats.logs import open_logs
    from aion_cli.formats.tf_fast import decode_tf_messages

    with open_logs([tmp_path / "tf.mcap"]) as logs:
        fast = decode_tf_messages(list(logs.messages({"/tf"})))
    assert not np.allclose(fast.translation, [10.0, 0.0, 0.0])


# --- topic choice -----------------------------------------------------------------------------


def nav_log(path: Path, people: bool = True) -> Path:
    """Navigation goals (PoseStamped), an initial pose, RViz markers and (optionally) a
    people tracker's PoseArray, 10 messages each."""
    from aion_cli.formats.writers import LogWriter, stamp

    with LogWriter(path, "mcap") as w:
        for k in range(10):
            t = T0 + k * S
            hdr = {"stamp": stamp(t), "frame_id": "map"}
            p = {"position": {"x": 3.0 + 0.5 * k, "y": 1.0}, "orientation": {"w": 1.0}}
            w.write("/move_base_simple/goal", "geometry_msgs/msg/PoseStamped",
                    {"header": hdr, "pose": p}, t)
            w.write("/initialpose", "geometry_msgs/msg/PoseWithCovarianceStamped",
                    {"header": hdr, "pose": {"pose": p}}, t)
            w.write("/rviz/markers", "visualization_msgs/msg/MarkerArray",
                    {"markers": [{"header": hdr, "pose": p}]}, t)
            if people:
                w.write("/people_tracker/poses", POSE_ARRAY, {"header": hdr, "poses": [p, p]}, t)
    return path


def test_generic_types_are_taken_only_from_topics_that_suggest_people(tmp_path: Path) -> None:
    log = nav_log(tmp_path / "nav.mcap")
    info = run_json("info", log, "--format", "json")
    why = {t["topic"]: (t["used"], t["why"]) for t in info["topics"]}
    assert why == {
        "/initialpose": (False, "skipped: generic PoseWithCovarianceStamped on /initialpose "
                         "(name does not suggest people; name it with --detections-topic)"),
        "/move_base_simple/goal": (False, "skipped: generic PoseStamped on "
                                   "/move_base_simple/goal (name does not suggest people; name "
                                   "it with --detections-topic)"),
        "/people_tracker/poses": (True, "generic PoseArray, the name suggests people"),
        "/rviz/markers": (False, "skipped: generic MarkerArray on /rviz/markers (name does not "
                          "suggest people; name it with --detections-topic)"),
    }  # fmt: skip
    assert info["will_use"]["detections"] == ["/people_tracker/poses"]
    table = run("info", log)
    assert table.exit_code == 0
    assert "name does not suggest people" in " ".join(table.stdout.split())
    report = run_json("build", log, "-o", tmp_path / "nav.aion", "--format", "json")
    assert report["detection_topics"] == ["/people_tracker/poses"]
    assert report["detections"]["read"] == 20
    named = run_json("build", log, "-o", tmp_path / "goal.aion", "--format", "json",
                     "--detections-topic", "/move_base_simple/goal")  # fmt: skip
    assert named["detection_topics"] == ["/move_base_simple/goal"]
    assert named["detection_decoding"]["/move_base_simple/goal"]["why"] == (
        "named with --detections-topic"
    )
    assert named["detections"]["read"] == 10


def test_a_log_without_ros_topics_is_refused_with_a_hint_that_says_so(tmp_path: Path) -> None:
    """An MCAP whose only channel is JSON (not ROS): the hint says there is no ROS topic
    (it listed an empty topic list before: "the log has: ; map a type ...")."""
    from mcap.writer import Writer

    log = tmp_path / "json_only.mcap"
    with log.open("wb") as f:
        writer = Writer(f)
        writer.start()
        schema = writer.register_schema("Person", "jsonschema", b"{}")
        channel = writer.register_channel("/people", "json", schema)
        for k in range(3):
            writer.add_message(channel, k * 10**9, b'{"x": 1}', k * 10**9)
        writer.finish()
    result = run("build", log, "-o", tmp_path / "json.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no people-detection topic of a supported type")
    assert "hint: it has no ROS topic aion can read" in result.stderr
    assert "the log has: ;" not in result.stderr
    assert not (tmp_path / "json.aion").exists()


def test_a_log_of_navigation_goals_only_is_refused_with_the_reason(tmp_path: Path) -> None:
    log = nav_log(tmp_path / "goals.mcap", people=False)
    result = run("build", log, "-o", tmp_path / "goals.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no people-detection topic of a supported type")
    assert (
        "hint: skipped: generic PoseWithCovarianceStamped on /initialpose (name does not "
        "suggest people; name it with --detections-topic); or map another type with "
        "--detections-mapping FILE"
    ) in " ".join(result.stderr.split())


def test_a_log_of_raw_laser_scans_points_to_a_people_tracker(tmp_path: Path) -> None:
    """A log of LaserScans only (as leg_tracker's demo bag): no mapping can read people from
    a scan, so neither info, nor the build, nor --suggest-mapping offers one (all three
    said a TOML mapping could read it)."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "scans.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(5):
            t = T0 + k * S
            scan = {"header": {"stamp": stamp(t), "frame_id": "laser"}, "ranges": [1.0, 2.0]}
            w.write("/scan", "sensor_msgs/msg/LaserScan", scan, t)
    info = run_json("info", log, "--format", "json")
    (topic,) = info["topics"]
    assert topic["why"] == "skipped: LaserScan is raw sensor data, not detected people"
    table = run("info", log)
    assert "it holds only raw sensor data" in " ".join(table.stderr.split())
    tracker = "record what a people detector or tracker makes of it"
    refused = run("build", log, "-o", tmp_path / "scans.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "no people-detection topic of a supported type")
    hint = f"hint: it holds only raw sensor data (/scan (sensor_msgs/msg/LaserScan)): {tracker}"
    assert hint in " ".join(refused.stderr.split())
    suggested = run("info", log, "--suggest-mapping", "/scan")
    assert suggested.exit_code == 2
    assert_one_line_error(suggested.stderr, "raw sensor data")
    assert tracker in suggested.stderr
    assert not (tmp_path / "scans.aion").exists()


def test_plumbing_topics_are_not_offered_a_mapping(tmp_path: Path) -> None:
    """A std_msgs String holds no positions: it is skipped as such, while a type a mapping
    may read (a Vector3Stamped: PointStamped is read as a generic type) keeps the pointer."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "chatter.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(3):
            t = T0 + k * S
            w.write("/chatter", "std_msgs/msg/String", {"data": f"hello {k}"}, t)
            w.write("/odom_marker", "geometry_msgs/msg/Vector3Stamped",
                    {"header": {"stamp": stamp(t), "frame_id": "map"}}, t)
    why = {t["topic"]: t["why"] for t in run_json("info", log, "--format", "json")["topics"]}
    assert why["/chatter"] == "skipped: String (std_msgs) holds no positions of people"
    assert "a TOML mapping can read it" in why["/odom_marker"]
    # the build's hint offers the topic a mapping may read, by name
    refused = run("build", log, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert "`aion info LOG --suggest-mapping /odom_marker` writes one" in refused.stderr


def test_a_type_without_a_position_is_not_offered_a_mapping(tmp_path: Path) -> None:
    """A Twist (velocities only) was 'not a type aion reads (a TOML mapping can read it:
    --detections-mapping)' while info's note on the same log said 'none of its types has a
    field a --detections-mapping could read as a position' (and --suggest-mapping refuses
    it); its reason now says it has no such field. A Vector3Stamped keeps the offer."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "cmd.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(3):
            t = T0 + k * S
            w.write("/cmd_vel", "geometry_msgs/msg/Twist", {"linear": {"x": 0.5}}, t)
    why = {t["topic"]: t["why"] for t in run_json("info", log, "--format", "json")["topics"]}
    assert why["/cmd_vel"] == ("skipped: Twist is not a type aion reads, and has no field a "
                               "--detections-mapping could read as a position")
    note = " ".join(run("info", log).stderr.split())
    assert "none of its types has a field a --detections-mapping could read as a position" in note
    suggested = run("info", log, "--suggest-mapping", "/cmd_vel")
    assert suggested.exit_code == 2, suggested.stderr
    log = tmp_path / "both.mcap"
    with LogWriter(log, "mcap") as w:  # beside a type that holds one, each has its own reason
        for k in range(3):
            t = T0 + k * S
            w.write("/cmd_vel", "geometry_msgs/msg/Twist", {"linear": {"x": 0.5}}, t)
            w.write("/odom_marker", "geometry_msgs/msg/Vector3Stamped",
                    {"header": {"stamp": stamp(t), "frame_id": "map"}}, t)
    why = {t["topic"]: t["why"] for t in run_json("info", log, "--format", "json")["topics"]}
    assert why["/cmd_vel"].endswith("could read as a position"), why
    assert why["/odom_marker"].endswith("(a TOML mapping can read it: --detections-mapping)")


def test_a_log_of_plumbing_only_is_not_sent_to_a_mapping(tmp_path: Path) -> None:
    """Only strings and logging: no mapping can read people from them, so neither build's
    hint nor info's note offers one (both did, and --suggest-mapping then refused)."""
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "talker.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(3):
            w.write("/chatter", "std_msgs/msg/String", {"data": f"hello {k}"}, T0 + k * S)
    refused = run("build", log, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    text = " ".join(refused.stderr.split())
    assert "hint: none of its topics holds positions of people (/chatter" in text
    assert "--detections-mapping" not in text
    described = run("info", log)
    note = " ".join(described.stderr.split())
    assert "none of its topics holds positions of people" in note
    assert "--suggest-mapping" not in note
    suggested = run("info", log, "--suggest-mapping", "/chatter")
    assert suggested.exit_code == 2
    assert "formats/detections" not in suggested.stderr  # no source path as a hint


def test_a_topic_in_another_encoding_is_said_to_be_there(tmp_path: Path) -> None:
    """An MCAP channel in a non-ROS encoding (the MCAP conformance suite's TenMessages: 'a'
    with schema encoding 'c'): named, it is in the log but unreadable, not "not in the log"."""
    from mcap.writer import Writer

    log = tmp_path / "other.mcap"
    with log.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema("Example", "c", b"")
        channel = writer.register_channel("example", "a", schema)
        for k in range(3):
            writer.add_message(channel, T0 + k * S, b"x", T0 + k * S)
        writer.finish()
    expected = "topic 'example' is in the log, but aion cannot read it: message encoding 'a'"
    for args in (["build", log, "--detections-topic", "example", "-o", tmp_path / "x.aion"],
                 ["info", log, "--suggest-mapping", "example"]):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, expected)
    described = run("info", log, "--format", "json")
    assert json.loads(described.stdout)["files"][0]["format"] == "mcap"  # not "mcap-ros2"
    note = " ".join(run("info", log).stderr.split())
    assert "it has no ROS topic aion can read: see the warnings" in note
    assert "--detections-topic" not in note
