"""Ctrl-C and SIGTERM at awkward moments: one ``error: interrupted`` line, exit 130, and what
the message says about the output is true. The interruption is injected (a function raises
KeyboardInterrupt, or a signal is sent to this process while it is held), never timed.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import signal
import sys
import threading
import time
from types import ModuleType

import pytest


class _FakeOpen3d(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports a stand-in ``open3d`` whose initialisation is hit by a Ctrl-C that the kernel
    hands to another thread of the process (a progress bar's, say), as it may: Python then
    raises KeyboardInterrupt in the main thread, whatever that thread's signal mask."""

    def __init__(self, other: threading.Thread) -> None:
        self.other = other

    def find_spec(self, name: str, path: object, target: object = None) -> object:
        if name != "open3d":
            return None
        return importlib.machinery.ModuleSpec(name, self)

    def create_module(self, spec: object) -> None:
        return None

    def exec_module(self, module: ModuleType) -> None:
        assert self.other.ident is not None
        signal.pthread_kill(self.other.ident, signal.SIGINT)
        for _ in range(10_000):  # bytecode, where a pending Python handler runs
            pass
        time.sleep(0.01)
        module.ready = True  # type: ignore[attr-defined]


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX threads")
def test_ctrl_c_during_the_open3d_import_waits_for_the_import(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Before: a Ctrl-C inside open3d's C++ initialisation (the first 0.4 s of a PLY/PCD
    export) became ``ImportError: initialization failed``; the half-initialised library then
    printed its memory statistics on stdout at exit and the process exited 1, not 130."""
    from aion_cli.formats import export

    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    real = sys.modules.pop("open3d", None)
    try:
        monkeypatch.setattr(sys, "meta_path", [_FakeOpen3d(other), *sys.meta_path])
        with pytest.raises(KeyboardInterrupt):
            export.open3d()
        fake = sys.modules["open3d"]
    finally:
        stop.set()
        other.join()
        sys.modules.pop("open3d", None)  # later tests import the real one
        if real is not None:
            sys.modules["open3d"] = real
    assert fake.ready  # the import finished; the Ctrl-C was raised after it
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # handler restored
