"""Provenance of an input log for the map manifest: path, size and sha256; and the check that
a log is a file or folder that can be hashed at all (before any byte is read)."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from aion_cli.errors import InputError


def _files_of(path: Path) -> list[Path]:
    """The files hashed for ``path``: itself, or the regular files of a folder. A FIFO or a
    device is an :class:`InputError`: hashing it would block or never end."""
    if path.is_dir():
        return sorted(p for p in path.rglob("*") if p.is_file())
    if not path.is_file():
        raise InputError(
            f"{path} is not a regular file", hint="give a log file or a rosbag2 folder"
        )
    return [path]


def provenance(path: Path) -> dict[str, Any]:
    """Path, size and sha256 of one log (a rosbag2 folder: over its files' names and bytes)."""
    digest = hashlib.sha256()
    size = 0
    for file in _files_of(path):
        if path.is_dir():
            digest.update(str(file.relative_to(path)).encode() + b"\0")
        with file.open("rb") as fh:
            while block := fh.read(1 << 20):
                digest.update(block)
                size += len(block)
    return {
        "path": str(path.resolve()),
        "name": path.name,
        "size": size,
        "sha256": digest.hexdigest(),
    }


def provenance_size(path: Path) -> int:
    """Bytes :func:`provenance` will hash for ``path``."""
    return sum(f.stat().st_size for f in _files_of(path))


def check_log_path(path: Path) -> None:
    """A log must exist and be a regular file or a folder (a rosbag2 folder): a FIFO, a
    device or a socket would make hashing block or read forever (``/dev/zero``), so it is
    refused (:func:`formats.raw.check_regular_input`, ``os.stat`` only) before any byte is
    read."""
    from aion_cli.formats.raw import check_regular_input

    if not path.exists():
        raise InputError(f"log not found: {path}", hint="check the path")
    check_regular_input(path, "log", hint="give a log file (MCAP, .bag) or a rosbag2 folder")


def distinct_logs(
    paths: tuple[Path, ...], progress: Any, known: set[str]
) -> tuple[tuple[Path, ...], list[dict[str, Any]], list[str]]:
    """The logs checked, then hashed: the distinct ones (a log given twice, or a byte-identical
    copy, is used once: a note), their provenance entries and the notes. A log whose sha256
    is in ``known`` (the continued map's inputs) is an :class:`InputError`. ``progress``: a
    :class:`~aion_cli.build_report.ProgressSink` (MiB hashed)."""
    for path in paths:
        check_log_path(path)
    sizes = [provenance_size(p) for p in paths]
    progress.start("hashing logs", max(sum(sizes) >> 20, 1), "MiB")
    new: list[dict[str, Any]] = []
    logs: list[Path] = []
    notes: list[str] = []
    first_of: dict[str, str] = {}
    for path, size in zip(paths, sizes, strict=True):
        entry = provenance(path)
        progress.advance(size >> 20)
        seen = first_of.get(entry["sha256"])
        if seen is not None:
            notes.append(f"{path} is the same log as {seen} (same sha256): it is used once")
            continue
        first_of[entry["sha256"]] = str(path)
        new.append(entry)
        logs.append(path)
    for entry in new:
        if entry["sha256"] in known:
            raise InputError(
                f"{entry['name']} is already in the map (same sha256)",
                hint="each log may be added to a map only once",
            )
    return tuple(logs), new, notes

