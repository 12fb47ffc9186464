"""aion's own MCAP reader against the MCAP conformance suite (../shared/data/logs/mcap_conformance:
342 files, every record type and writer option, each with a ``.json`` of the records a correct
reader must produce), and the two reading cases the suite showed were wrong before: messages out
of log-time order in a file read linearly, and a summary without channel records.

The suite's channels are not ROS (message encoding ``a``, schema encoding ``c``), so
:class:`~formats.logs.LogSet` lists none of them as topics. The reader is tested one level
below, on :meth:`formats.mcap_source._McapSource.records`: the same chunk-index, library and linear
paths ``LogSet.messages()`` takes, for every channel of the file (ROS or not). The ROS-level
path is tested on files written here with the same layouts.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from aion_cli.formats.mcap_source import _McapSource
from tests.shared_data import FIXTURES, SHARED_DATA, real_path

DATA = real_path("logs", "mcap_conformance")  # the whole suite, else tests/data's 8 files
WHOLE_SUITE = SHARED_DATA / "logs" / "mcap_conformance"
NO_DATA = "the MCAP conformance suite (../shared/data/logs/mcap_conformance) is not available"


def _cases() -> list[str]:
    if not DATA.is_dir():
        return []
    return sorted(str(p.relative_to(DATA)) for p in DATA.glob("*/*.mcap"))


def _expected(path: Path) -> tuple[list[tuple[int, int, bytes]], dict[int, str]]:
    """The Message records ``(log_time, channel_id, data)`` in file order, and the channel
    topics, as the suite's JSON lists them."""
    records = json.loads(path.with_suffix(".json").read_text())["records"]
    messages: list[tuple[int, int, bytes]] = []
    channels: dict[int, str] = {}
    for record in records:
        fields: dict[str, Any] = dict(record["fields"])
        if record["type"] == "Message":
            data = bytes(int(b) for b in fields["data"])
            messages.append((int(fields["log_time"]), int(fields["channel_id"]), data))
        elif record["type"] == "Channel":
            channels[int(fields["id"])] = fields["topic"]
    return messages, channels


def test_the_repository_keeps_a_part_of_the_suite() -> None:
    """tests/data holds 8 files of the suite with their expected records, so the reader is
    checked against it from any clone."""
    kept = sorted((FIXTURES / "logs" / "mcap_conformance").glob("*/*.mcap"))
    assert len(kept) == 8
    assert all(p.with_suffix(".json").is_file() for p in kept)


def test_the_whole_suite_is_here() -> None:
    if not WHOLE_SUITE.is_dir():
        pytest.skip(NO_DATA)
    assert DATA == WHOLE_SUITE
    assert len(_cases()) == 342
    assert all((DATA / name).with_suffix(".json").is_file() for name in _cases())


@pytest.mark.skipif(not DATA.is_dir(), reason=NO_DATA)
@pytest.mark.parametrize("name", _cases() or ["none"])
def test_reader_yields_exactly_the_listed_messages(name: str) -> None:
    path = DATA / name
    messages, channels = _expected(path)
    # in log-time order (the JSON lists file order; several files hold 0, 2, 1, 3, ...), ties
    # in file order
    ordered = sorted(messages, key=lambda m: m[0])
    source = _McapSource(path)
    try:
        assert source.channel_topics == channels
        assert list(source.records()) == ordered
        assert source.file.message_count == len(messages)
        if messages:
            assert source.file.start_ns == ordered[0][0]
            assert source.file.end_ns == max(m[0] for m in messages)
        for cid in channels:
            assert list(source.records([cid])) == [m for m in ordered if m[1] == cid]
        assert list(source.records([999])) == []
        # the channels are not ROS: skipped as topics, and said so; nothing else went wrong
        assert source.topics == {}
        assert all("is not ROS" in w for w in source.warnings)
        assert len(source.warnings) == len(set(channels.values()))
    finally:
        source.close()


@pytest.mark.skipif(not DATA.is_dir(), reason=NO_DATA)
@pytest.mark.parametrize("name", _cases() or ["none"])
def test_logset_lists_no_topic_of_a_non_ros_file(name: str) -> None:
    path = DATA / name
    messages, channels = _expected(path)
    if not messages:  # NoData, OneAttachment, OneMetadata: a log without messages is refused
        with pytest.raises(LogFormatError, match="no messages"):
            open_logs([path])
        return
    with open_logs([path]) as logs:
        assert logs.topics == []
        assert list(logs.messages()) == []
        assert logs.files[0].message_count == len(messages)
        assert any("is not ROS" in w for w in logs.warnings)
        # the warning says how many messages the skipped topics held
        counts: dict[str, int] = {}
        for _t, channel, _data in messages:
            counts[channels[channel]] = counts.get(channels[channel], 0) + 1
        for topic, n in counts.items():
            assert any(f"topic {topic} skipped ({n:,} message" in w for w in logs.warnings)


def test_info_says_how_many_messages_it_cannot_read() -> None:
    """``aion info`` of a log whose only topic is not ROS: none of its 10 messages readable,
    said in the header line, not "messages: 0" beside a file of 10."""
    from tests.cli.conftest import run

    path = real_path("logs", "mcap_conformance", "TenMessages", "TenMessages.mcap")
    if not path.exists():
        pytest.skip(f"{path} is not here: the real data of ../shared/data is absent")
    result = run("info", path)
    assert result.exit_code == 0, result.stderr
    assert "messages: 0 readable of 10 (see the warnings)" in " ".join(result.stdout.split())


# --- the same layouts with ROS channels, through LogSet -----------------------------------------

T0 = 1_700_000_000_000_000_000
ORDER = [0, 2, 1, 3, 3, 5, 4, 7, 8, 9]  # the suite's TenMessages log times, in file order


def _write(path: Path, **options: Any) -> Path:
    """Ten std_msgs/String messages on /a and /b at T0 + ORDER[k] (file order), payload k."""
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f, **options)
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        a = w.register_channel("/a", "cdr", schema)
        b = w.register_channel("/b", "cdr", schema)
        for k, t in enumerate(ORDER):
            payload = b"\x00\x01\x00\x00\x02\x00\x00\x00" + bytes([65 + k, 0])
            w.add_message(a if k % 2 == 0 else b, T0 + t, payload, T0 + t, sequence=k)
        w.finish()
    return path


def _payload_order(logs: Any, topics: list[str] | None = None) -> list[int]:
    return [m.data[8] - 65 for m in logs.messages(topics)]


# file index k -> stable order by log time
IN_TIME_ORDER = [k for _, k in sorted((t, k) for k, t in enumerate(ORDER))]


@pytest.mark.parametrize(
    "options",
    [
        {"use_chunking": False},  # unchunked, with a summary but no chunk index
        {"use_chunking": False, "use_statistics": False, "use_summary_offsets": False},
        {"chunk_size": 40},  # a chunk per message or two: overlapping chunks
        {"chunk_size": 40, "use_statistics": False},  # ... read linearly
        {"repeat_channels": False, "repeat_schemas": False},  # summary without channels
        {"repeat_channels": False, "repeat_schemas": False, "chunk_size": 40},
    ],
    ids=[
        "unchunked",
        "unchunked-no-summary",
        "small-chunks",
        "small-chunks-linear",
        "no-repeated-channels",
        "no-repeated-channels-small-chunks",
    ],
)
def test_messages_come_in_log_time_order_whatever_the_layout(
    options: dict[str, Any], tmp_path: Path
) -> None:
    path = _write(tmp_path / "t.mcap", **options)
    with open_logs([path]) as logs:
        assert [t.topic for t in logs.topics] == ["/a", "/b"]
        assert logs.total() == 10
        msgs = list(logs.messages())
        assert [m.log_time_ns - T0 for m in msgs] == sorted(ORDER)
        assert _payload_order(logs) == IN_TIME_ORDER
        assert _payload_order(logs, ["/b"]) == [k for k in IN_TIME_ORDER if k % 2]
        assert logs.decode(msgs[0]).data == "A"
        assert (logs.start_ns, logs.end_ns) == (T0, T0 + 9)
        assert logs.warnings == []


def test_out_of_order_truncated_file_keeps_order_up_to_the_break(tmp_path: Path) -> None:
    path = _write(tmp_path / "t.mcap", use_chunking=False)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 5])  # in the sixth message (of 10)
    with open_logs([cut]) as logs:
        assert logs.total() == 5
        assert "truncated or corrupt MCAP" in logs.warnings[0]
        times = [m.log_time_ns - T0 for m in logs.messages()]
        assert times == sorted(ORDER[:5]) == [0, 1, 2, 3, 3]
