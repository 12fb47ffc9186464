"""``aion merge`` of many fixed-sensor maps of different areas (a fleet of wall trackers).

Map ``k`` (``k = 0 .. 39``) is built from one converted log (``aion convert``: a canonical CSV
with ``--observed``, as ``tests/cli/test_merge_fixed_sensors.py`` writes): on day ``k`` from
10:00 UTC for two hours, ``PEOPLE`` people walk 30 m along +x, one every 15 minutes, each
on their own line ``y = 2 m * person``, in an area of its own (``x`` from ``200 m * k``), so
no two maps share a cell. Each map holds about 1,200 cells and its pending day (two hours of
fixed-sensor windows).

``--kind robot``: map ``k`` is built from one ``aion simulate`` log of the paper's office
(seed ``k``, one day from midnight of the ``k``-th weekday from Monday 2026-01-05: the
office is empty at weekends, and a map needs detections; a patrolling robot with Hydra scene
graphs, six people), so the maps share the office's places (node ids the same: ``--lineage
auto`` takes them as one session) and their days are disjoint: a fleet of robot maps, about
150 node entries each.

``--kind areas``: map ``k`` is built from one ``aion simulate`` log of a patrolling robot
in an area of its own (:func:`area_graph`: 8 x 8 places 3 m apart from ``x = 100 m * k``,
numbered from ``p(1000 k)``, as one scene-graph session numbers the places of every area it
explores; six people, seed ``k``, one day from midnight of the ``k``-th weekday),
55-56 node entries and 8 to 177 cells each, merged with ``--lineage same`` (``auto``
calls maps that share no node id different sessions): the result grows with every map, and
each earlier map's places, gone from the later graph, are released to cells.

For each ``N`` in ``--maps`` (default 5, 10, 20, 40) the first ``N`` maps are merged by
``aion merge`` in a child process; reported: the child's CPU time (user + system) and peak
resident memory (``ru_maxrss``) from ``os.wait4``, best of ``--repeats`` (CPU) and the
largest peak. ``--aion`` picks the command (a checkout's ``.venv/bin/aion`` or ``python -m
aion_cli`` with ``PYTHONPATH`` of another checkout, for before/after figures; runs of the two
alternated by ``--against``; both byte-compiled first, :func:`compile_checkout`). Logs and
maps are written once under ``benchmarks/_work``.

Run: ``python -m benchmarks.bench_fleet_merge [--kind cells|robot|areas] [--maps 5 10 20 40]
[--against DIR]``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.common import ROOT, WORK, child_usage

S = 10**9
DAY0 = 1_767_607_200  # 2026-01-05 10:00 UTC, seconds
PEOPLE = 20
FOLDER = WORK / "fleet_merge"
ROBOT_FOLDER = WORK / "fleet_merge_robot"
AREAS_FOLDER = WORK / "fleet_merge_areas"
GRID = 8  # an area's places: GRID x GRID, 3 m apart
ID_STRIDE = 1000  # area k's places from p(1000 k): the simulated session adds places after them


def _aion(checkout: Path) -> tuple[list[str], dict[str, str]]:
    """``aion`` of the checkout ``checkout`` (this interpreter, its package first: run in
    the checkout, since ``python -m`` puts the working folder before ``PYTHONPATH``)."""
    return [sys.executable, "-m", "aion_cli"], {"PYTHONPATH": str(checkout)}


def compile_checkout(checkout: Path) -> None:
    """Byte-compile ``checkout``'s packages before timing it. With ``PYTHONDONTWRITEBYTECODE``
    set (as on this machine) a checkout that ``make install`` never compiled, such as a fresh
    worktree given to ``--against``, compiles every module it imports in every child: about
    0.15 s of CPU per ``aion`` run, counted as the merge's."""
    subprocess.run(
        [sys.executable, "-m", "compileall", "-q", "aion_cli", "formats"],
        cwd=checkout,
        check=True,
        stdout=subprocess.DEVNULL,
    )


def _run(cmd: list[str], env: dict[str, str]) -> tuple[float, int]:
    """(CPU seconds, peak RSS bytes) of one child, run in the folder ``env`` names."""
    code, err, usage = child_usage(cmd, env={**os.environ, **env}, cwd=env["PYTHONPATH"])
    if code != 0:
        raise RuntimeError(f"{shlex.join(cmd)} failed: {err}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss * 1024


def fleet_maps(n: int) -> list[Path]:
    """The first ``n`` maps (written once)."""
    FOLDER.mkdir(parents=True, exist_ok=True)
    cmd, env = _aion(ROOT)
    out = []
    for k in range(n):
        aion = FOLDER / f"area{k:02d}.aion"
        out.append(aion)
        if aion.exists():
            continue
        t0 = DAY0 + k * 86_400
        rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
        for p in range(PEOPLE):
            start = t0 + p * 360
            rows += [
                f"{(start + i) * S},{k * 100 + p + 1},{200 * k + i * 0.05:.2f},{2.0 * p:.1f},"
                "0.0,0.0,0.5"
                for i in range(600)
            ]
        csv = FOLDER / f"area{k:02d}.csv"
        csv.write_text("\n".join(rows) + "\n")
        log = csv.with_suffix(".mcap")
        span = f"{t0}..{t0 + 7200}"
        _run([*cmd, "convert", str(csv), "-o", str(log), "--observed", span, "-q", "--force"], env)
        _run([*cmd, "build", str(log), "-o", str(aion), "-q"], env)
    return out


def robot_maps(n: int) -> list[Path]:
    """The first ``n`` robot maps (simulated and built once)."""
    ROBOT_FOLDER.mkdir(parents=True, exist_ok=True)
    cmd, env = _aion(ROOT)
    out = []
    for k in range(n):
        aion = ROBOT_FOLDER / f"office{k:02d}.aion"
        out.append(aion)
        if aion.exists():
            continue
        log = aion.with_suffix(".mcap")
        day = dt.date(2026, 1, 5) + dt.timedelta(days=7 * (k // 5) + k % 5)  # weekdays
        start = day.isoformat()
        sim = ["simulate", "-o", str(log), "--days", "1", "--seed", str(k), "--start", start]
        _run([*cmd, *sim, "-q", "--force"], env)
        _run([*cmd, "build", str(log), "-o", str(aion), "-q"], env)
    return out


def area_graph(path: Path, k: int) -> Path:
    """A Hydra ``dsg.json`` of area ``k``: ``GRID`` x ``GRID`` places 3 m apart from
    ``x = 100 m * k``, joined to their grid neighbours, numbered from ``p(ID_STRIDE k)``
    (one scene-graph session numbers the places of every area it explores; the simulated
    graphs add places of their own with the ids after an area's, which stay below the next
    area's)."""
    import numpy as np
    import spark_dsg

    graph = spark_dsg.DynamicSceneGraph()
    first = ID_STRIDE * k
    for i in range(GRID * GRID):
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.position = np.array([100.0 * k + 3.0 * (i % GRID), 3.0 * (i // GRID), 0.0])
        attrs.real_place = True
        graph.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", first + i), attrs)
    for i in range(GRID * GRID):
        for j in (i + 1, i + GRID):
            if j < GRID * GRID and (j == i + GRID or j % GRID):
                graph.insert_edge(
                    spark_dsg.NodeSymbol("p", first + i), spark_dsg.NodeSymbol("p", first + j)
                )
    graph.save(str(path), include_mesh=False)
    return path


def area_maps(n: int) -> list[Path]:
    """The first ``n`` maps of areas of their own (simulated and built once): map ``k`` is
    built from one ``aion simulate`` log of a patrolling robot in area ``k``
    (:func:`area_graph`, six people, seed ``k``, one day from midnight of the ``k``-th weekday
    from Monday 2026-01-05)."""
    AREAS_FOLDER.mkdir(parents=True, exist_ok=True)
    cmd, env = _aion(ROOT)
    out = []
    for k in range(n):
        aion = AREAS_FOLDER / f"area{k:02d}.aion"
        out.append(aion)
        if aion.exists():
            continue
        graph = area_graph(AREAS_FOLDER / f"area{k:02d}.json", k)
        log = aion.with_suffix(".mcap")
        day = dt.date(2026, 1, 5) + dt.timedelta(days=7 * (k // 5) + k % 5)  # weekdays
        sim = ["simulate", "-o", str(log), "--environment", str(graph), "--days", "1"]
        sim += ["--seed", str(k), "--start", day.isoformat(), "-q", "--force"]
        _run([*cmd, *sim], env)
        _run([*cmd, "build", str(log), "-o", str(aion), "-q"], env)
    return out


MAKERS = {"cells": fleet_maps, "robot": robot_maps, "areas": area_maps}
MERGE_OPTIONS = {"areas": ["--lineage", "same"]}  # auto: maps that share no node id differ


def merge_cost(
    checkout: Path, maps: list[Path], options: list[str] | None = None
) -> tuple[float, int]:
    cmd, env = _aion(checkout)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "merged.aion"
        merge = [*cmd, "merge", *map(str, maps), "-o", str(out), "-q", *(options or [])]
        return _run(merge, env)


def run(
    maps: tuple[int, ...] = (5, 10, 20, 40),
    repeats: int = 2,
    against: Path | None = None,
    kind: str = "cells",
) -> list[dict[str, float | int]]:
    """One row per number of maps: CPU seconds (best of ``repeats``) and peak MB (largest)
    of ``aion merge`` with this checkout and, alternated with it, ``against``'s; ``kind``:
    fixed-sensor maps of areas of their own (``cells``), robot maps of one office
    (``robot``) or robot maps of areas of their own, merged with ``--lineage same``
    (``areas``)."""
    paths = MAKERS[kind](max(maps))
    checkouts = {"this": ROOT} | ({"against": against} if against is not None else {})
    for checkout in checkouts.values():
        compile_checkout(checkout)
    rows = []
    for n in maps:
        best = {name: (float("inf"), 0) for name in checkouts}
        for _ in range(repeats):
            for name, checkout in checkouts.items():
                cpu, rss = merge_cost(checkout, paths[:n], MERGE_OPTIONS.get(kind))
                best[name] = (min(best[name][0], cpu), max(best[name][1], rss))
        row: dict[str, float | int] = {"maps": n}
        for name, (cpu, rss) in best.items():
            row[f"{name}_cpu_s"] = round(cpu, 2)
            row[f"{name}_peak_mb"] = round(rss / 1e6)
        if against is not None:
            row["cpu_ratio_against_over_this"] = round(best["against"][0] / best["this"][0], 2)
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--maps", type=int, nargs="+", default=[5, 10, 20, 40])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--against", type=Path, help="another checkout, run alternately")
    parser.add_argument("--kind", choices=sorted(MAKERS), default="cells")
    args = parser.parse_args()
    run(tuple(args.maps), args.repeats, args.against, args.kind)


if __name__ == "__main__":
    main()
