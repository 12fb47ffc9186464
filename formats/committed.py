"""Which outputs this command has already moved into place (complete), for what an
interruption says.

A Ctrl-C or SIGTERM that lands after a map or staged output was renamed over its target,
while the command fsyncs the folder, prints its summary or writes its next output, used to
be reported as "an existing output is left unchanged; rerun the command to finish" although
the output had been replaced, complete (rerunning ``build LOG --map M -o M`` then refused:
"LOG is already in the map"). :func:`note_committed` is called right after the rename (with
interrupts held across both); the command line reads :func:`committed_outputs` when it
reports an interruption and clears the record when a command starts.
"""

from __future__ import annotations

import os
from pathlib import Path

_COMMITTED: list[Path] = []


def note_committed(path: str | os.PathLike[str]) -> None:
    """Record that ``path`` now holds this command's complete output."""
    _COMMITTED.append(Path(path))


def committed_outputs() -> list[Path]:
    """The outputs moved into place since :func:`forget_committed`, in order."""
    return list(_COMMITTED)


def forget_committed() -> None:
    """Start a new command's record."""
    _COMMITTED.clear()
