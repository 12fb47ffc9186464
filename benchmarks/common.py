"""Shared benchmark helpers: best-of-k timing, peak memory in a subprocess, machine info.

Why these shapes:

* **Best of k.** The machine is shared; the minimum of k runs is the least disturbed estimate of
  what the code costs (noise only ever adds time). Every figure that matters is also reported
  as a ratio to a baseline timed in the same process on the same data, which cancels most of
  the drift between runs and machines.
* **Peak memory in a child process.** ``ru_maxrss`` is a high-water mark per process and numpy
  rarely gives memory back to the OS, so a measurement made after another one in the same
  process would see the earlier peak. :func:`peak_rss` runs one function in a fresh
  interpreter (``python -m benchmarks.common MODULE:FUNCTION JSON``) and reports that child's
  own high-water mark (``VmHWM``; see :func:`peak_rss_self` for why not ``ru_maxrss``) next
  to its resident size after imports, so each figure is isolated.
* **Machine info** goes into ``results.json`` with every run (CPU, cores, RAM, versions, load):
  numbers without the machine and its load are not comparable.
"""

from __future__ import annotations

import datetime as _dt
import importlib
import json
import os
import platform
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
WORK = ROOT / "benchmarks" / "_work"  # generated logs (gitignored)
MB = 1e6


def best_of(fn: Callable[[], Any], k: int = 3) -> float:
    """Smallest wall time (s) of ``k`` calls of ``fn``."""
    best = float("inf")
    for _ in range(max(1, k)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    """(wall seconds, result) of one call."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def cpu_timed(fn: Callable[[], Any]) -> tuple[float, float, Any]:
    """(wall seconds, CPU seconds, result) of one call. The CPU seconds are this process's
    (every thread) plus those of the child processes that ended during the call and were
    waited for (a parallel build's workers): what the call cost the machine's cores."""
    import resource

    def cpu() -> float:
        own = resource.getrusage(resource.RUSAGE_SELF)
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    c0, t0 = cpu(), time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, cpu() - c0, out


def current_rss() -> int:
    """Resident set size of this process now (bytes), from /proc (Linux) or psutil."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except OSError:
        import psutil  # type: ignore[import-untyped]

        return int(psutil.Process().memory_info().rss)


def peak_rss_self() -> int:
    """High-water resident size of this process image (bytes).

    Linux: ``VmHWM`` from /proc/self/status, which belongs to the memory map created by
    ``execve``. ``ru_maxrss`` is NOT used there: Linux carries it over from the parent across
    fork and exec, so a child started by a large parent would report the parent's size.
    Elsewhere ``ru_maxrss`` (bytes on macOS, kilobytes otherwise)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return int(usage.ru_maxrss) * (1 if sys.platform == "darwin" else 1024)


def peak_rss(target: str, timeout: float = 900.0, **kwargs: Any) -> dict[str, Any]:
    """Run ``target`` ("package.module:function", called with ``kwargs``; must return a
    JSON-serialisable dict) in a fresh interpreter and return its result plus
    ``peak_rss_bytes`` (the child's high-water resident size), ``base_rss_bytes`` (resident
    size after importing the module, before the call: interpreter, numpy, aion) and
    ``peak_above_base_bytes`` (what the call itself added at its peak)."""
    cmd = [sys.executable, "-m", "benchmarks.common", target, json.dumps(kwargs)]
    proc = subprocess.run(
        cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout, check=False
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{target} failed in a subprocess:\n{proc.stderr[-4000:]}")
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    result: dict[str, Any] = json.loads(lines[-1])
    return result


def child_usage(cmd: list[str], **popen: Any) -> tuple[int, str, Any]:
    """Run ``cmd`` (``popen``: more ``subprocess.Popen`` arguments; its stdout discarded) and
    wait for it with ``os.wait4``: its exit code, its stderr, and its own ``resource``
    usage (CPU ``ru_utime + ru_stime``; peak RSS ``ru_maxrss``, KiB on Linux)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, **popen)
    _, status, usage = os.wait4(proc.pid, 0)
    err = ""
    if proc.stderr is not None:
        err = proc.stderr.read().decode()
        proc.stderr.close()
    return os.waitstatus_to_exitcode(status), err, usage


def _child(target: str, kwargs_json: str) -> None:
    """Child side of :func:`peak_rss`: import, note the RSS, call, print one JSON line."""
    module_name, func_name = target.split(":")
    func = getattr(importlib.import_module(module_name), func_name)
    base = current_rss()
    out = func(**json.loads(kwargs_json))
    peak = peak_rss_self()
    out = dict(out)
    out.update(
        peak_rss_bytes=peak, base_rss_bytes=base, peak_above_base_bytes=max(peak - base, 0)
    )
    print(json.dumps(out, default=float))


def cpu_model() -> str:
    """CPU model name (Linux /proc/cpuinfo, else platform.processor())."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info() -> dict[str, Any]:
    """The machine and its load, recorded with every result."""
    import numpy as np
    import psutil

    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
            check=False,
        ).stdout.strip()
    except OSError:
        commit = ""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "date_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cpu_model": cpu_model(),
        "cores": os.cpu_count(),
        "ram_gb": round(psutil.virtual_memory().total / 2**30, 1),
        "ram_available_gb": round(psutil.virtual_memory().available / 2**30, 1),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
        "load_average_1_5_15": [round(x, 2) for x in load],
        "git_commit": commit,
    }


def corridor_points(
    rng: Any,
    n: int,
    extent: float = 1000.0,
    spacing: float = 100.0,
    width: float = 3.0,
    floors: int = 1,
    floor_height: float = 4.0,
) -> tuple[Any, Any]:
    """``n`` people positions (float64[n,3]) and walking headings (float64[n]) on a corridor
    network: corridors ``width`` wide along x and y every ``spacing`` metres over an
    ``extent`` square, on ``floors`` floors ``floor_height`` apart. People walk along the
    corridor (heading 0/π or ±π/2 with 0.3 rad noise), spread across it with a normal of
    sd width/5 clipped to the walls: the sparse environment a dense grid pays for in full."""
    import numpy as np

    lines = int(extent // spacing) + 1
    corridor = rng.integers(0, 2 * lines, n)
    along = rng.uniform(0.0, extent, n)
    across = np.clip(rng.normal(0.0, width / 5, n), -width / 2 + 0.01, width / 2 - 0.01)
    offset = (corridor % lines) * spacing + across
    along_x = corridor < lines  # corridors along x sit at y = offset
    xyz = np.empty((n, 3))
    xyz[:, 0] = np.where(along_x, along, offset)
    xyz[:, 1] = np.where(along_x, offset, along)
    xyz[:, 2] = rng.integers(0, floors, n) * floor_height + 0.9
    back = rng.random(n) < 0.5
    heading = np.where(along_x, 0.0, np.pi / 2) + np.where(back, np.pi, 0.0)
    heading = np.angle(np.exp(1j * (heading + rng.normal(0.0, 0.3, n))))
    return xyz, heading


def corridor_nodes(
    extent: float = 1000.0,
    spacing: float = 100.0,
    node_step: float = 2.0,
    floors: int = 1,
    floor_height: float = 4.0,
) -> tuple[Any, Any]:
    """Places along the corridors' centre lines every ``node_step`` m (a Hydra-like places
    layer; shared crossings de-duplicated) and 4-neighbour-ish edges between consecutive
    places: (xyz float64[m,3], edges int64[k,2])."""
    import numpy as np

    lines = int(extent // spacing) + 1
    steps = np.arange(0.0, extent + 1e-9, node_step)
    pts = []
    for f in range(floors):
        z = f * floor_height + 0.9
        for k in range(lines):
            c = k * spacing
            pts.append(np.c_[steps, np.full(len(steps), c), np.full(len(steps), z)])
            pts.append(np.c_[np.full(len(steps), c), steps, np.full(len(steps), z)])
    xyz = np.unique(np.round(np.concatenate(pts), 6), axis=0)
    # edges: neighbours at exactly node_step along x or y on the same floor
    key = {tuple(p): i for i, p in enumerate(np.round(xyz, 6).tolist())}
    edges = []
    for i, (x, y, z) in enumerate(xyz.tolist()):
        for dx, dy in ((node_step, 0.0), (0.0, node_step)):
            j = key.get((round(x + dx, 6), round(y + dy, 6), round(z, 6)))
            if j is not None:
                edges.append((i, j))
    return xyz, np.asarray(edges, np.int64).reshape(-1, 2)


def fmt_si(x: float, unit: str = "") -> str:
    """Compact number with an SI prefix (12.3 M, 450 k)."""
    if x != x:  # NaN
        return "nan"
    for factor, prefix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(x) >= factor:
            return f"{x / factor:.3g} {prefix}{unit}"
    return f"{x:.3g} {unit}".rstrip()


if __name__ == "__main__":
    _child(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "{}")
