"""A DsgUpdate's stamp and payload read from its bytes (:mod:`formats.dsg_update_fast`) equal
rosbags' decode of the message, in every container aion writes and in real logs; malformed
messages and other layouts go to the generic decoder; a build gives the same map with the
fast paths (payload and graph reading) as without them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.formats.dsg_update_fast import DSG_UPDATE, layout_matches, read_dsg_update
from aion_cli.formats.logs import open_logs
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import raw, reference
from tests.shared_data import SHARED_DATA

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
CONTAINERS = ["mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap"]


@st.composite
def updates(draw: st.DrawFn) -> dict[str, Any]:
    """DsgUpdate fields whose sizes shift every CDR alignment (frame id, payload and deleted
    lists of any length), stamps over the whole int32 / uint32 range (:func:`_in`)."""
    return {
        "header": {
            "stamp": {
                "sec": draw(st.integers(-(2**31), 2**31 - 1)),
                "nanosec": draw(st.integers(0, 2**32 - 1)),
            },
            "frame_id": draw(st.text(alphabet="map_/é1", max_size=9)),
        },
        "layer_contents": np.frombuffer(draw(st.binary(max_size=40)), np.uint8),
        "deleted_nodes": np.array(draw(st.lists(st.integers(0, 2**64 - 1), max_size=3)), np.uint64),
        "deleted_edges": np.array(draw(st.lists(st.integers(0, 2**64 - 1), max_size=3)), np.uint64),
        "full_update": draw(st.booleans()),
        "sequence_number": draw(st.integers(-(2**63), 2**63 - 1)),
    }


def _in(ros: int, update: dict[str, Any]) -> dict[str, Any]:
    """``update`` with its seconds as ROS ``ros`` holds them: ROS 1 ``time`` is unsigned (to
    2106; the drawn int32 taken modulo 2^32 covers all of uint32), ROS 2's int32."""
    if ros == 1:
        update["header"]["stamp"]["sec"] %= 2**32
    return update


def _assert_like_rosbags(m: RawMessage, expect_fast: bool = True) -> None:
    """The fast read equals rosbags' decode of ``m``; or it declines (never when
    ``expect_fast``), and must when rosbags refuses the message."""
    fields = read_dsg_update(m.data, m.encoding)
    try:
        ref = reference(m)
    except Exception:  # rosbags refuses it: so must the fast reader
        assert fields is None
        return
    if fields is None:
        assert not expect_fast
        return
    stamp = ref.header.stamp
    assert (fields.sec, fields.nanosec) == (stamp.sec, stamp.nanosec)
    assert fields.frame_id == ref.header.frame_id
    assert bytes(fields.payload) == np.asarray(ref.layer_contents, np.uint8).tobytes()
    assert isinstance(fields.payload, memoryview)  # a view of the message, not a copy
    assert fields.payload.obj is m.data


@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(update=updates())
def test_fields_equal_rosbags(ros: int, update: dict[str, Any]) -> None:
    _assert_like_rosbags(raw(DSG_UPDATE, _in(ros, update), ros))


@pytest.mark.parametrize("ros", [1, 2])
@SETTINGS
@given(update=updates(), data=st.data())
def test_damaged_messages_decline_or_equal_rosbags(
    ros: int, update: dict[str, Any], data: st.DataObject
) -> None:
    m = raw(DSG_UPDATE, _in(ros, update), ros)
    b = bytearray(m.data)
    i = data.draw(st.integers(0, len(b) - 1))
    how = data.draw(st.sampled_from(["flip", "cut", "truncate", "append"]))
    if how == "flip":
        b[i] = data.draw(st.integers(0, 255))
    elif how == "cut":
        del b[i : i + data.draw(st.integers(1, 9))]
    elif how == "truncate":
        del b[i:]
    else:
        b += bytes(data.draw(st.integers(1, 9)))
    _assert_like_rosbags(RawMessage(m.topic, m.msgtype, 0, bytes(b), m.encoding), False)


def test_big_endian_cdr_goes_to_rosbags() -> None:
    m = raw(DSG_UPDATE, {"layer_contents": np.arange(5, dtype=np.uint8)}, 2)
    assert read_dsg_update(m.data, "cdr") is not None
    assert read_dsg_update(b"\x00\x00" + m.data[2:], "cdr") is None


@pytest.mark.parametrize("container", CONTAINERS)
def test_every_container(container: str, tmp_path: Path) -> None:
    """Messages written by LogWriter and read back by open_logs: fast equals rosbags, and the
    log's own definition is the layout (``layout_matches``)."""
    from aion_cli.formats.writers import LogWriter

    rng = np.random.default_rng(3)
    path = tmp_path / ("log.bag" if container == "bag" else "log.mcap")
    if container.startswith("rosbag2"):
        path = tmp_path / "log"
    with LogWriter(path, container) as w:
        for k in range(6):
            w.write(
                "/hydra/backend/dsg",
                "hydra_msgs/msg/DsgUpdate",
                {
                    "header": {"stamp": {"sec": 100 + k, "nanosec": 7 * k}, "frame_id": "m" * k},
                    "layer_contents": rng.integers(0, 256, 1000 * k + k, dtype=np.uint8),
                    "deleted_nodes": np.arange(k % 3, dtype=np.uint64),
                    "full_update": True,
                    "sequence_number": k,
                },
                10**9 * (k + 1),
            )
    with open_logs([path]) as logs:
        msgs = list(logs.messages())
        assert len(msgs) == 6
        for m in msgs:
            definition = logs.definition(m.topic, m.msgtype, m.encoding)
            assert layout_matches(m.msgtype, m.encoding, *definition)
            _assert_like_rosbags(m)


def _real_logs_with_dsg() -> list[Path]:
    root = SHARED_DATA / "logs"
    if not root.exists():
        return []
    return [p for p in sorted(root.rglob("*")) if p.is_file() and b"DsgUpdate" in p.read_bytes()]


def test_real_logs() -> None:
    """Real logs carrying DsgUpdate messages (``../shared/data/logs``): none ships today."""
    found = _real_logs_with_dsg()
    if not found:
        pytest.skip("no log under ../shared/data/logs carries hydra_msgs/DsgUpdate messages")
    compared = 0
    for path in found:
        with open_logs([path]) as logs:
            for m in logs.messages():
                if m.msgtype == DSG_UPDATE:
                    _assert_like_rosbags(m, expect_fast=False)
                    compared += 1
    assert compared


OTHER_LAYOUT = """std_msgs/Header header
uint8[] layer_contents
string note
uint64[] deleted_nodes
uint64[] deleted_edges
bool full_update
int64 sequence_number
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def test_another_layout_goes_to_the_generic_decoder(tmp_path: Path) -> None:
    """A log whose own DsgUpdate has another layout (a field more): read by rosbags with that
    definition, never by the fast reader."""
    from mcap.writer import Writer

    from aion_cli.build_report import BuildReport
    from aion_cli.formats.typestores import _parse_definition
    from aion_cli.graph_feed import GraphFeed

    assert layout_matches(DSG_UPDATE, "cdr", "")  # a log embedding no definition
    assert not layout_matches(DSG_UPDATE, "cdr", OTHER_LAYOUT)
    assert not layout_matches("my_msgs/msg/DsgUpdate", "cdr", "")
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(_parse_definition(OTHER_LAYOUT, DSG_UPDATE, False))
    cls = store.types[DSG_UPDATE]
    header = store.types["std_msgs/msg/Header"]
    time = store.types["builtin_interfaces/msg/Time"]
    msg = cls(
        header(time(12, 34), "map"),
        np.arange(9, dtype=np.uint8),
        "a note",
        np.zeros(0, np.uint64),
        np.zeros(0, np.uint64),
        True,
        5,
    )
    path = tmp_path / "other.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        schema = w.register_schema(DSG_UPDATE, "ros2msg", OTHER_LAYOUT.encode())
        channel = w.register_channel("/dsg", "cdr", schema)
        w.add_message(channel, 10**9, bytes(store.serialize_cdr(msg, DSG_UPDATE)), 10**9)
        w.finish()
    feed = GraphFeed(BuildReport(output=tmp_path / "m.aion"), None, None, 0)
    with open_logs([path]) as logs:
        (m,) = logs.messages()
        payload, t_ns = feed.payload(logs, m)
    assert feed._fast_layout == {("/dsg", DSG_UPDATE, "cdr"): False}
    assert bytes(payload) == bytes(range(9))
    assert t_ns == 12 * 10**9 + 34


def test_a_build_gives_the_same_map_without_the_fast_paths(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The graph stream of tests/test_pipeline_graphs.py built with the fast payload and graph
    readers, and with both turned off (rosbags decode, spark_dsg): the same map."""
    from aion_cli.formats import dsg_payload, dsg_update_fast
    from tests.graph_stream_logs import assert_same_map, build_log, write_stream_log

    log = write_stream_log(tmp_path / "stream.mcap")
    calls = {"spark": 0, "fields": 0}
    spark, fields = dsg_payload.read_dsg_payload, dsg_update_fast.read_dsg_update

    def spark_counted(*args: Any, **kwargs: Any) -> Any:
        calls["spark"] += 1
        return spark(*args, **kwargs)

    def fields_counted(data: bytes, encoding: str) -> Any:
        got = fields(data, encoding)
        calls["fields"] += got is not None
        return got

    monkeypatch.setattr(dsg_payload, "read_dsg_payload", spark_counted)
    monkeypatch.setattr(dsg_update_fast, "read_dsg_update", fields_counted)
    fast = build_log(log, tmp_path / "fast.aion", graph_period_ns=0)
    assert calls == {"spark": 0, "fields": fast.graph_messages}
    monkeypatch.setattr(dsg_update_fast, "read_dsg_update", lambda data, encoding: None)
    monkeypatch.setattr(dsg_payload, "_fast_applies", lambda version: False)
    slow = build_log(log, tmp_path / "slow.aion", graph_period_ns=0)
    assert calls["spark"] == slow.graph_decoded == fast.graph_decoded > 0
    assert fast.graph_messages == slow.graph_messages
    assert_same_map(tmp_path / "fast.aion", tmp_path / "slow.aion")
