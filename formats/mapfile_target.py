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
import socket
import stat
import time
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

STALE_UNREADABLE_LOCK_S = 10.0
"""A lock file with no readable pid older than this is treated as stale (crash mid-create)."""


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
    """``office.aion`` -> ``office.aion.lock`` (a name too long for the suffix is cut and
    ends in its hash: :func:`formats.outputs.fitted_name`)."""
    from aion_cli.formats.outputs import fitted_name

    p = Path(path)
    return p.with_name(fitted_name(p.name, len(".lock")) + ".lock")


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
    """Create ``lock`` holding ``"<pid> <host>"``; False when it exists. A lock whose pid
    could not be written (a full disk) is removed before the error propagates: an empty lock
    left behind would block the next run as "written by another process (unknown)"."""
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(f"{os.getpid()} {socket.gethostname()}\n")  # may fail when closed
    except BaseException:
        with contextlib.suppress(OSError):
            lock.unlink()
        raise
    return True


@contextlib.contextmanager
def map_lock(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold ``<path>.lock`` (O_CREAT|O_EXCL, content ``"<pid> <host>"``) for the block.

    A stale lock (its process is dead) is removed and taken over once; temporary files a
    killed writer left beside the map are removed then. Another live writer is a
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
                hint="check free disk space and write permissions on the map's folder",
            ) from exc
    if not acquired:
        holder = ""
        with contextlib.suppress(OSError):
            holder = lock.read_text(encoding="utf-8", errors="replace").strip()
        raise MapLockedError(
            f"map {Path(path)} is being written by another process ({holder or 'unknown'})",
            hint=f"wait for it to finish; if no aion is running, delete {lock}",
        )
    _remove_orphaned_staging(Path(path))
    try:
        yield lock
    finally:
        with contextlib.suppress(OSError):
            lock.unlink()


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
