"""``RouteTable.insert`` at 10^4-10^6 route keys (stop 67): what a batch of detections with
new cells pays to insert them (a copy of the whole table, O(n)) beside the batch's lookup,
and a build's table grown by such inserts from none to 5,436 and 10^5 cells. Thread CPU
(``time.thread_time``), best of 3 runs of 200 batches; measurement only (docs/BENCHMARKS.md)::

    PYTHONPATH=. .venv/bin/python -m benchmarks.bench_route_insert
"""

from __future__ import annotations

import time

import numpy as np

#: route table sizes measured (cells plus redirects; a 10^5-place map holds ~7·10^5)
SIZES = (10_000, 100_000, 700_000, 1_000_000)
#: a batch: 109 known keys and 3 new ones (the 20-day 5 pm log: 112 detections per batch, a
#: median of 3 new cells per batch that had any)
BATCHES, KNOWN, NEW = 200, 109, 3
#: a build's table grown by inserts of 13 keys (the 20-day logs' mean) to these sizes
GROWN, PER_INSERT = (5_436, 100_000), 13


def per_batch_us(n: int, seed: int = 0) -> tuple[float, float]:
    """CPU microseconds per insert of ``NEW`` keys into a table of ``n``, and per lookup of
    the batch's ``KNOWN + NEW`` keys before it."""
    from aion_cli.engine.routing import RouteTable

    rng = np.random.default_rng(seed)
    keys = np.sort(rng.choice(10**13, 2 * n, replace=False).astype(np.int64))
    base, fresh = keys[::2], keys[1::2]
    best = [float("inf"), float("inf")]
    for run in range(3):
        table = RouteTable(base.copy(), np.arange(n, dtype=np.int64))
        spent = [0.0, 0.0]
        for b in range(BATCHES):
            at = (run * BATCHES + b) * NEW
            batch = np.concatenate([rng.choice(base, KNOWN), fresh[at : at + NEW]])
            t = time.thread_time()
            _, found = table.lookup(batch)
            spent[1] += time.thread_time() - t
            new = np.unique(batch[~found])
            t = time.thread_time()
            table.insert(new, np.arange(len(new), dtype=np.int64) + 2 * n)
            spent[0] += time.thread_time() - t
        best = [min(b, s) for b, s in zip(best, spent, strict=True)]
    return best[0] / BATCHES * 1e6, best[1] / BATCHES * 1e6


def grown_s(n: int, seed: int = 0) -> float:
    """CPU seconds of the inserts that grow an empty table to ``n`` keys, ``PER_INSERT`` at
    a time, in random places."""
    from aion_cli.engine.routing import RouteTable

    keys = np.random.default_rng(seed).choice(10**13, n, replace=False).astype(np.int64)
    table = RouteTable()
    t = time.thread_time()
    for at in range(0, n, PER_INSERT):
        new = np.sort(keys[at : at + PER_INSERT])
        table.insert(new, np.arange(len(new), dtype=np.int64))
    return time.thread_time() - t


def main() -> None:
    for n in SIZES:
        insert, lookup = per_batch_us(n)
        print(f"{n:>9,} keys: insert of {NEW} {insert:7.0f} us, lookup of {KNOWN + NEW} "
              f"{lookup:5.0f} us", flush=True)  # fmt: skip
    for n in GROWN:
        inserts = -(-n // PER_INSERT)
        print(f"grown to {n:,} keys by {inserts:,} inserts: {grown_s(n):.2f} s", flush=True)


if __name__ == "__main__":
    main()
