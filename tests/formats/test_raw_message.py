"""``formats.raw.raw_message``: the readers' fast constructor makes the same messages as
``RawMessage(...)`` (issue 15), and an MCAP file read back gives the messages written."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from aion_cli.formats.raw import RawMessage, raw_message


def test_raw_message_is_the_dataclass_instance() -> None:
    args = ("/people", "spencer_tracking_msgs/msg/TrackedPersons", 1_700_000_000_123, b"\x00\x01ab",
            "cdr")
    fast, slow = raw_message(*args), RawMessage(*args)  # type: ignore[arg-type]
    assert type(fast) is RawMessage
    assert fast == slow
    assert hash(fast) == hash(slow)
    assert repr(fast) == repr(slow)
    assert dataclasses.astuple(fast) == args
    assert vars(fast) == vars(slow)
    assert list(vars(fast)) == list(vars(slow))  # the fields in the same order
    assert dataclasses.replace(fast, log_time_ns=5).log_time_ns == 5
    assert fast != raw_message(*args[:2], 1_700_000_000_124, *args[3:])  # type: ignore[arg-type]
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.data = b""  # type: ignore[misc]


def test_mcap_messages_read_back_in_order(tmp_path: Path) -> None:
    """Messages written to an MCAP file (chunked, with a summary: the by-chunk path) come back
    as ``RawMessage`` instances equal to what was written, in log-time order, ties in the
    order written."""
    from aion_cli.formats.logs import open_logs
    from aion_cli.formats.writers import LogWriter

    path = tmp_path / "two.mcap"
    written = []
    with LogWriter(path, "mcap") as w:
        for i in range(300):
            t = 1_700_000_000_000_000_000 + (i // 3) * 10**8  # three messages per time
            topic = "/a" if i % 2 else "/b"
            w.write(topic, "std_msgs/msg/UInt32", {"data": i}, t)
            written.append((topic, t, i))
    with open_logs([path]) as logs:
        got = list(logs.messages())
    assert all(type(m) is RawMessage for m in got)
    assert [(m.topic, m.log_time_ns, int.from_bytes(m.data[4:8], "little")) for m in got] == written
    assert {(m.msgtype, m.encoding) for m in got} == {("std_msgs/msg/UInt32", "cdr")}
