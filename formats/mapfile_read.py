"""Reading a map file's arrays: :func:`open_map` (members on demand) and :func:`read_map`.

:class:`MapMembers` reads and verifies one member at a time on first access (size limits,
CRC-32 or sha256, ``.npy`` header without pickle, dtype, shape), stored members with one
positioned read or in place over a copy-on-write mapping. The archive-level checks it runs on
opening are :mod:`formats.mapfile_check`.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import mmap
import os
import struct
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.errors import MapCorruptError, MapFileError
from aion_cli.formats.crc import crc32
from aion_cli.formats.mapfile_check import (
    _check_totals,
    _check_zip_names,
    _corrupt,
    _open_zip,
    _read_manifest,
    _read_member_bytes,
    _too_many_members,
)
from aion_cli.formats.mapfile_format import (
    _LOCAL_HEADER_SIZE,
    DEFAULT_MAX_MEMBER_BYTES,
    DEFAULT_MAX_MEMBERS,
    DEFAULT_MAX_RATIO,
    DEFAULT_MAX_TOTAL_BYTES,
    MANIFEST_NAME,
    MEMBER_SUFFIX,
    Arrays,
)


def verify_checksum(
    data: bytes | memoryview, rec: dict[str, Any], path: Path, name: str
) -> None:
    """A member's bytes against its manifest record: the CRC-32 where the record has one
    (maps written since 2026-12-03; ~10 GB/s with ISA-L, :mod:`formats.crc`), else the sha256
    (~1.3 GB/s with SHA extensions): a query reads ~130 MB of a 10^5-entry map, and its
    checksums were 0.1-0.15 s of a 1-s ``aion predict``. Either catches a flipped byte; the
    sha256 stays in the manifest for other tools."""
    expected = rec.get("crc32")
    if expected is not None:
        if f"{crc32(data):08x}" != expected:
            raise _corrupt(path, name, "fails its crc32 checksum")
    elif hashlib.sha256(data).hexdigest() != rec["sha256"]:
        raise _corrupt(path, name, "fails its sha256 checksum")


def _load_member(data: bytes, name: str, rec: dict[str, Any], path: Path) -> npt.NDArray[Any]:
    if len(data) != rec["size"]:
        raise _corrupt(path, name, f"has {len(data)} bytes, manifest says {rec['size']}")
    verify_checksum(data, rec, path, name)
    try:
        arr = np.load(io.BytesIO(data), allow_pickle=False)
    except Exception as exc:  # a damaged .npy header also raises tokenize/syntax errors
        raise _corrupt(path, name, f"is not a valid .npy array ({exc})") from exc
    if not isinstance(arr, np.ndarray) or arr.dtype.str != rec["dtype"]:
        raise _corrupt(path, name, f"has dtype {getattr(arr, 'dtype', '?')}, not {rec['dtype']}")
    if list(arr.shape) != rec["shape"]:
        raise _corrupt(path, name, f"has shape {arr.shape}, not {tuple(rec['shape'])}")
    return arr


class MapMembers(Mapping[str, npt.NDArray[Any]]):
    """The arrays of an open map file, read and verified one member at a time, on first access.

    Opening (:func:`open_map`) runs every check that concerns the archive as a whole — the
    entry count, unsafe names, the declared totals, the manifest and its version, members
    missing from the archive or from the manifest — but reads no array. ``members[name]``
    then reads that member, checks its size limits, checksum, ``.npy`` header (``allow_pickle``
    never), dtype and shape, and caches the array: a query pays for the members it uses, and
    a flipped byte in any of them is still a :class:`MapCorruptError` naming it. The bytes read
    count against ``max_total_bytes`` as they are read. Stored (uncompressed) members, which
    is every member aion writes, are read with one positioned read straight into the array's
    buffer (no intermediate copy; the manifest's checksum covers what the zip's CRC would);
    deflated members written by other tools go through :mod:`zipfile`. With ``in_place``
    (:func:`open_map`) stored members are not copied at all: their arrays view a private
    copy-on-write mapping of the file (aion aligns every member's data to :data:`ALIGN`
    bytes; an unaligned member is copied). Close it (or use it as a context manager) to
    release the file; arrays already read stay valid.
    """

    def __init__(
        self,
        path: Path,
        *,
        max_member_bytes: int = DEFAULT_MAX_MEMBER_BYTES,
        max_ratio: float = DEFAULT_MAX_RATIO,
        max_members: int = DEFAULT_MAX_MEMBERS,
        max_total_bytes: int = DEFAULT_MAX_TOTAL_BYTES,
        in_place: bool = False,
    ) -> None:
        self.path = path
        self._max_member_bytes = max_member_bytes
        self._max_ratio = max_ratio
        self._max_total_bytes = max_total_bytes
        self._read_total = 0
        self._cache: Arrays = {}
        zf = _open_zip(path, max_members)
        try:
            _check_zip_names(zf, path)
            _check_totals(zf, path, max_total_bytes, max_ratio)
            manifest = _read_manifest(zf, path)
            members: dict[str, dict[str, Any]] = manifest["members"]
            if len(members) > max_members:
                raise _too_many_members(path, len(members), max_members)
            present = {n[: -len(MEMBER_SUFFIX)] for n in zf.namelist() if n != MANIFEST_NAME}
            unexpected = sorted(present - set(members))
            if unexpected:
                raise MapFileError(
                    f"map {path} contains members not listed in its manifest: {unexpected[:5]}",
                    hint="the file was modified outside aion; do not trust it",
                )
            missing = [name for name in members if name not in present]
            if missing:
                raise _corrupt(path, missing[0], "is missing from the file")
        except BaseException:
            zf.close()
            raise
        self._zf: zipfile.ZipFile | None = zf
        self.manifest = manifest
        self._records = members
        self._mm: mmap.mmap | None = None
        if in_place:
            with contextlib.suppress(OSError, ValueError, AttributeError):  # e.g. empty file
                assert zf.fp is not None
                self._mm = mmap.mmap(zf.fp.fileno(), 0, access=mmap.ACCESS_COPY)

    # -- Mapping ------------------------------------------------------------------------
    def __getitem__(self, name: str) -> npt.NDArray[Any]:
        cached = self._cache.get(name)
        if cached is not None:
            return cached
        rec = self._records.get(name)
        if rec is None:
            raise KeyError(name)
        arr = self._read(name, rec)
        self._cache[name] = arr
        return arr

    def __contains__(self, name: object) -> bool:
        return name in self._records

    def __iter__(self) -> Iterator[str]:
        return iter(self._records)

    def __len__(self) -> int:
        return len(self._records)

    @property
    def read_names(self) -> list[str]:
        """The members read (and verified) so far, in the order they were read."""
        return list(self._cache)

    def close(self) -> None:
        """Release the file; arrays already read stay valid (a mapping lives as long as the
        arrays that view it)."""
        self._mm = None
        if self._zf is not None:
            self._zf.close()
            self._zf = None

    def __enter__(self) -> MapMembers:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- reading ------------------------------------------------------------------------
    def _read(self, name: str, rec: dict[str, Any]) -> npt.NDArray[Any]:
        p = self.path
        if self._zf is None:
            raise MapFileError(f"map {p} is closed; member {name} was not read")
        if rec["size"] > self._max_member_bytes:
            raise MapFileError(
                f"map {p}: member {name} declares {rec['size']} bytes, over the "
                f"{self._max_member_bytes}-byte limit",
                hint="raise the member size limit if this map is genuinely that large",
            )
        info = self._zf.getinfo(name + MEMBER_SUFFIX)
        limit = min(self._max_member_bytes, self._max_total_bytes - self._read_total)
        if info.compress_type == zipfile.ZIP_STORED and info.file_size == info.compress_size:
            buffer = self._read_stored(info, limit)
            self._read_total += buffer.size
            return _member_array(buffer, name, rec, p)
        data = _read_member_bytes(self._zf, info, p, limit, self._max_ratio)
        self._read_total += len(data)
        return _load_member(data, name, rec, p)

    def _read_stored(self, info: zipfile.ZipInfo, limit: int) -> npt.NDArray[np.uint8]:
        """The bytes of a stored member, read at their offset into a fresh aligned buffer
        (the local header is parsed and its name compared with the central directory's)."""
        p, name = self.path, info.filename
        if info.file_size > limit:
            raise MapFileError(
                f"map {p}: member {name} declares {info.file_size} bytes, over the "
                f"{limit}-byte limit",
                hint="raise the member size limit if this map is genuinely that large",
            )
        assert self._zf is not None
        assert self._zf.fp is not None
        fd = self._zf.fp.fileno()
        try:
            header = os.pread(fd, _LOCAL_HEADER_SIZE, info.header_offset)
            if len(header) != _LOCAL_HEADER_SIZE or header[:4] != b"PK\x03\x04":
                raise _corrupt(p, name, "has a damaged zip local header")
            name_len, extra_len = struct.unpack("<HH", header[26:30])
            stored_name = os.pread(fd, name_len, info.header_offset + _LOCAL_HEADER_SIZE)
            if stored_name.decode("utf-8", "replace") != name:
                raise _corrupt(p, name, "has a zip local header naming another member")
            start = info.header_offset + _LOCAL_HEADER_SIZE + name_len + extra_len
            if self._mm is not None and start + info.file_size <= len(self._mm):
                # in place: a private (copy-on-write) mapping of the file, no fresh memory
                return np.frombuffer(self._mm, np.uint8, count=info.file_size, offset=start)
            buffer = np.empty(info.file_size, np.uint8)
            got = os.preadv(fd, [buffer.data], start) if buffer.size else 0
        except OSError as exc:
            raise MapCorruptError(
                f"map {p}: member {name} cannot be read ({exc})",
                hint="the file is damaged; rebuild it with `aion build`",
            ) from exc
        if got != buffer.size:
            raise _corrupt(p, name, f"is truncated ({got} of {buffer.size} bytes)")
        return buffer


def _member_array(
    buffer: npt.NDArray[np.uint8], name: str, rec: dict[str, Any], path: Path
) -> npt.NDArray[Any]:
    """The array of one member's ``.npy`` bytes in ``buffer``, verified against its manifest
    record (size, checksum, header, dtype, shape) and sharing ``buffer``'s memory (writable)."""
    if buffer.size != rec["size"]:
        raise _corrupt(path, name, f"has {buffer.size} bytes, manifest says {rec['size']}")
    verify_checksum(buffer.data, rec, path, name)
    try:
        head = io.BytesIO(buffer[: min(buffer.size, _MAX_NPY_HEADER)].tobytes())
        version = np.lib.format.read_magic(head)
        shape, fortran, dtype = _npy_header(head, version)
        if dtype.hasobject:
            raise ValueError("Object arrays cannot be loaded when allow_pickle=False")
        offset = head.tell()
        count = int(np.prod(shape, dtype=np.int64))
        if buffer.size - offset < count * dtype.itemsize:
            raise ValueError(f"{buffer.size - offset} data bytes, {count * dtype.itemsize} needed")
        flat = buffer[offset : offset + count * dtype.itemsize].view(dtype) if count else (
            np.zeros(0, dtype)
        )
        arr = flat.reshape(shape[::-1]).transpose() if fortran else flat.reshape(shape)
        if not arr.flags.aligned:  # a member another tool wrote unaligned: an aligned copy
            arr = arr.copy()
    except Exception as exc:  # a damaged .npy header also raises tokenize/syntax errors
        raise _corrupt(path, name, f"is not a valid .npy array ({exc})") from exc
    if arr.dtype.str != rec["dtype"]:
        raise _corrupt(path, name, f"has dtype {arr.dtype}, not {rec['dtype']}")
    if list(arr.shape) != rec["shape"]:
        raise _corrupt(path, name, f"has shape {arr.shape}, not {tuple(rec['shape'])}")
    return arr


def _npy_header(head: io.BytesIO, version: tuple[int, int]) -> tuple[Any, bool, np.dtype[Any]]:
    """``(shape, fortran_order, dtype)`` of a ``.npy`` header of version 1.0, 2.0 or 3.0 (3.0
    differs from 2.0 only in its UTF-8 field names, which numpy parses alike)."""
    fmt = np.lib.format
    if version == (1, 0):
        return fmt.read_array_header_1_0(head, max_header_size=_MAX_NPY_HEADER)
    if version in ((2, 0), (3, 0)):
        return fmt.read_array_header_2_0(head, max_header_size=_MAX_NPY_HEADER)
    raise ValueError(f"unsupported .npy version {version}")


_MAX_NPY_HEADER = 65_536
"""Longest ``.npy`` header parsed (numpy's own default safety limit is 10,000 characters;
aion's headers are under 200 bytes)."""


def open_map(
    path: str | os.PathLike[str],
    *,
    max_member_bytes: int = DEFAULT_MAX_MEMBER_BYTES,
    max_ratio: float = DEFAULT_MAX_RATIO,
    max_members: int = DEFAULT_MAX_MEMBERS,
    max_total_bytes: int = DEFAULT_MAX_TOTAL_BYTES,
    in_place: bool = False,
) -> MapMembers:
    """Open a map for reading members on demand (:class:`MapMembers`; its ``manifest`` is
    validated). The limits are :func:`read_map`'s; every archive-level check runs here, each
    member's own checks when it is first accessed.

    ``in_place``: stored members are arrays over a private copy-on-write mapping of the file
    (no fresh memory filled, pages copied only where the caller writes); for queries, which
    never write the map back. The file must then not be truncated in place while the arrays
    live (aion replaces maps by renaming, which a mapping survives); otherwise every member
    is read into memory of its own."""
    return MapMembers(
        Path(path),
        max_member_bytes=max_member_bytes,
        max_ratio=max_ratio,
        max_members=max_members,
        max_total_bytes=max_total_bytes,
        in_place=in_place,
    )


def read_map(
    path: str | os.PathLike[str],
    *,
    max_member_bytes: int = DEFAULT_MAX_MEMBER_BYTES,
    max_ratio: float = DEFAULT_MAX_RATIO,
    max_members: int = DEFAULT_MAX_MEMBERS,
    max_total_bytes: int = DEFAULT_MAX_TOTAL_BYTES,
) -> tuple[Arrays, dict[str, Any]]:
    """Read and verify a whole map file: ``(arrays, manifest)`` (:func:`open_map`, then every
    member read).

    The zip may have at most ``max_members`` entries (checked before its central directory is
    parsed) and its members at most ``max_total_bytes`` uncompressed in all (declared, and
    counted while reading) and, above 1 MiB, at most ``max_ratio`` times the file's size.
    Every member listed in the manifest must be present, within ``max_member_bytes`` (declared
    and actual), no more compressed than ``max_ratio`` (above 1 MiB), match its checksum, size,
    dtype and shape, and load with ``allow_pickle=False``. Members not in the manifest are
    refused. Errors: :class:`MapFileError` (not a map, unsafe content, over a limit),
    :class:`MapVersionError` (other major version), :class:`MapCorruptError` (a member fails
    its checks; names it).
    """
    with open_map(
        path,
        max_member_bytes=max_member_bytes,
        max_ratio=max_ratio,
        max_members=max_members,
        max_total_bytes=max_total_bytes,
    ) as members:
        arrays: Arrays = {name: members[name] for name in members}
        return arrays, members.manifest
