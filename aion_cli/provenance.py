"""Provenance of an input log for the map manifest: path, size and sha256; the check that
a log is a file or folder that can be hashed at all (before any byte is read); and which logs
of a build are distinct (:func:`distinct_logs`), hashing beside the build where it can."""

from __future__ import annotations

import hashlib
import os
import threading
from collections import Counter
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aion_cli.errors import InputError
from aion_cli.listing import first_few


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


def provenance(path: Path, stop: threading.Event | None = None,
               read: list[int] | None = None) -> dict[str, Any]:
    """Path, size and sha256 of one log (a rosbag2 folder: over its files' names and bytes).
    ``stop``: set from another thread to abandon the hash (:class:`_CancelledError`); ``read``: a
    one-element counter of the bytes hashed so far, for a progress bar in another thread."""
    digest = hashlib.sha256()
    size = 0
    for file in _files_of(path):
        if path.is_dir():
            digest.update(str(file.relative_to(path)).encode() + b"\0")
        with file.open("rb") as fh:
            while block := fh.read(1 << 20):
                if stop is not None and stop.is_set():
                    raise _CancelledError
                digest.update(block)  # releases the GIL: a thread hashes beside the build
                size += len(block)
                if read is not None:
                    read[0] += len(block)
    return {
        "path": str(path.resolve()),
        "name": path.name,
        "size": size,
        "sha256": digest.hexdigest(),
    }


class _CancelledError(Exception):
    """A background hash abandoned (the build failed or was interrupted)."""


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


@dataclass
class DistinctLogs:
    """The logs of a build with duplicates removed, and their provenance entries.

    Which logs are distinct is known at once. Their entries are ready only after
    :meth:`entries`: a log of a size no other log of the build or of the continued map has
    cannot be a byte-identical copy of any of them, so it is hashed by a thread *while the
    build learns* (sha256 of a 10 GB log takes about 20 s on one core; the hash is needed
    only for the manifest). Logs whose sizes collide are hashed before, as the check needs.
    """

    logs: tuple[Path, ...]
    notes: list[str]
    _entries: list[dict[str, Any] | None]
    _pending: list[tuple[int, Path]] = field(default_factory=list)
    _known: frozenset[str] = frozenset()
    _thread: threading.Thread | None = None
    _stop: threading.Event = field(default_factory=threading.Event)
    _read: list[int] = field(default_factory=lambda: [0])
    _error: list[BaseException] = field(default_factory=list)

    def _hash_pending(self) -> None:
        try:
            for slot, path in self._pending:
                self._entries[slot] = provenance(path, self._stop, self._read)
        except _CancelledError:
            return
        except BaseException as exc:  # raised again in the build's thread by entries()
            self._error.append(exc)

    def start(self) -> DistinctLogs:
        """Hash the pending logs in a daemon thread (an interrupted build does not wait for
        it at exit)."""
        if self._pending and self._thread is None:
            self._thread = threading.Thread(
                target=self._hash_pending, name="aion-hash-logs", daemon=True
            )
            self._thread.start()
        return self

    def entries(self, progress: Any) -> list[dict[str, Any]]:
        """The distinct logs' provenance entries, in the order of :attr:`logs`, waiting for
        the background hashes (with a progress bar if they are not done yet). A log whose
        sha256 is in the continued map is an :class:`InputError`."""
        thread = self._thread
        if thread is not None and thread.is_alive():
            total = sum(provenance_size(p) for _, p in self._pending)
            progress.start("hashing logs", max(total >> 20, 1), "MiB")
            shown = 0
            while thread.is_alive():
                thread.join(0.1)
                now = self._read[0] >> 20
                progress.advance(now - shown)
                shown = now
        elif thread is None and self._pending:
            self._hash_pending()  # never started: hash here
        if self._error:
            raise self._error[0]
        out = [e for e in self._entries if e is not None]
        _refuse_known(out, self._known)
        return out

    def cancel(self) -> None:
        """Stop a background hash (the build failed); :meth:`entries` must not follow."""
        self._stop.set()


def _refuse_known(
    entries: list[dict[str, Any]], known: Collection[str], logs: Sequence[Path] = ()
) -> None:
    """An :class:`InputError` naming every entry whose sha256 is ``known`` (in the continued
    map), and which of the ``logs`` given are new: ``aion build day*.mcap --map week.aion``
    names the one day to add, not only the first of the days the map holds."""
    held = [e for e in entries if e["sha256"] in known]
    if not held:
        return
    held_paths = {str(e["path"]) for e in held}
    new = [p.name for p in logs if str(p.resolve()) not in held_paths]
    names = [str(e["name"]) for e in held]
    raise InputError(
        f"{first_few(names, 3)} {'is' if len(held) == 1 else 'are'} already in the map "
        "(same sha256)",
        hint="each log may be added to a map only once"
        + (f": give only the new ones ({first_few(new, 5)})" if new else ""),
    )


def one_per_recording(paths: tuple[Path, ...]) -> tuple[tuple[Path, ...], list[str]]:
    """``paths`` without those another given path reads already, and a note for each: a
    storage file inside a bag folder also given (as the folder, its metadata.yaml or a file
    that opens the whole bag: ``aion build bag/*``, where the storage files read alone would
    split the bag's one recording), and a storage file beside its bag's metadata.yaml (which
    opens the whole bag) when that bag is given too, as its folder or as another of its
    files. The same path twice is left to the sha256 check."""
    from aion_cli.errors import LogFormatError
    from aion_cli.formats.log_format import guess_format

    def opens(path: Path) -> Path:
        try:
            return guess_format(path)[1].resolve()
        except LogFormatError:
            return path.resolve()  # reported when it is opened

    roots = [opens(p) for p in paths]
    folders = {root: path for root, path in zip(roots, paths, strict=True) if root.is_dir()}
    kept: list[Path] = []
    notes: list[str] = []
    first: dict[Path, Path] = {}
    for path, root in zip(paths, roots, strict=True):
        outer = next((f for f in folders if f in root.parents), None)
        if outer is not None:
            notes.append(f"{path} is part of {folders[outer]}, also given: it is used once")
            continue
        widened = root != path.resolve()
        if root in first and (widened or first[root].resolve() != root):
            notes.append(
                f"{path} opens the same rosbag2 bag as {first[root]} ({root}): it is used once"
            )
            continue
        first.setdefault(root, path)
        kept.append(path)
    return tuple(kept), notes


def distinct_logs(
    paths: tuple[Path, ...], progress: Any, known: Mapping[str, int]
) -> DistinctLogs:
    """The logs checked, then the distinct ones (a log given twice, or a byte-identical copy,
    is used once: a note). ``known``: sha256 → size of the continued map's inputs; a log
    whose sha256 is among them is an :class:`InputError` (at once if its size matches one of
    theirs, else it cannot be one). Only logs whose sizes collide — with each other or with
    ``known`` — are hashed here (``progress``: a
    :class:`~aion_cli.build_report.ProgressSink`, MiB hashed); the others, by
    :meth:`DistinctLogs.start` beside the build."""
    for path in paths:
        check_log_path(path)
    paths, notes = one_per_recording(paths)
    sizes = [provenance_size(p) for p in paths]
    taken = Counter(sizes)
    taken.update(set(known.values()))  # a size of the map's counts as taken by another
    now = [i for i, size in enumerate(sizes) if taken[size] > 1]
    if now:
        progress.start("hashing logs", max(sum(sizes[i] for i in now) >> 20, 1), "MiB")
    slots: list[dict[str, Any] | None] = []
    pending: list[tuple[int, Path]] = []
    logs: list[Path] = []
    first_of: dict[str, str] = {}
    for i, path in enumerate(paths):
        if taken[sizes[i]] == 1:
            pending.append((len(slots), path))
            slots.append(None)
            logs.append(path)
            continue
        entry = provenance(path)
        progress.advance(sizes[i] >> 20)
        seen = first_of.get(entry["sha256"])
        if seen is not None:
            if not _same_file(path, seen):
                said = f"is the same log as {seen} (same sha256)"
            else:  # not "run.mcap is the same log as run.mcap", as of a copy
                said = "is given twice" if str(path) == seen else f"is {seen} given again"
            notes.append(f"{path} {said}: it is used once")
            continue
        first_of[entry["sha256"]] = str(path)
        slots.append(entry)
        logs.append(path)
    _refuse_known([e for e in slots if e is not None], known, logs)
    return DistinctLogs(tuple(logs), notes, slots, pending, frozenset(known))


def _same_file(path: Path, other: str) -> bool:
    """Whether ``path`` and ``other`` name one file (the same path, ``./run.mcap`` beside
    ``run.mcap``, a link to it), not a copy of its bytes."""
    try:
        return os.path.samefile(path, other)
    except OSError:
        return False
