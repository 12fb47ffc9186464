"""A rosbag2 sqlite3 storage file cut short (a copy that did not finish, a recorder killed
while SQLite grew the file), read as far as SQLite can read it.

SQLite refuses a database file shorter than the page count its header states ("database disk
image is malformed") before reading any row, although the pages that are there usually hold
the schema, the topics and the first messages. :func:`cut_short` tells such a file from its
header (no row read); :func:`salvage_to_temp` copies what SQLite still reads (every table, in
rowid order, up to the first row it cannot read) into a new database in a temporary folder,
which the rosbag2 readers then read like any storage file, and says how much was lost, as the
ROS 1 bag reindex (:mod:`formats.bag_reindex`) does for a bag cut short. A file of which no
message can be read is refused, as cut short, not merely as unreadable.

A file of full size damaged inside (a page overwritten: a disk error, a bad copy), which SQLite
refuses with the same "malformed" once a query reaches the page, is copied past the damage
(:func:`salvage_damaged`): the messages' rows are read in rowid order, and where a read fails
the first rowid SQLite reads again after it is searched for (a damaged page holds a run of
rowids); the rows in between are lost, and counted (rosbag2 numbers its messages 1, 2, 3 ...).
"""

from __future__ import annotations

import sqlite3
import struct
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aion_cli.errors import LogFormatError
from aion_cli.formats.rosbag2_storage import SQLITE_MAGIC


class DamagedStorageError(LogFormatError):
    """A sqlite3 storage file SQLite refused to open for its damage (``file``: the file on
    disk; ``reason``: what SQLite said), which :func:`salvage_damaged` may read past."""

    def __init__(self, message: str, hint: str, file: Path, reason: str) -> None:
        super().__init__(message, hint=hint)
        self.file = file
        self.reason = reason


#: rows copied at a time (bounded memory whatever the payloads' sizes add up to)
_BATCH = 256


@dataclass(frozen=True)
class CutShort:
    """A sqlite3 file shorter than its header says: its size and the size the header states."""

    size: int
    page_size: int
    pages: int

    @property
    def stated(self) -> int:
        return self.page_size * self.pages

    def describe(self) -> str:
        """``1,000,000 of its 1,937,408 bytes (244 of 473 pages of 4,096 bytes)``."""
        return (
            f"{self.size:,} of its {self.stated:,} bytes ({self.size // self.page_size:,} of "
            f"{self.pages:,} pages of {self.page_size:,} bytes)"
        )


def cut_short(path: Path) -> CutShort | None:
    """What the header of the sqlite3 file ``path`` says it lacks, or None when it is whole
    (or no sqlite3 file, or its header states no size: SQLite then takes the file's)."""
    try:
        with path.open("rb") as f:
            head = f.read(100)
            size = f.seek(0, 2)
    except OSError:
        return None
    if len(head) < 100 or not head.startswith(SQLITE_MAGIC):
        return None
    page_size = struct.unpack_from(">H", head, 16)[0]
    page_size = 65536 if page_size == 1 else page_size
    change, pages, valid_for = (struct.unpack_from(">I", head, k)[0] for k in (24, 28, 92))
    if pages == 0 or change != valid_for or page_size < 512:
        return None  # the header's size is not in force: SQLite uses the file's
    return CutShort(size, page_size, pages) if size < page_size * pages else None


def salvage_damaged(
    path: Path, shown: Path | None = None, why: str = ""
) -> tuple[tempfile.TemporaryDirectory[str], Path, str]:
    """:func:`salvage_to_temp` for a sqlite3 file of full size that SQLite cannot read whole
    (``why``: what it said): its readable rows, past each damaged run of message rows, copied
    into a new database; the warning counts the message rows lost. Raises
    :class:`LogFormatError` when not one message can be read."""
    return salvage_to_temp(path, None, shown, why)


def salvage_to_temp(
    path: Path, cut: CutShort | None, shown: Path | None = None, why: str = ""
) -> tuple[tempfile.TemporaryDirectory[str], Path, str]:
    """Copy what SQLite reads of the cut-short sqlite3 file ``path`` into a new database of
    the same name in a new temporary folder: ``(folder, copy, warning)``; the caller owns the
    folder and calls its ``cleanup()``. Messages name ``shown`` (default ``path``: the file
    on disk when ``path`` is its decompressed copy). Raises :class:`LogFormatError` (the
    folder removed) when not one message can be read, or the temporary disk runs out.
    ``cut`` None: the file is whole but damaged inside (:func:`salvage_damaged`)."""
    name = shown if shown is not None else path
    try:
        tmp = tempfile.TemporaryDirectory(prefix="aion-salvage-")
    except OSError as exc:
        raise _no_room(name, exc) from exc
    copy = Path(tmp.name) / path.name
    try:
        target = Path(tmp.name) / f"whole-pages-{path.name}"
        whole = path if cut is None else _whole_pages(path, cut, target)
        try:
            read, stop, gaps = _copy_rows(whole, copy, skip=cut is None)
        finally:
            if whole != path:
                whole.unlink()
    except sqlite3.DatabaseError as exc:
        tmp.cleanup()
        if isinstance(exc, sqlite3.OperationalError) and "disk" in str(exc).lower():
            raise _no_room(name, exc) from exc
        raise _refused(name, cut, str(exc), why) from exc
    except OSError as exc:
        tmp.cleanup()
        raise _no_room(name, exc) from exc
    except BaseException:
        tmp.cleanup()
        raise
    if read == 0:
        tmp.cleanup()
        raise _refused(name, cut, stop or "its messages table is empty", why)
    if cut is None:
        return tmp, copy, _damaged_text(name, read, gaps, stop or why)
    warning = (
        f"{name.name}: the sqlite3 storage file is cut short, {cut.describe()}: its first "
        + ("message is read, those after it" if read == 1 else f"{read:,} messages are read, "
           "those after them")
        + " are lost"
        + (f" (SQLite: {stop})" if stop else "")
    )
    return tmp, copy, warning


def _whole_pages(path: Path, cut: CutShort, target: Path) -> Path:
    """``path`` itself when it ends at a page boundary, else a copy (``target``) of its whole
    pages: SQLite reads the bytes missing from a partial last page as zeros, which make rows
    of it that look whole; a page wholly missing is an error it reports."""
    keep = cut.size - cut.size % cut.page_size
    if keep == cut.size:
        return path
    with path.open("rb") as src, target.open("wb") as dst:
        while keep > 0 and (piece := src.read(min(keep, 1 << 20))):
            dst.write(piece)
            keep -= len(piece)
    return target


def _damaged_text(name: Path, read: int, gaps: Gaps, why: str) -> str:
    """The warning of a file salvaged past damage: the messages read, and the rows lost."""
    from aion_cli.number_text import counted

    tail = [a for a, b in gaps if b == _ON]  # the damage runs to the end: no count
    gaps = [(a, b) for a, b in gaps if b != _ON]
    lost = sum(b - a + 1 for a, b in gaps)
    runs = ", ".join(f"{a:,}" if a == b else f"{a:,} to {b:,}" for a, b in gaps[:5])
    more = f" and {len(gaps) - 5:,} more runs" if len(gaps) > 5 else ""
    read_text = f"{counted(read, 'message')} {'is' if read == 1 else 'are'} read"
    if tail:
        cannot = f"{lost:,} cannot be (ids {runs}{more}), " if gaps else ""
        return (
            f"{name.name}: the sqlite3 storage file is damaged inside (SQLite: {why}): "
            f"{read_text}, {cannot}none from id {tail[0]:,} on can be read: they are lost"
        )
    return (
        f"{name.name}: the sqlite3 storage file is damaged inside (SQLite: {why}): "
        f"{read_text}, {lost:,} cannot be (ids {runs}{more}) and {'is' if lost == 1 else 'are'} "
        "lost"
        if gaps
        else f"{name.name}: the sqlite3 storage file is damaged inside (SQLite: {why}), not in "
        + ("its messages: its one message is read" if read == 1
           else f"its messages: all {read:,} of them are read")
    )


Gaps = list[tuple[int, int]]
"""Runs ``(first, last)`` of rowids skipped as unreadable; ``last`` :data:`_ON`: every rowid
from ``first`` on (no row is read after the damage)."""
_ON = 2**63 - 1


def _copy_rows(path: Path, copy: Path, skip: bool = False) -> tuple[int, str, Gaps]:
    """Create ``copy`` with ``path``'s tables, indexes after their rows, and every row SQLite
    reads of each table, in rowid order up to the first it cannot read (``skip``: the
    messages' rows also after each damaged run, :func:`_resume`): (messages copied, SQLite's
    error where it stopped reading messages, "" when it read them all; the runs of message
    rowids skipped as unreadable)."""
    # read-only, and no write to the file's folder (a journal, a lock): it may be read-only;
    # every query its own read transaction, so an error ends with it
    source = path.resolve().as_uri() + "?mode=ro&immutable=1"
    cut = sqlite3.connect(source, uri=True, isolation_level=None)
    db = sqlite3.connect(copy, isolation_level=None)  # transactions by hand (savepoints)
    try:
        cut.execute("PRAGMA writable_schema = ON")  # reads a file shorter than its header says
        db.execute("PRAGMA journal_mode = MEMORY")
        db.execute("PRAGMA synchronous = OFF")
        entries = cut.execute(
            "SELECT type, name, sql FROM sqlite_master WHERE sql IS NOT NULL "
            "AND name NOT LIKE 'sqlite_%'"
        ).fetchall()
        tables = [name for kind, name, _ in entries if kind == "table"]
        if "messages" not in tables:
            raise sqlite3.DatabaseError("it has no messages table that SQLite can read")
        db.execute("BEGIN")
        for kind, _, sql in entries:
            if kind == "table":
                db.execute(sql)
        copied, stop, gaps = 0, "", []  # type: tuple[int, str, Gaps]
        for name in tables:
            count, why, skipped = _copy_table(cut, db, name, skip and name == "messages")
            if name == "messages":
                copied, stop, gaps = count, why, skipped
            elif why and name == "topics":  # messages without their topics cannot be read
                raise sqlite3.DatabaseError(f"its topics table cannot be read ({why})")
        for kind, _, sql in entries:
            if kind != "table":
                db.execute(sql)
        db.execute("COMMIT")
    finally:
        cut.close()
        db.close()
    return copied, stop, gaps


def _copy_table(
    cut: sqlite3.Connection, db: sqlite3.Connection, name: str, skip: bool = False
) -> tuple[int, str, Gaps]:
    """Copy table ``name`` of ``cut`` into ``db``, a batch at a time, until SQLite cannot
    read on (``skip``: on from the first rowid it reads after the damage, :func:`_resume`):
    (rows copied, its first error, "" when every row was read; the runs of rowids skipped).
    A batch is a ``LIMIT``: Python's sqlite3 steps one row ahead of the rows it returns, so a
    fetch of the row before the damage failed with it."""
    quoted = '"' + name.replace('"', '""') + '"'
    columns = cut.execute(f"PRAGMA table_info({quoted})").fetchall()
    insert = f"INSERT INTO {quoted} VALUES ({', '.join('?' * len(columns))})"
    select = f"SELECT rowid, * FROM {quoted} WHERE rowid >= ? ORDER BY rowid LIMIT ?"
    copied, start, size = 0, -(2**63), _BATCH
    first_why, gaps = "", []  # type: tuple[str, Gaps]
    while True:
        why, damaged = "", None  # damaged: the rowid of a row read whole that cannot be kept
        try:
            batch: list[Any] | None = cut.execute(select, (start, size)).fetchall()
        except sqlite3.DatabaseError as exc:
            batch, why = None, str(exc)
        if batch:
            db.execute("SAVEPOINT batch")
            try:
                db.executemany(insert, [row[1:] for row in batch])
            except sqlite3.IntegrityError as exc:  # a damaged row read as one (a NULL id)
                db.execute("ROLLBACK TO batch")
                damaged = batch[0][0] if len(batch) == 1 else None
                batch, why = None, f"a damaged row ({exc})"
            db.execute("RELEASE batch")
        if batch is None:
            if size > 1:  # the batch the damage is in: its rows before it, one by one
                size = 1
                continue
            first_why = first_why or why
            if not skip:
                return copied, first_why, gaps
            # past the row SQLite reads but that cannot be kept, else to where it reads again
            after = max(damaged, start) + 1 if damaged is not None else _resume(cut, quoted, start)
            if after is None:
                return copied, first_why, [*gaps, (max(start, 1), _ON)]
            if after - 1 >= max(start, 1):  # (rosbag2 numbers rows from 1)
                gaps.append((max(start, 1), after - 1))
            start, size = after, _BATCH
            continue
        if not batch:
            return copied, first_why, gaps
        copied += len(batch)
        start = max(batch[-1][0], start) + 1  # on, even where a damaged tree's order is not


def _resume(cut: sqlite3.Connection, quoted: str, start: int) -> int | None:
    """The smallest ``r`` > ``start`` from which SQLite reads the rows again (the rows
    ``start .. r - 1`` lie in a damaged page: a read from any of them fails, from ``r`` on it
    works); None when no row is readable after the damage. Steps of 1, 2, 4 ... find a
    readable start, then bisection the first (a damaged page holds one run of rowids)."""

    def reads_from(rowid: int) -> bool | None:  # True: a row is read, None: none is left
        try:  # the whole row, as the copy reads it: its rowid alone may read where it fails
            row = cut.execute(
                f"SELECT rowid, * FROM {quoted} WHERE rowid >= ? ORDER BY rowid LIMIT 1",
                (rowid,),
            ).fetchall()
        except sqlite3.DatabaseError:
            return False
        return True if row else None

    bad, step = start, 1
    while True:
        probe = 0 if bad < 0 else bad + step  # (no row read yet: rosbag2's ids are positive)
        if probe >= 2**63 - 1:
            return None
        got = reads_from(probe)
        if got is None:
            return None  # nothing after the damage
        if got:
            good = probe
            break
        bad, step = probe, step * 2 if bad >= 0 else 1
    while good - bad > 1:  # reads from ``good``, not from ``bad``
        mid = (bad + good) // 2
        if reads_from(mid):
            good = mid
        else:
            bad = mid
    return good


def _refused(path: Path, cut: CutShort | None, why: str, said: str = "") -> LogFormatError:
    if cut is None:
        return LogFormatError(
            f"{path}: not a readable rosbag2 sqlite3 storage file ({said or why}), and SQLite "
            f"reads none of its messages past the damage ({why})",
            hint="the storage file is corrupt: copy it again from its source",
        )
    return LogFormatError(
        f"{path}: the sqlite3 storage file is cut short, {cut.describe()}, and SQLite reads "
        f"none of its messages ({why})",
        hint="the copy or the recording did not finish: copy the file again from its source",
    )


def _no_room(path: Path, exc: Exception) -> LogFormatError:
    return LogFormatError(
        f"{path}: cannot copy what is readable of it into {tempfile.gettempdir()} ({exc})",
        hint="free disk space there, or set TMPDIR to a folder with room for the copy",
    )
