"""PLY / PCD scene files as aion writes them: checked complete, and marked as aion's own.

open3d reports success even when its writes fail: on a full disk it prints ``RPly: Failed
writing ...`` and returns True, leaving a 0-byte or cut-off file. So :func:`seal` reads the
header open3d wrote, computes the body's size from it (element counts and property types for
PLY, ``POINTS`` × the field sizes for PCD) and refuses a file of any other size
(:class:`~aion_cli.formats.export.ExportWriteError`), before the file is renamed into place.

It also writes the file again with one header comment (``comment written by aion export`` in
PLY, ``# written by aion export`` in PCD), which readers skip (open3d, PCL, Blender,
MeshLab): :func:`is_aion_scene_file` tells an export aion may replace from a PLY or PCD file
of someone else's (a scan, a mesh from open3d), which it never replaces. The copy is written
with Python's file functions, which do raise on a full disk.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO

MARKER = b"written by aion export"
PLY_MARKER = b"comment " + MARKER + b"\n"
PCD_MARKER = b"# " + MARKER + b"\n"
MAX_HEADER = 64 * 1024
"""Bytes read for a header (open3d's are a few hundred)."""

_PLY_SIZES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1,
    "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4,
    "double": 8, "float64": 8,
}  # fmt: skip


def is_aion_scene_file(path: Path) -> bool:
    """True when ``path`` is a PLY or PCD file whose header holds aion's marker (a file this
    module sealed); False for any other file, a missing or unreadable one."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(MAX_HEADER)
    except OSError:
        return False
    if head.startswith(b"ply\n"):
        end = head.find(b"end_header\n")
        return end > 0 and PLY_MARKER in head[:end]
    return PCD_MARKER in head[: _pcd_header_end(head) or 0]


def write_failed(path: Path, exc: OSError) -> Exception:
    """The :class:`ExportWriteError` (exit 2) of an ``OSError`` writing the scene file
    ``path``: a full disk, a folder not writable."""
    from aion_cli.formats.export import ExportWriteError

    return ExportWriteError(
        f"cannot write {path.name}: {exc.strerror or exc}",
        hint="check free disk space and that the output folder is writable",
    )


@contextlib.contextmanager
def writing(path: Path) -> Iterator[BinaryIO]:
    """``path`` opened for writing; on any failure (an interruption too) the partial file is
    removed, and an ``OSError`` becomes :func:`write_failed`'s error. The one way a scene
    file is written: :func:`seal`'s marked copy and :mod:`formats.ply_files`' PLY files."""
    try:
        with open(path, "wb") as fh:
            yield fh
    except OSError as exc:
        with contextlib.suppress(OSError):
            path.unlink()
        raise write_failed(path, exc) from exc
    except BaseException:
        with contextlib.suppress(OSError):
            path.unlink()
        raise


def header_comments(about: Sequence[str], ply: bool) -> bytes:
    """The lines ``about`` (what aion says of a scene: its time, whether that hour was
    observed) as header comments after the marker: PLY ``comment`` lines, PCD ``#`` lines;
    ASCII, a character outside it written as ``?``, a line break as a space."""
    start = b"comment " if ply else b"# "
    return b"".join(
        start + " ".join(line.splitlines()).encode("ascii", "replace") + b"\n"
        for line in about
    )


def seal(raw: Path, out: Path, about: Sequence[str] = ()) -> Path:
    """Check the PLY or PCD file ``raw`` (as open3d wrote it) is complete, then write it to
    ``out`` with aion's marker in its header (and the comments ``about``:
    :func:`header_comments`) and remove ``raw``. A file of another size than its header
    declares is an :class:`ExportWriteError` (``out`` not written)."""
    from aion_cli.formats.export import ExportWriteError

    try:
        with open(raw, "rb") as src:
            head = src.read(MAX_HEADER)
            size = os.fstat(src.fileno()).st_size
            if head.startswith(b"ply\n"):
                header_end, expected, at = _ply_layout(head, src)
                marker = PLY_MARKER
            else:
                header_end, expected = _pcd_layout(head)
                marker, at = PCD_MARKER, head.find(b"\n") + 1
            if header_end is None or at <= 0 or (expected is not None and size != expected):
                declared = "no complete header" if expected is None else f"{expected:,} declared"
                have = f"{size:,} bytes, {declared}"
                raise ExportWriteError(
                    f"cannot write {out.name}: it came out incomplete ({have})",
                    hint="check free disk space on the output's file system",
                )
            src.seek(0)
            with writing(out) as dst:
                dst.write(src.read(at))
                dst.write(marker + header_comments(about, marker is PLY_MARKER))
                shutil.copyfileobj(src, dst, 1 << 20)
    except OSError as exc:  # reading ``raw`` (``writing`` converts its own errors)
        raise write_failed(out, exc) from exc
    finally:
        with contextlib.suppress(OSError):
            raw.unlink()
    return out


def _ply_layout(head: bytes, src: BinaryIO) -> tuple[int | None, int | None, int]:
    """(header length, file size the header declares or None when it cannot be told, where
    the marker goes: after the ``format`` line) of a binary PLY file. A list property (the
    faces' vertex indices) is taken to hold as many items in every row as in the first,
    which is so for the triangles and lines open3d writes."""
    end = head.find(b"end_header\n")
    if end < 0:
        return None, None, 0
    header_end = end + len(b"end_header\n")
    lines = head[:end].decode("ascii", "replace").splitlines()
    at = head.find(b"\n", head.find(b"\nformat ") + 1) + 1
    if not any(line.startswith("format binary_") for line in lines):
        return header_end, None, at  # ASCII: no size to check (aion writes binary)
    little = any(line.startswith("format binary_little_endian") for line in lines)
    elements: list[tuple[int, list[list[str]]]] = []
    for line in lines:
        words = line.split()
        if words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            elements.append((int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][1].append(words[1:])
    total = header_end
    for count, props in elements:
        row = _ply_row(props, src, total, little)
        if row is None:
            return header_end, None, at
        total += count * row
    return header_end, total, at


def _ply_row(props: list[list[str]], src: BinaryIO, offset: int, little: bool) -> int | None:
    """Bytes of one row of a PLY element: fixed sizes summed; a single list property sized
    by the count of the element's first row (read at ``offset``); None otherwise."""
    if all(p and p[0] != "list" for p in props):
        sizes = [_PLY_SIZES.get(p[0]) for p in props]
        return None if None in sizes else sum(s for s in sizes if s is not None)
    if len(props) != 1 or len(props[0]) != 4:
        return None
    count_size, item_size = _PLY_SIZES.get(props[0][1]), _PLY_SIZES.get(props[0][2])
    if count_size is None or item_size is None:
        return None
    src.seek(offset)
    raw = src.read(count_size)
    if len(raw) < count_size:
        return count_size  # cut off before its first row: any size but this one is wrong
    items = int.from_bytes(raw, "little" if little else "big")
    return count_size + items * item_size


def _pcd_header_end(head: bytes) -> int | None:
    """Length of a PCD header (through its ``DATA`` line), or None."""
    at = head.find(b"\nDATA ")
    if at < 0 or not head.startswith((b"#", b"VERSION")):
        return None
    end = head.find(b"\n", at + 1)
    return None if end < 0 else end + 1


def _pcd_layout(head: bytes) -> tuple[int | None, int | None]:
    """(header length, file size the header declares or None) of a PCD file: ``POINTS`` ×
    the bytes of ``SIZE`` × ``COUNT`` for ``DATA binary``."""
    end = _pcd_header_end(head)
    if end is None:
        return None, None
    fields: dict[str, list[str]] = {}
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if words and not words[0].startswith("#"):
            fields[words[0]] = words[1:]
    if fields.get("DATA") != ["binary"]:
        return end, None
    try:
        sizes = [int(s) for s in fields["SIZE"]]
        counts = [int(c) for c in fields.get("COUNT", ["1"] * len(sizes))]
        points = int(fields["POINTS"][0])
    except (KeyError, ValueError, IndexError):
        return end, None
    return end, end + points * sum(s * c for s, c in zip(sizes, counts, strict=False))


def native_stderr_quiet() -> contextlib.AbstractContextManager[None]:
    """Send what native code prints to file descriptor 2 (open3d's ``RPly: Failed writing``
    lines, thousands on a full disk) to /dev/null for the block: :func:`seal` reports the
    failure as one error instead."""
    from aion_cli.formats.native_output import native_output_silenced

    return native_output_silenced((2,))
