"""open_logs / LogSet reading well-formed logs: every container read back (topics, counts, time
range, raw messages, decoding), several files merged in time order, the format guessed or
forced, decoding with the log's own or aion's shipped definitions, and the MCAP layouts (no
chunks, overlapping chunks, chunk compressions, interleaved iterations). Bad and damaged input:
``test_logs_bad_input.py``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.errors import LogFormatError, MessageDecodeError, TopicNotFoundError
from aion_cli.formats.logs import LogSet, open_logs
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.writers import CONTAINERS, LogWriter
from tests.formats.log_builders import T0, _write, _write_plain_mcap

FILE_NAMES = {"mcap": "log.mcap", "mcap-ros1": "log.mcap", "bag": "log.bag"}
FORMAT_NAMES = {"mcap": "mcap-ros2", "mcap-ros1": "mcap-ros1"}


def _path(tmp_path: Path, container: str) -> Path:
    return tmp_path / FILE_NAMES.get(container, "bag2")


@pytest.mark.parametrize("container", CONTAINERS)
def test_every_container_lists_topics_counts_and_time_range(container: str, tmp_path: Path) -> None:
    path = _write(_path(tmp_path, container), container)
    with open_logs([path]) as logs:
        (f,) = logs.files
        assert f.format == FORMAT_NAMES.get(container, container)
        assert f.size_bytes > 0
        assert f.message_count == 7
        topics = {t.topic: t for t in logs.topics}
        assert sorted(topics) == ["/hydra/backend/dsg", "/people", "/tf_static"]
        assert topics["/people"].msgtype == "people_msgs/msg/People"
        assert topics["/hydra/backend/dsg"].msgtype == "hydra_msgs/msg/DsgUpdate"
        assert topics["/tf_static"].msgtype == "tf2_msgs/msg/TFMessage"
        assert [topics[t].count for t in sorted(topics)] == [2, 4, 1]
        ros1 = container in ("bag", "mcap-ros1")
        assert {t.encoding for t in logs.topics} == {"ros1" if ros1 else "cdr"}
        assert "people_msgs/Person" in topics["/people"].definition
        assert logs.start_ns == T0
        assert logs.end_ns == T0 + 300
        assert logs.total() == 7
        assert logs.total(["/people", "/nope"]) == 4
        assert logs.warnings == []


@pytest.mark.parametrize("container", CONTAINERS)
def test_messages_are_raw_filtered_ordered_and_decodable(container: str, tmp_path: Path) -> None:
    path = _write(_path(tmp_path, container), container)
    with open_logs([path]) as logs:
        msgs = list(logs.messages({"/people", "/hydra/backend/dsg"}))
        p, d = "/people", "/hydra/backend/dsg"
        assert [m.topic for m in msgs] == [p, d, p, p, d, p]
        assert [m.log_time_ns - T0 for m in msgs] == [0, 1, 100, 200, 201, 300]
        for m in msgs:
            assert isinstance(m, RawMessage)
            assert type(m.data) is bytes
        ros1 = container in ("bag", "mcap-ros1")
        # CDR payloads carry the 4-byte encapsulation header; ROS 1 payloads start with seq
        if not ros1:
            assert msgs[0].data[:4] == b"\x00\x01\x00\x00"
        people = logs.decode(msgs[2])
        assert people.header.frame_id == "odom"
        assert (people.header.stamp.sec, people.header.stamp.nanosec) == divmod(T0 + 100, 10**9)
        assert [p.name for p in people.people] == ["p0", "p1"]
        assert [p.position.x for p in people.people] == [1.0, 1.5]
        assert people.people[1].position.y == 2.0
        assert people.people[0].velocity.x == 0.5
        dsg = logs.decode(msgs[4])
        assert np.asarray(dsg.layer_contents).tobytes() == bytes([2, 1, 2])
        assert list(logs.messages(["/not-a-topic"])) == []


def test_several_files_merge_in_log_time_order(tmp_path: Path) -> None:
    a = _write(tmp_path / "a.mcap", "mcap", offset=0, n=3)
    b = _write(tmp_path / "b.bag", "bag", offset=50, n=3)
    c = _write(tmp_path / "c", "rosbag2-sqlite3", offset=120, n=2)
    with open_logs([a, b, c]) as logs:
        assert [f.format for f in logs.files] == ["mcap-ros2", "bag", "rosbag2-sqlite3"]
        people = {t.topic: t for t in logs.topics}["/people"]
        assert people.count == 8
        assert people.source == f"{a}, {b}, {c}"
        times = [m.log_time_ns - T0 for m in logs.messages(["/people"])]
        assert times == [0, 50, 100, 120, 150, 200, 220, 250]
        assert logs.total(["/people"]) == 8
        assert logs.start_ns == T0
        assert logs.end_ns == T0 + 251
        encodings = [m.encoding for m in logs.messages(["/people"])]
        assert encodings == ["cdr", "ros1", "cdr", "cdr", "ros1", "cdr", "cdr", "ros1"]
        xs = [logs.decode(m).people[0].position.x for m in logs.messages(["/people"])]
        assert xs == [0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 1.0, 2.0]


def test_topic_lookup_names_candidates(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.mcap", "mcap")
    with open_logs([path]) as logs:
        assert logs.topic("/people").count == 4
        with pytest.raises(TopicNotFoundError) as info:
            logs.topic("/persons")
        assert "/people (people_msgs/msg/People)" in info.value.candidates


def test_format_is_guessed_from_content_and_can_be_forced(tmp_path: Path) -> None:
    mcap = _write(tmp_path / "a.mcap", "mcap")
    bag = _write(tmp_path / "b.bag", "bag")
    folder = _write(tmp_path / "c", "rosbag2-mcap")
    renamed_mcap = mcap.rename(tmp_path / "recording.log")
    renamed_bag = bag.rename(tmp_path / "recording.dat")
    with open_logs([renamed_mcap, renamed_bag]) as logs:
        assert [f.format for f in logs.files] == ["mcap-ros2", "bag"]
    with open_logs([renamed_mcap], fmt="mcap") as logs:
        assert logs.total() == 7
    # a rosbag2 folder by its metadata.yaml or by its storage file, a bare rosbag2 .mcap
    with open_logs([folder / "metadata.yaml"]) as logs:
        assert logs.files[0].format == "rosbag2-mcap"
    (storage,) = folder.glob("*.mcap")
    with open_logs([storage]) as logs:
        assert logs.files[0].format == "mcap-ros2"
        assert logs.total(["/people"]) == 4
    with open_logs([storage], fmt="rosbag2") as logs:
        assert logs.files[0].format == "rosbag2-mcap"
    with pytest.raises(LogFormatError, match="not a readable ROS 1 bag"):
        open_logs([renamed_mcap], fmt="bag")


def test_decode_uses_the_logs_own_definitions(tmp_path: Path) -> None:
    """A custom type, and a standard type the log defines differently from the ROS 2 store."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    custom = "int32 a\nstring b\ngeometry_msgs/Point p\n" + "=" * 80
    custom += "\nMSG: geometry_msgs/Point\nfloat32 x\n"
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(custom, "my_msgs/msg/Foo"))
    foo = store.types["my_msgs/msg/Foo"]
    point = store.types["geometry_msgs/msg/Point"]
    path = tmp_path / "custom.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        short_separator = custom.replace("=" * 80, "===")  # as some writers emit it
        schema = w.register_schema("my_msgs/msg/Foo", "ros2msg", short_separator.encode())
        channel = w.register_channel("/foo", "cdr", schema)
        data = bytes(store.serialize_cdr(foo(a=-7, b="hi", p=point(x=1.5)), "my_msgs/msg/Foo"))
        w.add_message(channel, T0, data, T0)
        w.finish()
    with open_logs([path]) as logs:
        (msg,) = logs.messages()
        decoded = logs.decode(msg)
        assert (decoded.a, decoded.b, decoded.p.x) == (-7, "hi", 1.5)


def test_decode_falls_back_to_shipped_definitions(tmp_path: Path) -> None:
    """Old rosbag2 logs carry no definitions: aion's own definition of the type is used."""
    from mcap.writer import Writer

    from aion_cli.formats.msgdefs import typestore
    from aion_cli.formats.writers import to_message

    path = tmp_path / "nodefs.mcap"
    msg = to_message("hydra_msgs/DsgUpdate", {"layer_contents": b"xyz", "sequence_number": 3})
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        schema = w.register_schema("hydra_msgs/msg/DsgUpdate", "ros2msg", b"")
        dsg = w.register_channel("/dsg", "cdr", schema)
        w.add_message(
            dsg, T0, bytes(typestore(2).serialize_cdr(msg, "hydra_msgs/msg/DsgUpdate")), T0
        )
        unknown = w.register_schema("foo_msgs/msg/Bar", "ros2msg", b"")
        bar = w.register_channel("/bar", "cdr", unknown)
        w.add_message(bar, T0 + 1, b"\x00\x01\x00\x00", T0 + 1)
        w.finish()
    with open_logs([path]) as logs:
        first, second = logs.messages()
        assert logs.decode(first).sequence_number == 3
        with pytest.raises(MessageDecodeError, match="no definition for foo_msgs/msg/Bar"):
            logs.decode(second)


def test_mcap_without_chunks_or_summary_is_read_linearly(tmp_path: Path) -> None:
    from mcap.writer import Writer

    from aion_cli.formats.msgdefs import definition, typestore
    from aion_cli.formats.writers import to_message

    path = tmp_path / "plain.mcap"
    with path.open("wb") as f:
        w = Writer(f, use_chunking=False, use_statistics=False, use_summary_offsets=False)
        w.start(profile="ros2")
        text = definition("geometry_msgs/PoseStamped", 2).encode()
        schema = w.register_schema("geometry_msgs/msg/PoseStamped", "ros2msg", text)
        channel = w.register_channel("/pose", "cdr", schema)
        for k in range(3):
            pose = to_message("geometry_msgs/PoseStamped", {"pose": {"position": {"x": k}}})
            data = bytes(typestore(2).serialize_cdr(pose, "geometry_msgs/msg/PoseStamped"))
            w.add_message(channel, T0 + k, data, T0 + k)
        w.finish()
    with open_logs([path]) as logs:
        assert logs.total() == 3
        assert (logs.start_ns, logs.end_ns) == (T0, T0 + 2)
        xs = [logs.decode(m).pose.position.x for m in logs.messages()]
        assert xs == [0.0, 1.0, 2.0]
        assert logs.warnings == []


def test_overlapping_chunks_still_come_out_in_time_order(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "overlap.mcap"
    with path.open("wb") as f:
        w = Writer(f, chunk_size=64)  # about one message per chunk
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        channel = w.register_channel("/e", "cdr", schema)
        for t in [0, 50, 10, 40, 20, 30]:
            w.add_message(channel, T0 + t, b"\x00\x01\x00\x00" + bytes(60), T0 + t)
        w.finish()
    with open_logs([path]) as logs:
        assert [m.log_time_ns - T0 for m in logs.messages()] == [0, 10, 20, 30, 40, 50]


def test_logset_closes_its_files(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.mcap", "mcap")
    logs: LogSet = open_logs([path])
    with logs:
        assert logs.total() == 7
    with pytest.raises(ValueError, match="closed"):
        list(logs.messages())


@pytest.mark.parametrize("compression", ["NONE", "LZ4", "ZSTD"])
def test_chunk_compressions(compression: str, tmp_path: Path) -> None:
    path = tmp_path / "c.mcap"
    _write_plain_mcap(path, compression)
    with open_logs([path]) as logs:
        odd = list(logs.messages(["/odd"]))
        assert [m.log_time_ns - T0 for m in odd] == list(range(1, 30, 2))
        assert [int.from_bytes(m.data[4:8], "little") for m in odd] == list(range(1, 30, 2))
        assert all(len(m.data) == 4 + 256 for m in odd)
        assert {m.topic for m in odd} == {"/odd"}
        assert len(list(logs.messages())) == 30


def test_one_topic_with_two_types_is_listed_twice(tmp_path: Path) -> None:
    path = tmp_path / "two.mcap"
    with LogWriter(path, "mcap") as w:
        w.write("/x", "std_msgs/String", {"data": "a"}, T0)
        w.write("/x", "std_msgs/Int32", {"data": 5}, T0 + 1)
        w.write("/x", "std_msgs/Int32", {"data": 6}, T0 + 2)
    with open_logs([path]) as logs:
        assert [(t.msgtype, t.count) for t in logs.topics] == [
            ("std_msgs/msg/String", 1),
            ("std_msgs/msg/Int32", 2),
        ]
        values = [logs.decode(m).data for m in logs.messages(["/x"])]
        assert values == ["a", 5, 6]


@pytest.mark.parametrize("chunked", [True, False])
def test_interleaved_iterations_do_not_disturb_each_other(chunked: bool, tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "i.mcap"
    with path.open("wb") as f:
        w = Writer(f, chunk_size=300, use_chunking=chunked, use_statistics=chunked)
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        channel = w.register_channel("/e", "cdr", schema)
        for k in range(20):
            w.add_message(channel, T0 + k, b"\x00\x01\x00\x00" + bytes([k]) * 100, T0 + k)
        w.finish()
    with open_logs([path]) as logs:
        first = logs.messages()
        head = [next(first) for _ in range(3)]
        second = list(logs.messages())
        rest = list(first)
        assert [m.data[4] for m in head + rest] == list(range(20))
        assert [m.data[4] for m in second] == list(range(20))


def test_rosbag2_storage_file_without_metadata(tmp_path: Path) -> None:
    folder = _write(tmp_path / "bag2", "rosbag2-sqlite3")
    (db3,) = folder.glob("*.db3")
    with open_logs([db3]) as logs:  # next to its metadata.yaml: the folder is opened
        assert logs.files[0].format == "rosbag2-sqlite3"
    (folder / "metadata.yaml").unlink()
    # without it, the storage file (or its folder) is indexed in memory, as `ros2 bag reindex`
    # would (more in tests/formats/test_rosbag2_reindex.py)
    for path in (db3, folder):
        with open_logs([path]) as logs:
            assert logs.files[0].format == "rosbag2-sqlite3"
            assert logs.total() == 7
            assert len(list(logs.messages())) == 7
    db3.unlink()
    with pytest.raises(LogFormatError, match="not a rosbag2 bag"):
        open_logs([folder])


@pytest.mark.parametrize(
    "text",
    ["# the layers of a scene graph\n# (no fields)\n", "# header\n" + "=" * 80 + "\nMSG: x/Y\n"],
)
def test_a_definition_of_comments_only_is_named_as_empty(text: str, tmp_path: Path) -> None:
    """A schema whose text is comments only gave a type aion ships no field: every message
    failed as "CDR message size mismatch". The error now names the type and says its
    definition is empty; a type that has no field anyway (std_msgs/Empty) still decodes."""
    from mcap.writer import Writer

    from aion_cli.formats.msgdefs import typestore
    from aion_cli.formats.writers import to_message

    path = tmp_path / "comments.mcap"
    msg = to_message("hydra_msgs/DsgUpdate", {"layer_contents": b"xyz", "sequence_number": 3})
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        schema = w.register_schema("hydra_msgs/msg/DsgUpdate", "ros2msg", text.encode())
        dsg = w.register_channel("/dsg", "cdr", schema)
        w.add_message(
            dsg, T0, bytes(typestore(2).serialize_cdr(msg, "hydra_msgs/msg/DsgUpdate")), T0
        )
        empty = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"# nothing\n")
        tick = w.register_channel("/tick", "cdr", empty)
        w.add_message(tick, T0 + 1, b"\x00\x01\x00\x00\x00", T0 + 1)  # the IDL placeholder
        w.finish()
    with open_logs([path]) as logs:
        first, second = logs.messages()
        with pytest.raises(MessageDecodeError) as caught:
            logs.decode(first)
        assert caught.value.message.startswith(
            "the log's definition of hydra_msgs/msg/DsgUpdate is empty: its .msg text gives "
            "it no field, only comments (aion's own definition of hydra_msgs/msg/DsgUpdate "
            "has 6 fields)"  # header, layer_contents, deleted_nodes / _edges, full_update, seq
        )
        assert logs.decode(second) is not None
