"""The one rich console (on stderr) and the progress-bar factory.

Everything for humans (progress, summaries, notes) goes to stderr through :func:`console`;
data (tables asked for with ``--format table``, JSON, CSV) goes to stdout through
:func:`data_console` or plain ``click.echo``. Both consoles look up ``sys.stderr`` /
``sys.stdout`` on every write, so click's test runner captures them.
"""

from __future__ import annotations

import errno
import re
import sys
from typing import TYPE_CHECKING

from rich.console import Console

if TYPE_CHECKING:
    from rich.console import RenderableType
    from rich.progress import Progress


class _Console(Console):
    """A rich console whose closed output (``aion predict MAP | head``) is a
    ``BrokenPipeError`` for :func:`aion_cli.cli.errors.report` (exit 0, no message): rich's
    own reaction is ``SystemExit(1)``, so a table read by ``head`` made the command fail."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        if self.stderr:
            # stderr's reader left (``2>&1 >out.csv | head -1``): the notes are lost, the
            # command carries on and writes its data; a broken pipe here would end it with
            # exit 0 and no output. stderr goes to /dev/null so the final flush cannot fail.
            from aion_cli.cli.errors import silence

            silence(sys.stderr)
            return
        raise BrokenPipeError(errno.EPIPE, "Broken pipe")


_ERR: Console | None = None
_OUT: Console | None = None
_QUIET: Console | None = None  # set by -q (set_quiet): every note and summary dropped


def set_quiet(quiet: bool) -> None:
    """``-q``: from now on :func:`console` prints nothing (notes, summaries, closing lines,
    progress); warnings (:func:`warn`) and errors stay. Reset for every command."""
    global _QUIET
    _QUIET = Console(stderr=True, quiet=True) if quiet else None


def is_quiet() -> bool:
    """Whether the command runs with ``-q`` (:func:`set_quiet`)."""
    return _QUIET is not None


def console() -> Console:
    """The console on stderr for progress, notes and summaries (silent after ``-q``)."""
    return _QUIET if _QUIET is not None else _loud()


def _loud() -> Console:
    """The console on stderr that ``-q`` does not silence (warnings)."""
    global _ERR
    if _ERR is None:
        _ERR = _Console(stderr=True, highlight=False)
    return _ERR


def data_console() -> Console:
    """A console on stdout for data rendered as a rich table (never wraps into nonsense:
    width falls back to 200 columns when stdout is not a terminal)."""
    global _OUT
    if _OUT is None:
        _OUT = _Console(highlight=False, width=None if sys.stdout.isatty() else 200)
    return _OUT


def print_table(table: RenderableType, err: bool = False) -> None:
    """Print a rich table on stdout (``err``: on stderr) without cutting a word of any cell.

    Rich shrinks a table to the terminal's width, cutting cells to ``p1…`` and ``21.…`` where
    that is narrower than the table (an 80-column terminal and ``predict``'s 13 columns, a
    40-column one, ``TERM=dumb``, which rich takes as 80 columns); such a table is printed at
    the narrowest width that keeps every word of every cell whole, and the terminal wraps its
    lines instead."""
    from rich.measure import Measurement
    from rich.table import Table

    out = console() if err else data_console()
    if out.quiet:  # -q: the wider console below would print it after all
        return
    wide = out.options.update_width(1 << 15)
    if isinstance(table, Table):  # rich measures a cell by its words, even where it may not wrap
        for column in table.columns:
            if column.no_wrap and column.min_width is None:
                cells = [column.header, *column.cells]
                column.min_width = max(Measurement.get(out, wide, c).maximum for c in cells)
    need = Measurement.get(out, wide, table).minimum
    if need > out.width:
        # a height too: without both, rich takes a dumb terminal as 80 columns whatever it is told
        out = _Console(stderr=err, highlight=False, width=need, height=out.size.height)
    out.print(table)


def note(message: str) -> None:
    """A one-line informational message on stderr (dimmed). ``message`` is plain text: rich
    markup in it is shown, not applied, and control characters are made visible
    (:func:`aion_cli.cli.output.markup_safe`), so names from a log cannot restyle or drive the
    terminal."""
    from aion_cli.cli.output import markup_safe

    console().print(f"[dim]{markup_safe(message)}[/dim]", soft_wrap=True)


def warn(message: str) -> None:
    """A one-line warning on stderr (``message`` is plain text, as for :func:`note`)."""
    from aion_cli.cli.output import markup_safe

    _loud().print(f"[yellow]warning:[/yellow] {markup_safe(message)}", soft_wrap=True)


#: how many warnings of one shape are printed before the rest are counted in one line
WARNINGS_PER_SHAPE = 3
_NUMBERS = re.compile(r"\d[\d,.:_TZ+-]*")
#: a warning about one file: its name (no space, colon or slash: not a topic such as ``/tf``;
#: with a suffix such as ``.mcap``), ``": "`` and what is said of it
_FILE_FIRST = re.compile(r"([^\s:/\\]+\.[A-Za-z][A-Za-z0-9]{0,7}): (.+)", re.DOTALL)


def warning_shape(message: str) -> str:
    """``message`` with every number, time and byte offset replaced by ``#``: warnings that
    differ only there (one per skipped chunk or message) have the same shape."""
    return _NUMBERS.sub("#", message)


def across_files(messages: list[str], named: int = WARNINGS_PER_SHAPE) -> list[str]:
    """``messages`` with a warning said alike of several files (``a.mcap: topic example
    skipped ...``, the text after the file's name the same) as one line, where the first of
    them was, naming how many files and the first ``named`` of them: ``topic example skipped
    ... in 154 files (a.mcap, b.mcap, c.mcap and 151 more)``. A warning of one file, or one
    whose text differs in more than the file's name, is left as it is (:func:`warning_shape`
    keeps telling files apart: ``x.mcap: chunk at byte 33 skipped`` and ``y.mcap: ...`` are
    two problems)."""
    from aion_cli.listing import first_few
    from aion_cli.number_text import counted

    said = [_FILE_FIRST.fullmatch(message) for message in messages]
    files: dict[str, list[str]] = {}  # what is said: the files it is said of, in order
    for match in said:
        if match and match[1] not in files.setdefault(match[2], []):
            files[match[2]].append(match[1])
    out: list[str] = []
    done: set[str] = set()
    for message, match in zip(messages, said, strict=True):
        if not match or len(files[match[2]]) < 2:
            out.append(message)
        elif match[2] not in done:  # once, where the first file's warning was
            done.add(match[2])
            alike = files[match[2]]
            out.append(f"{match[2]} in {counted(len(alike), 'file')} ({first_few(alike, named)})")
    return out


def warn_each(messages: list[str], limit: int = WARNINGS_PER_SHAPE) -> None:
    """Print ``messages`` as warnings, one line for a warning said alike of several files
    (:func:`across_files`), at most ``limit`` of each :func:`warning_shape` and then one line
    counting the rest, so 500 skipped messages do not bury the summary (the JSON output keeps
    every one)."""
    counts: dict[str, int] = {}
    first: dict[str, str] = {}
    for message in across_files(messages):
        shape = warning_shape(message)
        counts[shape] = counts.get(shape, 0) + 1
        first.setdefault(shape, message)
        if counts[shape] <= limit:
            warn(message)
    for shape, count in counts.items():
        if count > limit:
            example = first[shape] if len(first[shape]) <= 60 else first[shape][:57] + "..."
            warn(f"{count - limit:,} more like {example!r} (--format json lists every one)")


def progress(quiet: bool = False) -> Progress:
    """A progress bar on stderr with a real total, rate and ETA.

    Disabled (a no-op object with the same interface) with ``quiet`` (or the command's
    ``-q``: :func:`set_quiet`) or when stderr is not a terminal, so logs and test captures
    do not fill with redraws.
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TaskProgressColumn(),
        TextColumn("{task.fields[unit]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console(),
        transient=False,
        disable=quiet or is_quiet() or not sys.stderr.isatty(),
    )
