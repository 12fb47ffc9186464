"""The console script's entry point (``aion = aion_cli.cli.entry:main``).

Loading the command line (click, rich, the commands' modules) takes 0.2-0.5 s; a Ctrl-C in
that time used to print a KeyboardInterrupt traceback from the middle of an import, and a
SIGTERM killed the process without a word. Both are now what they are once a command runs:
``error: interrupted``, exit 130; so is SIGHUP, unless ignored (``nohup``). This module imports
nothing heavy itself.
"""

from __future__ import annotations

import signal
import sys
from types import FrameType


def _terminated(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def hangup_unwinds() -> None:
    """SIGHUP (the terminal or ssh session closed) unwinds like SIGTERM, so a build loses only
    its temporary map and lock (its default action killed the process and left both behind);
    not where it is ignored (``nohup aion build ...``): that run goes on."""
    hangup = getattr(signal, "SIGHUP", None)  # none on Windows
    if hangup is not None and signal.getsignal(hangup) is signal.SIG_DFL:
        signal.signal(hangup, _terminated)


def main() -> None:
    """Load the command line, then run it (:func:`aion_cli.cli.main.main`)."""
    signal.signal(signal.SIGTERM, _terminated)
    hangup_unwinds()
    try:
        from aion_cli.cli.main import main as run
    except KeyboardInterrupt as exc:
        from aion_cli.cli.errors import quiet_finalizers, report

        code = report(exc, False)
        quiet_finalizers()  # a module stopped half-way may fail again as it is freed
        sys.exit(code)
    run()
