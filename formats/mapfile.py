"""The ``.aion`` map file: a zip of ``manifest.json`` plus one ``.npy`` member per array.

The container is generic over arrays (it knows nothing of the engine's state layout): the caller
hands over ``dict[str, ndarray]`` and a manifest dict of its own fields (config, provenance, time
span, counts...). The format is specified in ``formats/MAPFILE.md``; in short:

- members are stored uncompressed (fast to read, and no decompression bombs in our own files),
  each with its sha256, size, dtype and shape in the manifest's ``members`` table;
- arrays are written with ``allow_pickle=False`` and read with ``allow_pickle=False``: a map file
  never executes code, and object arrays are refused on write;
- writing goes to a temporary file in the same folder, is flushed and fsync'd, then atomically
  renamed over the target, so an interrupted or failed write (full disk, Ctrl-C) leaves any
  previous map intact; a ``<map>.lock`` file stops two writers of the same map;
- reading is defensive: names with path traversal, unexpected or missing members, oversized
  members, suspicious compression ratios, manifests that fail the hand-written schema check,
  checksum mismatches and newer major versions are typed errors, never tracebacks.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import io
import json
import mmap
import os
import re
import socket
import stat
import struct
import tempfile
import time
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from aion_cli import __version__
from aion_cli.errors import (
    AionError,
    MapCorruptError,
    MapFileError,
    MapLockedError,
    MapVersionError,
)
from aion_cli.formats.outputs import fsync_dir, interrupts_held

MAP_FORMAT = "aion-map"
MAP_VERSION = (2, 0)
MANIFEST_NAME = "manifest.json"
MEMBER_SUFFIX = ".npy"

DEFAULT_MAX_MEMBER_BYTES = 4 * 1024**3
"""Largest uncompressed member accepted on read (declared and actual), 4 GiB."""
DEFAULT_MAX_RATIO = 100.0
"""Largest uncompressed/compressed ratio accepted for members above ``RATIO_MIN_BYTES``."""
RATIO_MIN_BYTES = 1024**2
DEFAULT_MAX_MEMBERS = 10_000
"""Most zip entries a map may have (a map written by aion has about 50): counted from the
zip's end record before its central directory is parsed."""
DEFAULT_MAX_TOTAL_BYTES = 16 * 1024**3
"""Largest sum of the members' uncompressed sizes accepted on read (declared and actual),
16 GiB; also, above ``RATIO_MIN_BYTES``, the sum may not exceed ``max_ratio`` times the file's
size, so many small deflated members (each under the per-member ratio check) cannot expand a
small file into gigabytes."""
MAX_MANIFEST_BYTES = 64 * 1024**2
STALE_UNREADABLE_LOCK_S = 10.0
"""A lock file with no readable pid older than this is treated as stale (crash mid-create)."""

RESERVED_KEYS = ("format", "version", "creator", "created", "members")
_NAME_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*(/[A-Za-z0-9_][A-Za-z0-9_.\-]*)*$")
_VERSION_RE = re.compile(r"^(\d+)\.(\d+)$")
_SHA_RE = re.compile(r"^[0-9a-f]{64}$")

Arrays = dict[str, npt.NDArray[Any]]


class MapWriteError(MapFileError):
    """The map file could not be written (disk full, permissions...); any old map is intact."""


class MapContentError(AionError, ValueError):
    """The arrays or manifest handed to :func:`write_map` cannot be stored (a caller bug)."""


# -- names and versions ---------------------------------------------------------------------


def is_valid_member_name(name: str) -> bool:
    """True for array names that are safe as zip member stems.

    Letters, digits, ``_ . -`` and ``/`` as a separator; no empty, ``.`` or ``..`` segments, no
    leading slash, no backslash or drive letters: nothing a careless extractor could turn into a
    path outside its folder.
    """
    if not isinstance(name, str) or not _NAME_RE.match(name) or len(name) > 255:
        return False
    return all(seg not in (".", "..") for seg in name.split("/"))


def format_version(version: tuple[int, int] = MAP_VERSION) -> str:
    """``(1, 0)`` -> ``"1.0"``."""
    return f"{version[0]}.{version[1]}"


def parse_version(text: object) -> tuple[int, int]:
    """``"1.0"`` -> ``(1, 0)``; anything else is a :class:`MapFileError`."""
    match = _VERSION_RE.match(text) if isinstance(text, str) else None
    if match is None:
        raise MapFileError(
            f"map manifest has an invalid version {text!r} (expected 'MAJOR.MINOR')",
            hint="the file is not a valid aion map; rebuild it with `aion build`",
        )
    return int(match.group(1)), int(match.group(2))


def check_version(text: object) -> tuple[int, int]:
    """Accept any minor of our major; a newer (or older) major is a :class:`MapVersionError`."""
    major, minor = parse_version(text)
    ours = MAP_VERSION[0]
    if major > ours:
        raise MapVersionError(
            f"map format {major}.{minor} is newer than this aion supports ({ours}.x); upgrade aion",
            hint="install a newer aion (pip install -U aion) to read this map",
        )
    if major < ours:
        raise MapVersionError(
            f"map format {major}.{minor} is older than this aion supports ({ours}.x)",
            hint="rebuild the map from its logs with `aion build`",
        )
    return major, minor


# -- writing --------------------------------------------------------------------------------


class _HashingWriter:
    """A write-only file object that feeds a zip member and a sha256 at once (no extra copy)."""

    def __init__(self, sink: IO[bytes]) -> None:
        self.sink = sink
        self.sha = hashlib.sha256()
        self.size = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        self.sha.update(data)
        self.sink.write(data)
        self.size += len(data)
        return len(data)


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


def _manifest_text(manifest: Mapping[str, Any], members: dict[str, dict[str, Any]]) -> bytes:
    if not isinstance(manifest, Mapping):
        raise MapContentError(f"manifest must be a dict, got {type(manifest).__name__}")
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


ALIGN = 64
"""Members' data start at a multiple of this many bytes in the file (and ``.npy`` headers
are padded to it), so a reader can map an array in place."""
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


def _write_zip(fileobj: IO[bytes], arrays: Mapping[str, Any], manifest: Any) -> None:
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
                    for block in arr.blocks():
                        writer.write(block.tobytes())
            members[name] = {
                "sha256": writer.sha.hexdigest(),
                "size": writer.size,
                "dtype": arr.dtype.str,
                "shape": list(arr.shape),
            }
        zf.writestr(MANIFEST_NAME, _manifest_text(manifest, members))


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
) -> None:
    """Write ``arrays`` and the caller's ``manifest`` fields to the map file ``path``, atomically.

    The container adds ``format``, ``version``, ``creator``, ``created`` and the ``members``
    table (those keys are reserved). The file appears complete or not at all: on any exception,
    KeyboardInterrupt included, the temporary file is removed and an existing map is untouched.
    Raises :class:`MapLockedError` if another live process holds ``<path>.lock``,
    :class:`MapContentError` for arrays/manifests that cannot be stored, :class:`MapWriteError`
    for OS failures. ``lock=False``: the caller already holds :func:`map_lock` for ``path``
    (a read-modify-write such as continuing a map holds it from the read to the write).
    """
    target = Path(path)
    _check_arrays(arrays)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise MapWriteError(
            f"cannot write map {target}: folder {folder} does not exist",
            hint="create the folder first or choose another output path",
        )
    check_map_target(target)
    with map_lock(target) if lock else contextlib.nullcontext(target):
        tmp: Path | None = None
        try:
            with interrupts_held():  # else Ctrl-C right after mkstemp leaves the file behind
                fd, tmp_name = tempfile.mkstemp(
                    dir=folder, prefix=f".{target.name}.", suffix=".tmp"
                )
                tmp = Path(tmp_name)
            os.chmod(tmp, _new_file_mode(target))  # mkstemp makes 0600; maps are shareable
            with os.fdopen(fd, "w+b") as fh:
                _write_zip(fh, arrays, manifest)
                fh.flush()
                os.fsync(fh.fileno())
            check_map_target(target)  # still a map (or nothing) after the write?
            os.replace(tmp, target)
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


# -- output targets -------------------------------------------------------------------------


def is_aion_map(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` (followed) is a regular file holding a zip whose ``manifest.json``
    says ``"format": "aion-map"`` (any version; nothing else is checked or read)."""
    p = Path(path)
    try:
        if not stat.S_ISREG(os.stat(p).st_mode):
            return False
        with zipfile.ZipFile(p, "r") as zf:
            info = zf.getinfo(MANIFEST_NAME)
            if info.file_size > MAX_MANIFEST_BYTES:
                return False
            with zf.open(info) as fh:
                doc = json.loads(fh.read(MAX_MANIFEST_BYTES + 1).decode("utf-8"))
    except Exception:  # not a zip, no manifest, not JSON, unreadable: not a map
        return False
    return isinstance(doc, dict) and doc.get("format") == MAP_FORMAT


def check_map_path(path: str | os.PathLike[str]) -> None:
    """Refuse a map output path that is not a place for a file: a device (``/dev/null``), a
    FIFO, a socket, a folder (:class:`MapWriteError`, exit 2). Cheap; :func:`map_lock` calls
    it, so nothing (not even ``<map>.lock``) is created beside such a path."""
    from aion_cli.formats.outputs import special_kind

    p = Path(path)
    kind = special_kind(p)
    if kind is not None:
        raise MapWriteError(
            f"cannot write map {p}: it is {kind}, not a regular file",
            hint="choose a path for a new .aion file (or an existing map to replace)",
        )
    if p.is_dir():
        raise MapWriteError(
            f"cannot write map {p}: it is a folder",
            hint="give a file path, e.g. -o office.aion",
        )


def check_map_target(path: str | os.PathLike[str]) -> None:
    """Refuse a map output path that :func:`write_map` must not replace: everything
    :func:`check_map_path` refuses, and an existing regular file that is not an aion map
    (:func:`is_aion_map`; an empty file is fine). Call it before a long build so a wrong
    ``-o`` fails before any work."""
    check_map_path(path)
    p = Path(path)
    if os.path.lexists(p) and not os.path.exists(p):
        raise MapWriteError(
            f"cannot write map {p}: it is a dangling symbolic link",
            hint="remove the link or choose another output path",
        )
    if p.exists() and p.stat().st_size > 0 and not is_aion_map(p):
        raise MapWriteError(
            f"cannot write map {p}: it exists and is not an aion map; refusing to replace it",
            hint="choose another output path (maps end in .aion) or remove the file yourself",
        )


# -- locking --------------------------------------------------------------------------------


def lock_path(path: str | os.PathLike[str]) -> Path:
    """``office.aion`` -> ``office.aion.lock``."""
    p = Path(path)
    return p.with_name(p.name + ".lock")


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def _lock_is_stale(lock: Path) -> bool:
    """A lock is stale if its pid (same host) is dead, or it has no pid and is old.

    Locks from another host cannot be checked and count as live.
    """
    try:
        text = lock.read_text(encoding="utf-8", errors="replace")
        age = time.time() - lock.stat().st_mtime
    except FileNotFoundError:
        return True
    lines = text.split()
    if not lines or not lines[0].isdigit():
        return age > STALE_UNREADABLE_LOCK_S
    host = lines[1] if len(lines) > 1 else socket.gethostname()
    if host != socket.gethostname():
        return False
    return not _pid_alive(int(lines[0]))


def _try_create_lock(lock: Path) -> bool:
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(f"{os.getpid()} {socket.gethostname()}\n")
    return True


@contextlib.contextmanager
def map_lock(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold ``<path>.lock`` (O_CREAT|O_EXCL, content ``"<pid> <host>"``) for the block.

    A stale lock (its process is dead) is removed and taken over once. Another live writer is a
    :class:`MapLockedError`. Known limit: two processes recovering the same stale lock at the
    same instant could both succeed; the window is the few microseconds between check and
    unlink.
    """
    check_map_path(path)  # never a lock beside /dev/null, a FIFO or a folder
    lock = lock_path(path)
    try:
        acquired = _try_create_lock(lock)
        if not acquired and _lock_is_stale(lock):
            with contextlib.suppress(FileNotFoundError):
                lock.unlink()
            acquired = _try_create_lock(lock)
    except OSError as exc:
        if isinstance(exc, FileExistsError):
            acquired = False
        else:
            raise MapWriteError(
                f"cannot create lock file {lock}: {exc.strerror or exc}",
                hint="check write permissions on the map's folder",
            ) from exc
    if not acquired:
        holder = ""
        with contextlib.suppress(OSError):
            holder = lock.read_text(encoding="utf-8", errors="replace").strip()
        raise MapLockedError(
            f"map {Path(path)} is being written by another process ({holder or 'unknown'})",
            hint=f"wait for it to finish; if no aion is running, delete {lock}",
        )
    try:
        yield lock
    finally:
        with contextlib.suppress(OSError):
            lock.unlink()


# -- reading --------------------------------------------------------------------------------


def _not_a_map(path: Path, why: str) -> MapFileError:
    return MapFileError(
        f"{path} is not a readable aion map: {why}",
        hint="pass a file written by `aion build` (a .aion map); if it was, it may be "
        "truncated or damaged: rebuild it from the logs",
    )


def _require(cond: bool, path: Path, what: str) -> None:
    if not cond:
        raise MapFileError(
            f"map {path} has an invalid manifest: {what}",
            hint="the file was not written by aion or is damaged; rebuild it with `aion build`",
        )


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def validate_manifest(manifest: object, path: Path) -> dict[str, Any]:
    """Hand-written schema check of a parsed manifest; returns it typed as a dict.

    Checks the container keys (format, version, creator, created, members) and every member
    record; the caller's own fields are passed through unchecked. The version is checked with
    :func:`check_version` before the rest, so a newer-major map gets the version error.
    """
    _require(isinstance(manifest, dict), path, "top level is not a JSON object")
    assert isinstance(manifest, dict)
    _require(manifest.get("format") == MAP_FORMAT, path, f"format is not {MAP_FORMAT!r}")
    check_version(manifest.get("version"))
    for key in ("creator", "created"):
        _require(isinstance(manifest.get(key), str), path, f"{key!r} missing or not a string")
    members = manifest.get("members")
    _require(isinstance(members, dict), path, "'members' missing or not an object")
    assert isinstance(members, dict)
    for name, rec in members.items():
        _require(is_valid_member_name(name), path, f"unsafe member name {name!r}")
        _require(isinstance(rec, dict), path, f"member {name!r} record is not an object")
        sha, size, dtype, shape = (rec.get(k) for k in ("sha256", "size", "dtype", "shape"))
        _require(isinstance(sha, str) and bool(_SHA_RE.match(sha)), path, f"{name}: sha256")
        _require(_is_int(size) and size >= 0, path, f"{name}: size")
        _require(isinstance(dtype, str), path, f"{name}: dtype")
        _require(
            isinstance(shape, list) and all(_is_int(s) and s >= 0 for s in shape),
            path,
            f"{name}: shape",
        )
    return manifest


def _check_zip_names(zf: zipfile.ZipFile, path: Path) -> None:
    names = [info.filename for info in zf.infolist()]
    if len(names) != len(set(names)):
        raise MapCorruptError(f"map {path} has duplicate zip members", hint="rebuild the map")
    for info in zf.infolist():
        name = info.filename
        stem = name[: -len(MEMBER_SUFFIX)] if name.endswith(MEMBER_SUFFIX) else None
        ok = name == MANIFEST_NAME or (stem is not None and is_valid_member_name(stem))
        if not ok or info.is_dir():
            raise MapFileError(
                f"map {path} contains an unsafe or unexpected member name {name!r}",
                hint="the file was not written by aion; do not trust it",
            )


def _read_member_bytes(
    zf: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path, limit: int, max_ratio: float
) -> bytes:
    """Read one member with size and ratio guards (the stream is capped at ``limit + 1``)."""
    name = info.filename
    if info.file_size > limit:
        raise MapFileError(
            f"map {path}: member {name} declares {info.file_size} bytes, over the "
            f"{limit}-byte limit",
            hint="raise the member size limit if this map is genuinely that large",
        )
    if info.file_size > RATIO_MIN_BYTES and info.file_size > max_ratio * max(info.compress_size, 1):
        raise MapFileError(
            f"map {path}: member {name} expands {info.file_size / max(info.compress_size, 1):.0f}"
            f"x (limit {max_ratio:.0f}x): refusing a possible zip bomb",
            hint="the file was not written by aion; do not trust it",
        )
    try:
        with zf.open(info) as fh:
            data = fh.read(limit + 1)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, NotImplementedError) as exc:
        raise MapCorruptError(
            f"map {path}: member {name} cannot be read ({exc})",
            hint="the file is damaged; rebuild it with `aion build`",
        ) from exc
    if len(data) > limit:
        raise MapFileError(
            f"map {path}: member {name} holds more than the {limit}-byte limit",
            hint="raise the member size limit if this map is genuinely that large",
        )
    return data


def _corrupt(path: Path, name: str, what: str) -> MapCorruptError:
    return MapCorruptError(
        f"map {path} is corrupted: member {name} {what}",
        hint="the file was damaged after writing; restore a backup or rebuild with `aion build`",
    )


def _load_member(data: bytes, name: str, rec: dict[str, Any], path: Path) -> npt.NDArray[Any]:
    if len(data) != rec["size"]:
        raise _corrupt(path, name, f"has {len(data)} bytes, manifest says {rec['size']}")
    if hashlib.sha256(data).hexdigest() != rec["sha256"]:
        raise _corrupt(path, name, "fails its sha256 checksum")
    try:
        arr = np.load(io.BytesIO(data), allow_pickle=False)
    except Exception as exc:  # a damaged .npy header also raises tokenize/syntax errors
        raise _corrupt(path, name, f"is not a valid .npy array ({exc})") from exc
    if not isinstance(arr, np.ndarray) or arr.dtype.str != rec["dtype"]:
        raise _corrupt(path, name, f"has dtype {getattr(arr, 'dtype', '?')}, not {rec['dtype']}")
    if list(arr.shape) != rec["shape"]:
        raise _corrupt(path, name, f"has shape {arr.shape}, not {tuple(rec['shape'])}")
    return arr


def _declared_entries(path: Path) -> int | None:
    """The entry count in the zip's end-of-central-directory record (ZIP64 included), read
    before ``ZipFile`` parses the whole central directory (one object per entry); None when
    the record cannot be found (``ZipFile`` then reports the damage)."""
    end_record = getattr(zipfile, "_EndRecData", None)  # CPython's own EOCD locator
    if end_record is None:  # pragma: no cover - every CPython has it
        return None
    try:
        with open(path, "rb") as fh:
            rec = end_record(fh)
    except Exception:
        return None
    if not rec:
        return None
    try:
        return int(rec[getattr(zipfile, "_ECD_ENTRIES_TOTAL", 4)])
    except (TypeError, ValueError, IndexError):
        return None


def _too_many_members(path: Path, count: int, limit: int) -> MapFileError:
    return MapFileError(
        f"map {path} has {count:,} zip entries, over the {limit:,}-entry limit (a map written "
        "by aion has about 50): refusing a possible zip bomb",
        hint="the file was not written by aion; do not trust it (read_map(max_members=...) "
        "raises the limit)",
    )


def _open_zip(path: Path, max_members: int = DEFAULT_MAX_MEMBERS) -> zipfile.ZipFile:
    from aion_cli.formats.outputs import special_kind

    if not path.exists():
        raise MapFileError(f"map file {path} does not exist", hint="check the path")
    if path.is_dir():
        raise MapFileError(f"{path} is a folder, not a map file", hint="pass the .aion file")
    kind = special_kind(path)
    if kind is not None:  # reading /dev/zero or a FIFO would never end
        raise MapFileError(f"{path} is {kind}, not a map file", hint="pass the .aion file")
    count = _declared_entries(path)
    if count is not None and count > max_members:
        raise _too_many_members(path, count, max_members)
    try:
        zf = zipfile.ZipFile(path, "r")
        if len(zf.infolist()) > max_members:  # the end record understated the count
            n = len(zf.infolist())
            zf.close()
            raise _too_many_members(path, n, max_members)
        return zf
    except OSError as exc:
        raise MapFileError(f"cannot open map {path}: {exc.strerror or exc}") from exc
    except MapFileError:
        raise
    except Exception as exc:  # BadZipFile, and e.g. NotImplementedError for a damaged version
        raise _not_a_map(path, f"not a zip container ({exc})") from exc


def _read_manifest(zf: zipfile.ZipFile, path: Path) -> dict[str, Any]:
    try:
        info = zf.getinfo(MANIFEST_NAME)
    except KeyError:
        raise _not_a_map(path, f"no {MANIFEST_NAME} inside") from None
    raw = _read_member_bytes(zf, info, path, MAX_MANIFEST_BYTES, DEFAULT_MAX_RATIO)
    try:
        parsed = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        # RecursionError: absurdly nested JSON, a hostile file rather than a map.
        raise _not_a_map(path, f"{MANIFEST_NAME} is not valid JSON ({type(exc).__name__})") from exc
    return validate_manifest(parsed, path)


def read_manifest(
    path: str | os.PathLike[str], *, max_members: int = DEFAULT_MAX_MEMBERS
) -> dict[str, Any]:
    """Only the validated manifest (cheap: no array is read or checksummed); the zip may have
    at most ``max_members`` entries, as for :func:`read_map`."""
    p = Path(path)
    with _open_zip(p, max_members) as zf:
        _check_zip_names(zf, p)
        return _read_manifest(zf, p)


def _check_totals(
    zf: zipfile.ZipFile, path: Path, max_total_bytes: int, max_ratio: float
) -> None:
    """The zip's declared uncompressed total against ``max_total_bytes`` and, above
    ``RATIO_MIN_BYTES``, against ``max_ratio`` times the file's size (before any read)."""
    total = sum(info.file_size for info in zf.infolist())
    if total > max_total_bytes:
        raise MapFileError(
            f"map {path}: its members declare {total:,} bytes in all, over the "
            f"{max_total_bytes:,}-byte limit",
            hint="raise read_map(max_total_bytes=...) if this map is genuinely that large",
        )
    size = max(path.stat().st_size, 1)
    if total > RATIO_MIN_BYTES and total > max_ratio * size:
        raise MapFileError(
            f"map {path}: its members expand {total / size:.0f}x over the file's {size:,} "
            f"bytes (limit {max_ratio:.0f}x): refusing a possible zip bomb",
            hint="the file was not written by aion (aion stores members uncompressed); do "
            "not trust it",
        )


class MapMembers(Mapping[str, npt.NDArray[Any]]):
    """The arrays of an open map file, read and verified one member at a time, on first access.

    Opening (:func:`open_map`) runs every check that concerns the archive as a whole — the
    entry count, unsafe names, the declared totals, the manifest and its version, members
    missing from the archive or from the manifest — but reads no array. ``members[name]``
    then reads that member, checks its size limits, sha256, ``.npy`` header (``allow_pickle``
    never), dtype and shape, and caches the array: a query pays for the members it uses, and
    a flipped byte in any of them is still a :class:`MapCorruptError` naming it. The bytes read
    count against ``max_total_bytes`` as they are read. Stored (uncompressed) members, which
    is every member aion writes, are read with one positioned read straight into the array's
    buffer (no intermediate copy; the sha256 covers what the zip's CRC would); deflated
    members written by other tools go through :mod:`zipfile`. With ``in_place``
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


_LOCAL_HEADER_SIZE = 30
"""Fixed part of a zip local file header (signature ... extra field length)."""


def _member_array(
    buffer: npt.NDArray[np.uint8], name: str, rec: dict[str, Any], path: Path
) -> npt.NDArray[Any]:
    """The array of one member's ``.npy`` bytes in ``buffer``, verified against its manifest
    record (size, sha256, header, dtype, shape) and sharing ``buffer``'s memory (writable)."""
    if buffer.size != rec["size"]:
        raise _corrupt(path, name, f"has {buffer.size} bytes, manifest says {rec['size']}")
    if hashlib.sha256(buffer.data).hexdigest() != rec["sha256"]:
        raise _corrupt(path, name, "fails its sha256 checksum")
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
    and actual), no more compressed than ``max_ratio`` (above 1 MiB), match its sha256, size,
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
