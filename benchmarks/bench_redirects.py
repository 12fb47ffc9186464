"""``Redirects.add`` at 10^4-10^6 redirects (stop 66): adds of 27 sorted new keys (the 1-hour
graph stream's median bind), timed per add, and a lookup of 1,000 keys after each (best of
3 runs of 200 adds, ``perf_counter``), on whatever ``aion_cli`` is imported: run it in two
checkouts for an A/B (docs/BENCHMARKS.md)::

    PYTHONPATH=. .venv/bin/python -m benchmarks.bench_redirects
"""

from __future__ import annotations

import time

import numpy as np

#: table sizes measured
SIZES = (10_000, 100_000, 300_000, 1_000_000)
ADDS, PER_ADD, PROBES = 200, 27, 1_000


def per_add_us(n: int, seed: int = 1) -> tuple[float, float]:
    """Microseconds per add into a table of ``n`` redirects, and per lookup after it."""
    from aion_cli.engine.nodes import Redirects

    rng = np.random.default_rng(seed)
    every = rng.choice(10**12, n + ADDS * PER_ADD, replace=False).astype(np.int64)
    base = np.sort(every[:n])
    base_nodes = rng.integers(1, 10**6, n).astype(np.uint64)
    adds = [(np.sort(r), rng.integers(1, 10**6, PER_ADD).astype(np.uint64))
            for r in every[n:].reshape(ADDS, PER_ADD)]  # fmt: skip
    probes = [rng.choice(base, PROBES) for _ in adds]
    best = [float("inf"), float("inf")]
    for _ in range(3):
        red = Redirects()
        red.keys, red.nodes = base.copy(), base_nodes.copy()
        spent = [0.0, 0.0]
        for (keys, nodes), probe in zip(adds, probes, strict=True):
            t = time.perf_counter()
            red.add(keys, nodes)
            spent[0] += time.perf_counter() - t
            t = time.perf_counter()
            red.lookup(probe)
            spent[1] += time.perf_counter() - t
        best = [min(b, s) for b, s in zip(best, spent, strict=True)]
        assert len(red) == n + ADDS * PER_ADD
    return best[0] / ADDS * 1e6, best[1] / ADDS * 1e6


def main() -> None:
    for n in SIZES:
        add, lookup = per_add_us(n)
        print(f"{n:>9,} redirects: add {add:8.1f} us, lookup {lookup:6.1f} us", flush=True)


if __name__ == "__main__":
    main()
