"""MCAP chunks read up to a tail the caller drops unread (issue 15, :mod:`formats.mcap_partial`).

A live Hydra log puts a large scene graph at the end of almost every chunk; a build that
thins the graphs says which it drops (:class:`formats.raw.UnreadHint`). The stream with the
hint has the same messages in the same order as the stream without it, every payload the
same, except that the hinted graphs ending a chunk come as :data:`formats.raw.UNREAD` — and
those chunks are decompressed only up to them (no whole read). Hinted messages inside a chunk
come read. A tail on channels the caller did not ask for is left unread with no hint. An
index that disagrees with the chunk makes the chunk read whole."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import aion_cli.formats.mcap_linear
from aion_cli.formats import mcap_partial
from aion_cli.formats.logs import open_logs
from aion_cli.formats.raw import UNREAD, Unread, UnreadHint
from tests.shared_data import needs, shared

S = 1_000_000_000
T0 = 1_700_006_400 * S
GRAPH_BYTES = 6_000


def write_graph_log(
    path: Path, compression: str, chunk_size: int, seconds: int = 12, seed: int = 7
) -> dict[int, bytes]:
    """Tracks at 10 Hz (60-byte payloads) and a graph every second (6,000 bytes, after the
    tracks of its second), every payload distinct; returns the graphs' payloads by log time
    (also used by ``test_mcap_views``)."""
    from mcap.writer import CompressionType, Writer

    kinds = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "": CompressionType.NONE}
    rng = np.random.default_rng(seed)
    graphs = {}
    with path.open("wb") as f:
        w = Writer(f, compression=kinds[compression], chunk_size=chunk_size)
        w.start(profile="ros2", library="test")
        tracks = w.register_schema("spencer_tracking_msgs/msg/TrackedPersons", "ros2msg", b"")
        dsg = w.register_schema("hydra_msgs/msg/DsgUpdate", "ros2msg", b"")
        c_tracks = w.register_channel("/tracks", "cdr", tracks)
        c_dsg = w.register_channel("/dsg", "cdr", dsg)
        for second in range(seconds):
            for tenth in range(10):
                t = T0 + second * S + tenth * S // 10
                w.add_message(c_tracks, t, rng.bytes(60), t)
            t = T0 + second * S + 950_000_000
            graphs[t] = rng.bytes(GRAPH_BYTES)
            w.add_message(c_dsg, t, graphs[t], t)
        w.finish()
    return graphs


def _write(path: Path, compression: str, chunk_size: int, seconds: int = 12) -> list[int]:
    """The log of :func:`write_graph_log`; returns the graph times."""
    return list(write_graph_log(path, compression, chunk_size, seconds))


def _stream(path: Path, hint: UnreadHint | None = None) -> list[tuple[str, int, bytes]]:
    with open_logs([path]) as logs:
        return [(m.topic, m.log_time_ns, m.data) for m in logs.messages(None, None, hint)]


def _chunk_end_times(path: Path) -> set[int]:
    """The log time of the last message of every chunk (from the summary's chunk indexes)."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {int(c.message_end_time) for c in summary.chunk_indexes}


def _count_whole_reads(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Calls of the whole-chunk decompression (by compressed size)."""
    calls: list[int] = []
    real = aion_cli.formats.mcap_linear._decompress

    def counting(data: Any, *args: Any) -> bytes:
        calls.append(len(data))
        return real(data, *args)

    monkeypatch.setattr(aion_cli.formats.mcap_linear, "_decompress", counting)
    return calls


@pytest.mark.parametrize("compression", ["zstd", "lz4", ""])
def test_hinted_graphs_ending_chunks_come_unread_and_their_chunks_are_read_in_part(
    tmp_path: Path, compression: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunks of one second (each ends with its graph); the hint names every graph but every
    fourth: those come UNREAD, all else exactly as without the hint, and only the chunks of
    the used graphs are decompressed whole."""
    log = tmp_path / "live.mcap"
    graphs = _write(log, compression, chunk_size=GRAPH_BYTES)
    whole = _stream(log)
    dropped = np.array([t for k, t in enumerate(graphs) if k % 4], np.int64)
    calls = _count_whole_reads(monkeypatch)
    hinted = _stream(log, UnreadHint(frozenset({"/dsg"}), dropped))
    assert [(topic, t) for topic, t, _ in hinted] == [(topic, t) for topic, t, _ in whole]
    unread = [(topic, t) for topic, t, data in hinted if isinstance(data, Unread)]
    assert unread == [("/dsg", int(t)) for t in dropped]
    assert set(graphs) <= _chunk_end_times(log)  # the layout the test is about
    for (_, _, got), (_, _, expected) in zip(hinted, whole, strict=True):
        assert isinstance(got, Unread) or got == expected
    if compression:  # uncompressed chunks are not decompressed either way
        assert len(calls) == len(graphs) - len(dropped)
    assert UNREAD == b""


def test_hinted_messages_inside_a_chunk_come_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunks of about four seconds: with the default threshold no tail (one graph, under
    half of a chunk) is left unread, every chunk is read whole; with any tail allowed, only
    the hinted graph that ends its chunk comes unread, the graphs followed by tracks in their
    chunk come read, with their payloads."""
    log = tmp_path / "live.mcap"
    graphs = _write(log, "zstd", chunk_size=4 * GRAPH_BYTES)
    whole = _stream(log)
    hint = UnreadHint(frozenset({"/dsg"}), np.array(graphs, np.int64))
    assert _stream(log, hint) == whole
    monkeypatch.setattr(mcap_partial, "_SMALLEST_TAIL", 0.0)
    hinted = _stream(log, hint)
    assert [(topic, t) for topic, t, _ in hinted] == [(topic, t) for topic, t, _ in whole]
    unread = [t for _, t, data in hinted if isinstance(data, Unread)]
    read_graphs = [
        t for topic, t, data in hinted if topic == "/dsg" and not isinstance(data, Unread)
    ]
    assert 2 <= len(unread) < len(graphs) / 2  # one per chunk
    assert len(read_graphs) == len(graphs) - len(unread)
    assert set(unread) <= _chunk_end_times(log)  # each the last message of its chunk
    for (_, t, got), (_, _, expected) in zip(hinted, whole, strict=True):
        if t not in unread:
            assert got == expected


def test_a_tail_on_channels_not_asked_for_is_left_unread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Asking for the tracks only, without any hint: the graphs ending the chunks are on a
    channel not asked for, so no chunk is decompressed whole, and the stream is the tracks,
    read, as a whole read gives them."""
    log = tmp_path / "live.mcap"
    _write(log, "zstd", chunk_size=GRAPH_BYTES)
    with open_logs([log]) as logs:
        everything = [(m.log_time_ns, m.data) for m in logs.messages() if m.topic == "/tracks"]
    calls = _count_whole_reads(monkeypatch)
    with open_logs([log]) as logs:
        tracks = [(m.log_time_ns, m.data) for m in logs.messages({"/tracks"})]
    assert tracks == everything
    assert len(tracks) == 120
    assert calls == []


def test_an_index_that_disagrees_with_its_chunk_makes_it_read_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Offsets that do not fall on the chunk's records (a damaged or foreign index): the head
    does not end where the index says the tail begins, so every chunk is read whole and the
    stream is that of the whole reads, nothing unread."""
    log = tmp_path / "live.mcap"
    graphs = _write(log, "zstd", chunk_size=GRAPH_BYTES)
    whole = _stream(log)
    real = mcap_partial._index_parts

    def shifted(*args: Any) -> Any:
        got = real(*args)
        if got is None:
            return None
        out = []
        for channel, entries in got:
            moved = entries.copy()
            moved["offset"] += 3
            out.append((channel, moved))
        return out

    monkeypatch.setattr(mcap_partial, "_index_parts", shifted)
    calls = _count_whole_reads(monkeypatch)
    hinted = _stream(log, UnreadHint(frozenset({"/dsg"}), np.array(graphs, np.int64)))
    assert hinted == whole
    assert len(calls) == len(graphs)


@needs(shared("logs"), "the real MCAP files of ../shared/data/logs")
def test_third_party_files_read_channel_by_channel_equal_their_whole_reads(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every indexed MCAP file of the shared data with two channels or more (rosbag2's test
    bags, the MCAP conformance suite: other writers' message indexes), read one channel at a
    time with any tail of other channels left unread (the half-chunk threshold off, so that
    every chunk with such a tail is read in part): each channel's messages equal those of the
    file's whole read, and chunks were read in part."""
    from aion_cli.formats.mcap_source import _open_mcap

    monkeypatch.setattr(mcap_partial, "_SMALLEST_TAIL", 0.0)
    real = mcap_partial.read_head
    in_part: list[bool] = []

    def counting(*args: Any) -> Any:
        got = real(*args)
        in_part.append(got is not None)
        return got

    monkeypatch.setattr(mcap_partial, "read_head", counting)
    nothing = (set[int](), np.zeros(0, np.int64), frozenset[int]())  # no views either
    files = checked = 0
    for path in sorted(shared("logs").rglob("*.mcap")):
        try:
            source = _open_mcap(path)
        except Exception:  # the suite's deliberately broken files: other tests cover them
            continue
        channels = list(source.channel_topics)
        if len(channels) < 2 or not source._by_chunk:
            continue
        files += 1
        whole = list(source.records())
        for channel in channels:
            alone = [r for b in source._chunk_batches({channel}, None, nothing) for r in b]
            assert alone == [r for r in whole if r[1] == channel], (path.name, channel)
            checked += 1
    assert files >= 10
    assert checked >= 30
    assert sum(in_part) >= 20


@given(
    st.lists(
        st.tuples(st.sampled_from(["/tracks", "/dsg", "/other"]), st.integers(0, 40),
                  st.integers(0, 3000)),
        min_size=1,
        max_size=40,
    ),
    st.integers(200, 8000),
    st.sets(st.integers(0, 40)),
    st.sampled_from(["zstd", "lz4", ""]),
)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_any_chunking_and_hint_gives_the_whole_reads_stream(
    events: list[tuple[str, int, int]], chunk_size: int, hinted: set[int], compression: str
) -> None:
    """Any messages (three channels, times out of order and tied, payloads of any size), any
    chunk size, any hinted times on /dsg, reading /tracks and /dsg: the stream is the whole
    read's, message for message and in the same order, except that some hinted /dsg messages
    come UNREAD — and only hinted ones (/other, not asked for, may be left unread too). With
    the half-chunk threshold off, so that every droppable tail is left unread."""
    import tempfile

    from mcap.writer import CompressionType, Writer

    kinds = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "": CompressionType.NONE}
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "any.mcap"
        with log.open("wb") as f:
            w = Writer(f, compression=kinds[compression], chunk_size=chunk_size)
            w.start(profile="ros2", library="test")
            schema = w.register_schema("std_msgs/msg/String", "ros2msg", b"")
            channels = {name: w.register_channel(name, "cdr", schema) for name in
                        ("/tracks", "/dsg", "/other")}
            for k, (name, second, size) in enumerate(events):
                t = T0 + second * S
                w.add_message(channels[name], t, bytes([k % 251]) * size, t)
            w.finish()
        hint = UnreadHint(frozenset({"/dsg"}), np.array(sorted(T0 + h * S for h in hinted)))
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(mcap_partial, "_SMALLEST_TAIL", 0.0)
            with open_logs([log]) as logs:
                whole = [  # every channel asked for: nothing may be left unread
                    (m.topic, m.log_time_ns, m.data)
                    for m in logs.messages()
                    if m.topic in ("/tracks", "/dsg")
                ]
                part = [
                    (m.topic, m.log_time_ns, m.data)
                    for m in logs.messages({"/tracks", "/dsg"}, None, hint)
                ]
    assert [(topic, t) for topic, t, _ in part] == [(topic, t) for topic, t, _ in whole]
    for (topic, t, got), (_, _, expected) in zip(part, whole, strict=True):
        if isinstance(got, Unread):
            assert topic == "/dsg"
            assert (t - T0) // S in hinted
        else:
            assert got == expected


def _write_graphs(path: Path, chunk_size: int, seconds: int = 12) -> list[int]:
    """Scene graphs alone (no tracks), one a second, 6,000 distinct bytes each."""
    from mcap.writer import CompressionType, Writer

    rng = np.random.default_rng(3)
    times = [T0 + second * S for second in range(seconds)]
    with path.open("wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=chunk_size)
        w.start(profile="ros2", library="test")
        dsg = w.register_schema("hydra_msgs/msg/DsgUpdate", "ros2msg", b"")
        channel = w.register_channel("/dsg", "cdr", dsg)
        for t in times:
            w.add_message(channel, t, rng.bytes(GRAPH_BYTES), t)
        w.finish()
    return times


def _chunk_reads(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Offsets of the chunk records the reader starts to read (their heads)."""
    from aion_cli.formats import mcap_records

    offsets: list[int] = []
    real = mcap_records.read_chunk_head

    def counting(f: Any, offset: int, *args: Any) -> Any:
        offsets.append(offset)
        return real(f, offset, *args)

    monkeypatch.setattr(mcap_records, "read_chunk_head", counting)
    return offsets


def test_a_chunk_of_a_left_out_graph_alone_is_not_read_at_all(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A log of scene graphs alone, a chunk each: the hinted graphs (three of four) come
    UNREAD without their chunks being opened (the chunk index says each holds one graph at a
    listed time); the others are read, with their bytes; the stream as without the hint. With
    two graphs per chunk (start and end times differ) every chunk is opened."""
    log = tmp_path / "graphs.mcap"
    graphs = _write_graphs(log, chunk_size=GRAPH_BYTES)
    assert set(graphs) <= _chunk_end_times(log)
    whole = _stream(log)
    dropped = [t for k, t in enumerate(graphs) if k % 4]
    reads = _chunk_reads(monkeypatch)
    hinted = _stream(log, UnreadHint(frozenset({"/dsg"}), np.array(dropped, np.int64)))
    assert [(topic, t) for topic, t, _ in hinted] == [(topic, t) for topic, t, _ in whole]
    assert [t for _, t, data in hinted if isinstance(data, Unread)] == dropped
    for (_, t, got), (_, _, expected) in zip(hinted, whole, strict=True):
        if t not in dropped:
            assert got == expected
            assert len(got) == GRAPH_BYTES
    assert len(reads) == len(graphs) - len(dropped)  # the used graphs' chunks only
    pairs = tmp_path / "pairs.mcap"
    _write_graphs(pairs, chunk_size=2 * GRAPH_BYTES)
    chunks = len(_chunk_end_times(pairs))
    assert chunks == len(graphs) // 2
    reads.clear()
    hinted = _stream(pairs, UnreadHint(frozenset({"/dsg"}), np.array(graphs, np.int64)))
    assert [t for _, t, _ in hinted] == graphs
    assert len(reads) == chunks


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 4), st.lists(st.integers(0, 2**64 - 1), min_size=0, max_size=6)),
        min_size=1,
        max_size=4,
    ),
    st.sets(st.integers(0, 4)),
    st.sets(st.integers(0, 4)),
    st.integers(0, 3),
)
def test_the_last_message_is_the_largest_offset_of_any_channel_first_listed_on_ties(
    channels: list[tuple[int, list[int]]], wanted: set[int], unread: set[int], seed: int
) -> None:
    """Whether a chunk's last message may be left unread is decided on the entry of the
    largest offset its index lists, of any channel (the first listed when two share it; the
    offsets read as the index's unsigned 64-bit numbers), found here by a plain scan: a
    channel not wanted, or one of the hint at a time it lists."""
    from aion_cli.formats.recorded import _INDEX_ENTRY

    rng = np.random.default_rng(seed)
    parts = []
    for cid, offsets in channels:
        if not offsets:
            continue  # (the index's reader keeps channels with entries only)
        entries = np.zeros(len(offsets), _INDEX_ENTRY)
        entries["offset"] = offsets
        entries["log_time"] = rng.integers(0, 4, len(offsets))
        parts.append((cid, entries))
    if not parts:
        return
    times = np.array([0, 2], np.int64)
    flat = [
        (int(o), cid, int(t))
        for cid, p in parts
        for t, o in zip(p["log_time"], p["offset"], strict=True)
    ]
    top = max(o for o, _, _ in flat)
    _, cid, t = next(e for e in flat if e[0] == top)
    expected = cid not in wanted or (cid in unread and t in (0, 2))
    channel, log_time, offset = mcap_partial._entries(parts)
    got = mcap_partial._last_droppable(channel, log_time, offset, wanted, unread, times)
    assert got == expected
