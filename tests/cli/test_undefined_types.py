"""A tracker's own message type in a log that records no message definitions (a ROS 2 Humble
rosbag2 of sqlite3 storage): no mapping can read it, and ``aion info`` / ``aion build`` say so
and what to do -- not that the type has no field a mapping could read as a position. The same
bag with its definitions builds with the README's mapping and counts back what was written."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from aion_cli.errors import NO_DEFINITION_HINT
from aion_cli.topic_mappable import NO_DEFINITION_REASON
from tests.cli.conftest import assert_one_line_error, run, run_json

S = 1_000_000_000
T0 = 1_767_600_000 * S
TOPIC = "/my_tracker/humans"
HUMANS = "my_tracker/msg/Humans"
MESSAGES = 40
MAPPING = f"""
[[topic]]
topic = "{TOPIC}"
msgtype = "{HUMANS}"
array = "humans"
position = ["x", "y"]
id = "id"
"""


def humans_bag(path: Path, definitions: bool) -> Path:
    """``my_tracker/msg/Humans`` (a header and ``Human[] humans``; ``Human``: ``float64 x, y``,
    ``uint32 id``) in a rosbag2 folder of sqlite3 storage, two people per message at 2 Hz in
    the map frame; ``definitions=False`` makes it a Humble bag (metadata version 5, database
    schema 3), which has no message-definition table."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = get_types_from_msg("float64 x\nfloat64 y\nuint32 id\n", "my_tracker/msg/Human")
    types.update(get_types_from_msg("std_msgs/Header header\nmy_tracker/Human[] humans\n", HUMANS))
    store.register(types)
    T = store.types
    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        conn = writer.add_connection(TOPIC, HUMANS, typestore=store)
        for k in range(MESSAGES):
            t = T0 + k * S // 2
            header = T["std_msgs/msg/Header"](
                stamp=T["builtin_interfaces/msg/Time"](sec=t // S, nanosec=t % S), frame_id="map"
            )
            humans = [T["my_tracker/msg/Human"](x=0.5 * k, y=0.0, id=1),
                      T["my_tracker/msg/Human"](x=0.0, y=5.0 + 0.4 * k, id=2)]  # fmt: skip
            msg = T[HUMANS](header=header, humans=humans)
            writer.write(conn, t, bytes(store.serialize_cdr(msg, HUMANS)))
    if not definitions:
        (db,) = path.glob("*.db3")
        with sqlite3.connect(db) as con:
            con.execute("DROP TABLE message_definitions")
            con.execute("UPDATE schema SET schema_version = 3, ros_distro = 'humble'")
        con.close()
        meta = path / "metadata.yaml"
        text = meta.read_text()
        assert "  version: 8\n" in text
        meta.write_text(text.replace("  version: 8\n", "  version: 5\n"))
    return path


def test_a_type_the_log_does_not_define_is_said_so_with_what_to_do(tmp_path: Path) -> None:
    log = humans_bag(tmp_path / "humble", definitions=False)
    info = run_json("info", log, "--format", "json")
    (topic,) = info["topics"]
    assert (topic["topic"], topic["used"]) == (TOPIC, False), topic
    assert topic["why"].endswith(NO_DEFINITION_REASON), topic["why"]
    assert info["mapping_example"] is None
    text = run("info", log)
    assert text.exit_code == 0, text.stderr
    note = " ".join(text.stderr.split())
    assert "ros2 bag record -s mcap" in note, note
    assert "could read as a position" not in note, note

    refused = run("build", log, "-o", tmp_path / "m.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "no people-detection topic of a supported type")
    hint = " ".join(refused.stderr.split())
    assert f"no --detections-mapping can read {TOPIC} ({HUMANS})" in hint, hint
    assert " ".join(NO_DEFINITION_HINT.split()) in hint, hint
    assert "could read as a position" not in hint, hint
    assert "people detector" not in hint, hint
    assert not (tmp_path / "m.aion").exists()

    mapping = tmp_path / "humans.toml"
    mapping.write_text(MAPPING)
    mapped = run("build", log, "-o", tmp_path / "m.aion", "--detections-mapping", mapping)
    assert mapped.exit_code == 2
    assert_one_line_error(mapped.stderr, f"no definition for {HUMANS}")
    assert "ros2 bag convert" in mapped.stderr
    suggested = run("info", log, "--suggest-mapping", TOPIC)
    assert suggested.exit_code == 2
    assert_one_line_error(suggested.stderr, f"no definition for {HUMANS}")


def test_the_same_bag_with_its_definitions_builds_with_the_mapping(tmp_path: Path) -> None:
    log = humans_bag(tmp_path / "iron", definitions=True)
    info = run_json("info", log, "--format", "json")
    assert info["mapping_example"] == TOPIC
    assert not info["topics"][0]["why"].endswith(NO_DEFINITION_REASON)
    mapping = tmp_path / "humans.toml"
    mapping.write_text(MAPPING)
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--detections-mapping", mapping,
                      "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 2 * MESSAGES, "used": 2 * MESSAGES, "dropped": {}}
    assert report["headings"]["track"] == 2 * MESSAGES - 2  # each id's first row has none
