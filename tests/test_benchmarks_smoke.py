"""Smoke test of the benchmarks: every module's ``run()`` works at a minimal size.

No timing assertions (speed is measured by ``make bench``, never asserted in tests): only that
each section runs end to end and returns well-formed rows, so the benchmarks do not rot while
the code they measure changes.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def _rows_ok(rows: list[dict[str, object]]) -> None:
    assert rows
    for row in rows:
        assert isinstance(row, dict)
        json.dumps(row, default=float)


def test_ingest_small() -> None:
    from benchmarks import bench_ingest

    rows = bench_ingest.run(detections=3000, repeats=1, rosbags_messages=20)
    _rows_ok(rows)
    assert rows[0]["detections"] >= 3000
    assert rows[0]["build_vs_raw"] > 0


def test_fremen_small() -> None:
    from benchmarks import bench_fremen

    _rows_ok(bench_fremen.run(sizes=(100,)))


def test_engine_and_queries_small() -> None:
    from benchmarks import bench_engine

    row = bench_engine.measure(5000, windows=2, repeats=1)
    assert row["detections"] == 5000
    assert row["bound_cells"] > 0  # the warm-up graph binds cells
    _rows_ok(bench_engine.run_queries(n_entries=300, export_nodes=50, plan=False, repeats=1,
                                      times=2))


def test_memory_small() -> None:
    from benchmarks import bench_memory

    rows = bench_memory.run(scale=0.001, envs=("building",), graphs=(True,), check_dense=False)
    _rows_ok(rows)
    (building,) = rows
    assert building["dense_cells"] == 5 * 211**2  # five floors of 103 m (+ margins) at 0.5 m
    assert building["peak_above_base_bytes"] > 0
    assert bench_memory.dense_cells("campus") > 4_000_000  # 1 km^2 at 0.5 m


def test_scaling_small(tmp_path: Path) -> None:
    from benchmarks import bench_scaling

    png = tmp_path / "scaling.png"
    rows = bench_scaling.run(det_sizes=(2000, 4000), entry_sizes=(50, 100),
                             entry_detections=2000, png=png)
    _rows_ok(rows)
    assert png.stat().st_size > 0
    assert {r["series"] for r in rows if "slopes" in str(r["name"])} == {"detections", "entries"}


def test_runner_quick_only(tmp_path: Path) -> None:
    from benchmarks import run

    out = tmp_path / "r.json"
    assert run.main(["--quick", "--only", "fremen", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["machine"]["cores"] >= 1
    assert data["summary"]
    assert "fremen" in data["results"]
