"""What ``aion predict`` imports: no scipy module that costs a query most of its time.

Issue 15 asks queries to answer at once. ``scipy.spatial`` costs more than the rest of a
query (a KD-tree for the robot's coverage of the open window, which a query of a patrolled
map closes as a build would; ~0.4 s CPU); that coverage is computed with numpy now
(``engine.sensor_reach``; its answers are tested against the tree's in
tests/engine/test_sensor_reach.py). scipy.stats is checked too. Each test runs the command
in a fresh interpreter and lists the modules it had imported when it exited.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SLOW = ("scipy.spatial", "scipy.stats")


_RUN = (
    "import atexit, runpy, sys\n"
    "atexit.register(lambda: sys.stderr.write('\\nMODULES ' + ' '.join(sys.modules) + '\\n'))\n"
    "sys.argv = ['aion', *sys.argv[1:]]\n"
    "runpy.run_module('aion_cli', run_name='__main__')\n"
)


def _predict(*args: str | Path) -> tuple[str, set[str]]:
    """``aion predict ARGS`` in a fresh interpreter: its stdout and every module it had
    imported when it exited."""
    proc = subprocess.run(
        [sys.executable, "-c", _RUN, "predict", *map(str, args)],
        capture_output=True, text=True, env={**os.environ, "TZ": "UTC"}, timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    listed = [line for line in proc.stderr.splitlines() if line.startswith("MODULES ")]
    assert len(listed) == 1, proc.stderr[-3000:]
    modules = set(listed[0].split()[1:])
    assert "numpy" in modules  # the list is there
    return proc.stdout, modules


def test_top_ten_of_a_patrolled_map_imports_no_kd_tree(sample_map: Path) -> None:
    from aion_cli.mapquery import load_map

    # the query measures the robot's coverage: an open window with poses of the robot in it
    state = load_map(sample_map).state
    assert state.open_window is not None
    window_ns = state.window_ns
    t = state.observation.pose_t
    in_open = (t >= state.open_window * window_ns) & (t < (state.open_window + 1) * window_ns)
    assert in_open.any()
    assert state.observation.merged_fixed()[0].size == 0  # no fixed sensor covers it
    out, modules = _predict(sample_map, "--top", "10", "-q", "--time", "2026-01-09 12:00")
    assert "predicted flows at" in out, out
    assert [m for m in SLOW if m in modules] == []
