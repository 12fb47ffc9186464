"""What ``aion predict`` imports: no scipy module that costs a query most of its time.

Issue 15 asks queries to answer at once. Two of scipy's modules cost more than the rest of a
query: ``scipy.spatial`` (a KD-tree for the robot's coverage of the open window, which a
query of a patrolled map closes as a build would; ~0.4 s CPU) and ``scipy.stats`` (the count
quantiles of flow_p10 / flow_p90 for more than 1,000 rows; ~0.9 s). Both are computed with
numpy now (``engine.sensor_reach``, ``engine.temporal.quantiles``; their answers are tested
against scipy's in tests/engine/test_sensor_reach.py and test_count_quantiles.py). Each test
runs the command in a fresh interpreter and lists the modules it had imported when it exited.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from tests.cli.atc_sessions import convert_atc
from tests.cli.conftest import run

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


def _crowded_tracks(path: Path) -> Path:
    """ATC rows (time s, id, x, y, speed, angle): 40 people a minute apart, each walking 40 m
    along a line of its own (y = 2 k m) at 1 m/s, a row a second, on 2026-11-23 from 08:00:
    1,600 cells of 0.5 m, more than quantiles' old limit of 1,000 rows."""
    t0 = datetime(2026, 11, 23, 8, 0, tzinfo=UTC).timestamp()
    rows = [
        f"{t0 + k * 60 + i:.3f},{k + 1},{-20.0 + i:.3f},{2.0 * k:.3f},1.0,0.0"
        for k in range(40)
        for i in range(40)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_a_full_json_of_more_than_a_thousand_rows_imports_no_scipy_stats(
    tmp_path: Path,
) -> None:
    log = tmp_path / "crowd.mcap"
    convert_atc(_crowded_tracks(tmp_path / "crowd.csv"), log)
    out = tmp_path / "crowd.aion"
    result = run("build", log, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    text, modules = _predict(out, "--format", "json", "-q", "--time", "2026-11-23 08:30")
    entries = json.loads(text)["entries"]
    assert len(entries) > 1000
    p90 = np.array([e["flow_p90"] for e in entries], dtype=float)
    assert np.isfinite(p90).all()  # the bands are there
    assert (p90 > 0).any()
    assert [m for m in SLOW if m in modules] == []


def test_the_engine_tables_quantiles_import_no_scipy_stats(sample_map: Path) -> None:
    """``EntryTable.flow_quantile`` (the engine's own bands, docs/CONTRACTS.md) of every
    entry: the numpy route too, with scipy's numbers (tests/engine/test_query.py)."""
    code = (
        "import sys\n"
        "from aion_cli.engine.query import predict_table\n"
        "from aion_cli.mapquery import load_map\n"
        "table = predict_table(load_map(sys.argv[1]).state, 1_767_960_000 * 10**9)\n"
        "p90 = table.flow_quantile(0.9)\n"
        "print(len(p90), int((p90 >= 0).sum()), 'scipy.stats' in sys.modules)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(sample_map)], capture_output=True,
                          text=True, check=True)
    rows, known, imported = proc.stdout.split()
    assert int(rows) == int(known) > 100  # every entry's band, none unknown
    assert imported == "False"


def test_top_ten_imports_neither_numpy_ma_nor_the_other_commands(sample_map: Path) -> None:
    """``aion predict`` loads its own command only (the others' modules are imported when
    they run: ``cli.main.COMMANDS``) and never ``numpy.ma``, which ``np.unique``'s first call
    imports (``engine.grouping.distinct`` instead): about 0.1 s of a 1 s query (issue 15)."""
    out, modules = _predict(sample_map, "--top", "10", "-q", "--time", "2026-01-09 12:00")
    assert "predicted flows at" in out, out
    assert "aion_cli.cli.predict" in modules
    others = ("aion_cli.cli.build", "aion_cli.cli.evaluate", "aion_cli.cli.simulate",
              "aion_cli.cli.report", "aion_cli.cli.export", "aion_cli.cli.plan", "numpy.ma")
    assert [m for m in others if m in modules] == []
    _, csv_modules = _predict(sample_map, "--top", "10", "--format", "csv",
                              "--time", "2026-01-09 12:00")
    assert "numpy.ma" not in csv_modules

