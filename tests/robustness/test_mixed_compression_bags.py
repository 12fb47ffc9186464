"""ROS 1 bags whose chunks differ from one another, read back through every entry point that
reads logs (as ``test_mixed_compression.py`` does for MCAP files): bags that mix ``none``,
``bz2`` and ``lz4`` chunks, hold an empty chunk, chunks whose ``size`` field is 0 (a writer that
does not fill it in), chunk info records out of file order and chunks out of time order. Every
bag is assembled record by record (``tests/formats/craft_bag.py``) around the messages a
LogWriter wrote, so what must come back is known exactly, and a map built from the crafted bag
equals the map built from the LogWriter's own bag. A damaged chunk among mixed ones, in a bag
and in an MCAP file, is skipped alone.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import run_json
from tests.formats.craft import McapFile, McapParts, records_chunk
from tests.formats.craft_bag import bag_topic, craft_bag
from tests.robustness.conftest import build_json, walk, write_log
from tests.robustness.test_mixed_compression import (
    assert_same_map,
    mcap,  # noqa: F401  (fixture)
    read_back,
)

# -- ROS 1 bags --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any, list[tuple[int, bytes]]]:
    """40 person messages on /tracks, one a second, as a LogWriter bag holds them."""
    source = write_log(tmp_path_factory.mktemp("bag") / "source.bag", walk(40), "bag")
    topic, msgs = bag_topic(source, "/tracks")
    return source, topic, msgs


MIXED = ["none", "bz2", "none", "lz4", "bz2"]


@pytest.mark.parametrize(
    ("packing", "options", "order"),
    [
        (MIXED, {}, [0, 1, 2, 3]),
        (["lz4", "bz2", "none", "none", "lz4"], {"info_order": [4, 2, 0, 3, 1]}, [0, 1, 2, 3]),
        (["none"] * 5, {"declared_sizes": [0] * 5}, [0, 1, 2, 3]),
        (["none", "bz2", "none", "lz4", "none"], {"declared_sizes": [0] * 5}, [0, 1, 2, 3]),
        (["bz2", "lz4", "lz4", "none", "bz2"], {"info_order": [3, 0, 4, 2, 1]}, [2, 0, 3, 1]),
    ],
    ids=[
        "mixed",
        "mixed-index-out-of-order",
        "size-0",
        "size-0-mixed",
        "chunks-out-of-time-order",
    ],
)
def test_bag_chunks_of_mixed_compression(
    packing: list[str],
    options: dict[str, Any],
    order: list[int],
    bag: tuple[Path, Any, list[tuple[int, bytes]]],
    tmp_path: Path,
) -> None:
    """Five chunks: four of ten messages and an empty one (index 2, its chunk info listing no
    connection); ``order``: which tens of messages the non-empty chunks hold, in file order.
    ``size-0``: every chunk's ``size`` field 0 (unknown: the data of an uncompressed one is
    its size; a compressed one is decompressed up to the cap, and may hold a message over the
    message cap, so the index gives no times: the build reads the messages). Every message
    comes back, in time order, from the stream, a time range and the index."""
    _source, topic, msgs = bag
    tens = [msgs[k * 10 : (k + 1) * 10] for k in range(4)]
    chunks = [tens[order[0]], tens[order[1]], [], tens[order[2]], tens[order[3]]]
    path = tmp_path / "mixed.bag"
    path.write_bytes(craft_bag(topic, chunks, packing, **options))
    got = read_back(path, ["/tracks"])
    assert got["messages"] == msgs
    assert got["ranged"] == got["wanted_range"]
    assert len(got["ranged"]) == 20
    unknown_sizes = "declared_sizes" in options and set(packing) != {"none"}
    assert got["index"] == (None if unknown_sizes else [t for t, _ in msgs])
    assert got["span"] == (msgs[0][0], msgs[-1][0])
    assert got["total"] == 40
    if order == sorted(order):
        assert got["warnings"] == []
    else:  # chunks out of time order in the file: said, and read in time order all the same
        (line,) = got["warnings"]
        assert "its log times go back" in line
    info = run_json("info", path, "--format", "json")
    assert info["compression"] == sorted(set(packing))
    assert (info["messages"], info["start_ns"], info["end_ns"]) == (40, msgs[0][0], msgs[-1][0])


def test_a_mixed_bag_builds_the_map_of_its_plain_twin(
    bag: tuple[Path, Any, list[tuple[int, bytes]]], tmp_path: Path
) -> None:
    source, topic, msgs = bag
    path = tmp_path / "mixed.bag"
    path.write_bytes(craft_bag(topic, [msgs[:10], msgs[10:20], [], msgs[20:30], msgs[30:]], MIXED))
    assert_same_map(path, source, tmp_path, 40)


def test_a_mixed_bag_without_its_index_is_reindexed_whole(
    bag: tuple[Path, Any, list[tuple[int, bytes]]], tmp_path: Path
) -> None:
    """The same bag cut where its index begins: indexed from its chunks, every compression
    decompressed, every message read."""
    _, topic, msgs = bag
    data = craft_bag(topic, [msgs[:10], msgs[10:20], [], msgs[20:30], msgs[30:]], MIXED)
    at = data.find(b"index_pos=")
    (index_pos,) = struct.unpack_from("<Q", data, at + len(b"index_pos="))
    path = tmp_path / "cut.bag"
    path.write_bytes(data[:index_pos])
    got = read_back(path, ["/tracks"])
    assert got["messages"] == msgs
    assert got["index"] == [t for t, _ in msgs]
    (line,) = got["warnings"]
    assert "indexed in memory from its 5 chunks, as `rosbag reindex` would: 40 messages" in line


def test_a_damaged_chunk_among_mixed_ones_is_skipped_alone(
    bag: tuple[Path, Any, list[tuple[int, bytes]]],
    mcap: tuple[Path, McapParts],  # noqa: F811
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The lz4 chunk of a bag (bz2, lz4, none, bz2) and of an MCAP (zstd, lz4, none, zstd)
    damaged inside its data: a build's first pass takes the log times from the index and so
    vouches for that chunk; its stream meets the damage (StaleIndexError, once) and starts
    over reading every message: the detections of the other chunks, the skipped one named
    once."""
    from aion_cli.errors import StaleIndexError

    stale: list[str] = []
    original = StaleIndexError.__init__

    def spy(self: StaleIndexError, message: str, *args: Any, **kw: Any) -> None:
        stale.append(message)
        original(self, message, *args, **kw)

    monkeypatch.setattr(StaleIndexError, "__init__", spy)
    _, topic, msgs = bag
    data = bytearray(craft_bag(topic, [msgs[:10], msgs[10:20], msgs[20:30], msgs[30:]],
                               ["bz2", "lz4", "none", "bz2"]))  # fmt: skip
    at = data.index(b"\x04\x22\x4d\x18")  # the lz4 frame's magic
    data[at + 30 : at + 40] = bytes(10)
    path = tmp_path / "damaged.bag"
    path.write_bytes(bytes(data))
    report = build_json(path, "-o", tmp_path / "bag.aion")
    assert report["detections"] == {"read": 30, "used": 30, "dropped": {}}
    (line,) = report["warnings"]
    assert line.startswith("damaged.bag: chunk at byte ")
    assert line.endswith("; 10 messages lost (/tracks 10)")
    (restart,) = stale
    assert restart.startswith("damaged.bag: ")

    _, parts = mcap
    f = McapFile(parts)
    head = [*parts.schemas, *parts.channels]
    for k, packing in enumerate(["zstd", "lz4", "", "zstd"]):
        f.chunk(records_chunk([*(head if k == 0 else []), *parts.messages[30 * k : 30 * k + 30]],
                              packing))  # fmt: skip
    raw = bytearray(f.bytes())
    at = f.chunk_offsets[1]
    raw[at + 120 : at + 130] = bytes(10)
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(raw))
    report = build_json(path, "-o", tmp_path / "mcap.aion")
    assert report["detections"] == {"read": 45, "used": 45, "dropped": {}}
    assert report["warnings"] == [
        f"damaged.mcap: corrupt chunk at byte {at} skipped: cannot decompress its lz4 data "
        "(LZ4F_decompress failed with code: ERROR_decompressionFailed); 30 messages lost "
        "(/tf 15, /tracks 15)"
    ]
    assert stale[1:] == [
        f"damaged.mcap: the chunk at byte {at} cannot be read, but its log times were taken "
        "from its index"
    ]
