"""The one place that turns exceptions into what the user sees.

Every failure becomes exactly one ``error: ...`` line on stderr, usually followed by one
``hint: ...`` line, and an exit code:

* 2 — the user's to fix: :class:`~aion_cli.errors.InputError` (bad file, option, value),
  click usage errors (unknown option, missing argument), missing or unreadable files, and
  the machine's limits: a full disk or quota, a read-only file system, a name or path too
  long (:data:`ENVIRONMENT`);
* 1 — anything else (an internal fault): the hint asks to rerun with ``--debug``;
* 130 — interrupted with Ctrl-C.

No traceback is printed unless ``--debug`` was given (or ``AION_DEBUG=1`` is set).
"""

from __future__ import annotations

import errno
import os
import sys
import traceback

import click

from aion_cli.errors import AionError, InputError, TopicNotFoundError

EXIT_OK = 0
EXIT_FAULT = 1
EXIT_INPUT = 2
EXIT_INTERRUPTED = 130


def one_line(text: str) -> str:
    """Collapse a message to one line (multi-line library messages join with '; ') that is
    safe to print: control characters that remain (ESC sequences from a topic or frame name
    in a log) become visible escapes (:func:`aion_cli.cli.output.printable`)."""
    from aion_cli.cli.output import printable

    parts = [p.strip() for p in str(text).splitlines() if p.strip()]
    return printable("; ".join(parts)) if parts else "(no message)"


def _emit(message: str, hint: str | None) -> None:
    err = sys.stderr
    color = err.isatty()
    label = click.style("error:", fg="red", bold=True) if color else "error:"
    click.echo(f"{label} {one_line(message)}", err=True)
    if hint:
        label = click.style("hint:", fg="cyan") if color else "hint:"
        click.echo(f"{label} {one_line(hint)}", err=True)


def _topic_hint(exc: TopicNotFoundError) -> str | None:
    if exc.hint:
        return exc.hint
    if exc.candidates:
        return "candidates: " + "  ".join(exc.candidates)
    return None


def _usage_hint(exc: click.ClickException) -> str:
    ctx = getattr(exc, "ctx", None)
    path = ctx.command_path if ctx is not None else "aion"
    return f"see '{path} --help'"


def _interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is an interrupt (Ctrl-C, SIGTERM, end of input at a prompt) or was
    raised while Ctrl-C unwound (its ``__context__`` chain holds one): e.g. a zip writer
    stopped half-way by Ctrl-C then refuses to close its archive — the user pressed Ctrl-C, it
    is not a fault of aion. (An EOFError deeper in the chain is a truncated file, not this.)"""
    if isinstance(exc, EOFError):
        return True
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        if isinstance(current, (KeyboardInterrupt, click.Abort)):
            return True
        seen.add(id(current))
        current = current.__context__
    return False


def quiet_finalizers() -> None:
    """Silence errors of finalizers for the rest of an interrupted process.

    Ctrl-C or SIGTERM can land inside a constructor: ``zipfile.ZipFile.__init__`` stopped
    before it set ``_writing`` later fails in ``__del__`` with an AttributeError, which Python
    prints as "Exception ignored ... Traceback" beneath the one ``error: interrupted`` line.
    Only for a process that exits right after: every later unraisable error is dropped.
    """
    sys.unraisablehook = _drop_unraisable


def _drop_unraisable(unraisable: object) -> None:
    """A ``sys.unraisablehook`` that prints nothing."""


def report(exc: BaseException, debug: bool) -> int:
    """Print ``exc`` for the user and return the exit code."""
    interrupted = _interrupted(exc)
    if debug and not interrupted and not isinstance(exc, click.exceptions.Exit):
        traceback.print_exception(exc, file=sys.stderr)
    if interrupted:
        _report_interrupt()
        return EXIT_INTERRUPTED
    if isinstance(exc, TopicNotFoundError):
        _emit(exc.message, _topic_hint(exc))
        return EXIT_INPUT
    if isinstance(exc, InputError):
        _emit(exc.message, exc.hint)
        return EXIT_INPUT
    if isinstance(exc, AionError):
        _emit(exc.message, exc.hint or "rerun with --debug for the traceback and report it")
        return EXIT_FAULT
    if isinstance(exc, click.UsageError) and isinstance(exc, NO_ARGS_IS_HELP):
        click.echo(exc.format_message(), err=True)  # `aion` or `aion evaluate` alone: the help
        return EXIT_INPUT
    if isinstance(exc, click.ClickException):
        _emit(exc.format_message(), _usage_hint(exc))
        return EXIT_INPUT
    if isinstance(exc, OSError):
        return _report_os_error(exc)
    _emit(
        f"internal error: {type(exc).__name__}: {exc}",
        "this is a bug in aion; rerun with --debug for the traceback and report it",
    )
    return EXIT_FAULT


NO_ARGS_IS_HELP: tuple[type[BaseException], ...] = tuple(
    getattr(click.exceptions, name)
    for name in ("NoArgsIsHelpError",)
    if hasattr(click.exceptions, name)
)
"""A group called without a command (click 8.2 on; 8.1 prints the help itself): its message
is the help text, which the one-line ``error:`` form would flatten into one line."""


def _report_interrupt() -> None:
    """``error: interrupted``; when an output was already moved into place (complete) before
    the interruption, the message names it instead of claiming it was left unchanged."""
    from aion_cli.formats.committed import committed_outputs

    written = list(dict.fromkeys(_shown_path(_relative(p)) for p in committed_outputs()))
    if not written:
        _emit("interrupted", "an existing output is left unchanged; rerun the command to finish")
        return
    _emit(
        f"interrupted after {', '.join(written)} was written",
        "what was written is complete; any other output of the command is left unchanged",
    )


def _relative(path: os.PathLike[str]) -> str:
    """``path`` relative to the current folder when it lies inside it."""
    text = os.fspath(path)
    try:
        rel = os.path.relpath(text)
    except ValueError:
        return text
    return text if rel.startswith(os.pardir) else rel


def silence(stream: object) -> None:
    """Point ``stream``'s file descriptor at /dev/null, so that its reader having gone, the
    interpreter's final flush cannot fail again (nothing to do without a real descriptor,
    e.g. a test runner's buffer)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, stream.fileno())  # type: ignore[attr-defined]
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def _stdout_reader_gone() -> bool:
    """Whether a broken pipe is stdout's: its reader has closed it (``| head``), which poll
    reports on the write end as POLLERR. A broken pipe of anything else (a socket to a
    scheduler, a child process's pipe) while stdout's reader still reads is a failure, not
    a reader that stopped early. Where stdout has no file descriptor to ask (a test runner's
    buffer), or poll is missing, it counts as stdout's."""
    import select

    try:
        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        events = poller.poll(0)
    except (OSError, ValueError, AttributeError):
        return True
    return any(event & (select.POLLERR | select.POLLHUP) for _, event in events)


ENVIRONMENT = {
    errno.ENOSPC: "free some disk space or write to another place; an existing output is "
    "left unchanged",
    errno.EDQUOT: "free some space within your quota or write to another place; an existing "
    "output is left unchanged",
    errno.EFBIG: "the file system cannot hold a file this large; write to another place",
    errno.EROFS: "the file system is read-only; write to another place",
    errno.ENAMETOOLONG: "use a shorter path: each name at most 255 bytes, the whole path at "
    "most 4096",
}
"""OS errors of the machine rather than of aion (exit 2), with the hint for each."""

SHOWN_PATH_CHARS = 200
"""A longer path is shown by its start and end (a path over 4096 bytes would fill a page)."""


def _shown_path(name: object) -> str:
    """A path for the message: a staged output's hidden temporary name (``.x.ply.<tag>.tmp``,
    ``formats.outputs.Staged``) shown as the output it stands for; a very long path shortened
    in its middle."""
    from aion_cli.formats.outputs import staged_target

    text = os.fsdecode(name) if isinstance(name, str | bytes | os.PathLike) else str(name)
    parts = text.split(os.sep)
    for i, part in enumerate(parts):
        target = staged_target(part)
        if target is not None:
            inner = parts[i + 1] if i + 1 < len(parts) else None
            parts[i] = target  # ".out.<tag>.tmp/out/x.csv" -> "out/x.csv"
            if inner is not None and inner.startswith(target.rsplit("~", 1)[0]):
                del parts[i + 1]
                parts[i] = inner  # the full name (a long one is cut in the staging name)
            break
    shown = os.sep.join(parts)
    if len(shown) > SHOWN_PATH_CHARS:
        half = SHOWN_PATH_CHARS // 2
        shown = f"{shown[:half]}...{shown[-half:]} ({len(os.fsencode(text)):,} bytes)"
    return shown


def _file_in_the_way(name: object) -> str | None:
    """The first folder of the path ``name`` that is a regular file (so nothing below it can
    be made), or None. A folder that cannot be looked at (its name too long, no permission)
    ends the search: this runs while an error is reported and must not raise another."""
    from pathlib import Path

    text = os.fsdecode(name) if isinstance(name, str | bytes | os.PathLike) else str(name)
    try:
        for folder in reversed(Path(os.path.abspath(text)).parents):
            if folder.is_file():
                return str(folder)
    except (OSError, ValueError):
        return None
    return None


def _report_os_error(exc: OSError) -> int:
    if exc.errno == errno.EPIPE and _stdout_reader_gone():  # `| head`: not a failure
        silence(sys.stdout)
        return EXIT_OK
    what = exc.strerror or str(exc)
    where = f": {_shown_path(exc.filename)}" if exc.filename else ""
    blocked = _file_in_the_way(exc.filename) if exc.filename else None
    if blocked is None and isinstance(exc, FileExistsError) and exc.filename:
        named = _shown_path(exc.filename)  # a folder to make where a file is (mkdir)
        blocked = named if os.path.isfile(named) else None
    if blocked is not None and isinstance(exc, FileExistsError | NotADirectoryError):
        _emit(f"{blocked} is a file, not a folder", "choose a path whose folders are folders")
        return EXIT_INPUT
    user_side = (
        FileNotFoundError,
        PermissionError,
        IsADirectoryError,
        NotADirectoryError,
        FileExistsError,
    )
    if isinstance(exc, user_side):
        _emit(f"{what}{where}", "check the path and its permissions")
        return EXIT_INPUT
    if exc.errno in ENVIRONMENT:
        _emit(f"{what}{where}", ENVIRONMENT[exc.errno])
        return EXIT_INPUT
    _emit(f"{what}{where}", "rerun with --debug for the traceback")
    return EXIT_FAULT
