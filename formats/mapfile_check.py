"""Opening a map file for reading: the archive-level checks and the manifest.

Everything that concerns the file as a whole before any array is read: the zip's entry count
(from its end record), unsafe member names, declared totals and compression ratios, and the
hand-written schema check of ``manifest.json`` (:func:`validate_manifest`,
:func:`read_manifest`). Reading members is :mod:`formats.mapfile_read`.
"""

from __future__ import annotations

import json
import os
import re
import zipfile
import zlib
from pathlib import Path
from typing import Any

from aion_cli.errors import MapCorruptError, MapFileError, path_word
from aion_cli.formats.mapfile_format import (
    DEFAULT_MAX_MEMBERS,
    DEFAULT_MAX_RATIO,
    MANIFEST_NAME,
    MAP_FORMAT,
    MAX_MANIFEST_BYTES,
    MEMBER_SUFFIX,
    RATIO_MIN_BYTES,
    check_version,
    is_valid_member_name,
)

_SHA_RE = re.compile(r"^[0-9a-f]{64}$")
_CRC_RE = re.compile(r"^[0-9a-f]{8}$")


def _not_a_map(path: Path, why: str) -> MapFileError:
    return MapFileError(
        f"{path} is not a readable aion map: {why}",
        hint=_what_it_is(path)
        or "pass a file written by `aion build` (a .aion map); if it was, it may be "
        "truncated or damaged: rebuild it from the logs",
    )


def _what_it_is(path: Path) -> str | None:
    """A hint when ``path`` is an input aion reads elsewhere, given where a map belongs: a
    log (build a map from it) or a scene-graph file (:func:`formats.input_kind.input_kind`)."""
    from aion_cli.formats.input_kind import input_kind
    from aion_cli.formats.scene_mcap import is_scene_mcap

    name = path.name
    word = path_word(path)  # the path in a command to paste
    kind = input_kind(path)
    if kind == "log" and is_scene_mcap(path):  # not a log: aion export's own
        return f"{name} is a scene aion exported from a map: give that map (.aion) instead"
    if kind == "log":
        return f"{name} is a log: build a map from it first, `aion build {word} -o MAP.aion`"
    if kind == "graph":
        return (
            f"{name} looks like a scene-graph file: `aion info {word}` shows it; a map is built "
            f"from logs with it, `aion build LOG --graph {word} -o MAP.aion`"
        )
    return None


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
        crc = rec.get("crc32")  # maps written before 2026-12-03 have none
        _require(crc is None or (isinstance(crc, str) and bool(_CRC_RE.match(crc))), path,
                 f"{name}: crc32")
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
    if MANIFEST_NAME not in names:  # a zip of anything: said so, not its first name "unsafe"
        from aion_cli.formats.input_kind import bare_zip

        bare = bare_zip(path)
        if bare is not None:
            raise MapFileError(*bare)
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
    """Read one member with size and ratio guards. The stream is read up to its declared size
    (plus one byte; the declared size is within ``limit``), not up to ``limit``: zipfile
    inflates as much as it is asked for before cutting the output to the declared size, so a
    member declaring 1,000 bytes whose stream inflates to gigabytes would otherwise take that
    memory before its CRC fails. A damaged
    deflate stream raises ``zlib.error`` (an LZMA one ``lzma.LZMAError``, a bzip2 one
    ``OSError``), which is the file's damage too."""
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
    import lzma  # zipfile's own choice for LZMA members: loaded already when one is read

    try:
        with zf.open(info) as fh:
            # zipfile returns at most the declared size, within the limit checked above; the
            # one byte more reaches the stream's end, where zipfile checks the CRC (an empty
            # member too)
            data = fh.read(info.file_size + 1)
    except (
        zipfile.BadZipFile,
        zlib.error,
        lzma.LZMAError,
        EOFError,
        OSError,
        ValueError,
        NotImplementedError,
    ) as exc:
        raise MapCorruptError(
            f"map {path}: member {name} cannot be read ({exc})",
            hint="the file is damaged; rebuild it with `aion build`",
        ) from exc
    return data


def _corrupt(path: Path, name: str, what: str) -> MapCorruptError:
    return MapCorruptError(
        f"map {path} is corrupted: member {name} {what}",
        hint="the file was damaged after writing; restore a backup or rebuild with `aion build`",
    )


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
        "by aion has about 80): refusing a possible zip bomb",
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
    if path.stat().st_size == 0:  # "not a zip container (File is not a zip file)" hid why
        raise _not_a_map(path, "the file is empty (0 bytes)")
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
