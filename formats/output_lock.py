"""One writer per output: the ``<output>.lock`` file a writer holds while it writes.

A second ``aion build`` of the same map, two ``aion convert`` runs to one log, a ``simulate``
whose log and ground truth could come from two different runs, two exports mixing their
frames in one folder: each writer holds the lock of its output until its output is in place,
and a second writer is refused at once (:class:`aion_cli.errors.OutputLockedError`, exit 2)
instead of racing it. The lock is a file created with ``O_CREAT|O_EXCL`` holding
``"<pid> <host>"``; one whose process is dead (a SIGKILLed writer) is taken over. Maps take it
through :func:`formats.mapfile_target.map_lock`, logs through
:class:`formats.writers.LogWriter`, ``simulate`` through :func:`aion_cli.sim.scenario.simulate`
(the log and its truth), exports through :func:`aion_cli.exports.write_export`, reports
through :func:`aion_cli.report.writer.write_report`.
"""

from __future__ import annotations

import contextlib
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from aion_cli.errors import InputError, OutputLockedError
from aion_cli.formats.interrupts import interrupts_held

STALE_UNREADABLE_LOCK_S = 10.0
"""An empty lock file older than this is treated as stale (a crash between its creation and
its pid's write); a file of that name with other text is not aion's and is never removed."""

INSIDE = ".aion.lock"
"""The lock's name inside a folder written into (``export -o DIR`` of an existing ``DIR``)."""


def lock_path(path: str | os.PathLike[str]) -> Path:
    """``office.aion`` -> ``office.aion.lock`` (a name too long for the suffix is cut and
    ends in its hash: :func:`formats.outputs.fitted_name`)."""
    from aion_cli.formats.outputs import fitted_name

    p = Path(path)
    return p.with_name(fitted_name(p.name, len(".lock")) + ".lock")


_HELD: set[str] = set()
"""The locks this process holds (resolved paths): a lock naming this process's own pid that
it does not hold was left by an earlier process that had the same pid (a container restarted
after its aion was killed runs the same entry point as the same pid), and is stale."""


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
    """A lock is stale if its pid (same host) is dead, or it is empty and old.

    Locks from another host cannot be checked and count as live; so does a file of the
    lock's name holding anything but ``"<pid> <host>"`` (someone's own ``notes.lock``, which
    removing would destroy: the refusal names it, to be moved away by hand).
    """
    try:
        text = lock.read_text(encoding="utf-8", errors="replace")
        age = time.time() - lock.stat().st_mtime
    except FileNotFoundError:
        return True
    lines = text.split()
    if not lines:
        return age > STALE_UNREADABLE_LOCK_S
    if not lines[0].isdigit():
        return False
    host = lines[1] if len(lines) > 1 else socket.gethostname()
    if host != socket.gethostname():
        return False
    pid = int(lines[0])
    if pid == os.getpid():  # this process: live only if it holds the lock itself
        return str(lock.resolve()) not in _HELD
    return not _pid_alive(pid)


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


def lock_of(path: str | os.PathLike[str], into: bool = False) -> Path:
    """The lock file of the output ``path``: :func:`lock_path` beside it, or, for a folder
    written into (``into``) that exists, :data:`INSIDE` it (``export -o .`` must not need
    the folder above the current one to be writable)."""
    target = Path(path)
    if into and target.is_dir():
        return target / INSIDE
    return lock_path(target)


def _cannot_write(
    path: str | os.PathLike[str],
    lock: Path,
    exc: OSError,
    what: str,
    failed: type[InputError],
) -> InputError:
    """The error for a lock that could not be created: it names the output the user asked
    for and the folder that refused a new file, never the ``.lock`` (a file the user did not
    ask for: ``-o /proc/x.aion`` said "cannot create lock file /proc/x.aion.lock")."""
    import errno

    output = f"{what} {Path(path)}" if what != "output" else str(Path(path))
    reason = exc.strerror or str(exc)
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        hint = "free some disk space, or choose an output path on another disk"
    else:
        hint = "choose an output path in a folder you can write to"
    return failed(
        f"cannot write {output}: files cannot be created in {lock.parent} ({reason})",
        hint=hint,
    )


@contextlib.contextmanager
def output_lock(
    path: str | os.PathLike[str],
    *,
    into: bool = False,
    what: str = "output",
    locked: type[InputError] = OutputLockedError,
    failed: type[InputError] | None = None,
) -> Iterator[Path]:
    """Hold the lock of the output ``path`` (:func:`lock_of`) for the block; yields it.

    Another live writer is ``locked`` (exit 2, with the holder's pid and host and the lock to
    delete should no aion be running); a lock that cannot be created (a full disk, a
    read-only folder) is ``failed`` (default :class:`formats.outputs.OutputPathError`), as
    is a missing folder above the output (:func:`formats.outputs.check_output_folder`). A
    stale lock (its process is dead) is removed and taken over once. ``what`` names the
    output in the message (``"map"``). Known limit: two processes recovering the same stale
    lock at the same instant could both succeed; the window is the few microseconds between
    check and unlink.
    """
    from aion_cli.formats.outputs import check_output_folder

    if failed is None:
        from aion_cli.formats.outputs import OutputPathError

        failed = OutputPathError
    lock = lock_of(path, into)
    if lock.parent != Path(path):  # beside it: a missing folder is the output's error
        check_output_folder(path, error=failed)  # (its mkdir -p hint), not the lock's
    acquired = False
    held = ""
    try:
        try:
            with interrupts_held():  # created and known to be ours (removed below), or neither
                acquired = _try_create_lock(lock)
            if not acquired and _lock_is_stale(lock):
                with contextlib.suppress(FileNotFoundError):
                    lock.unlink()
                with interrupts_held():
                    acquired = _try_create_lock(lock)
        except OSError as exc:
            if not isinstance(exc, FileExistsError):
                raise _cannot_write(path, lock, exc, what, failed) from exc
        if not acquired:
            holder = ""
            with contextlib.suppress(OSError):
                holder = lock.read_text(encoding="utf-8", errors="replace").strip()
            words = holder.split()
            if words and not words[0].isdigit():  # not "<pid> <host>": someone's own file
                raise locked(
                    f"{what} {Path(path)}: {lock} is in the way, a file that is not aion's lock",
                    hint=f"aion locks an output with a file of that name: move {lock} away",
                )
            raise locked(
                f"{what} {Path(path)} is being written by another process ({holder or 'unknown'})",
                hint=f"wait for it to finish; if no aion is running, delete {lock}",
            )
        held = str(lock.resolve())
        _HELD.add(held)
        yield lock
    finally:
        if acquired:  # an interrupt anywhere after the lock was made removes it too
            _HELD.discard(held)
            with contextlib.suppress(OSError):
                lock.unlink()
