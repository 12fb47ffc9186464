"""Deflated members, as another tool that re-zips a map writes them (``formats/MAPFILE.md``,
"Readers accept deflated members written by other tools, within the limits below").

aion writes every member stored, so these members take the reader's other path
(``formats/mapfile_check.py``: ``_read_member_bytes`` through :mod:`zipfile`). Each limit is
tested at its boundary, exactly at it (read) and one step past it (refused), with a map whose
sizes are arranged so that only the limit under test decides: the member limit, the per-member
ratio check and where it starts (above 1 MiB), and the ratio of the members' total to the
file's size (100x by default; the file's size set to the byte with a zip comment). Headers
that lie about a member's sizes, and a damaged deflate stream, must be a
:class:`MapCorruptError` naming the member, never another exception, and a member whose
stream inflates far past its declared size must not take that memory before it is refused.
"""

from __future__ import annotations

import io
import json
import math
import re
import tracemalloc
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import MapCorruptError, MapFileError
from aion_cli.formats.mapfile import (
    MAP_FORMAT,
    RATIO_MIN_BYTES,
    format_version,
    read_manifest,
    read_map,
)
from tests.formats.map_damage import declare_member, lie_about_sizes, member_data_offset

MB = 1024**2
NPY_HEADER = 128  # np.save's header for a 1-D uint8 array: magic, length, dict, padding


def npy_of_size(size: int, fill: np.ndarray | None = None) -> bytes:
    """The ``.npy`` bytes of a 1-D uint8 array, exactly ``size`` bytes long (zeros, or
    ``fill``'s bytes)."""
    arr = np.zeros(size - NPY_HEADER, np.uint8) if fill is None else fill
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    out = buf.getvalue()
    assert len(out) == size
    return out


def deflated_size(data: bytes) -> int:
    """The compressed size zipfile gives ``data`` with ZIP_DEFLATED at its default level."""
    co = zlib.compressobj(zlib.Z_DEFAULT_COMPRESSION, zlib.DEFLATED, -15)
    return len(co.compress(data) + co.flush())


def write_zip_map(
    path: Path,
    members: dict[str, bytes],
    *,
    stored: tuple[str, ...] = (),
    manifest_pad: int = 0,
    comment: bytes = b"",
    size_lie: int = 0,
) -> Path:
    """A valid map in every respect (manifest, sizes, checksums, dtypes, shapes) whose
    members (and manifest) are deflated except those named in ``stored``; ``manifest_pad``
    spaces end the manifest's JSON, ``comment`` is the zip's comment; ``size_lie`` bytes are
    added to every size the manifest declares."""
    records: dict[str, dict[str, Any]] = {}
    for name, data in members.items():
        arr = np.load(io.BytesIO(data), allow_pickle=False)
        records[name] = {}
        declare_member(records[name], data, dtype=arr.dtype.str, shape=list(arr.shape))
        records[name]["size"] += size_lie
    manifest = {"format": MAP_FORMAT, "version": format_version(), "creator": "another tool",
                "created": "2026-12-06T00:00:00Z", "members": records}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            method = zipfile.ZIP_STORED if name in stored else zipfile.ZIP_DEFLATED
            zf.writestr(name + ".npy", data, compress_type=method)
        zf.writestr("manifest.json", json.dumps(manifest) + " " * manifest_pad)
        zf.comment = comment
    return path


def filler() -> bytes:
    """2 MiB of random bytes, stored: keeps the whole file's expansion low, so that only a
    per-member check can refuse a map that holds it."""
    return npy_of_size(2 * MB, np.random.default_rng(1).integers(0, 256, 2 * MB - NPY_HEADER,
                                                                  dtype=np.uint8))


# -- the limits, at their boundaries ------------------------------------------------------


def test_a_deflated_member_reads_at_the_member_and_total_limits_and_not_past(
    tmp_path: Path,
) -> None:
    """The member limit compares the member's uncompressed size (not the few bytes it takes
    deflated), as the manifest and as the zip header declare it: 5,000 bytes of zeros read
    with a 5,000-byte limit, not with 4,999; likewise the declared total of every entry,
    manifest included."""
    data = npy_of_size(5000)
    path = write_zip_map(tmp_path / "m.aion", {"z": data})
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("z.npy")
        total = sum(i.file_size for i in zf.infolist())
    assert info.compress_type == zipfile.ZIP_DEFLATED
    assert info.compress_size < 200
    assert read_map(path, max_member_bytes=5000)[0]["z"].size == 5000 - NPY_HEADER
    with pytest.raises(MapFileError, match="member z declares 5000 bytes, over the 4999-byte"):
        read_map(path, max_member_bytes=4999)
    # the zip header is checked too: a manifest understating the size does not get it read
    understated = write_zip_map(tmp_path / "under.aion", {"z": data}, size_lie=-1)
    with pytest.raises(MapFileError, match=r"z\.npy declares 5000 bytes, over the 4999-byte"):
        read_map(understated, max_member_bytes=4999)
    assert read_map(path, max_total_bytes=total)[0]["z"].size == 5000 - NPY_HEADER
    with pytest.raises(MapFileError, match="in all, over the"):
        read_map(path, max_total_bytes=total - 1)


def test_the_member_ratio_check_starts_above_1_mib(tmp_path: Path) -> None:
    """Zeros deflate about 1000:1, ten times the default limit; the check applies to members
    above ``RATIO_MIN_BYTES`` (1 MiB) only: 1 MiB of them reads, 1 MiB + 1 byte is refused
    as a possible zip bomb (a stored random filler keeps the whole file's ratio near 1)."""
    fill = filler()
    at = write_zip_map(tmp_path / "at.aion", {"fill": fill, "z": npy_of_size(RATIO_MIN_BYTES)},
                       stored=("fill",))
    arrays, _ = read_map(at)
    assert arrays["z"].size == RATIO_MIN_BYTES - NPY_HEADER
    assert not arrays["z"].any()
    past = write_zip_map(tmp_path / "past.aion",
                         {"fill": fill, "z": npy_of_size(RATIO_MIN_BYTES + 1)}, stored=("fill",))
    with zipfile.ZipFile(past) as zf:
        info = zf.getinfo("z.npy")
    assert info.file_size > 100 * info.compress_size  # what the check is to see
    with pytest.raises(MapFileError, match=r"member z\.npy expands .*refusing a possible zip bomb"):
        read_map(past)


def test_a_member_expanding_exactly_max_ratio_times_reads(tmp_path: Path) -> None:
    """A member of 2 MiB and some bytes of zeros whose length is an exact multiple ``k`` of
    its deflated size expands exactly ``k`` times: ``max_ratio=k`` reads it, a ratio a hair
    below refuses it."""
    size = 2 * MB
    while True:  # the deflated size is constant over long runs of lengths: find a multiple
        c = deflated_size(npy_of_size(size))
        candidate = math.ceil(size / c) * c
        if deflated_size(npy_of_size(candidate)) == c:
            size = candidate
            break
        size = candidate + 1
    k = size // c
    path = write_zip_map(tmp_path / "k.aion", {"fill": filler(), "z": npy_of_size(size)},
                         stored=("fill",))
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("z.npy")
    assert (info.file_size, info.compress_size) == (size, c)
    assert info.file_size == k * info.compress_size
    assert read_map(path, max_ratio=k)[0]["z"].size == size - NPY_HEADER
    with pytest.raises(MapFileError, match=r"z\.npy expands .*zip bomb"):
        read_map(path, max_ratio=k * (1 - 1e-9))


def test_the_total_may_expand_exactly_100_times_the_files_size(tmp_path: Path) -> None:
    """Three members just under 1 MiB each (no per-member check) and a manifest padded so
    the declared total is a multiple of 100; a zip comment sets the file's size to exactly
    1/100 of it: read with the default limit (100x). One byte less of comment: refused
    before any member is read."""
    members = {f"z{i}": npy_of_size(RATIO_MIN_BYTES - 1000) for i in range(3)}
    plain = write_zip_map(tmp_path / "plain.aion", members)
    with zipfile.ZipFile(plain) as zf:
        total = sum(i.file_size for i in zf.infolist())
    pad = -total % 100
    padded = write_zip_map(tmp_path / "padded.aion", members, manifest_pad=pad)
    with zipfile.ZipFile(padded) as zf:
        total = sum(i.file_size for i in zf.infolist())
    assert total % 100 == 0
    assert total > RATIO_MIN_BYTES
    room = total // 100 - padded.stat().st_size  # bytes of comment that make the file total/100
    assert 1 < room < 65536
    at = write_zip_map(tmp_path / "at.aion", members, manifest_pad=pad, comment=b"c" * room)
    assert 100 * at.stat().st_size == total
    assert len(read_map(at)[0]) == 3
    past = write_zip_map(tmp_path / "past.aion", members, manifest_pad=pad,
                         comment=b"c" * (room - 1))
    with pytest.raises(MapFileError, match=r"over the file's .* bytes .*zip bomb"):
        read_map(past)


# -- headers that lie, and damaged streams ------------------------------------------------


def _member_map(tmp_path: Path) -> tuple[Path, bytes]:
    """A deflated map of one 200-KB member ``z`` (a ramp of bytes: compressible, not
    trivially) and its ``.npy`` bytes."""
    data = npy_of_size(200_000, (np.arange(200_000 - NPY_HEADER) % 251).astype(np.uint8))
    return write_zip_map(tmp_path / "m.aion", {"z": data}), data


def _declared(path: Path, name: str = "z.npy") -> zipfile.ZipInfo:
    with zipfile.ZipFile(path) as zf:
        return zf.getinfo(name)


def test_the_deflated_map_of_the_lies_reads_untouched(tmp_path: Path) -> None:
    """The map the next tests damage reads back whole: what they see is their change."""
    path, data = _member_map(tmp_path)
    info = _declared(path)
    assert info.compress_type == zipfile.ZIP_DEFLATED
    assert info.compress_size < info.file_size == len(data)
    np.testing.assert_array_equal(read_map(path)[0]["z"],
                                  np.load(io.BytesIO(data), allow_pickle=False))


def test_a_member_inflating_past_its_declared_size_is_corrupt(tmp_path: Path) -> None:
    """Headers declaring 1,000 bytes for a 200-KB stream: the read stops at 1,000 and the
    zip CRC of what was read fails."""
    path, _ = _member_map(tmp_path)
    lie_about_sizes(path, "z.npy", file_size=1000)
    with pytest.raises(MapCorruptError, match=r"member z\.npy cannot be read .*CRC"):
        read_map(path)


def test_a_truncated_stream_is_corrupt(tmp_path: Path) -> None:
    """The compressed size cut to half of the stream (its declared uncompressed size kept):
    the stream ends early, what it gave fails the CRC."""
    path, _ = _member_map(tmp_path)
    lie_about_sizes(path, "z.npy", compress_size=_declared(path).compress_size // 2)
    with pytest.raises(MapCorruptError, match=r"member z\.npy"):
        read_map(path)


def test_a_member_declaring_more_than_its_stream_holds_is_corrupt(tmp_path: Path) -> None:
    """Zip headers and manifest both declaring 1,000 bytes more than the stream inflates to
    (the zip CRC fits the bytes the stream holds, so only their count can tell): the bytes
    read are fewer than declared."""
    path, data = _member_map(tmp_path)
    write_zip_map(path, {"z": data}, size_lie=1000)
    lie_about_sizes(path, "z.npy", file_size=len(data) + 1000)
    with pytest.raises(MapCorruptError, match="member z has 200000 bytes, manifest says 201000"):
        read_map(path)


@pytest.mark.parametrize("member", ["z.npy", "manifest.json"])
def test_a_damaged_deflate_stream_is_corrupt_naming_the_member(
    tmp_path: Path, member: str
) -> None:
    """Eight bytes inverted at the start of a member's deflate stream: zlib refuses the
    stream (``zlib.error``: 'invalid stored block lengths' here), which is the file's damage,
    a :class:`MapCorruptError` naming the member, as a failed CRC is. (It escaped as a bare
    ``zlib.error`` before, and ``aion predict`` called it an internal error, exit 1.)"""
    path, _ = _member_map(tmp_path)
    raw = bytearray(path.read_bytes())
    start = member_data_offset(path, member)
    raw[start : start + 8] = bytes(b ^ 0xA5 for b in raw[start : start + 8])
    path.write_bytes(bytes(raw))
    with pytest.raises(MapCorruptError, match=f"member {re.escape(member)} cannot be read"):
        read_map(path)
    if member == "manifest.json":
        with pytest.raises(MapCorruptError, match=r"member manifest\.json cannot be read"):
            read_manifest(path)


def test_a_bomb_declaring_a_small_size_is_refused_in_little_memory(tmp_path: Path) -> None:
    """64 MiB of zeros deflated to ~64 KB, its headers and manifest declaring 1,000 bytes
    (so no size or ratio check sees it): refused as corrupt (the CRC of its first 1,000
    bytes fails) after reading what it declares, not what it holds. Before, zipfile was asked
    for up to the member limit (4 GiB) and inflated the whole stream first: a 65-KB file
    took 141 MiB, a 4-MB one would take gigabytes."""
    path = tmp_path / "bomb.aion"
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "|u1", "fortran_order": False, "shape": (64 * MB,)}
    )
    small = npy_of_size(1000)
    rec: dict[str, object] = {}
    declare_member(rec, small, dtype="|u1", shape=[1000 - NPY_HEADER])
    manifest = {"format": MAP_FORMAT, "version": format_version(), "creator": "a bomb",
                "created": "2026-12-06T00:00:00Z", "members": {"z": rec}}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        with zf.open("z.npy", "w") as fh:
            fh.write(header.getvalue())
            for _ in range(64):
                fh.write(bytes(MB))
        zf.writestr("manifest.json", json.dumps(manifest))
    lie_about_sizes(path, "z.npy", file_size=1000)
    assert path.stat().st_size < 100_000
    tracemalloc.start()
    try:
        with pytest.raises(MapCorruptError, match=r"member z\.npy cannot be read .*CRC"):
            read_map(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 4 * MB, peak / MB


@pytest.mark.parametrize("compression", [zipfile.ZIP_BZIP2, zipfile.ZIP_LZMA])
def test_other_compressions_read_the_same_and_their_damage_is_corrupt(
    tmp_path: Path, compression: int
) -> None:
    """The same map re-zipped with bzip2 or LZMA (methods Python's zipfile and other tools
    write) reads the same member; eight bytes inverted early in its stream are the file's
    damage, a :class:`MapCorruptError` naming the member (a damaged LZMA stream raises
    ``lzma.LZMAError``, which escaped as an internal error like ``zlib.error`` did)."""
    from tests.formats.map_damage import rezip

    deflated, data = _member_map(tmp_path)
    path = rezip(deflated, tmp_path / "other.aion", compression)
    assert _declared(path).compress_type == compression
    np.testing.assert_array_equal(read_map(path)[0]["z"],
                                  np.load(io.BytesIO(data), allow_pickle=False))
    raw = bytearray(path.read_bytes())
    start = member_data_offset(path, "z.npy") + 16  # past the LZMA properties header
    raw[start : start + 8] = bytes(b ^ 0xA5 for b in raw[start : start + 8])
    path.write_bytes(bytes(raw))
    with pytest.raises(MapCorruptError, match=r"member z\.npy cannot be read"):
        read_map(path)
