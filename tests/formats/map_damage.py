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


def member_data_offset(path: Path, member: str) -> int:
    """Where the (stored or compressed) bytes of zip member ``member`` start in ``path``."""
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    with open(path, "rb") as fh:
        fh.seek(info.header_offset)
        header = fh.read(30)
    return (info.header_offset + 30 + int.from_bytes(header[26:28], "little")
            + int.from_bytes(header[28:30], "little"))


def rezip(src: Path, dst: Path, compression: int = zipfile.ZIP_DEFLATED) -> Path:
    """``src``'s members, unchanged and in order, in a new zip written by Python's zipfile
    with ``compression``: a map as another tool might re-zip it."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", compression) as zout:
        for name in zin.namelist():
            zout.writestr(name, zin.read(name))
    return dst


def lie_about_sizes(
    path: Path, member: str, *, file_size: int | None = None, compress_size: int | None = None
) -> Path:
    """Make the zip headers (central directory and local header alike) of ``member`` declare
    another uncompressed and/or compressed size, in place; the bytes stay where they are."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
        if info.file_size >= 0xFFFFFFFF or info.compress_size >= 0xFFFFFFFF:
            raise ValueError("ZIP64 sizes are not patched here")
    name = member.encode()
    central = -1
    at = data.rfind(b"PK\x05\x06")  # the end record (no comment holds its signature here)
    cd_start = int.from_bytes(data[at + 16 : at + 20], "little")
    pos = cd_start
    while pos < at:
        n, m, k = (int.from_bytes(data[pos + o : pos + o + 2], "little") for o in (28, 30, 32))
        if data[pos + 46 : pos + 46 + n] == name:
            central = pos
            break
        pos += 46 + n + m + k
    if central < 0:
        raise KeyError(member)
    for offset, value in ((20, compress_size), (24, file_size)):  # central directory
        if value is not None:
            data[central + offset : central + offset + 4] = value.to_bytes(4, "little")
    for offset, value in ((18, compress_size), (22, file_size)):  # local header
        if value is not None:
            local = info.header_offset + offset
            data[local : local + 4] = value.to_bytes(4, "little")
    path.write_bytes(bytes(data))
    return path
