"""Damaging a map file on purpose, for the tests of readers that must catch it."""

from __future__ import annotations

import zipfile
from pathlib import Path


def flip_member_byte(path: Path, member: str, out: Path) -> Path:
    """A copy of ``path`` with one byte of ``member``'s array data inverted (its zip CRC and
    sha256 no longer match; the archive is otherwise intact)."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member + ".npy")
        header = data[info.header_offset : info.header_offset + 30]
        start = (info.header_offset + 30 + int.from_bytes(header[26:28], "little")
                 + int.from_bytes(header[28:30], "little"))
    data[start + info.file_size - 1] ^= 0xFF  # the last byte: array data, not the header
    out.write_bytes(bytes(data))
    return out
