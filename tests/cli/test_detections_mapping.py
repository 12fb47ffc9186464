"""TOML mappings of custom people messages from the command line (``--detections-mapping``,
``--suggest-mapping``, the README's examples), on logs with known contents: a
``leg_tracker/msg/Person`` bag whose walkers are counted back, bad mappings as one-line
errors, and an agent array whose suggested mapping builds."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import assert_one_line_error, map_cells, run, run_json
from tests.cli.own_definitions import Message, OwnTypes, write_mcap

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows
README = Path(__file__).resolve().parents[2] / "README.md"

PERSON = "leg_tracker/msg/Person"


def person_bag(path: Path) -> Path:
    """``leg_tracker/msg/Person`` messages (a Pose and a uint32 id, no header) on /people in
    a ROS 1 bag: person 4 walks +x from (0, 0), person 9 walks -x from (10, 5), 0.5 m per
    second, one message per person per second."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, "bag") as w:
        for k in range(20):
            t = T0 + k * S
            for pid, x, y in ((4, 0.5 * k, 0.0), (9, 10.0 - 0.5 * k, 5.0)):
                pose = {"position": {"x": x, "y": y}}
                w.write("/people", PERSON, {"pose": pose, "id": pid}, t + pid)
    return path


def test_person_messages_need_a_mapping_and_suggest_mapping_writes_one(tmp_path: Path) -> None:
    log = person_bag(tmp_path / "legs.bag")
    out = tmp_path / "legs.aion"
    refused = run("build", log, "-o", out)
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "no people-detection topic of a supported type")
    assert "--detections-mapping" in refused.stderr
    suggested = run("info", log, "--suggest-mapping", "/people")
    assert suggested.exit_code == 0, suggested.stderr
    text = suggested.stdout
    for line in ('topic = "/people"', f'msgtype = "{PERSON}"', 'position = "pose.position"',
                 'orientation = "pose.orientation"', 'id = "id"', 'frame_override = "map"'):
        assert line in text, line  # fmt: skip
    assert "array =" not in text.replace("# no array", "")
    mapping = tmp_path / "legs.toml"
    mapping.write_text(text)
    info = run_json("info", log, "--detections-mapping", mapping, "--format", "json")
    (people,) = [t for t in info["topics"] if t["topic"] == "/people"]
    assert (people["used"], people["why"], people["role"]) == (
        True, "--detections-mapping", "detections"
    )
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping, "--format",
                      "json")  # fmt: skip
    assert report["detections"] == {"read": 40, "used": 40, "dropped": {}}
    assert report["detection_decoding"]["/people"]["decoder"] == "mapping"
    # ids 4 and 9 differenced; a zero quaternion (the writer's default) is no heading
    assert report["headings"] == {"velocity": 0, "track": 38, "linked": 0, "pose_yaw": 0,
                                  "none": 2}  # fmt: skip
    assert "40 detections came from messages without a header" in " ".join(report["notes"])
    _, counts, nodir = map_cells(out)
    assert counts.sum(axis=0).tolist() == [19, 0, 0, 0, 19, 0, 0, 0]  # -x: bin 0, +x: bin 4
    assert nodir.sum() == 2
    # a held-out log of the same type is read with the same mapping (as the API's holdout)
    held = run_json("evaluate", "holdout", out, log, "--detections-mapping", mapping,
                    "--format", "json")  # fmt: skip
    assert held["test"]["detections"] == 40
    unmapped = run("evaluate", "holdout", out, log)
    assert unmapped.exit_code == 2


@pytest.mark.parametrize(
    ("change", "fragments"),
    [
        (('frame_override = "map"', ""), ("has no header", "frame")),
        (('topic = "/people"', 'topic = "/persons"'), ("names topic '/persons'",)),
        ((f'msgtype = "{PERSON}"', 'msgtype = "leg_tracker/msg/PersonArray"'),
         ("carries leg_tracker/msg/Person",)),
        (('position = "pose.position"', 'position = "pos"'),
         ("has no field 'pos'", "available: pose, id")),
        (("[[topic]]", "[topic]"), ("no [[topic]] tables",)),
        # a stamp or frame path must lead to a Time / a string, not just exist
        (('frame_override = "map"', 'stamp = "pose.position"\nframe_override = "map"'),
         ("stamp path 'pose.position' must lead to a time stamp",
          "not a message geometry_msgs/msg/Point")),
        # strings never equal a uint32: the filter would drop every person
        (('id = "id"', 'id = "id"\nfilter = { field = "id", equals = ["4", "9"] }'),
         ("filter on 'id' (uint32 value): equals must list whole numbers",)),
        (('frame_override = "map"', 'frame = "id"'),
         ("frame path 'id' must lead to a frame name (a string), not a uint32 value",)),
    ],
)
def test_bad_mappings_are_clear_errors(
    tmp_path: Path, change: tuple[str, str], fragments: tuple[str, ...]
) -> None:
    log = person_bag(tmp_path / "legs.bag")
    text = run("info", log, "--suggest-mapping", "/people").stdout
    assert change[0] in text
    mapping = tmp_path / "bad.toml"
    mapping.write_text(text.replace(*change))
    for command in ("build", "info"):
        args = ["-o", tmp_path / "x.aion"] if command == "build" else []
        result = run(command, log, *args, "--detections-mapping", mapping)
        assert result.exit_code == 2, (command, result.stderr)
        assert_one_line_error(result.stderr, *fragments)
    missing = run("build", log, "--detections-mapping", tmp_path / "absent.toml")
    assert missing.exit_code == 2
    assert_one_line_error(missing.stderr, "cannot read mapping file")


def test_two_mapping_files_are_refused_not_one_ignored(tmp_path: Path) -> None:
    """``--detections-mapping`` given twice: click kept the last file only, so the topics of
    the first went unread without a word (here the build used /people through the second
    file's wrong position). Now two files are one line of error (exit 2); the same file
    twice reads as once."""
    log = person_bag(tmp_path / "legs.bag")
    good = tmp_path / "good.toml"
    good.write_text(run("info", log, "--suggest-mapping", "/people").stdout)
    other = tmp_path / "other.toml"
    other.write_text(good.read_text().replace('position = "pose.position"',
                                              'position = "pose.orientation"'))  # fmt: skip
    for command in ("build", "info"):
        args = ["-o", tmp_path / "x.aion"] if command == "build" else []
        result = run(command, log, *args, "--detections-mapping", good,
                     "--detections-mapping", other)  # fmt: skip
        assert result.exit_code == 2, (command, result.stderr)
        assert_one_line_error(result.stderr, "--detections-mapping", "given 2 files",
                              "put all their [[topic]] tables into one file")  # fmt: skip
        assert not (tmp_path / "x.aion").exists()
    report = run_json("build", log, "-o", tmp_path / "x.aion", "--detections-mapping", good,
                      "--detections-mapping", good, "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 40, "used": 40, "dropped": {}}


def test_suggest_mapping_errors(tmp_path: Path) -> None:
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "chat.mcap"
    with LogWriter(log, "mcap") as w:
        w.write("/chatter", "std_msgs/msg/String", {"data": "hi"}, T0)
    result = run("info", log, "--suggest-mapping", "/chatter")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no field aion can read as a position")
    result = run("info", log, "--suggest-mapping", "/nope")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "topic '/nope' is not in the log")


AGENTS = "my_sim/msg/AgentArray"
AGENT_TYPES = {
    "my_sim/msg/Agent": "string name\nstring kind\nfloat64[3] position\n"
    "geometry_msgs/Vector3 velocity\n",
    AGENTS: "std_msgs/Header header\nmy_sim/Agent[] agents\n",
}


def readme_mapping() -> str:
    """The TOML examples of the README's "People detections" section, as one file."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("**People detections**") :]
    blocks = re.findall(r"```toml\n(.*?)```", section, re.DOTALL)
    assert len(blocks) >= 2, "the README shows the mapping examples as ```toml blocks"
    return "\n".join(blocks)


def two_mapped_topics(path: Path, t0: int = T0) -> Path:
    """One ROS 2 MCAP with the README's two examples: ``leg_tracker/msg/Person`` on /people
    (headerless, positions in base_laser; one person walking +y) and a simulator's
    ``my_sim/msg/AgentArray`` on /sim/agents (a person walking -x with velocity (-1, 0),
    and a robot that the filter drops); ten messages on each, one a second from ``t0``."""
    from aion_cli.formats.writers import LogWriter

    own = OwnTypes(AGENT_TYPES)
    T = own.T
    msgs = []
    with LogWriter(path.with_suffix(".tmp.mcap"), "mcap") as w:  # for its CDR of Person
        for k in range(10):
            t = t0 + k * S
            data = w.serialize(PERSON, {"pose": {"position": {"x": 2.0, "y": 0.5 * k}}, "id": 7})
            msgs.append(Message("/people", PERSON, data, t))
            vector = T["geometry_msgs/msg/Vector3"]
            agents = [
                T["my_sim/msg/Agent"](
                    name="alice", kind="person", position=np.array([20.0 - 1.0 * k, 3.0, 0.0]),
                    velocity=vector(x=-1.0, y=0.0, z=0.0),
                ),
                T["my_sim/msg/Agent"](
                    name="r2", kind="robot", position=np.array([0.0, 9.0, 0.0]),
                    velocity=vector(x=0.0, y=0.0, z=0.0),
                ),
            ]  # fmt: skip
            arr = T[AGENTS](header=own.header(t, "base_laser"), agents=agents)
            msgs.append(Message("/sim/agents", AGENTS, own.cdr(arr, AGENTS), t))
    return write_mcap(path, msgs, {AGENTS: own.definition(AGENTS)})


def test_the_readme_mapping_examples_read_both_topics(tmp_path: Path) -> None:
    log = two_mapped_topics(tmp_path / "mapped.mcap")
    mapping = tmp_path / "readme.toml"
    mapping.write_text(readme_mapping())
    out = tmp_path / "mapped.aion"
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping,
                      "--map-frame", "base_laser", "--format", "json")  # fmt: skip
    assert report["detection_topics"] == ["/people", "/sim/agents"]
    assert report["detections"] == {"read": 30, "used": 20, "dropped": {"filter": 10}}
    assert report["headings"] == {"velocity": 10, "track": 9, "linked": 0, "pose_yaw": 0,
                                  "none": 1}  # fmt: skip
    _, counts, nodir = map_cells(out)
    # alice heads π (velocity -x) -> bin 0; the Person walks +y -> bin 6
    assert counts.sum(axis=0).tolist() == [10, 0, 0, 0, 0, 0, 9, 0]
    assert nodir.sum() == 1


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_filter_that_drops_every_item_names_the_values_it_saw(
    tmp_path: Path, workers: str
) -> None:
    """A filter on ``kind`` that lists "pedestrian" where the agents are "person" and
    "robot": every item dropped, and the hint said "the topics carry no detections". It
    names the filter, how many items it dropped and the values ``kind`` held, with their
    counts (two logs a day apart, 10 messages of a person and a robot each), in one process
    and in two (one shard per log)."""
    logs = [two_mapped_topics(tmp_path / "mon.mcap"),
            two_mapped_topics(tmp_path / "tue.mcap", T0 + 86_400 * S)]  # fmt: skip
    mapping = tmp_path / "agents.toml"
    mapping.write_text(f'[[topic]]\ntopic = "/sim/agents"\nmsgtype = "{AGENTS}"\n'
                       'array = "agents"\nposition = "position[0..2]"\nid = "name"\n'
                       'filter = { field = "kind", equals = ["pedestrian"] }\n')  # fmt: skip
    out = tmp_path / "agents.aion"
    result = run("build", *logs, "-o", out, "--detections-mapping", mapping,
                 "--map-frame", "base_laser", "--workers", workers)  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "no people detection in the 20 messages of "
                          "/sim/agents (dropped: filter 40)")  # fmt: skip
    assert "carry no detections" not in result.stderr
    assert "hint: the --detections-mapping's filter dropped all 40 items; its field held " \
        'kind = "person" (20), kind = "robot" (20); list the values' in result.stderr  # fmt: skip
    assert "--suggest-mapping /sim/agents" in result.stderr
    assert not out.exists()


def test_info_names_a_filter_that_drops_every_item_of_its_sample(tmp_path: Path) -> None:
    """``aion info --detections-mapping`` with the filter above (``kind`` is "person" or
    "robot", never "pedestrian") said nothing, the build then failing: info warns in the
    build's words, with the items of its sample (10 messages, a person and a robot each)
    and the values ``kind`` held; a filter that keeps the person gives no such warning."""
    log = two_mapped_topics(tmp_path / "mon.mcap")
    mapping = tmp_path / "agents.toml"
    text = (f'[[topic]]\ntopic = "/sim/agents"\nmsgtype = "{AGENTS}"\narray = "agents"\n'
            'position = "position[0..2]"\nid = "name"\n'
            'filter = { field = "kind", equals = ["pedestrian"] }\n')  # fmt: skip
    mapping.write_text(text)
    info = run_json("info", log, "--detections-mapping", mapping, "--format", "json")
    (said,) = [w for w in info["warnings"] if "filter dropped" in w]
    assert said.startswith("/sim/agents: no item of its first 10 message(s) is kept")
    assert "the --detections-mapping's filter dropped all 20 items; its field held " \
        'kind = "person" (10), kind = "robot" (10); list the values' in said  # fmt: skip
    assert "--suggest-mapping /sim/agents" in said
    table = run("info", log, "--detections-mapping", mapping)
    assert table.exit_code == 0, table.stderr
    assert "filter dropped all 20 items" in " ".join((table.stdout + table.stderr).split())
    mapping.write_text(text.replace('"pedestrian"', '"person"'))
    kept = run_json("info", log, "--detections-mapping", mapping, "--format", "json")
    assert not [w for w in kept["warnings"] if "is kept" in w or "filter" in w]


def test_suggested_mapping_of_an_agent_array_builds(tmp_path: Path) -> None:
    log = two_mapped_topics(tmp_path / "mapped.mcap")
    result = run("info", log, "--suggest-mapping", "/sim/agents")
    assert result.exit_code == 0, result.stderr
    text = result.stdout
    for line in ('array = "agents"', 'position = "position[0..2]"', 'velocity = "velocity"',
                 'id = "name"'):
        assert line in text, line  # fmt: skip
    mapping = tmp_path / "agents.toml"
    mapping.write_text(text)
    report = run_json("build", log, "-o", tmp_path / "a.aion", "--detections-mapping", mapping,
                      "--map-frame", "base_laser", "--format", "json")  # fmt: skip
    assert report["detection_topics"] == ["/sim/agents"]
    assert report["detections"]["read"] == 20  # no filter in a suggestion: the robot too


SERVICE_EVENT = "example_interfaces/srv/AddTwoInts_Event"


def test_service_events_are_not_offered_a_mapping(tmp_path: Path) -> None:
    """A ROS 2 service-introspection topic (rosbag2's test bags record them): the log defines
    its type as the service, request --- response, which rosbags cannot parse. It was 'a type
    a TOML mapping can read', the build's hint sent the user to --suggest-mapping it, and that
    called the definition malformed; now it is skipped as the calls of a service."""
    payload = b"\x00\x01\x00\x00" + bytes(16)
    service = Message("/add_two_ints/_service_event", SERVICE_EVENT, payload, T0)
    log = write_mcap(tmp_path / "services.mcap", [service],
                     {SERVICE_EVENT: "int64 a\nint64 b\n---\nint64 sum\n"})  # fmt: skip
    (topic,) = run_json("info", log, "--format", "json")["topics"]
    assert topic["why"] == "skipped: AddTwoInts_Event records the calls of a service, not people"
    note = " ".join(run("info", log).stderr.split())
    assert "none of its topics holds positions of people: logging, parameters, service" in note
    refused = run("build", log, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert "hint: none of its topics holds positions of people" in refused.stderr
    assert "--suggest-mapping" not in refused.stderr
    suggested = run("info", log, "--suggest-mapping", service.topic)
    assert suggested.exit_code == 2
    assert_one_line_error(suggested.stderr, "records the calls of a service, not people")


TURTLE_POSE = "turtlesim/msg/Pose"


def test_the_build_hint_names_a_topic_that_suggest_mapping_reads(tmp_path: Path) -> None:
    """rosbag.js' turtlesim bag: the hint named the first topic of a type without an adapter,
    /tf (which the build reads as TF), or a Twist that --suggest-mapping then refused; it
    names the first topic whose type holds a position, the turtle's Pose."""
    own = OwnTypes({TURTLE_POSE: "float32 x\nfloat32 y\nfloat32 theta\n"})
    T = own.T
    tf = T["tf2_msgs/msg/TFMessage"](transforms=[])
    twist = T["geometry_msgs/msg/Twist"](
        linear=T["geometry_msgs/msg/Vector3"](x=1.0, y=0.0, z=0.0),
        angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.5),
    )
    pose = T[TURTLE_POSE](x=1.0, y=2.0, theta=0.5)
    messages = [
        Message("/tf", "tf2_msgs/msg/TFMessage", own.cdr(tf, "tf2_msgs/msg/TFMessage"), T0),
        Message("/turtle1/cmd_vel", "geometry_msgs/msg/Twist",
                own.cdr(twist, "geometry_msgs/msg/Twist"), T0),
        Message("/turtle1/pose", TURTLE_POSE, own.cdr(pose, TURTLE_POSE), T0),
    ]  # fmt: skip
    log = write_mcap(tmp_path / "turtle.mcap", messages, {TURTLE_POSE: own.definition(TURTLE_POSE)})
    refused = run("build", log, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert "`aion info LOG --suggest-mapping /turtle1/pose` writes one" in refused.stderr
    assert run("info", log, "--suggest-mapping", "/turtle1/pose").exit_code == 0
    only = write_mcap(tmp_path / "no-positions.mcap", messages[:2], {})
    refused = run("build", only, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert "none of their types has a field a --detections-mapping could read" in refused.stderr
    assert "--suggest-mapping" not in refused.stderr


def test_naming_a_topic_no_mapping_reads_is_not_sent_to_a_mapping(tmp_path: Path) -> None:
    """--detections-topic /tf, or a LaserScan: the hint offered `--suggest-mapping` of it
    (TF as people; a LaserScan, which --suggest-mapping then refused as raw sensor data)."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "robot.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(3):
            t = T0 + k * S
            w.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": []}, t)
            scan = {"header": {"stamp": stamp(t), "frame_id": "laser"}, "ranges": [1.0]}
            w.write("/scan", "sensor_msgs/msg/LaserScan", scan, t)
    expected = {
        "/tf": "the build reads /tf as TF, never as people",
        "/scan": "/scan: LaserScan is raw sensor data, not detected people",
    }
    for topic, fragment in expected.items():
        refused = run("build", log, "-o", tmp_path / "x.aion", "--detections-topic", topic)
        assert refused.exit_code == 2
        assert_one_line_error(refused.stderr, f"no people-detection topic '{topic}'")
        assert fragment in refused.stderr
        assert "--suggest-mapping" not in refused.stderr


def test_info_points_to_the_topic_suggest_mapping_reads(tmp_path: Path) -> None:
    """info's note on a log without people detections said 'map another type: aion info LOG
    --suggest-mapping TOPIC' whatever the log held; it names the topic the build's hint names
    (JSON mapping_example), or says that no type holds a position."""
    own = OwnTypes({TURTLE_POSE: "float32 x\nfloat32 y\nfloat32 theta\n"})
    zero = own.T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    twist = own.T["geometry_msgs/msg/Twist"](linear=zero, angular=zero)
    pose = own.T[TURTLE_POSE](x=1.0, y=2.0, theta=0.5)
    cmd = Message("/cmd_vel", "geometry_msgs/msg/Twist",
                  own.cdr(twist, "geometry_msgs/msg/Twist"), T0)  # fmt: skip
    turtle = Message("/turtle1/pose", TURTLE_POSE, own.cdr(pose, TURTLE_POSE), T0)
    defs = {TURTLE_POSE: own.definition(TURTLE_POSE)}
    for name, messages, example, note in (
        ("turtle", [cmd, turtle], "/turtle1/pose",
         "(map another type: aion info LOG --suggest-mapping /turtle1/pose)"),
        ("twist", [cmd], None,
         "(none of its types has a field a --detections-mapping could read as a position)"),
    ):  # fmt: skip
        log = write_mcap(tmp_path / f"{name}.mcap", messages, defs)
        assert run_json("info", log, "--format", "json")["mapping_example"] == example
        assert note in " ".join(run("info", log).stderr.split())


def test_the_mapping_example_is_a_topic_past_the_first_fifty(tmp_path: Path) -> None:
    """Sixty Twist topics before the one turtle pose: info's JSON ``mapping_example`` said
    ``"TOPIC"`` (a placeholder no command takes: only the first 50 topics were tried) and the
    note ``--suggest-mapping TOPIC``; every topic is considered now, each definition once."""
    own = OwnTypes({TURTLE_POSE: "float32 x\nfloat32 y\nfloat32 theta\n"})
    zero = own.T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    twist = own.cdr(own.T["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                    "geometry_msgs/msg/Twist")  # fmt: skip
    pose = own.cdr(own.T[TURTLE_POSE](x=1.0, y=2.0, theta=0.5), TURTLE_POSE)
    messages = [Message(f"/a{k:02d}/cmd_vel", "geometry_msgs/msg/Twist", twist, T0)
                for k in range(60)]  # fmt: skip
    messages.append(Message("/z/turtle1/pose", TURTLE_POSE, pose, T0))
    log = write_mcap(tmp_path / "many.mcap", messages, {TURTLE_POSE: own.definition(TURTLE_POSE)})
    assert run_json("info", log, "--format", "json")["mapping_example"] == "/z/turtle1/pose"
    note = "(map another type: aion info LOG --suggest-mapping /z/turtle1/pose)"
    assert note in " ".join(run("info", log).stderr.split())
