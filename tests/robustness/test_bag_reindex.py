"""ROS 1 bags whose index cannot be read are indexed in memory from their chunks, as
``rosbag reindex`` would (``formats.bag_reindex``): a recording that was not closed (index
position 0), a copy cut short (the index, kept at the end, is gone; the last chunk is cut
inside), a damaged index. They used to be refused whole ("not a readable ROS 1 bag (Bag
index looks damaged: ...)"); now what the chunks hold whole is read, with a warning.

Every bag is written by LogWriter or is a real rosbag.js fixture, and what must be read is
known from the intact bag's own index, read with rosbags.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from rosbags.rosbag1 import Reader

from aion_cli.formats.logs import open_logs
from tests.robustness.conftest import T0, S, build_json, fails, person, run, write_log


def _bag(path: Path, n: int) -> Path:
    """``n`` person messages a second apart, walking over 40 cells, as a ROS 1 bag."""
    walking = [person(T0 + k * S, (0.5 * (k % 40), 1.0, 0.0)) for k in range(n)]
    return write_log(path, walking, "bag")


def _index_pos(data: bytes) -> tuple[int, int]:
    """Where the bag header's index_pos field is, and its value."""
    at = data.index(b"index_pos=") + len(b"index_pos=")
    return at, struct.unpack_from("<Q", data, at)[0]


def _whole_before(bag: Path, cut: int) -> list[int]:
    """Log times of the messages whose records end by byte ``cut`` of the (uncompressed)
    bag, in file order, from its own index."""
    data = bag.read_bytes()
    ends = []
    with Reader(bag) as reader:
        for entries in reader.indexes.values():
            for e in entries:
                at = reader.chunks[e.chunk_pos].datapos + e.offset
                (header,) = struct.unpack_from("<I", data, at)
                (size,) = struct.unpack_from("<I", data, at + 4 + header)
                ends.append((at + 4 + header + 4 + size, e.time))
    return [t for end, t in sorted(ends) if end <= cut]


def test_a_bag_cut_short_builds_from_the_messages_it_holds_whole(tmp_path: Path) -> None:
    full = _bag(tmp_path / "full.bag", 500)
    data = full.read_bytes()
    _, index_pos = _index_pos(data)
    for size in (len(data) // 3, len(data) * 2 // 3, index_pos):
        want = _whole_before(full, size)
        assert 0 < len(want) <= 500
        cut = tmp_path / "cut.bag"
        cut.write_bytes(data[:size])
        with open_logs([cut]) as logs:
            assert [m.log_time_ns for m in logs.messages()] == want
        report = build_json(cut, "-o", tmp_path / "cut.aion")
        assert report["detections"]["read"] == len(want)
        (warning,) = [w for w in report["warnings"] if "rosbag reindex" in w]
        assert warning.startswith(f"cut.bag: the file ends at byte {size:,}, ")
        assert f"as `rosbag reindex` would: {len(want):,} messages" in warning
        if size < index_pos:
            assert f"before its index at byte {index_pos:,}: it was cut short" in warning
            assert "the file ends inside the chunk at byte " in warning


def test_a_bag_cut_before_any_whole_message_is_a_clear_error(tmp_path: Path) -> None:
    full = _bag(tmp_path / "full.bag", 50)
    data = full.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[:4200])  # the bag header (4 KiB) and the start of the first chunk
    result = run("build", cut, "-o", tmp_path / "cut.aion")
    fails(result, "not a readable ROS 1 bag", "the file ends at byte 4,200",
          "no message of its chunks could be read either")
    assert "rosbag reindex" in result.stderr
    assert not (tmp_path / "cut.aion").exists()


@pytest.mark.parametrize(
    ("index_pos", "says"),
    [(0, "it is not indexed (a recording that was not closed)"),
     (None, "its index cannot be read (Bag index looks damaged: ")],
)
def test_a_bag_without_a_usable_index_is_read_whole(
    index_pos: int | None, says: str, tmp_path: Path
) -> None:
    """Index position 0 (what a recorder writes until it closes the bag) or one pointing
    into the middle of the data: every message is read from the chunks."""
    full = _bag(tmp_path / "full.bag", 200)
    data = bytearray(full.read_bytes())
    at, _ = _index_pos(bytes(data))
    data[at : at + 8] = struct.pack("<Q", len(data) // 2 + 3 if index_pos is None else index_pos)
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    report = build_json(broken, "-o", tmp_path / "b.aion")
    assert report["detections"]["read"] == 200
    (warning,) = [w for w in report["warnings"] if "rosbag reindex" in w]
    assert warning.startswith(f"broken.bag: {says}")
    assert "as `rosbag reindex` would: 200 messages" in warning


def test_a_real_compressed_bag_without_its_index_reads_as_with_it(tmp_path: Path) -> None:
    """rosbag.js's example-bz2.bag (8,647 messages on nine topics in a bz2 chunk) with its
    index position zeroed: the same messages, payloads and topics as the intact bag."""
    from tests.shared_data import real

    source = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    data = bytearray(source.read_bytes())
    at, _ = _index_pos(bytes(data))
    data[at : at + 8] = bytes(8)
    unindexed = tmp_path / "unindexed.bag"
    unindexed.write_bytes(bytes(data))

    def everything(path: Path) -> list[tuple[str, int, bytes]]:
        with open_logs([path]) as logs:
            return [(m.topic, m.log_time_ns, bytes(m.data)) for m in logs.messages()]

    with Reader(source) as reader:
        assert reader.message_count == 8647
    assert everything(unindexed) == everything(source)
    with open_logs([unindexed]) as logs:
        assert logs.total() == 8647
        (warning,) = logs.warnings
    assert "as `rosbag reindex` would: 8,647 messages" in warning


@pytest.mark.parametrize("change", [+1000, -1000])
def test_a_bag_whose_second_chunk_length_is_damaged_says_what_it_loses(
    change: int, tmp_path: Path
) -> None:
    """The data length of a bag's second chunk damaged. Too long: rosbags cannot read the
    index records after it and the bag was refused whole; now the chunks are read in order,
    the records of each as far as they parse (the first two chunks whole). Too short:
    rosbags read other bytes as its index records without an error, and the chunk's 1,354
    messages vanished from the index and every count without a word; now a warning counts
    them (the other chunks are read through the index). No message is ever invented."""
    full = _bag(tmp_path / "full.bag", 5000)
    with Reader(full) as reader:
        first, second = sorted(reader.chunks)[:2]
        every = sorted(e.time for entries in reader.indexes.values() for e in entries)
        in_first, in_second = (
            sorted(e.time for entries in reader.indexes.values() for e in entries
                   if e.chunk_pos == pos)
            for pos in (first, second)
        )
    data = bytearray(full.read_bytes())
    (header_length,) = struct.unpack_from("<I", data, second)
    at = second + 4 + header_length
    (length,) = struct.unpack_from("<I", data, at)
    struct.pack_into("<I", data, at, length + change)
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    with open_logs([broken]) as logs:
        got = [m.log_time_ns for m in logs.messages()]
        (warning,) = logs.warnings
    assert got == sorted(got)
    assert set(got) <= set(every)
    if change > 0:
        assert set(in_first) | set(in_second) <= set(got)
        assert warning.startswith(
            f"broken.bag: the chunk at byte {second} or the index records after it do not "
            "parse"
        )
        assert f"as `rosbag reindex` would: {len(got):,} messages" in warning
    else:
        assert got == sorted(set(every) - set(in_second))
        assert warning == (
            f"broken.bag: its index lists 0 of the {len(in_second):,} messages its chunk info "
            f"gives the chunk at byte {second} (a damaged record length?): "
            f"{len(in_second):,} messages cannot be found and are not read"
        )


def test_a_bag_whose_only_chunk_is_1000_bytes_short_keeps_its_whole_messages(
    tmp_path: Path,
) -> None:
    """The data length of a bag's only chunk 1,000 bytes short: rosbags' index read trips an
    ``assert`` (no message), and the bag was refused as "not a readable ROS 1 bag ()"; now the
    warning names the chunk and the messages the shortened chunk holds whole are read."""
    full = _bag(tmp_path / "full.bag", 200)
    data = bytearray(full.read_bytes())
    with Reader(full) as reader:
        (chunk,) = reader.chunks
        data_at = reader.chunks[chunk].datapos
    (header_length,) = struct.unpack_from("<I", data, chunk)
    at = chunk + 4 + header_length
    (length,) = struct.unpack_from("<I", data, at)
    struct.pack_into("<I", data, at, length - 1000)
    want = _whole_before(full, data_at + length - 1000)
    assert 0 < len(want) < 200
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    info = run("info", broken)
    assert info.exit_code == 0, info.stderr
    report = build_json(broken, "-o", tmp_path / "b.aion")
    assert report["detections"]["read"] == len(want)
    (warning,) = report["warnings"]
    assert warning.startswith(
        f"broken.bag: the chunk at byte {chunk} or the index records after it do not parse: "
    )
    assert "()" not in warning
    assert f"as `rosbag reindex` would: {len(want):,} messages" in warning


def test_a_damaged_compressed_chunk_of_an_unindexed_bag_counts_the_messages_it_loses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bz2 bag without its index (a recording not closed) whose second chunk no longer
    decompresses: build and info said "1 chunk could not be read" and counted its messages
    fewer without saying so. The warning now names the chunk, why, and the messages lost per
    topic, from the index data records the recorder wrote after the chunk (as a skipped chunk
    of an indexed bag is counted); the count is the intact bag's own index's."""
    import rosbags.rosbag1 as rosbag1

    opened = rosbag1.Writer.open

    def bz2_open(self: rosbag1.Writer) -> None:
        self.set_compression(rosbag1.Writer.CompressionFormat.BZ2)
        opened(self)

    monkeypatch.setattr(rosbag1.Writer, "open", bz2_open)
    walking = [person(T0 + k * S, (0.5 * (k % 40), 1.0, 0.0)) for k in range(600)]
    from aion_cli.formats.writers import LogWriter

    full = tmp_path / "full.bag"
    with LogWriter(full, "bag", chunk_size=20_000) as writer:
        for message in walking:
            writer.write(*message)
    monkeypatch.undo()
    with Reader(full) as reader:
        assert len(reader.chunks) > 3
        second = sorted(reader.chunks)[1]
        data_at = reader.chunks[second].datapos
        inside = sum(1 for es in reader.indexes.values() for e in es if e.chunk_pos == second)
    assert inside > 0
    data = bytearray(full.read_bytes())
    (header_length,) = struct.unpack_from("<I", data, second)
    (length,) = struct.unpack_from("<I", data, second + 4 + header_length)
    data[data_at + length // 2] ^= 0xFF  # the bz2 stream no longer decodes
    at, _ = _index_pos(bytes(data))
    data[at : at + 8] = bytes(8)
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    said = (f"1 chunk could not be read (at byte {second}: cannot decompress its bz2 data",
            f"{inside:,} messages lost (/tracks {inside:,})")
    report = build_json(broken, "-o", tmp_path / "b.aion")
    assert report["detections"]["read"] == 600 - inside
    assert [w for w in report["warnings"] if all(part in w for part in said)], report["warnings"]
    info = run("info", broken)
    assert info.exit_code == 0, info.stderr
    assert all(part in " ".join(info.stderr.split()) for part in said), info.stderr
