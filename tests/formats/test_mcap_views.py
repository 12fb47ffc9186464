"""Payloads as views of their decompressed chunk (issue 15, :attr:`formats.raw.UnreadHint.views`).

A live Hydra log's scene graph fills nearly all of its chunk; copying it out of the chunk cost
as much as a third of decompressing it. A caller that takes the payloads of the hint's topics
as read-only memoryviews (the build's graph stream) gets a view of the chunk instead, where
the payload is at least half of the chunk (so a view keeps at most twice its bytes alive). The
payloads are the bytes written, whatever chunk is read after them; every other payload, and
every payload without ``views``, is ``bytes``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats import mcap_records
from aion_cli.formats.logs import open_logs
from aion_cli.formats.raw import Unread, UnreadHint
from tests.formats.test_mcap_partial import GRAPH_BYTES, write_graph_log


def _write(path: Path, compression: str, chunk_size: int, seconds: int = 8) -> dict[int, bytes]:
    """Tracks at 10 Hz and a graph each second (:func:`write_graph_log`); returns the graphs'
    payloads by log time."""
    return write_graph_log(path, compression, chunk_size, seconds, seed=11)


def _stream(path: Path, hint: UnreadHint | None) -> list[Any]:
    with open_logs([path]) as logs:
        return list(logs.messages(None, None, hint))


@pytest.mark.parametrize("compression", ["zstd", "lz4", ""])
@pytest.mark.parametrize("thinned", [False, True])
def test_graphs_filling_their_chunk_come_as_views_of_it(
    tmp_path: Path, compression: str, thinned: bool
) -> None:
    """Chunks of one second: every graph read is a read-only view of a chunk at most twice its
    size, holding the bytes written (checked after the whole stream was read); the tracks are
    bytes. The same with every other graph hinted unread (their chunks read in part)."""
    log = tmp_path / "live.mcap"
    graphs = _write(log, compression, chunk_size=GRAPH_BYTES)
    dropped = np.array(sorted(graphs)[1::2] if thinned else [], np.int64)
    msgs = _stream(log, UnreadHint(frozenset({"/dsg"}), dropped, views=True))
    read = [m for m in msgs if m.topic == "/dsg" and not isinstance(m.data, Unread)]
    assert [m.log_time_ns for m in read] == sorted(set(graphs) - set(dropped.tolist()))
    for m in read:
        assert isinstance(m.data, memoryview)
        assert m.data.readonly
        assert GRAPH_BYTES <= len(m.data.obj) <= 2 * GRAPH_BYTES  # the chunk it views
        assert m.data == graphs[m.log_time_ns]
        with pytest.raises(TypeError):
            m.data[0] = 0
    assert all(type(m.data) is bytes for m in msgs if m.topic == "/tracks")
    assert sum(m.topic == "/tracks" for m in msgs) == 10 * len(graphs)


def test_graphs_under_half_of_their_chunk_and_graphs_without_views_are_bytes(
    tmp_path: Path,
) -> None:
    """Chunks of about four seconds (a graph is under half of one): bytes even with
    ``views``; chunks of one second without ``views``: bytes. The same payloads either way."""
    small = tmp_path / "small.mcap"
    graphs = _write(small, "zstd", chunk_size=4 * GRAPH_BYTES)
    hint = UnreadHint(frozenset({"/dsg"}), np.zeros(0, np.int64), views=True)
    got = {m.log_time_ns: m.data for m in _stream(small, hint) if m.topic == "/dsg"}
    assert all(type(data) is bytes for data in got.values())
    assert got == graphs
    one = tmp_path / "one.mcap"
    graphs = _write(one, "zstd", chunk_size=GRAPH_BYTES)
    for plain in (None, UnreadHint(frozenset({"/dsg"}), np.zeros(0, np.int64))):
        got = {m.log_time_ns: m.data for m in _stream(one, plain) if m.topic == "/dsg"}
        assert all(type(data) is bytes for data in got.values())
        assert got == graphs


def test_chunk_messages_views_only_the_channels_asked_and_checks_the_records() -> None:
    """The records of a chunk built by hand: a 100-byte payload on channel 1 and a 10-byte one
    on channel 2 in a 172-byte chunk; channel 1 viewed when asked, channel 2 never (under
    half); a record overrunning the chunk still raises ChunkError with views."""
    import struct

    def message(channel: int, t: int, data: bytes) -> bytes:
        body = struct.pack("<HIQQ", channel, 0, t, t) + data
        return struct.pack("<BQ", mcap_records.OP_MESSAGE, len(body)) + body

    big, small = bytes(range(100)), b"0123456789"
    buf = message(1, 5, big) + message(2, 3, small)
    selected, oversized, seen = mcap_records.chunk_messages(buf, {1, 2}, 1 << 20, {1, 2})
    assert (seen, oversized) == (2, [])
    assert [(t, c) for t, c, _ in selected] == [(3, 2), (5, 1)]
    assert type(selected[0][2]) is bytes
    assert selected[0][2] == small
    assert isinstance(selected[1][2], memoryview)
    assert selected[1][2] == big
    assert selected[1][2].obj is buf
    plain, _, _ = mcap_records.chunk_messages(buf, {1, 2}, 1 << 20)
    assert all(type(data) is bytes for _, _, data in plain)
    with pytest.raises(mcap_records.caps.ChunkError):
        mcap_records.chunk_messages(buf[:-1], {1, 2}, 1 << 20, {1})
