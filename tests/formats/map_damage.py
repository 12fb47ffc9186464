"""Damaging a map file on purpose, for the tests of readers that must catch it."""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path
from typing import Any

from aion_cli.formats.crc import crc32


def declare_member(rec: dict[str, Any], data: bytes, **fields: Any) -> None:
    """A manifest member record made to match ``data`` (size, sha256 and CRC-32), so that
    the reader's later checks (header, dtype, shape, values) are the ones that see a change;
    ``fields`` are set after."""
    rec.update(size=len(data), sha256=hashlib.sha256(data).hexdigest(),
               crc32=f"{crc32(data):08x}", **fields)


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
