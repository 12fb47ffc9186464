"""The benchmark runner (``make bench`` = ``python -m benchmarks.run``).

Runs the sections below, prints one table (figure, value, ratio to an in-process baseline,
target, met/missed) and writes every raw result plus the machine (CPU, cores, RAM, Python,
numpy, load average, date) to ``benchmarks/results.json``.

Sections (``--only NAME``, repeatable): ``ingest`` (bench_ingest: ``aion build`` on a 5 M
detection log vs raw iteration and rosbags decoding), ``temporal`` (bench_temporal: the
temporal model's learning and prediction throughput), ``engine`` (bench_engine:
``Mapper.add_detections``), ``memory`` (bench_memory: aion vs dense grid),
``queries`` (bench_engine.run_queries: load, predict, plan, export), ``scaling``
(bench_scaling, writes ``scaling.png``), ``build`` (bench_build, issue 15: ``aion build`` vs raw
iteration on TrackedPersons logs at 1/5/25 people per message, the scene-graph share of a
build, map bytes per entry, ``aion predict`` / ``info`` process times, streaming peak RSS).

``--quick`` uses small sizes (seconds, for the smoke test and a fast look) and writes to
``benchmarks/_work/results-quick.json`` unless ``--out`` says otherwise, so it never replaces
the committed full results. Speed is never asserted here or in tests: targets are reported.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.common import ROOT, WORK, fmt_si, machine_info

SECTIONS = ("ingest", "temporal", "engine", "memory", "queries", "scaling", "build", "parallel")
RESULTS = ROOT / "benchmarks" / "results.json"


def _ingest(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_ingest

    if quick:
        return bench_ingest.run(detections=20_000, repeats=1, rosbags_messages=200)
    return bench_ingest.run(detections=5_000_000, repeats=1, rosbags_messages=20_000)


def _temporal(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_temporal

    return bench_temporal.run(sizes=(10**3,) if quick else (10**3, 10**4, 10**5, 10**6))


def _engine(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_engine

    if quick:
        return [bench_engine.measure(20_000, 1, 1) | {"name": "engine ingest quick, 1 window"}]
    return bench_engine.run(sizes=(10**6, 10**7), repeats=2)


def _memory(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_memory

    return bench_memory.run(scale=0.005 if quick else 1.0)


def _queries(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_engine

    if quick:
        return bench_engine.run_queries(n_entries=1000, export_nodes=200, plan=False,
                                        repeats=1, times=3)
    return bench_engine.run_queries(n_entries=100_000, export_nodes=10_000, plan=True,
                                    repeats=3, times=100)


def _scaling(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_scaling

    if quick:
        return bench_scaling.run(det_sizes=(10**4, 3 * 10**4), entry_sizes=(100, 400),
                                 entry_detections=10_000, png=WORK / "scaling-quick.png")
    return bench_scaling.run()


def _build(quick: bool) -> list[dict[str, Any]]:
    from benchmarks import bench_build

    return bench_build.run(quick)


def _parallel(quick: bool) -> list[dict[str, Any]]:
    """In a fresh interpreter: its workers are forked from the process that runs it, and a
    parent grown by the earlier sections (hundreds of MB of maps and logs) makes every fork
    slower and every worker's resident size include the parent's pages (a full run measured
    1.45 GB "per worker" against 0.3 GB alone) — a user's ``aion build`` starts fresh."""
    import subprocess
    import tempfile

    code = (
        "import json, sys\n"
        "from benchmarks import bench_parallel\n"
        "json.dump(bench_parallel.run(sys.argv[1] == 'quick'), open(sys.argv[2], 'w'))\n"
    )
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "parallel.json"
        subprocess.run(
            [sys.executable, "-c", code, "quick" if quick else "full", str(out)],
            check=True,
            cwd=ROOT,
        )
        rows: list[dict[str, Any]] = json.loads(out.read_text())
    return rows


RUNNERS: dict[str, Callable[[bool], list[dict[str, Any]]]] = {
    "ingest": _ingest, "temporal": _temporal, "engine": _engine, "memory": _memory,
    "queries": _queries, "scaling": _scaling, "build": _build, "parallel": _parallel,
}


# -- the table ---------------------------------------------------------------------------------
def _find(rows: list[dict[str, Any]], prefix: str) -> dict[str, Any] | None:
    return next((r for r in rows if str(r.get("name", "")).startswith(prefix)), None)


def summary(results: dict[str, list[dict[str, Any]]]) -> list[dict[str, Any]]:
    """Headline figures: ``{section, figure, value, vs, target, met}`` (met None = no target)."""
    out: list[dict[str, Any]] = []

    def add(section: str, figure: str, value: str, vs: str = "", target: str = "",
            met: bool | None = None) -> None:
        out.append({"section": section, "figure": figure, "value": value, "vs": vs,
                    "target": target, "met": met})

    for r in results.get("ingest", []):
        add("ingest", f"aion build, {r['detections']:,} detections",
            f"{fmt_si(r['build_detections_per_s'], 'det/s')} ({r['build_s']:.1f} s)",
            f"{r['build_vs_raw']:.1f}x raw iteration", "<= 2x raw iteration",
            r["build_vs_raw"] <= 2.0)
        add("ingest", "raw message iteration", fmt_si(r["raw_detections_per_s"], "det/s"),
            f"{r['raw_iteration_s']:.1f} s")
        if "decode_s" in r:
            add("ingest", "read + decode + map frame (no Mapper)", f"{r['decode_s']:.1f} s",
                f"{r['decode_vs_raw']:.2f}x raw iteration", "<= 2x raw iteration",
                r["decode_vs_raw"] <= 2.0)
        add("ingest", "rosbags generic decode (extrapolated)",
            fmt_si(r["rosbags_detections_per_s"], "det/s"),
            f"{r['rosbags_vs_build']:.2f}x build time")
    temporal = results.get("temporal", [])
    if temporal:
        top = max(temporal, key=lambda r: r["entries"])
        size = f"{top['entries']:,} entries ({top['timed_entries']:,} timed)"
        add("temporal", f"learn updates/s (entry·value-bin, window), {size}",
            fmt_si(top["updates_per_s"]),
            f"{top['learn_vs_loop']:.1f}x absorb loop", ">= 20 M/s",
            top["updates_per_s"] >= 20e6)
        add("temporal", f"absorb-only updates/s, {size}",
            fmt_si(top["absorb_updates_per_s"]), f"{top['absorb_vs_loop']:.1f}x absorb loop")
        add("temporal", f"Predictor.at predictions/s, {size}",
            fmt_si(top["predictions_per_s"]),
            f"{top['predict_vs_loop']:.1f}x flow loop; Predictor.of {top['predictor_of_s']:.2f} s",
            ">= 20 M/s", top["predictions_per_s"] >= 20e6)
    for r in results.get("engine", []):
        target = r["windows"] == 1
        add("engine", str(r["name"]).replace("engine ingest ", "add_detections "),
            fmt_si(r["detections_per_s"], "det/s"),
            f"{r['vs_bincount']:.1f}x bincount time, {r['vs_dict_loop']:.0f}x dict loop",
            ">= 2 M det/s" if target else "", (r["detections_per_s"] >= 2e6) if target else None)
        if "sketch_vs_ingest" in r:
            add("engine", f"recording sample of the same {r['detections']:,} det",
                f"{r['sketch_seconds']:.2f} s", f"{r['sketch_vs_ingest']:.2f}x add_detections")
    for r in results.get("memory", []):
        if "dense_cells" not in r:
            add("memory", "dense grid check: bytes/cell measured vs analytic",
                f"{r['measured_peak_bytes_per_cell']:.0f} B",
                f"analytic {r['analytic_bytes_per_cell']:.0f} B", "")
            continue
        campus_graph = r["env"] == "campus" and r["graph"]
        add("memory", str(r["name"]),
            f"{r['aion_peak_bytes'] / 1e6:.0f} MB peak, map {r.get('map_file_bytes', 0) / 1e6:.0f}"
            f" MB",
            f"dense {r['dense_bytes_analytic'] / 1e9:.1f} GB = "
            f"{r['ratio_dense_over_aion_peak']:.1f}x peak, "
            f"{r['ratio_dense_over_aion_state']:.1f}x retained state",
            "<= 1/20 dense (peak)" if campus_graph else "",
            (r["ratio_dense_over_aion_peak"] >= 20) if campus_graph else None)
    q = results.get("queries", [])
    for prefix, target, limit in (("map load", "", None),
                                  ("first predict_table", "", None),
                                  ("predict_table, 1 time", "< 50 ms", 0.05),
                                  ("predict_table x", "", None),
                                  ("batched Predictor.pairs", "", None),
                                  ("plan temporal corner-corner", "< 1 s", 1.0),
                                  ("plan distance-only", "", None),
                                  ("export", "", None)):
        found = _find(q, prefix)
        if found is None:
            continue
        vs = ", ".join(f"{k}={v:.3g}" for k, v in found.items()
                       if k.startswith("vs_") and isinstance(v, float))
        size = found.get("entries", found.get("nodes", found.get("expanded", "")))
        add("queries", f"{found['name']} ({size})", f"{found['seconds'] * 1e3:.1f} ms", vs,
            target, (found["seconds"] < limit) if limit is not None else None)
    for r in results.get("scaling", []):
        if str(r["name"]).endswith("slopes"):
            add("scaling", f"log-log slope vs {r['series']}",
                f"time {r['time_slope']:.2f}, memory {r['memory_slope']:.2f}", "",
                "~1 (linear)" if r["series"] == "detections" else "")
    _build_summary(results.get("build", []), add)
    _parallel_summary(results.get("parallel", []), add)
    return out


def _parallel_summary(rows: list[dict[str, Any]], add: Callable[..., None]) -> None:
    """The ``parallel`` section's rows (bench_parallel: issue 17's figures)."""
    for r in rows:
        name = str(r.get("name", ""))
        if name.startswith("parallel build"):
            add("parallel", f"{name}, {r['detections']:,} det: speed-up",
                f"{r['speedup']:.2f}x ({r['workers2_s']:.2f} s vs {r['sequential_s']:.2f} s)",
                f"same map: {r['same_map']}; {r['shards']} shards, "
                f"{r['shards_learnt_in_sequence']} learnt in sequence; joins {r['fold_s']:.2f} s",
                ">= 1.6x", r["speedup"] >= 1.6)
            if "speedup_bound_2_cores" in r:
                add("parallel", f"{name}: bound on two cores",
                    f"{r['speedup_bound_2_cores']:.2f}x",
                    f"CPU: sequential {r['sequential_cpu_s']:.2f} s "
                    f"({r['sequential_cores_used']:.2f} cores), 2 workers "
                    f"{r['workers2_cpu_s']:.2f} s in all")
            if "machine_two_shard_throughput" in r:
                add("parallel", f"{name}: this machine's two-process ceiling",
                    f"{r['machine_two_shard_throughput']:.2f}x",
                    f"one shard alone {r['one_shard_alone_s']:.2f} s, two at once "
                    f"{r['two_shards_at_once_s']:.2f} s; the speed-up is "
                    f"{r['speedup_of_ceiling']:.0%} of it")
            add("parallel", f"{name}: peak memory per worker",
                f"{max(r['worker_peak_rss_mb']):.0f} MB",
                f"{fmt_si(max(r['shard_detections_per_s']), 'det/s')} per worker (best shard)")
        elif name.startswith("time shards"):
            add("parallel", f"{name}, {r['detections']:,} det: speed-up",
                f"{r['speedup']:.2f}x ({r['workers2_s']:.2f} s vs {r['sequential_s']:.2f} s)",
                f"median {r['speedup_median']:.2f}x; same map: {r['same_map']}; "
                f"{r['shards']} shards, {r['shards_learnt_in_sequence']} learnt in sequence; "
                f"joins {r['fold_s'] or 0:.2f} s")
        elif name.startswith("Hydra"):
            kept = r.get("kept_together", [])
            how = "; ".join(
                (["sessions kept together"] if kept else []) + r["learnt_without_waiting"]
                + r["not_cut"]
            ) or "joined"
            add("parallel", f"{name}, {r['graph_messages']:,} graphs: speed-up",
                f"{r['speedup']:.2f}x ({r['workers2_s']:.2f} s vs {r['sequential_s']:.2f} s)",
                f"median {r['speedup_median']:.2f}x; same map: {r['same_map']}"
                + (f" ({', '.join(d.split(':')[0] for d in r['differences'])})"
                   if r["differences"] else "")
                + f"; {r['shards_built_by_workers']} shards built by workers, "
                f"{r['shards_learnt_in_sequence']} learnt again in sequence; {how[:120]}")
        elif name.startswith("merge_maps"):
            add("parallel", f"{name}: cost per entry", f"{r['us_per_entry']:.0f} us",
                f"{r['seconds']:.2f} s for {r['entries']:,} entries")


def _build_summary(rows: list[dict[str, Any]], add: Callable[..., None]) -> None:
    """The ``build`` section's rows (bench_build: issue 15's targets)."""
    for r in rows:
        name = str(r.get("name", ""))
        if name.startswith("build ") and "per_message" in r:
            k = r["per_message"]
            add("build", f"aion build, {k}/msg, {r['detections']:,} det, {r['days']} days",
                f"{fmt_si(r['build_detections_per_s'], 'det/s')} ({r['build_s']:.2f} s)",
                f"{r['build_vs_raw']:.1f}x raw iteration ({r['raw_iteration_s']:.2f} s)",
                "<= 2x raw iteration", r["build_vs_raw"] <= 2.0)
            if k == 5:
                add("build", "end to end detections/s at 5/msg",
                    fmt_si(r["build_detections_per_s"], "det/s"), "", ">= 1 M det/s",
                    r["build_detections_per_s"] >= 1e6)
        elif name.startswith("graph stream"):
            add("build", f"scene graphs, {r['places']:,} places at 1 Hz, "
                f"{r['seconds'] / 3600:.2g} h: share of build",
                f"{100 * r['graph_share']:.0f} % ({r['build_s']:.1f} s vs "
                f"{r['build_without_graphs_s']:.1f} s without)",
                f"{1e3 * r['graph_s_per_message']:.1f} ms/graph msg; spark_dsg "
                f"{1e3 * r.get('spark_from_binary_s_per_graph', float('nan')):.1f} ms, "
                f"decode_dsg {1e3 * r.get('decode_dsg_s_per_graph', float('nan')):.1f} ms "
                f"({1e3 * r.get('decode_dsg_stream_s_per_graph', float('nan')):.1f} ms "
                "reading a stream by changes), "
                f"add_graph {1e3 * r.get('add_graph_s_per_graph', float('nan')):.1f} ms",
                "<= 25 %", r["graph_share"] <= 0.25)
            if "graph_share_floor_reading" in r:
                add("build", "scene graphs: share if only reading them cost (floor)",
                    f"{100 * r['graph_share_floor_reading']:.0f} %",
                    f"reading graph bytes {r['graph_reading_s']:.2f} s of raw iteration "
                    f"{r['raw_iteration_s']:.2f} s")
        elif name.startswith("map size") and "query-only" in name:
            add("build", f"query-only map bytes per entry ({r['entries']:,} entries)",
                f"{r['bytes_per_entry']:.0f} B ({r['map_bytes'] / 1e6:.0f} MB)",
                f"{r['vs_baseline']:.2f}x smaller than before, {r['vs_full_map']:.2f}x smaller "
                f"than the full map (aion compact, {r['compact_s']:.1f} s; same predictions, "
                "cannot be continued or merged)", ">= 4x smaller", r["vs_baseline"] >= 4.0)
        elif name.startswith("map size"):
            kinds = ", ".join(f"{k} {v:.0f}" for k, v in
                              list(r["bytes_per_entry_by_kind"].items())[:3])
            add("build", f"map bytes per entry ({r['entries']:,} entries)",
                f"{r['bytes_per_entry']:.0f} B ({r['map_bytes'] / 1e6:.0f} MB)",
                f"{r['vs_baseline']:.2f}x smaller than before; {kinds}",
                ">= 4x smaller", r["vs_baseline"] >= 4.0)
        elif name.startswith(("aion predict", "aion info")):
            predict = name.startswith("aion predict")
            same = "" if "same_answer" not in r else (
                "; same top 10 as the full map" if r["same_answer"] else "; ANSWER DIFFERS")
            add("build", f"{name} ({r['entries']:,} entries), whole process",
                f"{r['seconds']:.2f} s",
                f"{r['vs_aion_help']:.1f}x aion --help ({r['aion_help_s']:.2f} s){same}",
                "<= 1 s" if predict else "", (r["seconds"] <= 1.0) if predict else None)
        elif name == "stream memory fit":
            judged = r["largest_gb"] >= 1.0  # below, the chunk buffers are still filling
            how = "extrapolated" if r["extrapolated"] else "measured"
            add("build", f"streaming peak RSS, log up to {r['largest_gb']:.2g} GB",
                f"{r['largest_peak_mb']:.0f} MB at {r['largest_gb']:.2g} GB",
                f"{r['mb_per_gb']:.1f} MB per GB of log; 10 GB: {r['peak_mb_at_10gb']:.0f} MB "
                f"({how})", "<= 500 MB on 10 GB",
                (r["peak_mb_at_10gb"] <= 500.0) if judged else None)


def print_table(rows: list[dict[str, Any]]) -> None:
    """The summary as an aligned text table."""
    head = ("section", "figure", "value", "vs baseline", "target", "status")
    cells = [[r["section"], r["figure"], r["value"], r["vs"], r["target"],
              "" if r["met"] is None else ("met" if r["met"] else "MISSED")] for r in rows]
    widths = [max(len(h), *(len(c[i]) for c in cells)) if cells else len(h)
              for i, h in enumerate(head)]
    line = "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True))
    print(line)
    print("-" * len(line))
    for c in cells:
        print("  ".join(v.ljust(w) for v, w in zip(c, widths, strict=True)))


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The summary as a Markdown table (for docs/BENCHMARKS.md)."""
    lines = ["| section | figure | value | vs baseline | target | status |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        status = "" if r["met"] is None else ("met" if r["met"] else "**missed**")
        lines.append(f"| {r['section']} | {r['figure']} | {r['value']} | {r['vs']} | "
                     f"{r['target']} | {status} |")
    return "\n".join(lines)


def _clean(x: Any) -> Any:
    """JSON-safe copy (NaN/inf -> None, numpy scalars -> Python)."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if hasattr(x, "item") and not isinstance(x, (str, bytes)):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small sizes (seconds)")
    parser.add_argument("--only", action="append", choices=SECTIONS, metavar="NAME",
                        help=f"run only this section (repeatable): {', '.join(SECTIONS)}")
    parser.add_argument("--out", type=Path, default=None, help="results JSON path")
    parser.add_argument("--markdown", type=Path, default=None, metavar="RESULTS_JSON",
                        help="print the summary of a results file as Markdown and exit")
    args = parser.parse_args(argv)
    if args.markdown is not None:
        print(markdown_table(json.loads(args.markdown.read_text())["summary"]))
        return 0
    sections = args.only or list(SECTIONS)
    out = args.out or (WORK / "results-quick.json" if args.quick else RESULTS)
    WORK.mkdir(parents=True, exist_ok=True)
    machine = machine_info()
    print(f"machine: {machine['cpu_model']}, {machine['cores']} cores, {machine['ram_gb']} GB, "
          f"Python {machine['python']}, numpy {machine['numpy']}, load "
          f"{machine['load_average_1_5_15']}", flush=True)
    results: dict[str, list[dict[str, Any]]] = {}
    seconds: dict[str, float] = {}
    for name in sections:
        t0 = time.perf_counter()
        print(f"[{name}] running ...", flush=True)
        results[name] = RUNNERS[name](args.quick)
        seconds[name] = time.perf_counter() - t0
        print(f"[{name}] done in {seconds[name]:.0f} s", flush=True)
    if args.only and out.exists():  # keep the sections not run this time
        try:
            old = json.loads(out.read_text())
        except (OSError, ValueError):
            old = {}
        results = {**old.get("results", {}), **results}
        seconds = {**old.get("section_seconds", {}), **seconds}
    table = summary(results)
    print()
    print_table(table)
    machine["load_average_after"] = [round(x, 2) for x in __import__("os").getloadavg()]
    payload = {"command": "python -m benchmarks.run" + (" --quick" if args.quick else "")
               + "".join(f" --only {s}" for s in args.only or []),
               "machine": machine, "section_seconds": seconds, "summary": table,
               "results": results}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(_clean(payload), indent=1) + "\n")
    print(f"\nwrote {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
