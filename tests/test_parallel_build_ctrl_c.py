"""Ctrl-C during ``aion build --workers N``: every worker stopped, quietly, the map as before,
also when the Ctrl-C reaches the workers as they start (a terminal's SIGINT goes to the whole
process group) and on a loaded machine (stop 66's flake)."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.test_parallel_build import _build


def _running(pid: int) -> bool:
    """Whether process ``pid`` is alive (exists and is not a zombie), from /proc."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


def _children(pid: int) -> list[int]:
    """Live processes whose parent is ``pid`` (from /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                out.append(int(entry.name))
    return out


_CLI_WITHOUT_BREAKS = (
    "import aion_cli.shard_graphs as g; "
    "g.graph_breaks = lambda groups, *_: [False] * (len(groups) - 1); "
    "from aion_cli.cli.main import main; main()"
)
"""``aion`` in a process whose planner tells no session boundary
(:func:`tests.test_parallel_build._no_breaks`): the workers do start."""

_CLI_SLOW_WORKERS = (
    "import os, time, multiprocessing.util as u\n"
    "def hold(t):\n"
    "    at = os.path.join(os.environ['STARTING'], str(os.getpid()))\n"
    "    open(at, 'w').close()\n"
    "    while not os.path.exists(os.path.join(os.environ['STARTING'], 'go')):\n"
    "        t.sleep(0.01)\n"
    "    open(at + '.on', 'w').close()\n"
    "u.register_after_fork(time, hold)\n"
    + _CLI_WITHOUT_BREAKS
)
"""That ``aion``, whose forked workers, before they run ``process_pool._worker`` (in an
after-fork hook of ``multiprocessing``, which runs in the child before its target), make a
file named by their pid in the folder ``$STARTING``, wait for a file ``go`` there, and make
``<pid>.on``: held at the moment they still have the parent's signal handlers (a loaded
machine can make it as long)."""


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc to list child processes")
@pytest.mark.parametrize("early", [False, True], ids=["running", "terminal-as-they-start"])
def test_ctrl_c_stops_every_worker_and_keeps_the_previous_map(
    tmp_path: Path, early: bool
) -> None:
    # early: Ctrl-C in a terminal (SIGINT to the process group: the workers too) while the
    # workers are still starting (_CLI_SLOW_WORKERS); they raised KeyboardInterrupt by the
    # parent's handler and printed a traceback, and so did the parent's SIGTERM stopping them
    # at that moment (the flake of stop 66 on a loaded machine: SIGINT as the workers forked)
    logs = []
    for k in range(4):  # simulated patrols: seconds of work each
        log = tmp_path / f"sim{k}.mcap"
        subprocess.run(
            [sys.executable, "-m", "aion_cli", "simulate", "-o", str(log), "--days", "0.5",
             "--seed", str(k), "--start", f"2026-01-{5 + 2 * k:02d}", "-q"],
            check=True,
        )
        logs.append(log)
    out = tmp_path / "map.aion"
    _build(logs[:1], out, 1)
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    starting = tmp_path / "starting"
    starting.mkdir()
    proc = subprocess.Popen(  # (told no session boundary, so that the workers do start)
        [sys.executable, "-c", _CLI_SLOW_WORKERS if early else _CLI_WITHOUT_BREAKS, "build",
         *map(str, logs[1:]), "--map", str(out), "--workers", "2", "-q"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "STARTING": str(starting)},
    )
    try:
        # until the workers exist (or the build has ended without them): reading the logs before
        # can take long on a loaded machine, so the bound is only against a hang
        deadline = time.monotonic() + 300
        while len(_children(proc.pid)) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = _children(proc.pid)
        assert len(workers) >= 2, "the workers did not start"
        if early:  # Ctrl-C reaches both workers before their handlers are set (then the parent)
            while len(list(starting.iterdir())) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert sorted(int(f.name) for f in starting.iterdir()) == sorted(workers)
            for worker in workers:
                os.kill(worker, signal.SIGINT)
            (starting / "go").touch()
            while time.monotonic() < deadline and [
                w for w in workers if _running(w) and not (starting / f"{w}.on").exists()
            ]:
                time.sleep(0.05)
        went_on = [w for w in workers if not early or (starting / f"{w}.on").exists()]
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert went_on == workers, f"a worker ended at the Ctrl-C it had as it started: {err}"
        assert proc.returncode == 130, err
        # the workers end quietly: only the parent's error and hint (a worker interrupted as it
        # started printed "Process ForkProcess-2:" and a traceback, cut short or not)
        lines = [line for line in err.splitlines() if line.strip()]
        assert lines[0].startswith("error: interrupted"), err
        assert all(line.startswith("hint: ") for line in lines[1:]), err
    finally:  # not left building if an assertion failed
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert hashlib.sha256(out.read_bytes()).hexdigest() == before
    # the workers are gone too: the parent has exited, so an orphan would have a new parent
    # (init or a subreaper) and be looked up by its own pid
    deadline = time.monotonic() + 10
    while [w for w in workers if _running(w)] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert [w for w in workers if _running(w)] == []
    assert not list(tmp_path.glob("*.tmp*"))
