"""Suite-wide checks: the third parties' data the tests read is left exactly as it was.

``../shared/data`` is read-only by permission, but a test running as root can still write
there (an SQLite reader opened with ``mode=ro`` alone left ``-wal`` / ``-shm`` files beside a
rosbag2 bag). The run lists every file's size and modification time before the first test and
after the last, and fails, naming the paths, when anything was added, removed or changed.
A run that inherits SIGINT ignored takes Python's Ctrl-C handler back (:func:`pytest_configure`).
Property tests run without hypothesis's 200 ms deadline per example: an example that builds a
map or decodes a log takes longer on a loaded machine, and the deadline then failed a test
whose every example held (``tests/formats/test_recorded_windows.py``, once under load).
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from hypothesis import settings

from tests.shared_data import SHARED_DATA

settings.register_profile("aion", deadline=None)
settings.load_profile("aion")

_SNAPSHOT = pytest.StashKey[dict[str, tuple[int, int]]]()


def tree_snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """``relative path -> (size, mtime ns)`` of every file and folder under ``root`` (empty
    when it does not exist)."""
    out: dict[str, tuple[int, int]] = {}
    if not root.is_dir():
        return out
    for folder, dirs, files in os.walk(root):
        for name in [*dirs, *files]:
            path = Path(folder, name)
            st = path.lstat()
            size = 0 if path.is_dir() else st.st_size
            out[str(path.relative_to(root))] = (size, st.st_mtime_ns)
    return out


Snapshot = dict[str, tuple[int, int]]


def changed_paths(before: Snapshot, after: Snapshot) -> list[str]:
    """Paths added, removed or changed between two snapshots, sorted."""
    keys = set(before) | set(after)
    return sorted(k for k in keys if before.get(k) != after.get(k))


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C raises KeyboardInterrupt, whoever started the run. A run started in the
    background by a script (``pytest &``, some CI agents) inherits SIGINT ignored, and Python
    leaves an ignored SIGINT ignored, in itself and in every aion it starts: the tests of what
    a Ctrl-C does then sent one that nothing received and failed (test_interrupts,
    test_parallel_build). A SIGINT the run catches is the default again in a child process."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_sessionstart(session: pytest.Session) -> None:
    session.stash[_SNAPSHOT] = tree_snapshot(SHARED_DATA)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    before = session.stash.get(_SNAPSHOT, None)
    if before is None:
        return
    changed = changed_paths(before, tree_snapshot(SHARED_DATA))
    if not changed:
        return
    more = f" and {len(changed) - 10} more" if len(changed) > 10 else ""
    shown = ", ".join(changed[:10]) + more
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    message = f"the tests changed the shared data under {SHARED_DATA}: {shown}"
    if reporter is not None:
        reporter.write_line(f"ERROR: {message}", red=True)
    else:
        print(f"ERROR: {message}")
    session.exitstatus = pytest.ExitCode.TESTS_FAILED
