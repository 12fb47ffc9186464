"""Where one ``aion build`` spends its time (``python -m benchmarks.bench_build --profile`` and
``--sample``): :func:`profile_build`, a cProfile of the main thread and of the detection decode
worker thread; :func:`sample_build`, wall-clock samples of every thread's Python stack (no
cost per call added). Each builds in this process with :func:`benchmarks.bench_build.build`."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from benchmarks.bench_build import build


def profile_build(path: Path, top: int = 25, dump: Path | None = None) -> str:
    """cProfile of one build of ``path``: the ``top`` functions by cumulative and by own time,
    for the main thread and, separately, for the detection decode worker thread
    (``DetectionFeeder.decode_rows``, which every decode of a chunk or of a job of chunks goes
    through, runs there; the main thread's profile sees it only as waiting; it is wrapped for
    the run, here only, to profile it as well). ``dump``: also write the raw stats to
    ``dump``-main.prof and ``dump``-worker.prof (for pstats / snakeviz)."""
    import cProfile
    import io
    import pstats

    from aion_cli.detection_feed import DetectionFeeder

    out = path.with_suffix(".profile.aion")
    main, worker = cProfile.Profile(), cProfile.Profile()
    decode = DetectionFeeder.decode_rows
    calls = [0]

    def profiled(self: Any, *args: Any) -> Any:
        calls[0] += 1
        worker.enable()
        try:
            return decode(self, *args)
        finally:
            worker.disable()

    DetectionFeeder.decode_rows = profiled  # type: ignore[method-assign,assignment]
    try:
        t0 = time.perf_counter()
        main.enable()
        report = build(path, out)
        main.disable()
        wall = time.perf_counter() - t0
    finally:
        DetectionFeeder.decode_rows = decode  # type: ignore[method-assign]
    out.unlink(missing_ok=True)
    if dump is not None:
        main.dump_stats(f"{dump}-main.prof")
        worker.dump_stats(f"{dump}-worker.prof")
    buf = io.StringIO()
    buf.write(f"build of {path.name}: {wall:.2f} s under cProfile, "
              f"{report.detections_read:,} detections, {report.graph_messages:,} graphs, "
              f"{report.windows:,} windows, {calls[0]:,} decodes (per topic: chunks or jobs of "
              "chunks)\n\n")
    for label, prof in (("main thread", main), ("decode worker thread", worker)):
        for order in ("cumulative", "tottime"):
            buf.write(f"## {label}, top {top} by {order}\n")
            pstats.Stats(prof, stream=buf).sort_stats(order).print_stats(top)
    return buf.getvalue()


def sample_build(path: Path, every_s: float = 0.002, least: float = 0.01) -> str:
    """Wall-clock samples of one build of ``path``: every ``every_s`` a helper thread reads
    each other thread's Python stack (``sys._current_frames``) and counts its functions
    (inclusive: once per sample wherever they are on the stack) and the innermost one (own
    time; numpy's C calls count for the Python function calling them). Unlike cProfile, no
    cost per call is added, so Python-heavy parts are not inflated; but waits (for the GIL,
    for I/O) count as much as work. Shares of each thread's samples, ``least`` and above."""
    import collections
    import sys
    import threading

    out = path.with_suffix(".sample.aion")
    inclusive: collections.Counter[tuple[str, str]] = collections.Counter()
    own: collections.Counter[tuple[str, str]] = collections.Counter()
    samples: collections.Counter[str] = collections.Counter()
    main, done = threading.get_ident(), threading.Event()

    def sampler() -> None:
        me = threading.get_ident()
        while not done.wait(every_s):
            for tid, frame in sys._current_frames().items():
                if tid == me:
                    continue
                thread = "main thread" if tid == main else "other threads"
                samples[thread] += 1
                names = []
                f: Any = frame
                while f is not None:
                    names.append(f"{Path(f.f_code.co_filename).name}:{f.f_code.co_name}")
                    f = f.f_back
                own[(thread, names[0])] += 1
                inclusive.update((thread, name) for name in set(names))

    helper = threading.Thread(target=sampler, daemon=True)
    helper.start()
    t0 = time.process_time()
    try:
        build(path, out)
    finally:
        done.set()
        helper.join()
        out.unlink(missing_ok=True)
    lines = [f"build of {path.name}: {time.process_time() - t0:.2f} s CPU, samples {dict(samples)}"]
    for thread in ("main thread", "other threads"):
        for label, counts in (("inclusive", inclusive), ("own", own)):
            lines.append(f"## {thread}, {label}")
            for (t, name), n in counts.most_common():
                share = n / max(samples[thread], 1)
                if t == thread and share >= least:
                    lines.append(f"{100 * share:6.1f} %  {name}")
    return "\n".join(lines)
