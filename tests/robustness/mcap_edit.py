"""Copy an MCAP record by record with extra messages, for times and payloads that
``formats.writers.LogWriter`` rightly refuses to write (uint64 log times past 2262, garbage
payloads on a real channel)."""

from __future__ import annotations

import struct
from collections.abc import Iterable
from pathlib import Path

STRING_CDR = b"\x00\x01\x00\x00" + struct.pack("<I", 6) + b"hello\x00"
"""A std_msgs/String "hello" in CDR."""


def copy_with(
    src: Path,
    dst: Path,
    extra: Iterable[tuple[str, str, bytes, int]] = (),
    replace: dict[str, bytes] | None = None,
) -> Path:
    """Copy the MCAP ``src`` to ``dst``, adding ``(topic, type, payload, log time)`` messages
    (on the topic's channel when ``src`` has it, else on a new ``std_msgs/String``-schema
    channel; uint64 log times beyond what LogWriter writes) and replacing the payload of every
    message on a topic of ``replace``. Messages are written in log-time order."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    replace = replace or {}
    with src.open("rb") as fin, dst.open("wb") as fout:
        reader = make_reader(fin)
        writer = Writer(fout)
        writer.start(profile="ros2", library="aion tests")
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}

        def channel(topic: str, name: str, encoding: str, data: bytes) -> int:
            if topic not in channels:
                if name not in schemas:
                    schemas[name] = writer.register_schema(name, encoding, data)
                channels[topic] = writer.register_channel(topic, "cdr", schemas[name])
            return channels[topic]

        rows: list[tuple[int, int, bytes]] = []
        for schema, chan, message in reader.iter_messages(log_time_order=True):
            assert schema is not None
            cid = channel(chan.topic, schema.name, schema.encoding, schema.data)
            data = replace.get(chan.topic, bytes(message.data))
            rows.append((message.log_time, cid, data))
        for topic, msgtype, payload, t in extra:
            rows.append((t, channel(topic, msgtype, "ros2msg", b"string data"), payload))
        for t, cid, data in sorted(rows, key=lambda row: row[0]):
            writer.add_message(cid, t, data, t)
        writer.finish()
    return dst


def payload_of(log: Path, topic: str) -> bytes:
    """The payload of the first message on ``topic``."""
    from mcap.reader import make_reader

    with log.open("rb") as fh:
        for _, _, message in make_reader(fh).iter_messages(topics=[topic]):
            return bytes(message.data)
    raise AssertionError(f"no message on {topic}")
