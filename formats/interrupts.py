"""Holding Ctrl-C, SIGTERM and SIGHUP back for a few statements: :func:`interrupts_held`.

A temporary file is created and then named in two steps, a C library initialises, a file is
renamed into place and recorded as such: an interrupt between two such steps would leave
something behind that nobody removes (or a half-initialised library). The block runs whole,
and the signal acts right after it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from typing import Any

# SIGHUP too: the command line makes it unwind like SIGTERM (aion_cli/cli/entry.py), so it
# interrupts a block as they do (it left the temporary map of a build behind)
_HELD_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


@contextlib.contextmanager
def interrupts_held(forks: bool = False) -> Iterator[None]:
    """Hold SIGINT, SIGTERM and SIGHUP back for the block; delivered (and raising) right after.

    Creating a temporary file or folder and learning its name are two steps; an interrupt
    between them would leave something nobody removes. A C library's initialisation (open3d's
    import) must not be cut short either. In the main thread the Python handlers are replaced
    by one that only notes the signal (blocking it in this thread is not enough: the kernel
    delivers a process signal to any thread that does not block it, a progress bar's thread
    say, and Python then raises it in the main thread all the same); the noted signal goes to
    the previous handler after the block. Elsewhere (or where a handler was installed by C
    code, which Python cannot put back) the signals are blocked in this thread.

    ``forks``: processes are forked in the block (a parallel build's workers). They are
    blocked in this thread too, so that a child starts with them blocked (a fork inherits the
    thread's mask, not the signals pending) until :func:`release_held_signals`, once its own
    handlers are in place: a Ctrl-C or SIGTERM that reaches it first acts then, as its new
    handlers say, not as the parent's handlers it was forked with (which raised
    KeyboardInterrupt in the worker and printed its traceback).
    """
    main = threading.current_thread() is threading.main_thread()
    if main and all(signal.getsignal(held) is not None for held in _HELD_SIGNALS):
        with _handlers_held(), (_signals_masked() if forks else contextlib.nullcontext()):
            yield
        return
    with _signals_masked():
        yield


def release_held_signals() -> None:
    """Unblock SIGINT, SIGTERM and SIGHUP in this thread: in a process forked inside
    ``interrupts_held(forks=True)``, once its handlers are set (a signal pending acts now)."""
    with contextlib.suppress(AttributeError, OSError, ValueError):  # no pthread_sigmask
        signal.pthread_sigmask(signal.SIG_UNBLOCK, set(_HELD_SIGNALS))


@contextlib.contextmanager
def _handlers_held() -> Iterator[None]:
    """:func:`interrupts_held` in the main thread: note the signals, deliver them afterwards."""
    noted: list[int] = []

    def note(signum: int, frame: object) -> None:
        noted.append(signum)

    previous: dict[int, Any] = {}
    try:
        for held in _HELD_SIGNALS:
            previous[held] = signal.signal(held, note)
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if noted:
            _deliver(noted[0], previous[noted[0]])


def _deliver(signum: int, handler: Any) -> None:
    """Act on a noted signal as ``handler`` (what ``signal.signal`` returned) would have."""
    if callable(handler):
        handler(signum, None)  # Python's default_int_handler raises KeyboardInterrupt
    elif handler == signal.SIG_DFL:
        os.kill(os.getpid(), signum)  # the default action (the handler is back in place)


@contextlib.contextmanager
def _signals_masked() -> Iterator[None]:
    """:func:`interrupts_held` outside the main thread (or for the processes forked in the
    block): block the signals in this thread."""
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, ())  # the mask now (runs pending handlers)
    except (AttributeError, OSError, ValueError):  # no pthread_sigmask on this platform
        yield
        return
    try:  # a handler that raises *inside* this call must not leave the two signals blocked
        signal.pthread_sigmask(signal.SIG_BLOCK, set(_HELD_SIGNALS))
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        raise
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
