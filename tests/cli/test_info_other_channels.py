"""``aion info LOG`` left channels in encodings that are not ROS (JSON, protobuf: the
``/aion/scene`` of ``aion export --format mcap``) out of ``topics``: the table and the JSON
said nothing of them but a warning. Every channel is listed now, with its encoding and
message count, marked ``readable: false``; ``messages`` still counts the readable ones."""

from __future__ import annotations

from pathlib import Path

from mcap.writer import Writer

from tests.cli.conftest import run, run_json

T0 = 1_700_000_000_000_000_000
S = 1_000_000_000


def _write(path: Path, counts: dict[str, int]) -> None:
    """An MCAP of ROS 2 std_msgs/String on /chatter, JSON on /json and protobuf on /scene:
    ``counts[topic]`` messages each, one a second ."""
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        ros = w.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        js = w.register_schema("Person", "jsonschema", b"{}")
        pb = w.register_schema("foxglove.SceneUpdate", "protobuf", b"\x0a\x00")
        kinds = {  # schema, message encoding, payload (a CDR empty string for ROS)
            "/chatter": (ros, "cdr", b"\x00\x01\x00\x00\x01\x00\x00\x00\x00"),
            "/json": (js, "json", b'{"x": 1}'),
            "/scene": (pb, "protobuf", b""),
        }
        for topic, n in counts.items():
            schema, encoding, payload = kinds[topic]
            channel = w.register_channel(topic, encoding, schema)
            for k in range(n):
                w.add_message(channel, T0 + k * S, payload, T0 + k * S)
        w.finish()


def test_every_channel_is_listed_with_its_encoding_and_count(tmp_path: Path) -> None:
    log = tmp_path / "mixed.mcap"
    counts = {"/chatter": 2, "/json": 3, "/scene": 5}
    _write(log, counts)
    doc = run_json("info", log, "--format", "json")
    topics = {t["topic"]: t for t in doc["topics"]}
    assert set(topics) == set(counts)
    found = {n: (t["type"], t["encoding"], t["count"], t["readable"]) for n, t in topics.items()}
    assert found == {
        "/chatter": ("std_msgs/msg/String", "cdr", 2, True),
        "/json": ("Person", "json", 3, False),
        "/scene": ("foxglove.SceneUpdate", "protobuf", 5, False),
    }
    assert topics["/scene"]["rate_hz"] == 5 / 4  # five messages over four seconds
    assert not topics["/json"]["used"]
    assert "is not ROS" in topics["/json"]["why"]
    assert doc["messages"] == 2  # what a ROS reader decodes
    assert doc["files"][0]["messages"] == 10
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    rows = {line.split("│")[1].strip(): line for line in table.stdout.splitlines() if "│" in line}
    assert set(rows) == set(counts)
    assert "foxglove.SceneUpdate" in rows["/scene"]
    assert "'protobuf'" in rows["/scene"]
    assert " 5 " in rows["/scene"]


def test_a_log_of_other_encodings_only_says_no_ros_topic(tmp_path: Path) -> None:
    """The note of a log without a ROS topic stays (the listed channels are not read)."""
    log = tmp_path / "json.mcap"
    _write(log, {"/json": 3})  # a log without ROS channels
    doc = run_json("info", log, "--format", "json")
    assert [(t["topic"], t["count"]) for t in doc["topics"]] == [("/json", 3)]
    assert doc["messages"] == 0
    note = " ".join(run("info", log).stderr.split())
    assert "it has no ROS topic aion can read: see the warnings" in note
