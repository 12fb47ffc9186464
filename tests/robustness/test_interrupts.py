"""Ctrl-C and SIGTERM at awkward moments: one ``error: interrupted`` line, exit 130, and what
the message says about the output is true. The interruption is injected (a function raises
KeyboardInterrupt, or a signal is sent to this process while it is held), never timed.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import signal
import sys
import threading
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from tests.robustness.conftest import Office, assert_one_error, run, walk, write_log


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


# -- an interruption after the output was moved into place --------------------------------------


def _interrupt(*args: Any, **kw: Any) -> None:
    raise KeyboardInterrupt


def test_ctrl_c_after_the_map_was_replaced_says_it_was_written(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: a Ctrl-C after the continued map was renamed into place (while its folder was
    fsync'd, or the summary printed) said "an existing output is left unchanged; rerun the
    command to finish"; the map had been replaced, and the rerun refused ("already in the
    map")."""
    from aion_cli.formats import mapfile_write

    target = office.copy_map(tmp_path / "m.aion")
    before = target.read_bytes()
    second = write_log(tmp_path / "later.mcap", walk(1200, start_s=30 * 86400))
    with monkeypatch.context() as patch:
        patch.setattr(mapfile_write, "fsync_dir", _interrupt)
        result = run("build", second, "--map", target, "-o", target, "-q")
    assert result.exit_code == 130, result.stderr
    assert_one_error(result.stderr, "interrupted after", "m.aion was written")
    assert "left unchanged; rerun" not in result.stderr
    assert target.read_bytes() != before
    assert sorted(os.listdir(tmp_path)) == ["later.mcap", "m.aion"]  # no lock, no staging
    assert run("info", "--verify", target).exit_code == 0


def test_ctrl_c_before_the_map_was_replaced_says_it_is_unchanged(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The other side of the rename: the map as it was, and the message says so (also in a
    later command of the same process, which starts a new record)."""
    from aion_cli.formats import mapfile_write

    target = office.copy_map(tmp_path / "m.aion")
    before = target.read_bytes()
    second = write_log(tmp_path / "later.mcap", walk(1200, start_s=30 * 86400))
    with monkeypatch.context() as patch:
        patch.setattr(mapfile_write, "fsync_dir", _interrupt)
        assert run("compact", target, "-o", tmp_path / "q.aion").exit_code == 130
        patch.setattr(mapfile_write, "check_map_target", _interrupt)
        result = run("build", second, "--map", target, "-o", target, "-q")
    assert result.exit_code == 130, result.stderr
    assert_one_error(result.stderr, "interrupted")
    assert "left unchanged" in result.stderr
    assert "was written" not in result.stderr
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["later.mcap", "m.aion", "q.aion"]


def test_ctrl_c_after_a_staged_log_was_moved_in_says_it_was_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same for outputs written beside their target and renamed (``convert``, ``export``,
    ``report``, ``simulate``): ``formats.outputs.Staged``."""
    from aion_cli.formats import outputs

    tracks = Path(__file__).parents[1] / "data" / "atc" / "atc-1024-9_test.csv"
    out = tmp_path / "o.mcap"
    with monkeypatch.context() as patch:
        patch.setattr(outputs, "fsync_dir", _interrupt)
        result = run("convert", tracks, "--layout", "atc", "-o", out)
    assert result.exit_code == 130, result.stderr
    assert_one_error(result.stderr, "interrupted after", "o.mcap was written")
    assert os.listdir(tmp_path) == ["o.mcap"]
    assert run("info", out).exit_code == 0


# -- an interruption while the command line loads ---------------------------------------------


class _InterruptedImport(importlib.abc.MetaPathFinder):
    """Ctrl-C while ``aion_cli.cli.main`` (click, rich, the commands) is being imported."""

    def find_spec(self, name: str, path: object, target: object = None) -> object:
        if name == "aion_cli.cli.main":
            raise KeyboardInterrupt
        return None


def test_ctrl_c_while_the_command_line_loads_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: a Ctrl-C in the first 0.2-0.5 s of any command printed a KeyboardInterrupt
    traceback from inside an import (the console script imported everything before aion's
    error handling existed); a SIGTERM then killed it without a word."""
    from aion_cli.cli import entry

    previous = signal.getsignal(signal.SIGTERM)
    monkeypatch.delitem(sys.modules, "aion_cli.cli.main")
    monkeypatch.setattr(sys, "meta_path", [_InterruptedImport(), *sys.meta_path])
    try:
        with pytest.raises(SystemExit) as stop:
            entry.main()
        assert signal.getsignal(signal.SIGTERM) is entry._terminated  # SIGTERM unwinds too
    finally:
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = sys.__unraisablehook__
    assert stop.value.code == 130
    err = capsys.readouterr().err
    assert_one_error(err, "interrupted")


# -- what a writer killed with SIGKILL left ------------------------------------------------------


def test_a_killed_writers_temporary_map_is_removed_by_the_next_writer(
    office: Office, tmp_path: Path
) -> None:
    """Before: every SIGKILL mid-write left a hidden ``.m.aion.<random>.tmp`` (up to a map's
    size) for good; the stale lock was recovered, the file never. Only files of that exact
    pattern go: a staging file of another target and a file of the user's stay."""
    import socket
    import subprocess

    target = office.copy_map(tmp_path / "m.aion")
    gone = subprocess.Popen(["true"])  # a process that has exited: the lock's holder died
    gone.wait()
    (tmp_path / "m.aion.lock").write_text(f"{gone.pid} {socket.gethostname()}\n")
    orphan = tmp_path / ".m.aion.k7_x2q9a.tmp"
    orphan.write_bytes(b"PK\x03\x04 half a map")
    kept = [tmp_path / ".m.aion.x.abcdefgh.tmp", tmp_path / ".m.aion.notes.tmp"]
    for path in kept:
        path.write_text("not aion's to remove")
    result = run("compact", office.map, "-o", target, "-q")
    assert result.exit_code == 0, result.stderr
    assert not orphan.exists()
    assert sorted(os.listdir(tmp_path)) == sorted(["m.aion", *(p.name for p in kept)])


def test_a_ctrl_c_as_the_temporary_graph_file_is_made_leaves_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A spark_dsg payload is decoded through a temporary file: a Ctrl-C between its creation
    and the ``try`` that removes it left /tmp/aion-dsg-*.sparkdsg behind."""
    import tempfile

    from aion_cli.formats import dsg_payload

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    real = tempfile.mkstemp

    def interrupted(*args: Any, **kwargs: Any) -> tuple[int, str]:
        made = real(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)  # the user's Ctrl-C, right after the file exists
        return made

    monkeypatch.setattr(tempfile, "mkstemp", interrupted)
    with pytest.raises(KeyboardInterrupt):
        dsg_payload._load_with_header(b"\x00" * 16, "1.1.0")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_signal_as_the_temporary_map_file_is_made_leaves_no_file(
    sig: str, office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: a SIGHUP (terminal closed) landing right after the build's temporary map file
    was created, before its name was kept, left ``.m.aion.<random>.tmp`` behind: SIGHUP
    unwinds like SIGTERM but was not held back with Ctrl-C and SIGTERM. Now any of the three
    unwinds with the old map byte for byte and no temporary file or lock."""
    import tempfile

    import numpy as np

    from aion_cli.cli import entry
    from aion_cli.formats.mapfile import write_map

    signum = getattr(signal, sig, None)
    if signum is None:
        pytest.skip(f"no {sig} on this platform")
    target = office.copy_map(tmp_path / "m.aion")
    old = target.read_bytes()
    real = tempfile.mkstemp
    sent: list[str] = []

    def signalled(*args: Any, **kwargs: Any) -> tuple[int, str]:
        made = real(*args, **kwargs)
        sent.append(Path(made[1]).name)
        signal.raise_signal(signum)  # right after the file exists, before its name is kept
        return made

    monkeypatch.setattr(tempfile, "mkstemp", signalled)
    previous = signal.getsignal(signum)
    if signum != signal.SIGINT:  # as the console script installs them (entry.main)
        signal.signal(signum, entry._terminated)
    try:
        with pytest.raises(KeyboardInterrupt):
            write_map(target, {"x": np.arange(4)}, {})
    finally:
        signal.signal(signum, previous)
    assert len(sent) == 1  # the signal came once, after the file was made
    assert sent[0].startswith(".m.aion.")
    assert target.read_bytes() == old
    assert sorted(os.listdir(tmp_path)) == ["m.aion"]


def test_a_ctrl_c_as_the_map_lock_is_made_leaves_no_lock(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: a Ctrl-C right as ``m.aion.lock`` was created (before its pid was written and
    the ``try`` that removes it entered) left an empty lock behind, and the next build of the
    map was refused as "being written by another process (unknown)" for 10 s. Now the lock
    goes with the interrupt and the old map stays byte for byte."""
    import numpy as np

    from aion_cli.formats.mapfile import write_map

    target = office.copy_map(tmp_path / "m.aion")
    old = target.read_bytes()
    real = os.open
    made: list[str] = []

    def signalled(path: Any, *args: Any, **kwargs: Any) -> int:
        fd = real(path, *args, **kwargs)
        if str(path).endswith(".lock"):
            made.append(Path(path).name)
            signal.raise_signal(signal.SIGINT)  # right after the lock exists
        return fd

    monkeypatch.setattr(os, "open", signalled)
    with pytest.raises(KeyboardInterrupt):
        write_map(target, {"x": np.arange(4)}, {})
    monkeypatch.undo()
    assert made == ["m.aion.lock"]
    assert target.read_bytes() == old
    assert sorted(os.listdir(tmp_path)) == ["m.aion"]


@pytest.mark.skipif(not hasattr(os, "fork") or not hasattr(signal, "pthread_sigmask"),
                    reason="needs fork and pthread_sigmask")  # fmt: skip
def test_a_process_forked_with_interrupts_held_gets_them_once_its_handlers_are_set() -> None:
    """``interrupts_held(forks=True)`` (a parallel build starting its workers): a child forked
    in the block starts with SIGINT, SIGTERM and SIGHUP blocked, so a SIGTERM sent before its
    handlers are set waits, and acts by them (here the default: it ends) at
    ``release_held_signals``; the parent's mask is as before the block, and a Ctrl-C sent
    during the block raises right after it, once."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, ())
    read, write = os.pipe()
    pids: list[int] = []
    with pytest.raises(KeyboardInterrupt):
        _fork_with_interrupts_held(write, pids)
    os.close(write)
    _, status = os.waitpid(pids[0], 0)
    with os.fdopen(read, "rb") as said:
        assert said.read() == b"held"
    assert os.WIFSIGNALED(status)
    assert os.WTERMSIG(status) == signal.SIGTERM
    assert signal.pthread_sigmask(signal.SIG_BLOCK, ()) == before


def _fork_with_interrupts_held(write: int, pids: list[int]) -> None:
    """Fork a child inside ``interrupts_held(forks=True)`` (its pid into ``pids``) that sends
    itself SIGTERM, writes to ``write`` whether the signals were blocked, and releases them;
    then a Ctrl-C in the block."""
    from aion_cli.formats.interrupts import interrupts_held, release_held_signals

    with interrupts_held(forks=True):
        pid = os.fork()
        if pid == 0:  # the child: nothing but os calls, then os._exit
            code = 1
            try:
                blocked = signal.pthread_sigmask(signal.SIG_BLOCK, ())
                held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                os.kill(os.getpid(), signal.SIGTERM)  # pending, not acted on
                os.write(write, b"held" if held <= set(blocked) else b"not blocked")
                release_held_signals()  # the SIGTERM ends the child here
                os.write(write, b", lived on")
                code = 0
            finally:
                os._exit(code)
        pids.append(pid)
        signal.raise_signal(signal.SIGINT)  # noted, delivered after the block
