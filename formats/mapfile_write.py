"""Writing a map file: arrays and a manifest into a ``.aion`` zip, atomically.

:func:`write_map` checks what it is handed, writes every array as an aligned, uncompressed
``.npy`` member (hashed while it is written, streamed members block by block) into a
temporary file, fsyncs it and renames it over the target under the map's lock. Reading never
needs this code, so it is a module of its own (:mod:`formats.mapfile` re-exports it).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import json
import os
import struct
import tempfile
import time
import zipfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

from aion_cli import __version__
from aion_cli.formats.committed import note_committed
from aion_cli.formats.crc import crc32
from aion_cli.formats.interrupts import interrupts_held
from aion_cli.formats.mapfile_format import (
    _LOCAL_HEADER_SIZE,
    ALIGN,
    MANIFEST_NAME,
    MAP_FORMAT,
    MEMBER_SUFFIX,
    RESERVED_KEYS,
    MapContentError,
    MapWriteError,
    format_version,
    is_valid_member_name,
)
from aion_cli.formats.mapfile_target import check_map_output, check_map_target, map_lock
from aion_cli.formats.outputs import fsync_dir, staging_prefix


class _HashingWriter:
    """A write-only file object that feeds a zip member, a sha256 and a CRC-32 at once (no
    extra copy).

    The bytes go straight to the zip's file and the member is handed their CRC-32 and size
    by :meth:`finish`: ``zipfile``'s member would compute a CRC-32 of every byte a second
    time, with ``zlib.crc32`` at a quarter of :func:`~aion_cli.formats.crc.crc32`'s speed
    (0.4 s of CPU of a 10^5-entry map's write, stop 70). A member without the attributes
    this hands over (another ``zipfile`` than CPython 3.11-3.13's) is written through, as
    before. The zip's CRC-32 of every member is checked in tests (``ZipFile.testzip``)."""

    def __init__(self, member: Any) -> None:  # zipfile's member writer (``zf.open(.., "w")``)
        self.member = member
        self.direct = all(hasattr(member, a) for a in _MEMBER_STATE) and (
            getattr(member, "_compressor", True) is None  # a stored member's
        )
        self.sink: IO[bytes] = self.member._fileobj if self.direct else member
        self.sha = hashlib.sha256()
        self.crc = 0
        self.size = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        self.sha.update(data)
        self.crc = crc32(data, self.crc)
        self.sink.write(data)
        size = memoryview(data).nbytes
        self.size += size
        return size

    def finish(self) -> None:
        """Hand the member what it would have counted (before it is closed)."""
        if self.direct:
            self.member._crc = self.crc
            self.member._file_size = self.size


_MEMBER_STATE = ("_fileobj", "_crc", "_file_size")
"""What :class:`_HashingWriter` uses of ``zipfile``'s member writer (``_ZipWriteFile``)."""


def _is_blocks(arr: Any) -> bool:
    """A streamed member: ``shape``, ``dtype`` and ``blocks()`` yielding C-contiguous arrays
    of consecutive rows (e.g. ``aion_cli.engine.types.RowTake``)."""
    return (
        callable(getattr(arr, "blocks", None))
        and isinstance(getattr(arr, "dtype", None), np.dtype)
        and isinstance(getattr(arr, "shape", None), tuple)
    )


def _check_arrays(arrays: Mapping[str, Any]) -> None:
    if not isinstance(arrays, Mapping):
        raise MapContentError(f"arrays must be a dict of name -> ndarray, got {type(arrays)}")
    for name, arr in arrays.items():
        if not is_valid_member_name(name):
            raise MapContentError(
                f"invalid array name {name!r}: use letters, digits, '_', '.', '-' and '/' "
                "(no '..' or leading '/')"
            )
        if not isinstance(arr, np.ndarray) and not _is_blocks(arr):
            raise MapContentError(f"array {name!r} is a {type(arr).__name__}, not an ndarray")
        if arr.dtype.hasobject:
            raise MapContentError(
                f"array {name!r} has dtype {arr.dtype} holding Python objects; map files store "
                "only plain numeric/bool/string arrays (no pickle)"
            )


Seal = Callable[[Mapping[str, Any], dict[str, dict[str, Any]]], Mapping[str, Any]]
"""Manifest fields computed from the caller's manifest and the members table (each member's
checksums, as written): ``write_map(..., seal=...)``."""


def _manifest_text(
    manifest: Mapping[str, Any], members: dict[str, dict[str, Any]], seal: Seal | None = None
) -> bytes:
    if not isinstance(manifest, Mapping):
        raise MapContentError(f"manifest must be a dict, got {type(manifest).__name__}")
    if seal is not None:  # fields that need the members' checksums, known only now
        manifest = {**manifest, **seal(manifest, members)}
    clash = sorted(set(manifest) & set(RESERVED_KEYS))
    if clash:
        raise MapContentError(f"manifest keys {clash} are reserved for the map container")
    created = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds").replace("+00:00", "Z")
    full = {
        "format": MAP_FORMAT,
        "version": format_version(),
        "creator": f"aion {__version__}",
        "created": created,
        **manifest,
        "members": members,
    }
    try:
        return json.dumps(full, indent=1, sort_keys=False, allow_nan=False).encode("utf-8")
    except (TypeError, ValueError) as exc:
        raise MapContentError(f"manifest is not JSON-serialisable (strict JSON): {exc}") from exc


_ALIGN_EXTRA_ID = 0xD935
"""The zip extra-field id of the padding (the id Android's zipalign uses for the same)."""


def _aligned_info(filename: str, offset: int, zip64: bool) -> zipfile.ZipInfo:
    """A stored member's ``ZipInfo`` whose local header, written at ``offset``, ends at a
    multiple of :data:`ALIGN` (an extra field of padding): its data, and the array after
    its 64-byte-padded ``.npy`` header, are then aligned in the file."""
    zinfo = zipfile.ZipInfo(filename, date_time=time.localtime(time.time())[:6])
    zinfo.compress_type = zipfile.ZIP_STORED
    end = offset + _LOCAL_HEADER_SIZE + len(filename.encode("utf-8")) + (20 if zip64 else 0)
    pad = (-(end + 4)) % ALIGN
    zinfo.extra = struct.pack("<HH", _ALIGN_EXTRA_ID, pad) + bytes(pad)
    return zinfo


def _write_zip(
    fileobj: IO[bytes], arrays: Mapping[str, Any], manifest: Any, seal: Seal | None = None
) -> None:
    members: dict[str, dict[str, Any]] = {}
    with zipfile.ZipFile(fileobj, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, arr in arrays.items():
            big = arr.nbytes > 1024**3
            zinfo = _aligned_info(name + MEMBER_SUFFIX, zf.start_dir, big)
            with zf.open(zinfo, "w", force_zip64=big) as member:
                writer = _HashingWriter(member)
                if isinstance(arr, np.ndarray):
                    np.save(writer, arr, allow_pickle=False)
                else:  # streamed: the same .npy bytes np.save writes, block by block
                    header = {
                        "descr": np.lib.format.dtype_to_descr(arr.dtype),
                        "fortran_order": False,
                        "shape": tuple(arr.shape),
                    }
                    np.lib.format.write_array_header_1_0(writer, header)
                    for block in arr.blocks():  # its bytes as they are: no copy
                        writer.write(block.reshape(-1).view(np.uint8).data)
                writer.finish()
            members[name] = {
                "sha256": writer.sha.hexdigest(),
                "crc32": f"{writer.crc:08x}",
                "size": writer.size,
                "dtype": arr.dtype.str,
                "shape": list(arr.shape),
            }
        zf.writestr(MANIFEST_NAME, _manifest_text(manifest, members, seal))


def _new_file_mode(target: Path) -> int:
    """The replaced map's permissions, else what ``open()`` would give (0666 minus umask)."""
    try:
        return target.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_map(
    path: str | os.PathLike[str],
    arrays: Mapping[str, Any],
    manifest: Mapping[str, Any],
    *,
    lock: bool = True,
    seal: Seal | None = None,
) -> None:
    """Write ``arrays`` and the caller's ``manifest`` fields to the map file ``path``, atomically.

    The container adds ``format``, ``version``, ``creator``, ``created`` and the ``members``
    table (those keys are reserved). The file appears complete or not at all: on any exception,
    KeyboardInterrupt included, the temporary file is removed and an existing map is untouched.
    Raises :class:`MapLockedError` if another live process holds ``<path>.lock``,
    :class:`MapContentError` for arrays/manifests that cannot be stored, :class:`MapWriteError`
    for OS failures. ``lock=False``: the caller already holds :func:`map_lock` for ``path``
    (a read-modify-write such as continuing a map holds it from the read to the write).
    ``seal``: called with the caller's manifest and the members table once every member is
    written; the fields it returns are added to the manifest (``aion_cli.derived_seal``:
    a digest of the members' checksums).
    """
    target = Path(path)
    _check_arrays(arrays)
    folder = target.parent if str(target.parent) else Path(".")
    check_map_output(target)
    with map_lock(target) if lock else contextlib.nullcontext(target):
        tmp: Path | None = None
        try:
            with interrupts_held():  # else Ctrl-C right after mkstemp leaves the file behind
                fd, tmp_name = tempfile.mkstemp(
                    dir=folder, prefix=staging_prefix(target.name), suffix=".tmp"
                )
                tmp = Path(tmp_name)
            os.chmod(tmp, _new_file_mode(target))  # mkstemp makes 0600; maps are shareable
            with os.fdopen(fd, "w+b") as fh:
                _write_zip(fh, arrays, manifest, seal)
                fh.flush()
                os.fsync(fh.fileno())
            check_map_target(target)  # still a map (or nothing) after the write?
            with interrupts_held():  # replaced and recorded as such, or neither
                os.replace(tmp, target)
                note_committed(target)
        except BaseException as exc:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    tmp.unlink()
            if isinstance(exc, OSError):
                raise MapWriteError(
                    f"cannot write map {target}: {exc.strerror or exc}",
                    hint="check free disk space and write permissions; the previous map (if "
                    "any) is unchanged",
                ) from exc
            raise
    fsync_dir(folder)
