"""Smoke test of the benchmarks: every module's ``run()`` works at a minimal size.

No timing assertions (speed is measured by ``make bench``, never asserted in tests): only that
each section runs end to end and returns well-formed rows, so the benchmarks do not rot while
the code they measure changes.
"""

from __future__ import annotations

import json
import sys
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


def test_temporal_small() -> None:
    """Both sizes run; the per-entry loops compute what the vectorised model computes (the
    baselines measure the same work), and the counts are as sparse as documented."""
    from benchmarks import bench_temporal

    rows = bench_temporal.run(sizes=(100, 300), days=2)
    _rows_ok(rows)
    for row, size in zip(rows, (100, 300), strict=True):
        assert row["entries"] == row["timed_entries"] == size
        assert row["windows"] == 2 * 144
        assert row["updates"] == size * row["values"] * row["windows"]
        assert 0.1 < row["count_fraction"] < 0.3
        assert row["loop_max_abs_error"] < 1e-6
        assert row["loop_predict_max_abs_error"] < 1e-9
        assert sum(row["flow_families"].values()) == size
        assert row["updates_per_s"] > 0
        assert row["predictions_per_s"] > 0


def test_temporal_large_size_times_a_subset(monkeypatch: pytest.MonkeyPatch) -> None:
    from benchmarks import bench_temporal

    monkeypatch.setattr(bench_temporal, "POPULATION_CAP", 50)
    (row,) = bench_temporal.run(sizes=(1000,), days=1)
    assert (row["entries"], row["timed_entries"]) == (1000, 50)
    assert row["updates"] == 50 * row["values"] * 144


def test_engine_and_queries_small() -> None:
    from benchmarks import bench_engine

    row = bench_engine.measure(5000, windows=2, repeats=1)
    assert row["detections"] == 5000
    assert row["bound_cells"] > 0  # the warm-up graph binds cells
    sketch = bench_engine.sample_all(bench_engine.batches(5000, 2))
    assert sketch.detections == 5000  # every detection of the batches sampled
    assert row["sketch_vs_ingest"] > 0
    queries = bench_engine.run_queries(n_entries=300, export_nodes=50, plan=False, repeats=1,
                                       times=2)
    _rows_ok(queries)
    names = [str(r["name"]) for r in queries]
    assert any(n.startswith("first predict_table") for n in names)
    assert any(n.startswith("batched Predictor.pairs") for n in names)


def test_query_map_has_a_mature_temporal_state() -> None:
    """The query benchmark's map: two weeks of history before its window, so forecasts use
    scored families and admitted periods (not a map of one window)."""
    from benchmarks import bench_engine

    state = bench_engine.build_state(300)
    live = state.entries.live_rows()
    assert state.pending  # its own window waits in the pending day, as after a build
    assert state.temporal.glob.n[0] == 14 * 144  # fixed-sensor history windows
    assert (state.temporal.flow_scored[live] > 0).all()
    rows, predictor = state.predictor()
    assert rows.size == live.size
    assert predictor.forecaster.observed.all()


def test_places_map_small(tmp_path: Path) -> None:
    """The export-at-scale map of docs/BENCHMARKS.md (``write_places_map``), small: a map a
    command reads, one place entry per graph place on the corridors."""
    from benchmarks import bench_build_scale

    path = tmp_path / "places.aion"
    made = bench_build_scale.write_places_map(60.0, 14.0, path)
    assert made["places"] > 10
    assert made["entries"] >= made["places"]
    import aion_cli as aion

    m = aion.Map.load(path)
    assert len(m.predict("2023-11-16 12:00", layer="places", tz="UTC")) == made["places"]


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
    assert run.main(["--quick", "--only", "temporal", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["machine"]["cores"] >= 1
    assert {r["section"] for r in data["summary"]} == {"temporal"}
    assert len(data["summary"]) == 3
    (row,) = data["results"]["temporal"]
    assert row["entries"] == 1000


def test_build_small() -> None:
    """Issue 15's section at tiny sizes: every part runs and its rows hold what the runner's
    summary reads; the generated logs hold what was asked (counts read back by the build)."""
    from benchmarks import bench_build, bench_build_scale, run

    ratio = bench_build.run_ratio(per_messages=(3,), messages=200, days=1, repeats=1)
    (r,) = ratio
    assert r["messages"] == 200 + r["graph_messages"]  # every 10 min a graph, nothing skipped
    assert r["graph_messages"] > 0
    assert r["nodes"] > 0
    assert r["detections"] == r["detections_used"] >= 200  # 1 + Poisson(2) people a message
    assert r["build_vs_raw"] > 0
    graphs = bench_build.run_graphs(places=40, seconds=5.0)
    (g,) = graphs
    assert g["graph_messages_in_log"] == 5
    # --graph-period's default (5 s) thins five 1-Hz graphs to the first and the last
    assert 2 <= g["graph_messages_used"] <= 5
    assert g["nodes"] == g["places"] == 40
    assert g["detections"] >= 50
    # the build reading graphs as before the numpy readers, and both decode paths per graph
    assert g["build_spark_dsg_s"] > 0
    assert g["decode_dsg_s_per_graph"] > 0
    assert g["decode_dsg_spark_s_per_graph"] > 0
    assert g["payload_fast_s_per_graph"] > 0
    maps = bench_build_scale.run_map(sizes=(200,), repeats=1)
    size, compact, predict, info, predict_compact = maps
    assert size["entries"] > 150
    assert sum(size["bytes_per_entry_by_kind"].values()) * size["entries"] <= size["map_bytes"]
    assert compact["entries"] == size["entries"]
    assert compact["map_bytes"] < size["map_bytes"]  # the Fourier sums left out
    assert compact["vs_full_map"] == pytest.approx(size["map_bytes"] / compact["map_bytes"])
    assert predict["seconds"] > 0
    assert predict["cpu_s"] > 0  # the children's rusage
    assert predict["help_cpu_s"] > 0
    assert info["seconds"] > 0
    assert predict_compact["same_answer"]  # the query-only map's top 10 is the map's
    memory = bench_build_scale.run_memory(sizes_gb=(0.002, 0.004))
    assert memory[0]["peak_rss_bytes"] > memory[0]["base_rss_bytes"] > 0
    assert memory[-1]["name"] == "stream memory fit"
    assert memory[-1]["extrapolated"]
    rows = ratio + graphs + maps + memory
    _rows_ok(rows)
    table = run.summary({"build": rows})
    assert {t["section"] for t in table} == {"build"}
    # build, graph share + its floor, map size (full, query-only), predict (both), info, memory
    assert len(table) == 9
    assert [t["met"] for t in table][-1] is None  # memory not judged below 1 GB of log


def test_build_samples_small() -> None:
    """``bench_build --sample``: the stacks of a tiny build, sampled, name the build's own
    functions among the main thread's, with shares of its samples."""
    from benchmarks.build_logs import ratio_log
    from benchmarks.build_profile import sample_build

    text = sample_build(ratio_log(3, 200, 1))
    main = text.split("## main thread, inclusive\n")[1].split("##")[0].splitlines()
    assert any(line.endswith("pipeline.py:build_map") for line in main)
    shares = [float(line.split("%")[0]) for line in main]
    assert shares == sorted(shares, reverse=True)
    assert all(0 < share <= 100 for share in shares)


def test_time_shards_small() -> None:
    """Issue 17's time-shard row at a tiny size: the one-day log is cut in two and the
    2-worker build gives the sequential build's map."""
    from benchmarks import bench_parallel, run

    row = bench_parallel.run_time_shards(200, 1, repeats=1)
    assert row["same_map"]
    assert row["shards"] == 2
    assert row["shards_learnt_in_sequence"] == 0
    assert len(row["cuts"]) == 1
    _rows_ok([row])
    (line,) = run.summary({"parallel": [row]})
    assert "same map: True" in line["vs"]


def test_hydra_small() -> None:
    """Issue 17's live-Hydra row at a tiny size: two simulated sessions of 72 minutes whose
    graphs reuse node ids at other places, built with two workers. The second session's first
    graph lacks places of the first's last, so the planner keeps them together and builds
    them in sequence: no worker, the map of one pass (a join of the two had differed in the
    stability timers of nodes both sessions hold). The row says so."""
    from benchmarks import bench_parallel, run

    row = bench_parallel.run_hydra(2, 0.05, repeats=1)
    assert row["graph_messages"] > 0
    assert row["shards_built_by_workers"] == 0
    assert len(row["kept_together"]) == 1
    assert row["differences"] == []
    assert row["same_map"] is True
    _rows_ok([row])
    (line,) = run.summary({"parallel": [row]})
    assert "same map: True" in line["vs"]
    assert "sessions kept together" in line["vs"]


def test_hydra_logs_make_the_work_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a fresh checkout (no ``benchmarks/_work``) the Hydra section's logs are simulated
    into a folder it makes: simulate no longer makes the folders above its output, and the
    section, run alone (``test_hydra_small``), failed on the missing folder."""
    from benchmarks import bench_parallel

    monkeypatch.setattr(bench_parallel, "WORK", tmp_path / "_work")
    (log,) = bench_parallel.hydra_logs(1, 0.01)
    assert log.parent == tmp_path / "_work"
    assert log.is_file()


def test_fleet_merge_small() -> None:
    """``aion merge`` of two fixed-sensor maps of different areas, timed in a child."""
    from benchmarks import bench_fleet_merge

    rows = bench_fleet_merge.run(maps=(2,), repeats=1)
    _rows_ok(rows)
    assert rows[0]["maps"] == 2
    assert rows[0]["this_peak_mb"] > 0


def test_fleet_merge_robot_small() -> None:
    """``--kind robot``: two simulated robot maps of the office, with scene graphs of one
    session (the merge adds their nodes by id), on disjoint days, merged in a child."""
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import load_map_head
    from benchmarks import bench_fleet_merge

    rows = bench_fleet_merge.run(maps=(2,), repeats=1, kind="robot")
    _rows_ok(rows)
    assert rows[0]["maps"] == 2
    early, late = (load_map_head(p) for p in bench_fleet_merge.robot_maps(2))
    for head in (early, late):
        assert head.graph is not None
        assert head.graph.places.ids.size > 100
    first, second = (Manifest.from_dict(head.manifest) for head in (early, late))
    assert first.end_ns is not None
    assert second.start_ns is not None
    assert first.end_ns < second.start_ns


def test_fleet_merge_areas_small() -> None:
    """``--kind areas``: two simulated robot maps of areas of their own, whose places one
    session numbered on (no node id shared), merged with ``--lineage same`` in a child."""
    from aion_cli.mapquery import load_map_head
    from benchmarks import bench_fleet_merge

    rows = bench_fleet_merge.run(maps=(2,), repeats=1, kind="areas")
    _rows_ok(rows)
    early, late = (load_map_head(p).graph for p in bench_fleet_merge.area_maps(2))
    assert early is not None
    assert late is not None
    assert early.places.ids.size > 40
    assert not set(early.places.ids.tolist()) & set(late.places.ids.tolist())
    assert early.places.xyz[:, 0].max() < late.places.xyz[:, 0].min()


def test_fleet_merge_times_compiled_checkouts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A checkout given to ``--against`` is byte-compiled before its merges are timed: with
    ``PYTHONDONTWRITEBYTECODE`` set (as on this machine) a fresh worktree compiled every
    module in every timed child, about 0.15 s counted as the merge's (0.79 vs 1.12 s CPU for
    the same code at 5 robot maps)."""
    from benchmarks import bench_fleet_merge

    other = tmp_path / "other"
    for package in ("aion_cli", "formats"):
        (other / package).mkdir(parents=True)
        (other / package / "__init__.py").write_text("")
        (other / package / "part.py").write_text("X = 1\n")
    compiled: dict[Path, list[str]] = {}

    def merge_cost(
        checkout: Path, maps: list[Path], options: list[str] | None = None
    ) -> tuple[float, int]:
        compiled[checkout] = sorted(p.stem for p in checkout.glob("*/__pycache__/*.pyc"))
        return 1.0, 1

    monkeypatch.setattr(bench_fleet_merge, "merge_cost", merge_cost)
    monkeypatch.setitem(bench_fleet_merge.MAKERS, "cells", lambda n: [tmp_path / "a.aion"] * n)
    bench_fleet_merge.run(maps=(2,), repeats=1, against=other)
    tag = sys.implementation.cache_tag
    assert compiled[other] == [f"__init__.{tag}", f"__init__.{tag}", f"part.{tag}", f"part.{tag}"]
