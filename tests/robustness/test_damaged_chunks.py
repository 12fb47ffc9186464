"""A byte flipped inside the compressed chunk of a real bag (rosbag.js's example-bz2.bag and
example-lz4.bag: one chunk of 8,647 messages): the chunk is lost either way, and the warning
said why. Most flips in bz2 data read "its bz2 data expands beyond the 743,449 bytes it
declares": decompression stops one byte past the declared size, before the damaged block's
CRC is checked, so damaged data passed for a lying size field. The compression library itself
(decompressing the whole chunk) says the data is damaged; the warning now says so too."""

from __future__ import annotations

import bz2
from pathlib import Path

import lz4.frame  # type: ignore[import-untyped]
import pytest

from aion_cli.formats.bag_reader import BagReader
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.logs import open_logs
from tests.shared_data import real

WHOLE = {"bz2": bz2.decompress, "lz4": lz4.frame.decompress}


def _chunk(path: Path) -> tuple[int, int, str]:
    """Where the bag's one chunk's compressed data lies, and its compression."""
    reader = BagReader(path, ReadLimits())
    reader.open()
    try:
        ((pos, chunk),) = reader.chunks.items()
        return chunk.datapos, chunk.datasize, reader.chunk_meta[pos][0]
    finally:
        reader.close()


@pytest.mark.parametrize("name", ["example-bz2.bag", "example-lz4.bag"])
def test_a_flipped_byte_in_a_compressed_chunk_is_said_to_be_damage(
    name: str, tmp_path: Path
) -> None:
    original = real("logs", "rosbagjs_fixtures", name)
    data = original.read_bytes()
    start, size, compression = _chunk(original)
    assert compression == name.split("-")[1].removesuffix(".bag")
    damaged_seen = 0
    for k in range(1, 13):  # a byte every 1/13 of the data
        at = start + k * size // 13
        flipped = bytearray(data)
        flipped[at] ^= 0xFF
        try:
            WHOLE[compression](bytes(flipped[start : start + size]))
            continue  # the library reads it: not damage it can tell
        except Exception:  # each library's own error
            damaged_seen += 1
        path = tmp_path / f"flip{k}.bag"
        path.write_bytes(bytes(flipped))
        with open_logs([path]) as logs:
            assert sum(1 for _ in logs.messages()) == 0
            (said,) = [w for w in logs.warnings if "chunk at byte" in w]
        assert f"skipped: cannot decompress its {compression} data (" in said, (k, said)
        assert "8,647 messages lost" in said
    assert damaged_seen >= 6
