"""Where a map may be written: output-path checks and the ``<map>.lock`` of its writer.

:func:`check_map_target` refuses a path that is no place for a map (a device, a folder, a
file that is not an aion map) before a long build starts; :func:`map_lock` keeps two writers
off one map, and is also held by callers across a read-modify-write (continuing a map,
merging). Neither writes or reads arrays, so they are apart from :mod:`formats.mapfile_write`.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import zipfile
from collections.abc import Iterator
from pathlib import Path

from aion_cli.errors import MapLockedError
from aion_cli.formats.mapfile_format import (
    MANIFEST_NAME,
    MAP_FORMAT,
    MAX_MANIFEST_BYTES,
    MapWriteError,
)

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
            hint=f"name a file, e.g. {p / 'office.aion'}",
        )


def check_map_folder(path: str | os.PathLike[str]) -> None:
    """:class:`MapWriteError` unless the folder a map at ``path`` goes to exists (the rule of
    every output: :func:`formats.outputs.check_output_folder`)."""
    from aion_cli.formats.outputs import check_output_folder

    check_output_folder(path, f"map {Path(path)}", MapWriteError)


def check_map_output(path: str | os.PathLike[str]) -> None:
    """:func:`check_map_folder` and :func:`check_map_target`: what a command writing a map
    checks before any work (reading logs or maps, hashing them)."""
    check_map_folder(path)
    check_map_target(path)


#: suffixes of the other files aion reads or writes (pictures, exports, reports, logs, configs):
#: a map named so (``-o map.png``) is a slip a user would not see until opening it
OTHER_SUFFIXES = frozenset({
    ".png", ".svg", ".jpg", ".jpeg", ".pdf", ".json", ".csv", ".ply", ".pcd", ".html", ".mcap",
    ".bag", ".db3", ".toml", ".yaml",
})


def check_map_suffix(path: str | os.PathLike[str]) -> None:
    """Refuse (:class:`MapWriteError`) a map output named as another kind of file aion reads
    or writes (:data:`OTHER_SUFFIXES`): ``aion build LOG -o map.png`` wrote a zip named
    ``.png``. Any other name (``.aion``, none, ``.zip``) is the user's choice. Checked by the
    commands that name a map from ``-o`` (build, merge), not by :func:`write_map`."""
    p = Path(path)
    if p.suffix.lower() in OTHER_SUFFIXES:
        raise MapWriteError(
            f"cannot write map {p}: {p.suffix} names another kind of file (a map is a .aion "
            "zip)",
            hint=f"name it {p.with_suffix('.aion').name} (pictures and other formats of a "
            "map come from it with `aion export`)",
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


@contextlib.contextmanager
def map_lock(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold ``<path>.lock`` for the block (:func:`formats.output_lock.output_lock`, the lock
    of every writer): another live writer of the map is a :class:`MapLockedError`, a lock
    that cannot be created a :class:`MapWriteError`. Once held, the temporary files a killed
    writer of the map left beside it are removed."""
    from aion_cli.formats.output_lock import output_lock

    check_map_path(path)  # never a lock beside /dev/null, a FIFO or a folder
    with output_lock(path, what="map", locked=MapLockedError, failed=MapWriteError) as lock:
        _remove_orphaned_staging(Path(path))
        yield lock


def _remove_orphaned_staging(path: Path) -> None:
    """Remove the hidden temporary files (``.<map>.<random>.tmp``) a writer of ``path`` killed
    with SIGKILL (or by a power cut) left beside it. Every writer of a map holds its lock while
    its temporary file exists, so once this process holds the lock no such file belongs to a
    live writer. Best effort: only regular files of exactly that name pattern."""
    from aion_cli.formats.outputs import STAGING_ROOM, fitted_name, staged_target

    folder = path.parent if str(path.parent) else Path(".")
    mine = fitted_name(path.name, STAGING_ROOM)
    with contextlib.suppress(OSError), os.scandir(folder) as entries:
        for entry in entries:
            if staged_target(entry.name) == mine and entry.is_file(follow_symlinks=False):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)
